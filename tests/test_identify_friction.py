"""Stribeck model, Kalman disturbance estimate and Stribeck identification (thesis eq. 2.1, §2.1.3)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from friction_sim import Axis, simulate, trapezoid

from feedtune.errors import DataError, IllConditionedError, UsageError
from feedtune.identify.friction import fit_stribeck, identify_friction
from feedtune.identify.kalman import discrete_model, estimate_disturbance, steady_state_gain
from feedtune.identify.rigid import fit_rigid
from feedtune.log import Log
from feedtune.models.ballscrew import BallScrewModel
from feedtune.models.friction import StribeckFriction
from feedtune.models.rigid import RigidBodyModel

MASS, VISCOUS = 20.0, 40.0  # kg, N/(m/s) of the simulated axis
TRUTH = StribeckFriction(dc_pos=12.0, ds_pos=20.0, dc_neg=-10.0, ds_neg=-17.0, omega_pos=0.008)
FIT_NAMES = ("dc_pos", "ds_pos", "dc_neg", "ds_neg", "omega_pos", "omega_negative")


# ------------------------------------------------------------------------------------ test simulator
def _simulate(friction: StribeckFriction, *, fs: float = 1000.0, substeps: int = 10, quant: float = 0.5e-6,
              seed: int = 0):
    """``m x'' = u - b x' - d(x')`` under a PID loop (15 Hz) with model feedforward, sampled at ``fs``, along
    trapezoids to +-0.004 .. 0.08 m/s (:mod:`friction_sim`: ZOH command, quantised position with 0.2 um noise);
    the log (``x`` [m], ``u`` [N]) and the true velocity at the samples."""
    axis = Axis(mass=MASS, viscous=VISCOUS, dc_pos=friction.dc_pos, ds_pos=friction.ds_pos, dc_neg=friction.dc_neg,
                ds_neg=friction.ds_neg, omega=friction.omega_pos, omega_neg=friction.omega_negative)
    return simulate(axis, trapezoid((0.004, 0.01, 0.02, 0.04, 0.08), 0.1, 0.3, fs), fs=fs, substeps=substeps,
                    quant=quant, noise_x=0.2e-6, bandwidth_hz=15.0, seed=seed, true_velocity=True)


@pytest.fixture(scope="module")
def closed_loop():
    return _simulate(TRUTH)


def _assert_close_to(friction: StribeckFriction, truth: StribeckFriction, rel: float) -> None:
    for name in FIT_NAMES:
        assert getattr(friction, name) == pytest.approx(getattr(truth, name), rel=rel), name


# ------------------------------------------------------------------------------------ Stribeck model
def test_stribeck_force_by_hand():
    f = StribeckFriction(dc_pos=10.0, ds_pos=15.0, dc_neg=-8.0, ds_neg=-12.0, omega_pos=0.01, omega_neg=0.02)
    v = np.array([0.01, 0.0, -0.02, 1.0])
    expected = [10.0 + 5.0 * math.exp(-1.0), 0.0, -8.0 - 4.0 * math.exp(-1.0), 10.0]
    assert f.force(v) == pytest.approx(expected, rel=1e-12)
    assert f.force(0.0) == 0.0
    d = f.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["units"]["dc_pos"] == "N" and d["units"]["omega_neg"] == "m/s" and d["omega_neg"] == 0.02


def test_stribeck_smoothed_is_linear_inside_band_and_exact_outside():
    f = StribeckFriction(dc_pos=10.0, ds_pos=15.0, dc_neg=-8.0, ds_neg=-12.0, omega_pos=0.01)
    eps = 0.002
    edge_pos, edge_neg = 10.0 + 5.0 * math.exp(-0.2), -8.0 - 4.0 * math.exp(-0.2)
    assert f.smoothed([0.0, 0.001, -0.0005], eps) == pytest.approx([0.0, edge_pos / 2, edge_neg / 4])
    v = np.array([-0.5, -0.002, 0.002, 0.03])
    assert f.smoothed(v, eps) == pytest.approx(f.force(v))
    with pytest.raises(UsageError, match="v_eps"):
        f.smoothed(v, 0.0)


def test_stribeck_rejects_bad_parameters():
    with pytest.raises(DataError, match="omega_pos"):
        StribeckFriction(1.0, 2.0, -1.0, -2.0, omega_pos=0.0)
    with pytest.raises(DataError, match="velocity_unit"):
        StribeckFriction(1.0, 2.0, -1.0, -2.0, omega_pos=0.1, velocity_unit="mm/s")


# ---------------------------------------------------------------------------------------- the filter
def test_discrete_model_matches_python_control_and_closed_form():
    control = pytest.importorskip("control")
    m, b, dt, q = 3.0, 2.0, 1e-3, 5.0
    F, B, _ = discrete_model(m, b, dt, q)
    A = np.array([[0.0, 1.0, 0.0], [0.0, -b / m, -1.0 / m], [0.0, 0.0, 0.0]])
    sysd = control.c2d(control.ss(A, [[0.0], [1.0 / m], [0.0]], np.eye(3), np.zeros((3, 1))), dt, "zoh")
    assert np.allclose(F, sysd.A, rtol=1e-12, atol=1e-15)
    assert np.allclose(B, np.asarray(sysd.B).ravel(), rtol=1e-12, atol=1e-18)
    # without viscous friction the Van Loan integral has a closed form (triple-integrator chain)
    _, _, Q = discrete_model(m, 0.0, dt, q)
    expected = q * np.array([
        [dt**5 / (20 * m**2), dt**4 / (8 * m**2), -(dt**3) / (6 * m)],
        [dt**4 / (8 * m**2), dt**3 / (3 * m**2), -(dt**2) / (2 * m)],
        [-(dt**3) / (6 * m), -(dt**2) / (2 * m), dt],
    ])
    assert np.allclose(Q, expected, rtol=1e-8, atol=0.0)


def test_steady_state_gain_matches_riccati_iteration():
    m, b, dt, r = 20.0, 40.0, 1e-3, 1e-13
    q = m**2 * r * dt * (2 * math.pi * 50.0) ** 6
    F, _, Q = discrete_model(m, b, dt, q)
    K, P = steady_state_gain(F, Q, r, m, dt)
    H = np.array([[1.0, 0.0, 0.0]])
    Pi = np.eye(3)
    for _ in range(5000):  # plain Riccati recursion of the time-varying filter
        Ki = Pi @ H.T / (H @ Pi @ H.T + r)
        Pi = F @ (Pi - Ki @ H @ Pi) @ F.T + Q
    assert np.allclose(P, Pi, rtol=1e-6, atol=0.0)
    assert np.allclose(K, (Pi @ H.T / (H @ Pi @ H.T + r)).ravel(), rtol=1e-6)


def test_filterpy_and_steady_state_agree_after_the_transient(closed_loop):
    log = closed_loop[0].slice(None, 2.0)
    opts = {"position": "x", "command": "u", "mass": MASS, "viscous": VISCOUS}
    fast = estimate_disturbance(log, **opts)
    ref = estimate_disturbance(log, method="filterpy", **opts)
    settled = log.t >= 0.2  # the time-varying filter starts from a wide covariance
    assert np.max(np.abs(fast.disturbance - ref.disturbance)[settled]) < 1e-4  # N, on ~15 N
    assert np.max(np.abs(fast.velocity - ref.velocity)[settled]) < 1e-8  # m/s
    assert np.max(np.abs(fast.position - ref.position)[settled]) < 1e-10  # m
    assert np.max(np.abs(fast.disturbance - ref.disturbance)[:20]) > 1e-3  # they did start differently


def test_disturbance_estimate_is_exact_on_zoh_data():
    """Noise-free data made with an independent exact ZOH discretisation: d_hat settles on the true offset
    and stays there through every command step (the command sample k acts on [t_k, t_k+1))."""
    from scipy.signal import cont2discrete

    m, b, d, dt = 2.0, 0.5, 3.0, 1e-3
    Ad, Bd, *_ = cont2discrete((np.array([[0.0, 1.0], [0.0, -b / m]]), np.array([[0.0], [1.0 / m]]),
                                np.eye(2), np.zeros((2, 1))), dt, method="zoh")
    u = np.repeat(np.random.default_rng(7).uniform(-20.0, 20.0, 40), 50)
    state = np.zeros((u.size, 2))
    for k in range(1, u.size):
        state[k] = Ad @ state[k - 1] + Bd[:, 0] * (u[k - 1] - d)
    log = Log(np.arange(u.size) * dt, {"x": state[:, 0], "u": u}, {"x": "m", "u": "N"})
    est = estimate_disturbance(log, position="x", command="u", mass=m, viscous=b, r_position=1e-14)
    settled = log.t >= 0.2
    assert np.max(np.abs(est.disturbance[settled] - d)) < 1e-5
    assert np.max(np.abs(est.velocity - state[:, 1])[settled]) < 1e-8


def test_disturbance_estimate_follows_the_true_friction(closed_loop):
    log, v_true = closed_loop
    est = estimate_disturbance(log, position="x", command="u", mass=MASS, viscous=VISCOUS)
    assert est.observer_poles_hz == pytest.approx([50.0, 50.0, 50.0], rel=0.01)  # min(0.05 fs, 50 Hz)
    sliding = est.after_transient() & (np.abs(v_true) > 0.003)
    err = est.disturbance[sliding] - TRUTH.force(v_true[sliding])
    assert np.sqrt(np.mean(err**2)) < 0.5  # N, on a friction of 10..20 N (measured 0.28 N)
    assert np.max(np.abs(est.velocity - v_true)[est.after_transient()]) < 2e-3  # m/s
    summary = est.to_dict()
    json.dumps(summary, allow_nan=False)
    assert summary["units"]["disturbance"] == "N" and summary["units"]["q_disturbance"] == "N^2/s"
    assert set(est.to_log().signals) == {"x_hat", "v_hat", "d_hat"}
    assert len(est.to_dict(include_series=True)["disturbance"]) == log.n


# ---------------------------------------------------------------------------------- Stribeck fitting
def test_fit_stribeck_recovers_noise_free_curve_and_subtracts_viscous():
    v = np.concatenate([np.linspace(0.001, 0.1, 400), -np.linspace(0.001, 0.1, 400)])
    fit = fit_stribeck(v, TRUTH.force(v) + 25.0 * v, viscous=25.0, min_speed=0.0005)
    _assert_close_to(fit.friction, TRUTH, rel=1e-6)
    assert fit.rms_error < 1e-6
    assert fit.coulomb == pytest.approx(11.0) and fit.offset == pytest.approx(1.0)
    json.dumps(fit.to_dict(), allow_nan=False)


def test_fit_stribeck_per_direction_omega():
    truth = StribeckFriction(12.0, 20.0, -10.0, -17.0, omega_pos=0.008, omega_neg=0.015)
    v = np.concatenate([np.linspace(0.001, 0.1, 400), -np.linspace(0.001, 0.1, 400)])
    noise = np.random.default_rng(3).normal(0.0, 0.05, v.size)
    fit = fit_stribeck(v, truth.force(v) + noise, per_direction_omega=True, min_speed=0.0005)
    _assert_close_to(fit.friction, truth, rel=0.05)
    assert fit.std["omega_neg"] < 0.1 * truth.omega_negative


def test_fit_stribeck_without_stribeck_effect_stays_bounded():
    """Pure Coulomb friction (ds = dc): Omega is not identifiable but stays inside its speed-based bounds,
    so the levels remain finite and the Coulomb levels are right."""
    coulomb = StribeckFriction(12.0, 12.0, -10.0, -10.0, omega_pos=0.01)
    v = np.concatenate([np.linspace(0.002, 0.1, 500), -np.linspace(0.002, 0.1, 500)])
    noise = np.random.default_rng(5).normal(0.0, 0.2, v.size)
    fit = fit_stribeck(v, coulomb.force(v) + noise)
    assert fit.friction.dc_pos == pytest.approx(12.0, rel=0.02)
    assert fit.friction.dc_neg == pytest.approx(-10.0, rel=0.02)
    lo, hi = fit.omega_bounds["pos"]
    assert lo <= fit.friction.omega_pos <= hi
    assert abs(fit.friction.ds_pos) < 100.0 and abs(fit.friction.ds_neg) < 100.0
    json.dumps(fit.to_dict(), allow_nan=False)


def test_fit_stribeck_ill_conditioned_cases():
    v = np.concatenate([np.full(300, 0.05), np.full(300, -0.05)]) + np.random.default_rng(0).normal(0, 1e-4, 600)
    with pytest.raises(IllConditionedError, match="range of speeds"):
        fit_stribeck(v, TRUTH.force(v))
    v = np.linspace(0.001, 0.1, 500)
    with pytest.raises(IllConditionedError, match="too few samples with v < 0"):
        fit_stribeck(v, TRUTH.force(v))
    with pytest.raises(DataError, match="samples"):
        fit_stribeck(v, TRUTH.force(v)[:-1])
    with pytest.raises(DataError, match="NaN"):
        fit_stribeck(np.append(v, np.nan), np.append(TRUTH.force(v), 1.0))


# ------------------------------------------------------------------------- full identification (sim)
def test_identify_friction_recovers_the_simulated_truth(closed_loop):
    log, _ = closed_loop
    result = identify_friction(log, position="x", command="u", mass=MASS, viscous=VISCOUS)
    _assert_close_to(result.friction, TRUTH, rel=0.10)
    assert all(np.isfinite(s) for s in result.fit.std.values())
    assert not result.fit.omega_at_bound
    out = result.to_dict()
    json.dumps(out, allow_nan=False)
    assert out["units"]["mass"] == "N/(m/s^2)" and out["friction"]["units"]["omega_pos"] == "m/s"


def test_identify_friction_from_several_logs_recovers_the_simulated_truth(closed_loop):
    # the run cut in two files at a standstill between moves: each gets its own filter, one fit over both
    log, _ = closed_loop
    cut = log.t[log.n // 2]
    parts = [log.slice(None, cut), log.slice(cut, None)]
    result = identify_friction(parts, position="x", command="u", mass=MASS, viscous=VISCOUS)
    _assert_close_to(result.friction, TRUTH, rel=0.10)
    assert result.n_logs == 2 and result.to_dict()["n_logs"] == 2
    # without a mass: the joint fit of mass, viscous friction and the law runs over both logs as well
    joint = identify_friction(parts, position="x", command="u")
    assert joint.joint_fit is not None and joint.n_logs == 2
    assert joint.mass == pytest.approx(MASS, rel=0.02)
    _assert_close_to(joint.friction, TRUTH, rel=0.10)


def test_identify_friction_with_direction_dependent_omega():
    truth = StribeckFriction(12.0, 20.0, -10.0, -17.0, omega_pos=0.006, omega_neg=0.012)
    log, _ = _simulate(truth, seed=1)
    result = identify_friction(log, position="x", command="u", mass=MASS, viscous=VISCOUS,
                               per_direction_omega=True)
    _assert_close_to(result.friction, truth, rel=0.10)


def test_identify_friction_from_a_ball_screw_model(closed_loop):
    """Same dynamics read as screw rotation [rad] and volts; the log's position is table travel [m]."""
    log, _ = closed_loop
    lead = 0.01 / (2 * math.pi)
    table = Log(log.t, {"x": log["x"] * lead, "u": log["u"]}, {"x": "m", "u": "V"})
    model = BallScrewModel(m1=15.0, m2=5.0, b1=30.0, b2=10.0, k=1e6, c=0.0, lead_m_per_rad=lead)
    result = identify_friction(table, position="x", command="u", model=model)
    _assert_close_to(result.friction, TRUTH, rel=0.10)
    assert result.friction.velocity_unit == "rad/s" and result.friction.command_unit == "V"
    assert result.mass == 20.0 and result.viscous == 40.0


