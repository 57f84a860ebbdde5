"""The gantry twin: analytic responses, sampling effects, experiments, identification round trips, contours."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedtune.errors import UsageError
from feedtune.identify.gantry import fit_gantry
from feedtune.identify.mass import fit_axis_mass, fit_mass_distribution
from feedtune.machines.gantry.experiments import (
    AxisHoldingController,
    HoldingController,
    measure_gantry_frf,
    measure_mass,
    run_contour,
    run_gantry_ropesnap,
    run_gantry_tracking,
    tracking_trajectory,
)
from feedtune.machines.gantry.twin import GantryTwin, GantryTwinParams, continuous_system, encoder_matrix
from feedtune.models.gantry import THESIS_GANTRY as MODEL
from feedtune.sim.contour import circle, diamond, thesis_path

FS = 15000.0
QUIET = {"noise_m": 0, "pwm_noise_v": 0, "floor_m": 0, "quantization_m": 0}


# ------------------------------------------------------------------------ controllers for the tests
class SidePD:
    """Independent PD per side with a low-pass on the derivative (the gantry controller interface)."""

    controller = "test-pd"
    source = "tests"
    delay_samples = 1

    def __init__(self, bandwidth_hz: float = 20.0, gain: float = 1.0, preview: int = 0) -> None:
        w = 2 * math.pi * bandwidth_hz
        m = MODEL.m / 2
        self.kp, self.kd = gain * m * w * w / 3, gain * m * w
        self.fs, self.preview_samples = FS, preview
        self.a = math.exp(-2 * math.pi * 500 / FS)
        self.reset()

    def reset(self) -> None:
        self.prev = None
        self.d = [0.0, 0.0]

    def check_target(self, fs: float) -> None:
        assert fs == self.fs

    def step(self, r, y1, y2, x):
        e = (r - y1, r - y2)
        if self.prev is None:
            self.prev = e
        out = []
        for i in range(2):
            self.d[i] = self.a * self.d[i] + (1 - self.a) * (e[i] - self.prev[i]) * self.fs
            out.append(self.kp * e[i] + self.kd * self.d[i])
        self.prev = e
        return out[0], out[1]


class AxisPD(SidePD):
    """PD on the table (the x-axis controller interface)."""

    def __init__(self, bandwidth_hz: float = 20.0) -> None:
        super().__init__(bandwidth_hz)
        w = 2 * math.pi * bandwidth_hz
        self.kp, self.kd = MODEL.m_x * w * w / 3, MODEL.m_x * w

    def step(self, r, x):
        return super().step(r, x, x, x)[0]


class Silent(SidePD):
    """Zero command (open loop)."""

    def step(self, r, y1, y2, x):
        return 0.0, 0.0


class SilentAxis(SidePD):
    def step(self, r, x):
        return 0.0


# ------------------------------------------------------------------------------------ analytic responses
def test_continuous_response_is_eq_4_4_plus_base_and_structural_modes():
    f = np.geomspace(2, 2000, 200)
    s = 2j * np.pi * f
    x = 0.2
    ideal = GantryTwin(GantryTwinParams.ideal()).frequency_response(f, x, sampled=False)
    assert np.allclose(ideal, MODEL.frequency_response(f, x), rtol=1e-9)  # eq. 4.4
    p = GantryTwinParams().with_overrides({"amp_hz": 2000.0, "amp_zeta": 0.5})  # y amplifiers (off by default)
    m = MODEL.m
    expected = MODEL.frequency_response(f, x).copy()
    wb = 2 * np.pi * p.base_hz
    # relative coordinates: y = G f + [1, 1] (f1 + f2) / (m_b (s^2 + 2 zeta wb s + wb^2))
    expected += 1.0 / (p.base_mass_ratio * m * (s**2 + 2 * p.base_zeta * wb * s + wb**2))
    for mode in (p.mode320, p.bending, p.mode940):
        w = 2 * np.pi * mode.freq_hz
        phi = np.asarray(mode.shape)
        expected += np.outer(phi, phi)[:, :, None] * mode.gain / m / (s**2 + 2 * mode.zeta * w * s + w**2)
    wa = 2 * np.pi * p.amp_hz  # the forces are the commands through the amplifiers' 2nd-order low-pass
    expected *= wa**2 / (s**2 + 2 * p.amp_zeta * wa * s + wa**2)
    got = GantryTwin(p).frequency_response(f, x, sampled=False)
    assert np.allclose(got, expected, rtol=1e-8, atol=0)


def test_axis_response_is_the_table_mass_plus_its_modes_behind_the_amplifier():
    f = np.geomspace(2, 2000, 200)
    s = 2j * np.pi * f
    ideal = GantryTwin(GantryTwinParams.ideal()).axis_frequency_response(f, sampled=False)
    assert np.allclose(ideal, 1.0 / (MODEL.m_x * s**2), rtol=1e-9)  # eq. 4.17's double integrator
    p = GantryTwinParams()
    expected = 1.0 / (MODEL.m_x * s**2)
    for mode in (p.x_mode186, p.x_mode332, p.x_mode404):
        w = 2 * np.pi * mode.freq_hz  # shape = (at the motor, at the encoder)
        expected += mode.shape[0] * mode.shape[1] * mode.gain / MODEL.m_x / (s**2 + 2 * mode.zeta * w * s + w**2)
    wa = 2 * np.pi * p.x_amp_hz
    expected *= wa**2 / (s**2 + 2 * p.x_amp_zeta * wa * s + wa**2)
    twin = GantryTwin(p)
    assert np.allclose(twin.axis_frequency_response(f, sampled=False), expected, rtol=1e-8, atol=0)
    # the sampled response: exact ZOH discretization and one sample of delay (python-control as the reference)
    control = pytest.importorskip("control")
    from feedtune.machines.gantry.twin import axis_encoder_row

    A, B = continuous_system(p, 0.0)
    sysd = control.c2d(control.ss(A, B[:, 2:3], axis_encoder_row(p)[None], np.zeros((1, 1))), 1 / FS, "zoh")
    fk = np.array([1.0, 130.0, 186.0, 404.0, 3000.0])
    z = np.exp(2j * np.pi * fk / FS)
    ref = np.array([complex(np.squeeze(sysd(zk))) / zk for zk in z])
    assert np.allclose(twin.axis_frequency_response(fk), ref, rtol=1e-7)


def test_sampled_response_is_the_zoh_discretization_with_one_sample_delay():
    control = pytest.importorskip("control")
    p = GantryTwinParams()
    x = -0.1
    A, B = continuous_system(p, x)
    C = encoder_matrix(p, x)
    sysd = control.c2d(control.ss(A, B[:, :2], C, np.zeros((2, 2))), 1 / FS, "zoh")
    f = np.array([1.0, 23.0, 94.0, 216.0, 382.0, 3000.0])
    z = np.exp(2j * np.pi * f / FS)
    ref = np.stack([sysd(zk) / zk for zk in z], axis=-1)
    got = GantryTwin(p).frequency_response(f, x)
    assert np.allclose(got, ref, rtol=1e-7)


def test_interpolated_discrete_matrices_are_exact_on_the_grid_and_close_between():
    twin = GantryTwin()
    for x in (0.0, 0.3):  # grid points (5 mm grid)
        Ad, Bd = twin.discrete_system(x)
        Ai, Bi = twin.interpolated_system(x)
        assert np.max(np.abs(Ai - Ad)) < 1e-12 * np.max(np.abs(Ad))  # batched vs single expm: rounding only
        assert np.max(np.abs(Bi - Bd)) < 1e-12 * np.max(np.abs(Bd))
    for x in (0.0025, -0.4975, 0.2475):  # mid-grid: measured 9e-6 relative on Bd
        Ad, Bd = twin.discrete_system(x)
        Ai, Bi = twin.interpolated_system(x)
        assert np.max(np.abs(Ai - Ad)) < 1e-6 * np.max(np.abs(Ad))
        assert np.max(np.abs(Bi - Bd)) < 3e-5 * np.max(np.abs(Bd))


def test_table_force_deflects_the_table_by_the_thesis_compliance():
    # §4.5: 32.5 N/um; 57 N -> 1.754 um. Static pitch deflection from the pitch block of (A, B)
    p = GantryTwinParams()
    A, B = continuous_system(p, 0.0)
    q = -np.linalg.solve(A[10:12, 10:12], B[10:12, 3] * 57.0 / p.force_constant_n_per_v)
    assert q[0] == pytest.approx(57.0 / 32.5e6, rel=1e-9)
    assert not B[10:12, :3].any()  # the motors do not excite pitching


def test_yaw_mode_and_x_dependence_as_eq_4_16():
    twin = GantryTwin(GantryTwinParams.ideal())
    for x in (-0.3, 0.0, 0.3):
        eig = np.linalg.eigvals(continuous_system(twin.params, x)[0])
        wn = np.max(np.abs(eig)) / (2 * np.pi)  # |lambda| of the yaw pair = sqrt(k / J(x))
        assert wn == pytest.approx(math.sqrt(MODEL.k / MODEL.inertia(x)) / (2 * np.pi), rel=1e-9)
    assert MODEL.yaw_mode(0.0).freq_hz == pytest.approx(94.3, abs=0.05)


# ------------------------------------------------------------------------------------ sampling effects
def test_encoders_read_multiples_of_the_resolution_and_carry_noise():
    twin = GantryTwin()
    q = twin.params.quantization_m
    n = 3000
    run = twin.simulate(HoldingController.for_twin(twin), AxisHoldingController.for_twin(twin), np.full(n, 1e-4),
                        x_ref=0.1, seed=3)
    for sig in (run.y1, run.y2, run.x):
        assert np.allclose(sig / q, np.round(sig / q), rtol=0, atol=1e-6)
    quiet = GantryTwin(GantryTwinParams().with_overrides({"quantization_m": 0, "pwm_noise_v": 0}))
    r = quiet.simulate(Silent(), SilentAxis(), np.zeros(n), seed=4)
    enc_noise = r.y1 - r.y1_true - (r.y1 - r.y1_true).mean()  # modes stay at rest without forces
    assert np.std(enc_noise) == pytest.approx(1e-9, rel=0.1)


def test_one_sample_of_computational_delay_and_saturation():
    twin = GantryTwin(GantryTwinParams.ideal().with_overrides({"u_max": 10.0}))
    n, k0 = 60, 20
    exc = np.zeros((n, 2))
    exc[k0:, 0] = 25.0  # saturates at 10 V
    run = twin.simulate(Silent(), SilentAxis(), np.zeros(n), excitation=exc, seed=0)
    assert np.all(run.u1[k0:] == 10.0) and np.all(run.u1[:k0] == 0.0)
    moved = np.flatnonzero(run.y1 != 0.0)
    assert moved[0] == k0 + 2  # command at k0, held from k0 + 1, first seen by the encoder at k0 + 2
    # one held step of 10 V on u1 from rest: y1 = (Cd Bd)[0, 0] * 10 V of eq. 4.3's exact ZOH (scipy)
    from scipy.signal import cont2discrete

    A, B, C = MODEL.state_space(0.0)
    _, Bd, Cd, _, _ = cont2discrete((A, B, C, np.zeros((2, 2))), 1 / FS, method="zoh")
    assert run.y1[k0 + 2] == pytest.approx((Cd @ Bd)[0, 0] * 10.0, rel=1e-9)


def test_python_and_numba_engines_agree():
    twin = GantryTwin()
    tr = tracking_trajectory({"distance": 0.002, "v_max": 0.05, "a_max": 1.0, "j_max": 100.0}, FS)
    runs = [twin.simulate(SidePD(), AxisPD(), tr.pos[:1500], x_ref=0.05, seed=1, engine=e) for e in ("numba", "python")]
    for name in ("y1", "y2", "x", "u1", "u2", "ux", "y_table"):
        assert np.allclose(getattr(runs[0], name), getattr(runs[1], name), rtol=0, atol=1e-15)


def test_table_reaction_turns_the_gantry_in_proportion_to_the_arm():
    peaks = []
    for arm in (0.0, 0.05, 0.1):
        twin = GantryTwin(GantryTwinParams.ideal().with_overrides({"x_reaction_arm_m": arm}))
        tr = tracking_trajectory({"distance": 0.1, "v_max": 0.2, "a_max": 2.0, "j_max": 50.0}, FS)
        run = twin.simulate(Silent(), AxisPD(), np.zeros(tr.n), x_ref=tr.pos - 0.05, seed=0)
        peaks.append(np.max(np.abs(run.y2_true - run.y1_true)))
    assert peaks[0] == 0.0
    assert peaks[2] / peaks[1] == pytest.approx(2.0, rel=1e-6)


def test_unstable_controller_trips_with_a_clear_message():
    twin = GantryTwin()
    tr = tracking_trajectory("200mm_s", FS)
    res = run_gantry_tracking(twin, SidePD(gain=-1.0), tr, AxisPD())
    assert res.tripped and res.metrics is None
    assert "following-error trip" in res.run.trip_message and "0.5 mm" in res.run.trip_message
    assert res.log.meta["trip"] == res.run.trip_message
    assert res.log.t[-1] < 0.2  # stopped early
    with pytest.raises(UsageError, match="table travel"):
        twin.simulate(SidePD(), AxisPD(), np.zeros(10), x_ref=0.7)


# ------------------------------------------------------------------------------------ identification
@pytest.fixture(scope="module")
def frf_runs():
    twin = GantryTwin()
    xs = (-0.4, 0.0, 0.4)
    return twin, xs, [measure_gantry_frf(twin, x, seed=1) for x in xs]


def test_measured_frf_agrees_with_the_analytic_response_near_the_yaw_mode(frf_runs):
    twin, xs, runs = frf_runs
    for x, res in zip(xs, runs, strict=True):
        frf = res.frf
        assert frf.outputs == ("y1", "y2") and frf.inputs == ("u1", "u2") and frf.output_unit == "m"
        f = frf.freq_hz
        band = (f > 0.85 * MODEL.yaw_mode(x).freq_hz) & (f < 1.15 * MODEL.yaw_mode(x).freq_hz)
        good = band & np.all(frf.coherence > 0.999, axis=(0, 1))
        assert good.sum() >= 8
        G = twin.frequency_response(f[good], x, sampled=False)  # delay and ZOH phase removed by default
        err = np.abs(frf.response[..., good] - G) / np.abs(G)
        assert np.max(err) < 0.05  # measured: 2.0 % max (PWM, floor and encoder noise)


def test_measured_axis_frf_agrees_with_the_analytic_response():
    from feedtune.machines.gantry.experiments import measure_axis_frf

    twin = GantryTwin()
    res = measure_axis_frf(twin, 0.1, seed=1)
    frf = res.frf
    assert list(frf.channels) == ["x/ux"] and frf.output_unit == "m" and frf.input_unit == "V"
    assert set(res.log.signals) >= {"rx", "ux", "x", "u1", "u2"} and res.summary["delay_removed"]
    f = frf.freq_hz
    err = np.abs(frf.response[0, 0] / twin.axis_frequency_response(f, sampled=False) - 1)
    band = (f >= 50.0) & (f <= 500.0)  # the loop-shaping band; measured 0.8 % to 200 Hz, 2.6 % to 500 Hz
    assert np.max(err[band]) < 0.05


def test_new_parameters_override_and_validate():
    p = GantryTwinParams().with_overrides({"x_mode186.gain": "0.02", "mode940": "none", "x_amp_hz": "none",
                                           "amp_hz": "1500", "x_mode404.shape": "1,-1"})
    assert p.x_mode186.gain == 0.02 and p.mode940 is None and p.x_amp_hz is None and p.amp_hz == 1500.0
    assert p.x_mode404.shape == (1.0, -1.0)
    A, B = continuous_system(p, 0.0)
    assert not A[12:14].any() and B[15, 0] > 0 and not B[27].any()  # 940 Hz mode off, y amplifier on, x off
    with pytest.raises(UsageError, match="amp_hz = 8000 Hz is above the Nyquist"):
        GantryTwinParams().with_overrides({"amp_hz": 8000})
    with pytest.raises(UsageError, match=r"x_mode332\.freq_hz"):
        GantryTwinParams().with_overrides({"x_mode332.freq_hz": 9000})


def test_frf_estimate_is_exact_without_noise():
    twin = GantryTwin(GantryTwinParams().with_overrides(QUIET))
    res = measure_gantry_frf(twin, 0.1, seed=0, f_hi=400.0, remove_delay=False)
    f = res.frf.freq_hz
    G = twin.frequency_response(f, 0.1)  # sampled, with the delay
    err = np.abs(res.frf.response - G) / np.abs(G)
    yaw_band = (f >= 60.0) & (f <= 300.0)
    assert np.max(err[..., yaw_band]) < 1e-3  # measured 3e-4
    assert np.max(err) < 5e-3  # measured 1.3e-3 near 44 Hz (slow closed-loop transients of the holding loop)


def test_fit_gantry_on_measured_frfs_recovers_eq_4_16(frf_runs):
    _, xs, runs = frf_runs
    fit = fit_gantry([r.frf for r in runs], xs, L=MODEL.L)
    for name in ("J0", "d", "m_x", "c", "k"):
        assert getattr(fit.model, name) == pytest.approx(getattr(MODEL, name), rel=0.05), name
    # measured: J0 +0.07 %, d +0.06 %, m_x -0.1 %, c +0.05 %, k +0.03 %; the 320/382 Hz modes lie above the band
    assert all(f.band_hz[1] < 300.0 for f in fit.fits)


def test_mass_runs_recover_mass_distribution_and_table_mass():
    twin = GantryTwin()
    xs = (-0.3, 0.3)
    runs, axis = measure_mass(twin, xs, move={"distance": 0.05}, seed=2)
    fit = fit_mass_distribution([r.log for r in runs], xs, acc_ref="ay_ref")
    assert fit.m == pytest.approx(MODEL.m, rel=0.02)  # measured +0.5 %
    for x in xs:
        assert fit.alpha(x)[0] == pytest.approx(MODEL.alpha(x)[0], rel=0.01)  # measured 0.1 %
    assert fit_axis_mass(axis.log, u="ux", acc_ref="a_ref") == pytest.approx(MODEL.m_x, rel=0.02)


# ------------------------------------------------------------------------------------ experiments
def test_ropesnap_tracking_and_contour_logs():
    twin = GantryTwin()
    rope = run_gantry_ropesnap(twin, HoldingController.for_twin(twin), None, t_release=0.3, after_s=0.3)
    assert not rope.tripped
    for name in ("y_table", "y1", "y2", "u1", "u2", "F_table"):
        assert name in rope.log
    before = rope.log.t < 0.3
    assert rope.log["F_table"][before][-1] == pytest.approx(-57.0 / 30.0)
    assert rope.summary["peak_um"] > 0 and rope.metrics.t_release == pytest.approx(0.3, abs=1e-4)
    tr = tracking_trajectory("200mm_s", FS)
    track = run_gantry_tracking(twin, SidePD(30.0), tr, AxisPD(), x=0.1)
    assert set(track.log.signals) >= {"y_ref", "vy_ref", "ay_ref", "y1", "y2", "u1", "u2", "e1", "e2"}
    assert track.summary["max_um"] == pytest.approx(np.max(np.abs(track.log["e1"])) * 1e6, rel=0.5)
    path = diamond(0.02, v_max=0.05, a_max=1.0, j_max=50.0, fs=FS, start=(0.05, 0.0))
    res = run_contour(twin, SidePD(30.0), AxisPD(30.0), path)
    assert not res.tripped
    e = res.log["contour_error"]
    assert res.summary["max_um"] == pytest.approx(np.max(np.abs(e)) * 1e6)
    assert np.all(np.abs(res.log["x"] - res.log["x_ref"]) < 1e-3)


def test_real_gantry_runtime_runs_on_the_twin():
    from feedtune.control.filters import FilterPack, LeadStage, Notch
    from feedtune.design.gantry_mimo import design_gantry_mimo
    from feedtune.design.loopshape import design_loopshape
    from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
    from feedtune.machines import load_runtime

    h = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                    450.0, 2, 0.7, [LeadStage(154.0, 70.0)])
    mimo = load_runtime(gantry_gains_document(design_gantry_mimo(MODEL, filters=h)))
    x_filters = FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0)
    ax = load_runtime(axis_gains_document(design_loopshape(MODEL.m_x, crossover_hz=130.0, pm_deg=35.0,
                                                           filters=x_filters)))
    twin = GantryTwin()
    path = circle(0.05, v_max=0.2, a_max=2.0, j_max=50.0, fs=FS, start=(0.1, 0.0), dwell_after=0.05)
    res = run_contour(twin, mimo, ax, path)
    assert not res.tripped, res.run.trip_message
    assert res.summary["max_um"] < 2.0  # thesis (200 mm circle): 1.9 um; measured here 0.05 um


# ------------------------------------------------------------------------------------ contour paths
@pytest.mark.parametrize("make", [circle, diamond])
@pytest.mark.parametrize(("clockwise", "s_max"), [(False, None), (True, None), (False, 2500.0)])
def test_contour_paths_are_closed_feed_limited_and_exactly_differentiated(make, clockwise, s_max):
    path = make(0.2, v_max=0.2, a_max=2.0, j_max=50.0, s_max=s_max, fs=FS, start=(0.1, -0.05), clockwise=clockwise,
                dwell_before=0.01, dwell_after=0.01)
    h = 1 / FS
    assert np.max(path.feed) <= 0.2 * (1 + 1e-12)
    assert np.max(path.feed) == pytest.approx(0.2, rel=1e-9)
    names = ("pos", "vel", "acc", "jerk", "snap")
    pairs = [("pos", "vel"), ("vel", "acc"), ("acc", "jerk")] + ([("jerk", "snap")] if s_max else [])
    for ax in (path.x, path.y):
        assert ax.pos[-1] == pytest.approx(ax.pos[0], abs=1e-15)  # closed: ends where it started
        assert ax.vel[0] == 0.0 and ax.vel[-1] == 0.0
        for lo_name, hi_name in pairs:  # central differences, away from the knots where ``hi`` jumps
            lo, hi = getattr(ax, lo_name), getattr(ax, hi_name)
            top = np.max(np.abs(hi))
            smooth = np.ones(hi.size, bool)
            smooth[1:-1] = (np.abs(np.diff(hi)[1:]) < 0.01 * top) & (np.abs(np.diff(hi)[:-1]) < 0.01 * top)
            num = np.gradient(lo, h)
            i = names.index(hi_name)
            nxt = np.max(np.abs(getattr(ax, names[i + 1]))) if i + 1 < len(names) else 0.0
            assert smooth[1:-1].mean() > 0.99
            # central difference: exact to O(h^2) on smooth parts, h * |next derivative| next to its knots
            assert np.max(np.abs(num - hi)[1:-1][smooth[1:-1]]) < 1e-3 * top + h * nxt, (lo_name, hi_name)
    assert path.contour_error(path.x.pos, path.y.pos).max_abs < 1e-15
    k = np.flatnonzero(path.feed > 0)[10]  # just after the start
    turn = -1.0 if clockwise else 1.0
    if make is circle:  # from the rightmost point: up (counter-clockwise) or down (clockwise)
        assert np.sign(path.y.vel[k]) == turn
    else:  # from the lowest corner: up-right (counter-clockwise) or up-left (clockwise)
        assert path.y.vel[k] > 0 and np.sign(path.x.vel[k]) == turn


def test_circle_contour_error_matches_the_polyline_metric_and_sign():
    from feedtune.analysis.metrics import contour_error

    path = circle(0.2, v_max=0.2, a_max=2.0, j_max=50.0, fs=FS)
    cx, cy = path.centre
    th = np.linspace(0, 2 * np.pi, 20001)
    poly_x, poly_y = cx + 0.1 * np.cos(th), cy + 0.1 * np.sin(th)
    rng = np.random.default_rng(0)
    ang = rng.uniform(0, 2 * np.pi, 50)
    rad = 0.1 + rng.uniform(-5e-6, 5e-6, 50)
    px, py = cx + rad * np.cos(ang), cy + rad * np.sin(ang)
    exact = path.contour_error(px, py).distance
    poly = contour_error(poly_x, poly_y, px, py).distance
    sagitta = 0.1 * (1 - np.cos(np.pi / 20000))
    assert np.max(np.abs(exact - poly)) < 2 * sagitta
    assert np.all(np.sign(exact) == np.sign(0.1 - rad))  # counter-clockwise: inside is positive


def test_thesis_features_and_bad_sizes():
    p = thesis_path("diamond", "1um", fs=FS)
    assert p.size_m == 1e-6 and np.max(p.feed) <= 1e-6 * (1 + 1e-12)
    with pytest.raises(UsageError):
        circle(-1.0, v_max=0.1, a_max=1.0, j_max=10.0)
    with pytest.raises(UsageError):
        thesis_path("square", "1mm")
