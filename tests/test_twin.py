"""The ball-screw twin: analytic responses, physics checks, FRF measurement, closed loop, safety trip."""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.analysis.ballscrew import analyze_ballscrew
from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.design.ppi import design_ppi
from feedtune.errors import DataError, UsageError
from feedtune.identify.ballscrew import fit_ballscrew
from feedtune.io.gains import gains_document
from feedtune.machines.ballscrew.experiments import measure_closed_loop, measure_frf, run_ropesnap, run_tracking
from feedtune.machines.ballscrew.runtime import GainsRuntime
from feedtune.machines.ballscrew.twin import BallScrewTwin, TwinParams, pitch_sos
from feedtune.models import THESIS_TABLE_3_1 as MODEL
from feedtune.sim.engine import numba_available
from feedtune.sim.trajectory import point_to_point

FS = 20000.0
MCPPC = GainsRuntime.from_document(gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK)), "mcppc")


def _zero_controller() -> GainsRuntime:
    unit = [[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]]
    sos = {k: unit for k in ("filter_pack", "rotary", "table", "feedforward")}
    return GainsRuntime(dict.fromkeys(("Kx1", "Kx2", "Kv1", "Kv2", "Ki2"), 0.0), sos, FS, 1, 0)


# ------------------------------------------------------------------------------------ analytic responses
def test_continuous_response_is_the_closed_form_model_with_input_dynamics():
    f = np.geomspace(1, 3000, 300)
    s = 2j * np.pi * f
    g = MODEL.frequency_response(f)  # eq. 3.4
    wp1, wp2, wc = 2 * np.pi * 440, 2 * np.pi * 1100, 2 * np.pi * 450

    def tors(wp):
        wz = 0.95 * wp
        # zeros at 0.95 wp damped 0.05, poles damped 0.03 (calibrated to thesis §3.3, docs/twin.md "Calibration")
        return (s**2 + 2 * 0.05 * wz * s + wz**2) / (s**2 + 2 * 0.03 * wp * s + wp**2) * (wp / wz) ** 2

    extra = wc / (s + wc) * tors(wp1) * tors(wp2)  # the form of examples/make_examples.py
    got = BallScrewTwin().frequency_response(f, sampled=False)
    assert np.allclose(got["x1"], g["G11"] * extra, rtol=1e-9)
    assert np.allclose(got["x2"], g["G21"] * extra, rtol=1e-9)


def test_sampled_response_matches_python_control_zoh_with_delay():
    control = pytest.importorskip("control")
    A, B, C = MODEL.state_space()
    sysd = control.c2d(control.ss(A, B[:, :1], C, np.zeros((2, 1))), 1 / FS, "zoh")
    f = np.array([1.0, 10.0, 100.0, 130.0, 500.0, 5000.0])
    z = np.exp(2j * np.pi * f / FS)
    ref = np.array([sysd(zk)[:, 0] for zk in z]) / z[:, None]  # one sample of computational delay
    got = BallScrewTwin(TwinParams.ideal()).frequency_response(f)
    assert np.allclose(got["x1"], ref[:, 0], rtol=1e-7)
    assert np.allclose(got["x2"], ref[:, 1], rtol=1e-7)


def test_pitching_section_has_the_static_compliance_and_43_hz():
    p = TwinParams()
    sos = pitch_sos(p)[0]
    assert sum(sos[:3]) / sum(sos[3:]) == pytest.approx(p.pitch_compliance, rel=1e-9)
    pole = np.roots(sos[3:])[0]
    wn = abs(np.log(pole)) * FS / (2 * np.pi)
    assert wn == pytest.approx(43.0, rel=1e-9)


# ------------------------------------------------------------------------------------ physics in the loop
def test_stiction_holds_below_the_static_level_and_releases_above():
    # zero controller, table friction only (static 0.03 V): a 0.02 V table force never moves the table;
    # 0.05 V slides it until the spring and friction balance: |F - k x2| <= static level (closed form)
    fr = TwinParams().friction_table
    p = TwinParams.ideal()
    from dataclasses import replace

    p = replace(p, friction_table=fr)
    twin = BallScrewTwin(p)
    n = 4000
    held = twin.simulate(_zero_controller(), np.zeros(n), d2=np.full(n, 0.02))
    assert np.max(np.abs(held.x2_true)) < 1e-12
    # now the motor is free (no motor friction), so hold it with the spring: use motor friction too
    p2 = replace(p, friction_motor=TwinParams().friction_motor)
    slid = BallScrewTwin(p2).simulate(_zero_controller(), np.zeros(3 * n), d2=np.full(3 * n, 0.05))
    x1, x2 = slid.x1_true[-1], slid.x2_true[-1]
    assert abs(x1) < 1e-7  # 0.3 nm: the spring force stays far below the motor's 0.16 V static level
    spring = MODEL.k * (x2 - x1)
    assert -fr.ds_pos - 1e-6 <= 0.05 - spring <= -fr.ds_neg + 1e-6
    assert x2 > 0.01 / MODEL.k  # it did move