def test_identify_friction_from_a_rigid_body_model(closed_loop):
    log, _ = closed_loop
    direct = identify_friction(log, position="x", command="u", mass=MASS, viscous=VISCOUS)
    symmetric = identify_friction(log, position="x", command="u", model=RigidBodyModel(mass=MASS,
                                                                                       viscous=VISCOUS))
    assert symmetric.friction == direct.friction
    model = RigidBodyModel(mass=MASS, viscous=30.0, viscous_neg=50.0)  # asymmetric: mean 40 in the filter
    result = identify_friction(log, position="x", command="u", model=model)
    assert result.viscous == 40.0
    assert result.fit.viscous_pos == -10.0 and result.fit.viscous_neg == 10.0
    # the truth has 40 N/(m/s) both ways: the fit sees an extra +10 v (v > 0) that raises dc+ by 0..0.8 N
    assert 0.1 < result.friction.dc_pos - direct.friction.dc_pos < 0.8
    with pytest.raises(DataError, match="rigid-body model is in rad"):
        identify_friction(log, position="x", command="u", model=RigidBodyModel(mass=1.0, position_unit="rad"))


def test_identify_friction_ill_conditioned_logs():
    t = np.arange(4000) / 1000.0
    tri = np.where(t < 2.0, 0.05 * t, 0.2 - 0.05 * t)  # constant speeds, abrupt reversal
    u = np.where(t < 2.0, 1.0, -1.0) * (VISCOUS * 0.05 + 12.0)
    log = Log(t, {"x": tri, "u": u}, {"x": "m", "u": "N"})
    with pytest.raises(IllConditionedError, match="range of speeds"):
        identify_friction(log, position="x", command="u", mass=MASS, viscous=VISCOUS)
    ramp = Log(t, {"x": 0.05 * t, "u": np.full(t.size, 14.0)}, {"x": "m", "u": "N"})
    with pytest.raises(IllConditionedError, match="no acceleration"):
        identify_friction(ramp, position="x", command="u")  # mass from fit_rigid: impossible


