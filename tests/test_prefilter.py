"""Least-squares trajectory pre-filter (eq. 3.16-3.23) and friction feedforward, library to command line."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from cli_run import run
from scipy.signal import bilinear, lfilter, lsim

from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.control.friction import friction_feedforward
from feedtune.control.prefilter import ORDERS, correction_sos, prefilter_response
from feedtune.design.mcppc import design_mcppc
from feedtune.design.prefilter import filtered_derivatives, fit_prefilter, fit_prefilter_arrays
from feedtune.errors import DataError, IllConditionedError, UsageError
from feedtune.io import read_document, write_document, write_log_csv
from feedtune.io.gains import gains_document, with_friction_feedforward, with_prefilter
from feedtune.log import Log
from feedtune.machines.ballscrew.experiments import run_tracking
from feedtune.machines.ballscrew.runtime import GainsRuntime
from feedtune.machines.ballscrew.twin import BallScrewTwin, TwinParams
from feedtune.models import THESIS_TABLE_3_1 as MODEL
from feedtune.models.friction import StribeckFriction
from feedtune.sim.trajectory import point_to_point

FS = 20000.0
GAINS = {"K_vel": 2e-4, "K_acc": -3e-6, "K_jerk": 4e-9, "K_snap": -5e-12}


def _move(v: float, fs: float = FS, **kw):
    args = {"a_max": 5.0, "j_max": 500.0, "dwell_before": 0.05, "dwell_after": 0.2, **kw}
    return point_to_point(0.15, v_max=v, fs=fs, **args)


def _continuous_correction(gains: dict, lpf_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """``F(s) - 1 = sum_k K_k s^k w^(k+1) / (s + w)^(k+1)`` as polynomials over ``(s + w)^5``, by hand."""
    w = 2 * np.pi * lpf_hz
    K = [gains["K_vel"], gains["K_acc"], gains["K_jerk"], gains["K_snap"]]
    num = np.zeros(6)
    for k in range(1, 5):
        term = K[k - 1] * w ** (k + 1) * np.polymul(np.r_[1.0, np.zeros(k)], np.poly(-w * np.ones(4 - k)))
        num[-term.size:] += term
    return num, np.poly(-w * np.ones(5))


# ------------------------------------------------------------------------------------------ the fit
def test_fit_recovers_the_maclaurin_coefficients_of_a_known_error_transfer_function():
    # G_track = 1 / (1 + s/w0)^2, so G_e = 1 - G_track = 2x - 3x^2 + 4x^3 - 5x^4 + ..., x = s/w0 (hand-derived
    # from 1/(1+x)^2 = sum (-1)^k (k+1) x^k): c_k = (-1)^(k+1) (k+1) / w0^k
    w0 = 2 * np.pi * 100.0
    expected = [(-1) ** (k + 1) * (k + 1) / w0**k for k in range(1, 5)]
    fs = 5000.0
    tr = point_to_point(0.1, v_max=0.1, a_max=1.0, j_max=10.0, s_max=100.0, fs=fs, dwell_before=0.1,
                        dwell_after=0.5)
    _, x2, _ = lsim(([1.0], np.polymul([1 / w0, 1.0], [1 / w0, 1.0])), tr.pos, tr.t)
    log = tr.to_log().with_signals({"e2": tr.pos - x2}, {"e2": "m"})
    for lpf in (80.0, 200.0):
        fit = fit_prefilter(log, lpf_hz=lpf)
        got = fit.maclaurin()
        for k in range(1, 5):
            assert got[f"c{k}"] == pytest.approx(expected[k - 1], rel=0.05), (lpf, k)
        assert fit.predicted_reduction > 0.999
    # far above the dynamics the gains themselves are the coefficients (G ~ 1): K_vel = c1 exactly enough
    assert fit_prefilter(log, lpf_hz=1000.0).gains["K_vel"] == pytest.approx(expected[0], rel=0.01)


def test_position_only_and_logged_derivatives_give_the_same_regressors():
    tr = _move(0.5)  # jerk-limited: s_ref is zero between knots, the snap regressor comes from j_ref
    direct = filtered_derivatives(FS, x_ref=tr.pos, derivatives={"vel": tr.vel, "acc": tr.acc, "jerk": tr.jerk,
                                                                 "snap": tr.snap})
    chained = filtered_derivatives(FS, x_ref=tr.pos)
    for order in ORDERS:
        a, b = direct.columns[order], chained.columns[order]
        assert np.sqrt(np.mean((a - b) ** 2)) < 0.01 * np.sqrt(np.mean(b**2)), order
    assert direct.sources["vel"] == "vel" and "disagrees" in direct.sources["snap"]
    # closed form: at constant velocity the filtered velocity equals it (G^2 has unit DC gain)
    cruise = np.flatnonzero(np.abs(tr.vel - 0.5) < 1e-12)
    mid = cruise[cruise.size // 2]
    assert chained.columns["vel"][mid] == pytest.approx(0.5, rel=1e-9)


@pytest.fixture(scope="module")
def twin_runs():
    design = design_mcppc(MODEL, filters=THESIS_FILTER_PACK)
    doc = gains_document(design)
    twin = BallScrewTwin(TwinParams())
    plain = GainsRuntime.from_document(doc, "mcppc")
    ident = run_tracking(twin, plain, _move(0.5))
    fit = fit_prefilter(ident.log)
    with_pf = GainsRuntime.from_document(with_prefilter(doc, fit), "mcppc + prefilter")
    return {"doc": doc, "twin": twin, "plain": plain, "with_pf": with_pf, "fit": fit, "ident": ident}


def _correlated_rms(log: Log) -> float:
    """RMS of the projection of the table error on the filtered derivative regressors of that run [m]."""
    X = filtered_derivatives(log.fs, x_ref=log["x_ref"]).matrix(ORDERS)
    theta, *_ = np.linalg.lstsq(X, log["e2"], rcond=None)
    return float(np.sqrt(np.mean((X @ theta) ** 2)))


@pytest.mark.parametrize("speed", [0.2, 1.0])
def test_prefilter_identified_at_500_mm_s_removes_the_correlated_error_at_other_speeds(twin_runs, speed):
    r = twin_runs
    before = run_tracking(r["twin"], r["plain"], _move(speed))
    after = run_tracking(r["twin"], r["with_pf"], _move(speed))
    c0, c1 = _correlated_rms(before.log), _correlated_rms(after.log)
    # measured: 200 mm/s RMS 0.362 -> 0.133 um, correlated part 0.331 -> 0.028 um;
    #           1000 mm/s RMS 0.800 -> 0.171 um, correlated part 0.778 -> 0.034 um
    assert c1 <= 0.2 * c0, (c0, c1)
    assert after.summary["rms_um"] < 0.6 * before.summary["rms_um"]
    assert after.summary["max_um"] < before.summary["max_um"]


def test_fit_reports_what_the_run_predicts(twin_runs):
    fit = twin_runs["fit"]
    e = twin_runs["ident"].log["e2"]
    assert fit.error_rms == pytest.approx(np.sqrt(np.mean(e**2)))
    assert fit.residual_rms < fit.error_rms
    assert fit.fitted_rms**2 + fit.residual_rms**2 == pytest.approx(fit.error_rms**2, rel=1e-6)  # orthogonality
    d = fit.to_dict()
    assert d["units"]["K_acc"] == "s^2" and d["units"]["error_rms"] == "m" and d["condition_number"] < 100
    assert all(v > 0 for v in d["std"].values())


# ------------------------------------------------------------------------------------------ ill-conditioned
def test_constant_velocity_log_is_ill_conditioned_with_the_reason():
    t = np.arange(4000) / FS
    log = Log(t, {"x_ref": 0.01 + 0.2 * t, "v_ref": np.full(t.size, 0.2), "e2": 1e-6 * np.sin(50 * t)},
              {"x_ref": "m", "v_ref": "m/s", "e2": "m"}, {"source": "cv.csv"})
    with pytest.raises(IllConditionedError, match=r"cv.csv: .*no acc, jerk, snap \(constant velocity only\)"):
        fit_prefilter(log)
    with pytest.raises(IllConditionedError, match="does not move"):
        fit_prefilter_arrays(FS, np.zeros(100), x_ref=np.full(100, 0.3))


def test_collinear_regressors_are_ill_conditioned():
    # an exponential reference: every derivative (and filtered derivative) is a multiple of the position
    t = np.arange(20000) / FS
    x = 1e-3 * np.exp(20.0 * (t - 1.0))
    with pytest.raises(IllConditionedError, match=r"regressors are nearly collinear .*condition number"):
        fit_prefilter_arrays(FS, 1e-3 * x, x_ref=x, lpf_hz=80.0)


def test_bad_inputs_are_one_line_errors():
    tr = _move(0.5)
    log = tr.to_log()
    with pytest.raises(DataError, match="no tracking error 'e2' and no measured position"):
        fit_prefilter(log)
    with pytest.raises(UsageError, match="orders must be"):
        fit_prefilter(log.with_signals({"e2": tr.pos}), orders="vel,crackle")
    with pytest.raises(UsageError, match=r"lpf_hz must be > 0 and below fs/4 = 5000 Hz, got 6000\.0") as err:
        fit_prefilter(log.with_signals({"e2": tr.pos}), lpf_hz=6000.0)
    assert err.value.parameter == "lpf_hz"
    mixed = log.with_signals({"x2": tr.pos / MODEL.lead_m_per_rad}, {"x2": "rad"})
    with pytest.raises(DataError, match="x2 is in 'rad' but the reference is in 'm'"):
        fit_prefilter(mixed)
    assert fit_prefilter(mixed, lead_m_per_rad=MODEL.lead_m_per_rad, orders="vel").residual_rms < 1e-12


# ------------------------------------------------------------------------------------------ the filter
def test_runtime_prefilter_equals_an_independent_discretization_of_the_continuous_filter():
    doc = with_prefilter(gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK)), gains=GAINS, lpf_hz=80.0)
    rt = GainsRuntime.from_document(doc)
    x = _move(0.5).pos / MODEL.lead_m_per_rad
    b, a = bilinear(*_continuous_correction(GAINS, 80.0), fs=FS)  # scipy's own bilinear of the polynomials
    expected = rt.previewed(x) + lfilter(b, a, rt.previewed(x))
    got = rt.prefiltered(x)
    corr = expected - rt.previewed(x)
    assert np.max(np.abs(got - expected)) <= 1e-6 * np.max(np.abs(corr))
    # and the paths run on it: the table reference is the pre-filtered reference delayed by the preview
    _, x2r, _ = rt.reference_signals(x)
    P = rt.preview_samples
    assert np.allclose(x2r[P:], got[:-P], rtol=0, atol=1e-12 * np.max(np.abs(x)))


def test_prefilter_closed_form_on_a_parabola_and_low_frequency_response():
    # x = a t^2 / 2 after the transients: F x = x + c1 a t + c2 a with c1 = K_vel, c2 = K_acc - 2 K_vel / w
    # (G^2 = 1 - 2 s/w + ...); the bilinear map keeps the s and s^2 terms exactly
    w = 2 * np.pi * 80.0
    t = np.arange(int(0.3 * FS)) / FS
    acc = 3.0
    x = acc * t**2 / 2
    y = x + lfilter_sos(correction_sos(GAINS, 80.0, FS), x)
    tail = t > 0.2
    c1, c2 = GAINS["K_vel"], GAINS["K_acc"] - 2 * GAINS["K_vel"] / w
    assert np.allclose(y[tail] - x[tail], c1 * acc * t[tail] + c2 * acc, rtol=1e-7, atol=0)
    f = np.array([1.0, 10.0, 50.0, 100.0])
    cont = prefilter_response(GAINS, 80.0, f)
    disc = prefilter_response(GAINS, 80.0, f, FS, method="tustin")
    bound = (2 * np.pi * f / FS) ** 2 / 4 * np.abs(cont - 1) + 1e-12  # bilinear warping, O((wT)^2)
    assert np.all(np.abs(disc - cont) <= bound)


def lfilter_sos(sos, x):
    from scipy.signal import sosfilt

    return sosfilt(sos, x)


def test_zero_gains_leave_the_reference_alone_and_no_section_changes_nothing():
    doc = gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK))
    x = _move(0.2).pos / MODEL.lead_m_per_rad
    plain = GainsRuntime.from_document(doc)
    zero = GainsRuntime.from_document(with_prefilter(doc, gains=dict.fromkeys(GAINS, 0.0), lpf_hz=80.0))
    for a, b in zip(plain.reference_signals(x), zero.reference_signals(x), strict=True):
        assert np.array_equal(a, b)


# ------------------------------------------------------------------------------------------ friction
def test_friction_feedforward_is_the_stribeck_force_of_the_reference_velocity():
    fr = StribeckFriction(dc_pos=0.1, ds_pos=0.16, dc_neg=-0.09, ds_neg=-0.15, omega_pos=2e-3, omega_neg=1.5e-3,
                          command_unit="V", velocity_unit="m/s")
    lead = MODEL.lead_m_per_rad
    doc = gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK))
    band = 1e-4  # m/s
    rt_ff = GainsRuntime.from_document(with_friction_feedforward(doc, fr, v_band=band))
    rt = GainsRuntime.from_document(doc)
    tr = _move(0.2, dwell_after=0.0)
    x = np.r_[tr.pos, tr.pos[::-1]] / lead  # out and back: both signs
    extra = rt_ff.reference_signals(x)[2] - rt.reference_signals(x)[2]
    p = rt.previewed(x)
    v_table = np.diff(p, prepend=p[0]) * FS * lead  # backward difference [m/s]
    outside = np.abs(v_table) >= band
    assert np.allclose(extra[outside], fr.force(v_table[outside]), rtol=1e-9, atol=1e-12)
    inside = ~outside
    edge = np.where(v_table[inside] >= 0, fr.force(band), fr.force(-band))
    assert np.allclose(extra[inside], edge * np.abs(v_table[inside]) / band, rtol=1e-9, atol=1e-12)
    assert np.any(v_table > band) and np.any(v_table < -band) and np.any(inside & (v_table != 0))


def test_friction_units_must_match_the_gains_file():
    doc = gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK))
    newton = StribeckFriction(dc_pos=10, ds_pos=12, dc_neg=-10, ds_neg=-12, omega_pos=0.01, command_unit="N")
    with pytest.raises(DataError, match="friction levels are in 'N' but the gains file's command is in 'V'"):
        with_friction_feedforward(doc, newton)
    rad = StribeckFriction(dc_pos=0.1, ds_pos=0.2, dc_neg=-0.1, ds_neg=-0.2, omega_pos=0.5, command_unit="V",
                           velocity_unit="rad/s")
    ff = friction_feedforward(rad, command_unit="V", lead_m_per_rad=MODEL.lead_m_per_rad)
    assert ff.friction.omega_pos == 0.5 and ff.v_band == pytest.approx(0.05)  # rad/s: no conversion
    with pytest.raises(UsageError, match="band must be > 0"):
        friction_feedforward(rad, command_unit="V", lead_m_per_rad=1.0, v_band=-1.0)


# ------------------------------------------------------------------------------------------ command line


def test_cli_prefilter_writes_a_gains_file_the_runtime_executes(twin_runs, tmp_path, capsys, monkeypatch):
    log_path, gains = tmp_path / "track.csv", tmp_path / "mcppc.toml"
    write_log_csv(twin_runs["ident"].log, log_path)
    write_document(gains, twin_runs["doc"])
    out = tmp_path / "mcppc_pf.toml"
    code, text, err = run(["prefilter", log_path, "--gains", gains, "--out", out, "--json"], capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(text)
    fit = twin_runs["fit"]
    for name, value in fit.gains.items():
        assert res["gains"][name]["value"] == pytest.approx(value, rel=1e-6, abs=1e-12 * abs(value) + 1e-20)
    rt = GainsRuntime.from_file(out)
    assert rt.to_dict()["prefilter"]["gains"]["K_acc"] == pytest.approx(fit.gains["K_acc"], rel=1e-6)
    assert (tmp_path / "mcppc_pf.json").exists() and "prefilter" in read_document(tmp_path / "mcppc_pf.json")
    x = _move(1.0).pos / MODEL.lead_m_per_rad
    assert np.allclose(rt.reference_signals(x)[1], twin_runs["with_pf"].reference_signals(x)[1], rtol=1e-6,
                       atol=1e-9)
    # the summary names the units
    code, text, err = run(["prefilter", log_path], capsys, monkeypatch)
    assert code == 0, err
    assert "K_acc" in text and "s^2" in text and "um" in text and "predicted reduction" in text
    # --refine adds to the existing pre-filter
    code, text, err = run(["prefilter", log_path, "--gains", out, "--refine", "--json"], capsys, monkeypatch)
    assert code == 0, err
    written = json.loads(text)["written_gains"]["K_acc"]["value"]
    assert written == pytest.approx(2 * fit.gains["K_acc"], rel=1e-6)


def test_cli_prefilter_bad_input_is_one_line(twin_runs, tmp_path, capsys, monkeypatch):
    log_path, gains = tmp_path / "track.csv", tmp_path / "g.toml"
    write_log_csv(twin_runs["ident"].log, log_path)
    write_document(gains, twin_runs["doc"])
    code, _, err = run(["prefilter", log_path, "--error", "nope"], capsys, monkeypatch)
    assert code == 1 and "no signal 'nope'" in err and err.count("\n") == 1
    out = tmp_path / "exists.toml"
    out.write_text("x = 1\n")
    code, _, err = run(["prefilter", log_path, "--gains", gains, "--out", out], capsys, monkeypatch)
    assert code == 2 and "exists" in err and err.count("\n") == 1
    assert out.read_text() == "x = 1\n"
    code, _, err = run(["prefilter", log_path, "--gains", gains, "--out", gains], capsys, monkeypatch)
    assert code == 2 and "--force" in err
    code, _, err = run(["prefilter", log_path, "--out", tmp_path / "new.toml"], capsys, monkeypatch)
    assert code == 2 and "--out needs --gains" in err


def test_cli_design_with_friction(tmp_path, capsys, monkeypatch):
    from feedtune.io import save_model

    model, fric, gains = tmp_path / "m.toml", tmp_path / "friction.toml", tmp_path / "g.toml"
    save_model(model, MODEL)
    fr = StribeckFriction(dc_pos=0.1, ds_pos=0.16, dc_neg=-0.09, ds_neg=-0.15, omega_pos=2e-3, command_unit="V")
    save_model(fric, fr)
    code, text, err = run(["design", "ppc", model, "--notch", "420,0.55,0.7", "--notch", "1080,0.05,0.7", "--lpf",
                           "2000", "--friction", fric, "--out", gains], capsys, monkeypatch)
    assert code == 0, err
    assert "friction feedforward" in text
    rt = GainsRuntime.from_file(gains)
    assert rt.friction is not None
    assert rt.friction.friction.omega_pos == pytest.approx(2e-3 / MODEL.lead_m_per_rad)
    code, _, err = run(["design", "ppc", model, "--friction", model], capsys, monkeypatch)
    assert code == 1 and "--friction expects a friction model file" in err
    assert math.isfinite(rt.friction.v_band)


def test_one_prefilter_two_realisations_and_two_spellings_agree():
    """The ball-screw (K_vel, Tustin cascade) and gantry (k_vel, matched terms) pre-filters are the same F(s)."""
    from feedtune.control.prefilter import PrefilterGains, reference_filters

    f = np.geomspace(1.0, 200.0, 50)
    typed = PrefilterGains(*(GAINS[f"K_{o}"] for o in ORDERS))
    cont = prefilter_response(GAINS, 80.0, f)
    # closed form of the continuous pre-filter, written out here (not through the module)
    s, w = 2j * np.pi * f, 2 * np.pi * 80.0
    G = w / (s + w)
    closed = 1 + sum(GAINS[f"K_{o}"] * s ** n * G ** (n + 1) for n, o in enumerate(ORDERS, start=1))
    assert np.allclose(cont, closed, rtol=1e-12)
    assert np.allclose(prefilter_response(typed, 80.0, f), closed, rtol=1e-12)
    tustin = prefilter_response(GAINS, 80.0, f, FS, method="tustin")
    matched = prefilter_response(typed, 80.0, f, FS, method="matched")
    # both discretizations approximate F - 1 to O((w T)^2) and O(w T) at most: 1e-3 of |F - 1| below 200 Hz
    for disc in (tustin, matched):
        assert np.all(np.abs(disc - closed) <= 1e-3 * np.abs(closed - 1))
    # the matched realisation is the sum of the per-term filters the gantry laws run
    from scipy.signal import freqz_zpk

    filters = reference_filters(80.0, FS)
    summed = 1 + sum(getattr(typed, f"k_{o}") * freqz_zpk(filters[f"prefilter_{o}"].zeros,
                                                          filters[f"prefilter_{o}"].poles,
                                                          filters[f"prefilter_{o}"].gain, worN=f, fs=FS)[1]
                     for o in ORDERS)
    assert np.allclose(summed, matched, rtol=1e-9)
    with pytest.raises(UsageError, match="matched"):
        prefilter_response(GAINS, 80.0, f, FS, method="zoh")