def test_constant_velocity_command_is_viscous_plus_coulomb_friction():
    # in a steady cruise at v the mean command equals (b1 + b2) v + dc_motor + dc_table (Stribeck decayed)
    full = TwinParams()
    from dataclasses import replace

    p = replace(TwinParams.ideal(), friction_motor=full.friction_motor, friction_table=full.friction_table)
    twin = BallScrewTwin(p)
    ppi = GainsRuntime.from_document(gains_document(design_ppi(MODEL, Kpx=60.0, Kpv=0.8, Kiv=100.0)))
    tr = point_to_point(0.1, v_max=0.2, a_max=4.0, j_max=400.0, fs=FS)
    run = twin.simulate(ppi, tr.pos / twin.lead).from_zero()
    cruise = (np.abs(tr.vel - 0.2) < 1e-12) & (tr.t > tr.t[np.argmax(tr.vel >= 0.2)] + 0.1)
    v = 0.2 / twin.lead
    expected = (MODEL.b1 + MODEL.b2) * v + full.friction_motor.dc_pos + full.friction_table.dc_pos
    assert np.mean(run.u[cruise]) == pytest.approx(expected, rel=2e-3)


def test_encoders_read_whole_increments_of_10_nm():
    twin = BallScrewTwin()
    tr = point_to_point(0.01, v_max=0.1, a_max=2.0, j_max=200.0, fs=FS, dwell_after=0.02)
    run = twin.simulate(MCPPC, tr.pos / twin.lead)
    q = 10e-9 / twin.lead
    for x in (run.x1, run.x2):
        assert np.allclose(x / q, np.round(x / q), atol=1e-6)
    assert np.max(np.abs(run.x2 - run.x2_true)) < 30e-9 / twin.lead


# ------------------------------------------------------------------------------------ runtime in the loop
def test_compiled_loop_executes_the_gains_file_exactly():
    # the closed loop's controller equals GainsRuntime.step on the recorded encoder readings
    twin = BallScrewTwin()
    tr = point_to_point(0.02, v_max=0.2, a_max=4.0, j_max=400.0, fs=FS, dwell_after=0.02)
    run = twin.simulate(MCPPC, tr.pos / twin.lead)
    assert np.max(np.abs(run.u)) < 0.5 * twin.params.u_max and run.lead_samples == MCPPC.preview_samples
    MCPPC.reset()
    pv = MCPPC.previewed(np.r_[np.zeros(run.lead_samples), tr.pos / twin.lead])
    stepped = np.array([MCPPC.step(a, b, c) for a, b, c in zip(pv, run.x1, run.x2, strict=True)])
    assert np.max(np.abs(stepped - run.u)) <= 1e-9 * np.max(np.abs(run.u))


@pytest.mark.skipif(not numba_available(), reason="numba not installed")
def test_numba_and_python_engines_agree():
    twin = BallScrewTwin()
    tr = point_to_point(0.01, v_max=0.2, a_max=4.0, j_max=400.0, fs=FS, dwell_after=0.01)
    a = twin.simulate(MCPPC, tr.pos / twin.lead, engine="numba")
    b = twin.simulate(MCPPC, tr.pos / twin.lead, engine="python")
    assert np.allclose(a.u, b.u, rtol=1e-12, atol=1e-12) and np.allclose(a.x2, b.x2, rtol=0, atol=1e-12)