def test_identify_friction_usage_errors(closed_loop):
    log = closed_loop[0].slice(None, 1.0)
    opts = {"position": "x", "command": "u"}
    with pytest.raises(UsageError, match="not both"):
        identify_friction(log, model=RigidBodyModel(mass=1.0), mass=2.0, **opts)
    with pytest.raises(UsageError, match="method"):
        estimate_disturbance(log, mass=MASS, method="ekf", **opts)
    with pytest.raises(UsageError, match="mass"):
        estimate_disturbance(log, mass=-1.0, **opts)
    with pytest.raises(UsageError, match="bandwidth_hz"):
        estimate_disturbance(log, mass=MASS, bandwidth_hz=400.0, **opts)
    with pytest.raises(UsageError, match="not both"):
        estimate_disturbance(log, mass=MASS, bandwidth_hz=20.0, q_disturbance=1.0, **opts)
    with pytest.raises(DataError, match="no signal"):
        estimate_disturbance(log, mass=MASS, position="x", command="missing")
    with pytest.raises(UsageError, match="mass must be a number"):
        identify_friction(log, mass="heavy", **opts)
    with pytest.raises(UsageError, match="reversal_guard_s"):
        identify_friction(log, mass=MASS, reversal_guard_s=-1.0, **opts)


# --------------------------------------------------------------------------------------------- EMPS
def test_emps_coulomb_levels_near_benchmark(real_data_dir):
    from scipy.io import loadmat

    d = loadmat(real_data_dir / "EMPS" / "DATA_EMPS.mat")
    log = Log(d["t"].ravel(), {"qm": d["qm"].ravel(), "vir": d["vir"].ravel()}, {"qm": "m", "vir": "V"})
    gtau, fc = 35.15065, 20.3935  # N/V; published IDIM-LS Coulomb friction [N]
    opts = {"position": "qm", "command": "vir", "command_scale": gtau}
    asym = fit_rigid(log, force="vir", position="qm", force_scale=gtau, asymmetric=True)
    result = identify_friction(log, model=asym.model, **opts)
    assert result.friction.dc_pos == pytest.approx(fc, rel=0.20)
    assert -result.friction.dc_neg == pytest.approx(fc, rel=0.20)
    assert result.friction.command_unit == "N"
    sym = fit_rigid(log, force="vir", position="qm", force_scale=gtau)
    result = identify_friction(log, model=sym.model, **opts)
    # a symmetric viscous model leaves the offset and the viscous asymmetry in the two levels;
    # their symmetric part is the Coulomb friction
    assert result.fit.coulomb == pytest.approx(fc, rel=0.20)
    # rigid first: the symmetric IDIM-LS fit is made on the same log first: same result as with its model
    first = identify_friction(log, joint=False, **opts)
    assert first.rigid_fit is not None and first.rigid_fit.values["mass"] == pytest.approx(95.1089, rel=0.02)
    assert first.friction == result.friction
    # without a model, by default: mass, viscous friction and the Stribeck law fitted together
    auto = identify_friction(log, **opts)
    assert auto.joint_fit is not None and auto.mass == pytest.approx(95.1089, rel=0.02)
    assert auto.fit.coulomb == pytest.approx(fc, rel=0.20)


# ------------------------------------------------------------------------------------- model file
def test_friction_model_file_round_trip_and_errors(tmp_path):
    from feedtune.io import load_model, save_model

    shared = StribeckFriction(0.1, 0.16, -0.09, -0.15, omega_pos=0.8, command_unit="V", velocity_unit="rad/s")
    split = StribeckFriction(12.0, 20.0, -10.0, -17.0, omega_pos=0.006, omega_neg=0.012)
    for k, model in enumerate((shared, split)):
        path = tmp_path / f"f{k}.toml"
        save_model(path, model, fit={"log": "run.csv"})
        assert load_model(path) == model
        assert load_model(path.with_suffix(".json")) == model
    text = (tmp_path / "f0.toml").read_text()
    assert 'kind = "friction"' in text and 'velocity_unit = "rad/s"' in text and "omega_neg" not in text
    bad = tmp_path / "bad.toml"
    for old, new, message in (('unit = "rad/s" }', 'unit = "m/s" }', "unit 'm/s' where 'rad/s' is expected"),
                              ('dc_pos = { value = 0.1, unit = "V" }\n', "", "params.dc_pos is missing"),
                              ('velocity_unit = "rad/s"', 'velocity_unit = "mm/s"', "velocity_unit = 'mm/s'"),
                              ("value = 0.8,", "value = -0.8,", "omega_pos must be > 0")):
        bad.write_text(text.replace(old, new, 1))
        with pytest.raises(DataError, match=message):
            load_model(bad)