def test_closed_loop_sine_sweep_matches_analysis_case_c():
    # the runtime on the twin without unmodeled dynamics reproduces the discrete analysis (case c) below 200 Hz
    twin = BallScrewTwin(TwinParams.ideal())
    design = design_mcppc(MODEL, filters=THESIS_FILTER_PACK)
    rt = GainsRuntime.from_document(gains_document(design))
    cl = measure_closed_loop(twin, rt, [5, 20, 50, 80, 100, 120, 130, 150, 180, 195])
    analysis = analyze_ballscrew(design.law(), MODEL, frf=twin.frf(cl.freq_hz, sampled=False))
    case_c = analysis.cases["discrete"]
    n = cl.freq_hz.size  # the case continues above the measured lines
    assert np.allclose(case_c.freq_hz[:n], cl.freq_hz)
    err = np.abs(cl.tracking / case_c.tracking[:n] - 1)
    assert err.max() < 0.01
    assert np.abs(np.abs(cl.tracking) - 1).max() > 0.02  # a real, non-trivial closed-loop response


# ------------------------------------------------------------------------------------ FRF measurement
@pytest.mark.parametrize("excitation", ["multisine", "prbs", "chirp"])
def test_measured_frf_agrees_with_the_twin_and_identifies_its_parameters(excitation):
    twin = BallScrewTwin()
    res = measure_frf(twin, excitation=excitation, periods=4)
    frf = res.frf
    assert set(res.log.signals) == {"r", "u", "x1", "x2"}
    assert frf.meta["sampling"] == "removed" and res.summary["sampling_removed"] is True
    g = twin.frequency_response(frf.freq_hz, sampled=False)  # ZOH and delay removed: the continuous plant
    f_mode = MODEL.modes()[0].freq_hz
    near = (frf.freq_hz > 0.85 * f_mode) & (frf.freq_hz < 1.15 * f_mode)
    for ch, out in (("x1/u", "x1"), ("x2/u", "x2")):
        good = near & (frf.channel_coherence(ch) > 0.999)
        assert good.sum() >= 5
        assert np.max(np.abs(frf.channel(ch)[good] / g[out][good] - 1)) < 0.02
    fit = fit_ballscrew(frf)
    for name in ("m1", "m2", "k", "c"):
        assert getattr(fit.model, name) == pytest.approx(getattr(MODEL, name), rel=0.05), name


def test_keep_sampling_gives_the_sampled_response_and_default_removes_zoh_and_delay():
    twin = BallScrewTwin(TwinParams.ideal())
    kept = measure_frf(twin, periods=3, keep_sampling=True).frf
    removed = measure_frf(twin, periods=3).frf
    assert kept.meta["sampling"] == "not_removed" and kept.meta["sampling_fs_hz"] == "20000"
    band = (kept.freq_hz >= 200) & (kept.freq_hz <= 500)  # ZOH + delay lag 5.4..13.5 deg here
    good = band & (kept.channel_coherence("x1/u") > 0.999)
    assert good.sum() > 100
    h = kept.channel("x1/u")[good]
    g_sampled = twin.frequency_response(kept.freq_hz[good], sampled=True)["x1"]
    g_continuous = twin.frequency_response(kept.freq_hz[good], sampled=False)["x1"]
    assert np.max(np.abs(h / g_sampled - 1)) < 0.015
    assert np.min(np.abs(h / g_continuous - 1)) > 0.08
    # same run (same seed): the two files differ by the ZOH and 1 sample of delay, a lag of
    # 360 f 1.5 / fs = 4.32 deg at 160 Hz (hand-computed), with magnitude sinc(160/20000) = 0.99989
    i = int(np.argmin(np.abs(kept.freq_hz - 160.0)))
    assert kept.freq_hz[i] == pytest.approx(160.0)
    ratio = kept.channel("x1/u")[i] / removed.channel("x1/u")[i]
    assert np.degrees(np.angle(ratio)) == pytest.approx(-4.32, abs=1e-9)
    assert abs(ratio) == pytest.approx(np.sinc(160.0 / FS), rel=1e-12)


def test_bad_experiment_parameters_are_usage_errors():
    twin = BallScrewTwin(TwinParams.ideal())
    with pytest.raises(UsageError, match="excitation must be one of"):
        measure_frf(twin, excitation="hammer")
    with pytest.raises(UsageError, match="f_lo < f_hi"):
        measure_frf(twin, f_lo=500, f_hi=100)
    tr = point_to_point(0.01, v_max=0.1, a_max=2.0, j_max=200.0, fs=10000.0)
    with pytest.raises(UsageError, match="10000 Hz"):
        run_tracking(twin, MCPPC, tr)
    slow = GainsRuntime.from_document(gains_document(design_mcppc(MODEL, fs=10000.0)), "slow.toml")
    with pytest.raises(DataError, match=r"slow\.toml.*10000 Hz"):
        run_ropesnap(twin, slow)
    with pytest.raises(UsageError, match="unknown twin parameter 'mass'"):
        TwinParams().with_overrides({"mass": 1})
    with pytest.raises(UsageError, match="current_loop_hz"):
        TwinParams().with_overrides({"current_loop_hz": "-3"})


def test_overrides_reach_the_model_and_friction():
    p = TwinParams().with_overrides({"k": "300", "friction_motor.dc_pos": "0.2", "friction_table": "none",
                                     "torsional_hz": "500", "noise_m": 0})
    assert p.model.k == 300.0 and p.friction_motor.dc_pos == 0.2 and p.friction_table is None
    assert [m.freq_hz for m in p.torsional] == [500.0] and p.noise_m == 0.0


def test_torsional_damping_overrides_apply_after_the_frequencies():
    # given before torsional_hz on purpose: the modes are set first, then their damping
    p = TwinParams().with_overrides({"torsional_zeta_p": "0.05, 0.01", "torsional_hz": "400,1000",
                                     "torsional_zeta_z": 0.2, "torsional_zero_ratio": "1.1"})
    assert [(m.freq_hz, m.zeta_p, m.zeta_z, m.zero_ratio) for m in p.torsional] == [
        (400.0, 0.05, 0.2, 1.1), (1000.0, 0.01, 0.2, 1.1)]
    # the response follows: pole pair at 400 Hz damped 0.05, zero pair at 440 Hz damped 0.2 (closed form)
    f = np.array([50.0, 300.0, 420.0])
    s = 2j * np.pi * f
    wp, wz, wp2, wz2 = 2 * np.pi * 400, 2 * np.pi * 440, 2 * np.pi * 1000, 2 * np.pi * 1100
    extra = (2 * np.pi * 450 / (s + 2 * np.pi * 450)
             * (s**2 + 0.4 * wz * s + wz**2) / (s**2 + 0.1 * wp * s + wp**2) * (wp / wz) ** 2
             * (s**2 + 0.4 * wz2 * s + wz2**2) / (s**2 + 0.02 * wp2 * s + wp2**2) * (wp2 / wz2) ** 2)
    got = BallScrewTwin(p).frequency_response(f, sampled=False)
    assert np.allclose(got["x2"], MODEL.frequency_response(f)["G21"] * extra, rtol=1e-9)
    assert TwinParams().torsional[0].zeta_p == 0.03  # the calibrated default (docs/twin.md)


@pytest.mark.parametrize(("overrides", "needle"), [
    ({"torsional_zeta_p": "0.1,0.2,0.3"}, "one number or 2 comma-separated"),
    ({"torsional_zeta_z": "abc"}, "torsional_zeta_z: expected one number"),
    ({"torsional_zeta_p": "-0.1"}, "torsional_zeta_p must be a finite number >= 0"),
    ({"torsional_zero_ratio": "0"}, "torsional_zero_ratio must be a finite number > 0"),
    ({"torsional_hz": "none", "torsional_zeta_p": "0.1"}, "no torsional modes"),
])
def test_bad_torsional_overrides_name_the_parameter(overrides, needle):
    with pytest.raises(UsageError, match=needle):
        TwinParams().with_overrides(overrides)


# ------------------------------------------------------------------------------------ safety envelope
def test_wrong_sign_controller_trips_the_following_error_envelope():
    doc = gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK))
    for g in doc["gains"].values():
        g["value"] = -g["value"]  # e.g. an encoder counting backwards: positive feedback
    res = run_ropesnap(BallScrewTwin(), GainsRuntime.from_document(doc, "flipped"), t_release=0.3, after_s=0.5)
    assert res.tripped and res.metrics is None
    msg = res.run.trip_message
    assert "following-error trip" in msg and "safety envelope of 1 mm" in msg and "\n" not in msg
    assert res.log.meta["trip"] == msg and res.run.t[-1] < 0.8


def test_high_frequency_instability_trips_the_overload_protection():
    # saturation keeps a fast limit cycle inside the envelope; the I2t protection stops it
    wild = GainsRuntime.from_document(gains_document(design_ppi(MODEL, Kpx=400.0, Kpv=30.0, Kiv=5000.0)), "wild")
    res = run_ropesnap(BallScrewTwin(), wild, t_release=0.3, after_s=0.5)
    assert res.tripped and "overload trip" in res.run.trip_message
    assert np.max(np.abs(res.run.u)) == pytest.approx(10.0)