def test_compiled_steady_state_pass_equals_scipy_dlsim_of_the_same_filter():
    """The time-invariant filter run sample by sample equals scipy's state-space simulation of
    ``s[k+1] = Phi s[k] + G e[k], x[k] = Phi s[k] + G e[k]`` (``e = [u[k-1], y[k]]``)."""
    from scipy.signal import dlsim

    from feedtune.identify.kalman import _run_steady_state

    m, dt = 2.0, 1e-4
    F, B, Q = discrete_model(m, 5.0, dt, 1e3)
    K, _ = steady_state_gain(F, Q, 1e-12, m, dt)
    rng = np.random.default_rng(5)
    u = rng.normal(size=4000)
    y = np.cumsum(rng.normal(size=4000)) * 1e-6
    got = _run_steady_state(F, B, K, u, y)
    IKH = np.eye(3) - np.outer(K, [1.0, 0.0, 0.0])
    Phi, G = IKH @ F, np.column_stack([IKH @ B, K])
    _, ref, _ = dlsim((Phi, G, Phi, G, 1.0), np.column_stack([u, y]))
    scale = np.max(np.abs(ref), axis=0)
    assert np.max(np.abs(got.T - ref) / scale) < 1e-10


def test_omega_on_its_bound_says_which_samples_min_speed_left_out():
    """examples/ballscrew_reversals.csv moves slowly through the low speeds (2 mm/s) before 50 and 200 mm/s: the
    default min_speed (2 % of the peak) leaves those samples out and Omega ends on its bound. The warning counts them
    and names the parameter (the option on the command line); with a lower min_speed Omega is resolved."""
    from pathlib import Path

    from feedtune.errors import cli_message
    from feedtune.io import read_log

    log = read_log(Path(__file__).resolve().parents[1] / "examples" / "ballscrew_reversals.csv")
    rigid = fit_rigid(log, force="u", position="x2")
    ident = identify_friction(log, position="x2", command="u", model=rigid.model)
    assert ident.fit.omega_at_bound
    w = next(w for w in ident.warnings if "Omega ended on its bound" in w)
    slow = int(w.split(": ")[1].split(" samples")[0])
    assert slow >= 100 and "pass a lower min_speed" in w and "--" not in w
    assert "pass a lower --min-speed" in cli_message(w)
    lower = identify_friction(log, position="x2", command="u", model=rigid.model, min_speed=0.1)
    assert not lower.fit.omega_at_bound and not any("Omega" in w for w in lower.warnings)
    assert lower.n_used >= ident.n_used + 0.5 * slow  # the slow samples entered the fit
