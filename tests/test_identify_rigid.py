"""Rigid-body IDIM-LS: EMPS benchmark reference values, synthetic ground truth, ill-conditioning."""

from __future__ import annotations

import json

import numpy as np
import pytest

from feedtune.errors import DataError, IllConditionedError, UsageError
from feedtune.identify.rigid import decimate_columns, fit_rigid, validate_rigid
from feedtune.log import Log
from feedtune.models.rigid import RigidBodyModel

GTAU = 35.15065  # N/V, EMPS drive gain (README)

# EMPS_Description.pdf via the README: IDIM-LS values, standard deviations, relative error, condition number
EMPS_SYMMETRIC = {"mass": 95.1089, "viscous": 203.5034, "coulomb": 20.3935, "offset": -3.1648}
EMPS_SYMMETRIC_STD = {"mass": 0.1085, "viscous": 1.1460, "coulomb": 0.1012, "offset": 0.0444}
EMPS_ASYMMETRIC = {"mass": 95.1540, "viscous_pos": 166.7061, "coulomb_pos": 20.1440, "viscous_neg": 240.4236,
                   "coulomb_neg": 20.6277}


def _emps_log(path) -> Log:
    from scipy.io import loadmat

    d = loadmat(path)
    return Log(d["t"].ravel(), {"qm": d["qm"].ravel(), "vir": d["vir"].ravel()}, {"qm": "m", "vir": "V"},
               {"source": path.name})


@pytest.fixture(scope="module")
def emps(real_data_dir) -> Log:
    return _emps_log(real_data_dir / "EMPS" / "DATA_EMPS.mat")


@pytest.fixture(scope="module")
def emps_fit(emps):
    return fit_rigid(emps, force="vir", position="qm", force_scale=GTAU)


def _synthetic(model: RigidBodyModel, fs: float = 1000.0, seconds: float = 20.0, both_ways: bool = True,
               quant: float = 0.0) -> Log:
    """Sum-of-sines motion with analytic derivatives; force from the model (inverse dynamics)."""
    t = np.arange(round(seconds * fs)) / fs
    w = 2 * np.pi * np.array([0.15, 0.4, 1.1])
    amp = np.array([0.08, 0.02, 0.004])
    offset = 0.0 if both_ways else 0.2  # velocity offset keeps one direction only
    x = (amp[:, None] * np.sin(w[:, None] * t)).sum(0) + offset * t
    v = (amp[:, None] * w[:, None] * np.cos(w[:, None] * t)).sum(0) + offset
    a = -(amp[:, None] * w[:, None] ** 2 * np.sin(w[:, None] * t)).sum(0)
    if quant:
        x = np.round(x / quant) * quant
    return Log(t, {"x": x, "u": model.force(a, v)}, {"x": "m", "u": "N"}, {"source": "synthetic"})


# ------------------------------------------------------------------------------------------ the model
def test_rigid_model_force_by_hand():
    m = RigidBodyModel(mass=2.0, viscous=3.0, coulomb_pos=5.0, coulomb_neg=7.0, offset=-1.0, viscous_neg=4.0)
    # v>0: 2*1 + 3*0.5 + 5 - 1 = 7.5 ; v<0: 2*1 + 4*(-0.5) - 7 - 1 = -8 ; v=0: 2*1 - 1 = 1
    assert m.force([1.0, 1.0, 1.0], [0.5, -0.5, 0.0]).tolist() == [7.5, -8.0, 1.0]
    assert m.units["mass"] == "N/(m/s^2)"
    assert not m.is_symmetric
    json.dumps(m.to_dict(), allow_nan=False)
    with pytest.raises(DataError, match="mass"):
        RigidBodyModel(mass=0.0)
    with pytest.raises(DataError, match="position_unit"):
        RigidBodyModel(mass=1.0, position_unit="mm")


# --------------------------------------------------------------------------------------- EMPS benchmark
def test_emps_symmetric_matches_published_idim_ls(emps_fit):
    for name, ref in EMPS_SYMMETRIC.items():
        assert emps_fit.values[name] == pytest.approx(ref, rel=0.02), name
        assert emps_fit.std[name] == pytest.approx(EMPS_SYMMETRIC_STD[name], rel=0.1), name
    assert emps_fit.relative_error_pct == pytest.approx(4.08, abs=0.2)
    assert emps_fit.condition_number == pytest.approx(25.99, rel=0.01)
    assert emps_fit.decimate == 10  # round(fs / cutoff) = 1000 / 100, the published factor
    d = emps_fit.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["units"]["mass"] == "N/(m/s^2)" and d["units"]["viscous"] == "N/(m/s)"


def test_emps_asymmetric_matches_published_idim_ls(emps):
    fit = fit_rigid(emps, force="vir", position="qm", force_scale=GTAU, asymmetric=True)
    for name, ref in EMPS_ASYMMETRIC.items():
        assert fit.values[name] == pytest.approx(ref, rel=0.05), name
    assert fit.relative_error_pct == pytest.approx(3.11, abs=0.2)
    assert fit.model.offset == 0.0
    assert fit.model.coulomb_negative == pytest.approx(20.6277, rel=0.05)


def test_emps_pulses_cross_validation(real_data_dir, emps_fit):
    pulses = _emps_log(real_data_dir / "EMPS" / "DATA_EMPS_PULSES.mat")
    val = validate_rigid(pulses, emps_fit.model, force="vir", position="qm", force_scale=GTAU)
    assert val.relative_error_pct == pytest.approx(5.98, abs=0.5)  # published cross-test error
    json.dumps(val.to_dict(), allow_nan=False)
    rotary = RigidBodyModel(mass=1.0, position_unit="rad")
    with pytest.raises(DataError, match="model is in rad"):
        validate_rigid(pulses, rotary, force="vir", position="qm")


def test_emps_position_in_mm_gives_same_fit(emps, emps_fit):
    mm = emps.with_signals({"qm": emps["qm"] * 1e3}, {"qm": "mm"})
    fit = fit_rigid(mm, force="vir", position="qm", force_scale=GTAU)
    assert fit.values["mass"] == pytest.approx(emps_fit.values["mass"], rel=1e-9)


# ------------------------------------------------------------------------------------ synthetic truth
def test_synthetic_symmetric_truth_recovered():
    truth = RigidBodyModel(mass=12.0, viscous=30.0, coulomb_pos=8.0, offset=1.5)
    fit = fit_rigid(_synthetic(truth), force="u", position="x", cutoff_hz=20.0)
    assert fit.values["mass"] == pytest.approx(12.0, rel=0.01)
    assert fit.values["viscous"] == pytest.approx(30.0, rel=0.01)
    assert fit.values["coulomb"] == pytest.approx(8.0, rel=0.01)
    assert fit.values["offset"] == pytest.approx(1.5, abs=0.05)
    # leaving out the slow samples around reversals (where sign(dq) is smeared by decimation) still works
    slow = fit_rigid(_synthetic(truth), force="u", position="x", cutoff_hz=20.0, velocity_threshold=0.02)
    assert slow.n_samples < fit.n_samples
    assert slow.values["coulomb"] == pytest.approx(8.0, rel=0.01)
    assert slow.values["mass"] == pytest.approx(12.0, rel=0.01)


def test_synthetic_asymmetric_truth_recovered_with_quantisation():
    truth = RigidBodyModel(mass=12.0, viscous=30.0, coulomb_pos=8.0, coulomb_neg=5.0, viscous_neg=45.0)
    fit = fit_rigid(_synthetic(truth, quant=1e-6), force="u", position="x", cutoff_hz=20.0, asymmetric=True)
    expected = {"mass": 12.0, "viscous_pos": 30.0, "coulomb_pos": 8.0, "viscous_neg": 45.0, "coulomb_neg": 5.0}
    for name, ref in expected.items():
        assert fit.values[name] == pytest.approx(ref, rel=0.02), name


def test_force_scale_and_unit():
    truth = RigidBodyModel(mass=12.0, viscous=30.0, coulomb_pos=8.0)
    log = _synthetic(truth)
    volts = log.with_signals({"u": log["u"] / 4.0}, {"u": "V"})
    fit = fit_rigid(volts, force="u", position="x", cutoff_hz=20.0, force_scale=4.0)
    assert fit.values["mass"] == pytest.approx(12.0, rel=0.01)
    assert fit.force_unit == "N"
    raw = fit_rigid(volts, force="u", position="x", cutoff_hz=20.0)
    assert raw.values["mass"] == pytest.approx(3.0, rel=0.01)
    assert raw.units["mass"] == "V/(m/s^2)"


def test_decimation_in_stages_keeps_a_slow_sine():
    fs, factor = 20_000.0, 200  # > 13: applied as stages 10 x 10 x 2
    t = np.arange(200_000) / fs
    x = np.sin(2 * np.pi * 3.0 * t)
    y = decimate_columns(x[:, None], factor)[:, 0]
    assert y.size == 1000
    # zero phase and sample-aligned: y = g sin + h cos with h ~ 0; g within the Chebyshev ripple
    # (0.05 dB per pass, forward and backward, three stages: at most ~3.5 % low)
    td = t[::factor][50:-50]
    basis = np.column_stack([np.sin(2 * np.pi * 3.0 * td), np.cos(2 * np.pi * 3.0 * td)])
    g, h = np.linalg.lstsq(basis, y[50:-50], rcond=None)[0]
    assert abs(h) < 1e-4
    assert 0.96 < g <= 1.0


# ----------------------------------------------------------------------------------- ill-conditioning
def test_constant_velocity_is_ill_conditioned():
    t = np.arange(5000) / 1000.0
    log = Log(t, {"x": 0.05 * t, "u": np.full(t.size, 7.0)}, {"x": "m", "u": "N"})
    with pytest.raises(IllConditionedError, match="no acceleration"):
        fit_rigid(log, force="u", position="x")


def test_constant_velocity_with_quantisation_noise_is_ill_conditioned():
    t = np.arange(5000) / 1000.0
    rng = np.random.default_rng(1)
    x = np.round((0.05 * t + rng.normal(0, 2e-6, t.size)) / 1e-6) * 1e-6
    log = Log(t, {"x": x, "u": 7.0 + rng.normal(0, 0.1, t.size)}, {"x": "m", "u": "N"})
    with pytest.raises(IllConditionedError, match=r"sign\(dq\).*1 \(constant\)|mass"):
        fit_rigid(log, force="u", position="x")


def test_standstill_is_ill_conditioned():
    t = np.arange(3000) / 1000.0
    log = Log(t, {"x": np.full(t.size, 0.1), "u": np.zeros(t.size)}, {"x": "m", "u": "N"})
    with pytest.raises(IllConditionedError, match="did not move"):
        fit_rigid(log, force="u", position="x")


def test_one_direction_fits_mass_viscous_and_the_constant_of_that_direction_with_a_warning():
    # truth: constant for dq > 0 is Fc + offset = 8 - 1.5 = 6.5 N; the sign column equals the constant one
    truth = RigidBodyModel(mass=12.0, viscous=30.0, coulomb_pos=8.0, offset=-1.5)
    log = _synthetic(truth, both_ways=False)
    for asymmetric in (False, True):
        fit = fit_rigid(log, force="u", position="x", cutoff_hz=20.0, asymmetric=asymmetric)
        assert set(fit.values) == {"mass", "viscous", "constant"}
        assert fit.values["mass"] == pytest.approx(12.0, rel=1e-3)
        assert fit.values["viscous"] == pytest.approx(30.0, rel=1e-3)
        assert fit.values["constant"] == pytest.approx(6.5, rel=1e-3)
        assert fit.to_dict()["model"] == "rigid-one-direction"
        assert any("one direction only" in w and "cannot be separated" in w for w in fit.warnings)
        # stored as the offset: the model reproduces the force for motion in the measured direction
        assert fit.model.offset == pytest.approx(6.5, rel=1e-3) and fit.model.coulomb_pos == 0.0


def test_several_logs_one_direction_each_separate_coulomb_and_offset():
    # two runs, one each way (as the HSM150 steps): stacked, the full symmetric model is identifiable
    truth = RigidBodyModel(mass=12.0, viscous=30.0, coulomb_pos=8.0, offset=-1.5)
    fwd = _synthetic(truth, both_ways=False)
    t = fwd.t
    w = 2 * np.pi * np.array([0.15, 0.4, 1.1])
    amp = np.array([0.08, 0.02, 0.004])
    vb = -((amp[:, None] * w[:, None] * np.cos(w[:, None] * t)).sum(0) + 0.2)
    ab = (amp[:, None] * w[:, None] ** 2 * np.sin(w[:, None] * t)).sum(0)
    back = Log(t, {"x": -fwd.get("x"), "u": truth.force(ab, vb)}, {"x": "m", "u": "N"}, {"source": "back"})
    fit = fit_rigid([fwd, back], force="u", position="x", cutoff_hz=20.0)
    assert set(fit.values) == {"mass", "viscous", "coulomb", "offset"}
    for name, value in (("mass", 12.0), ("viscous", 30.0), ("coulomb", 8.0), ("offset", -1.5)):
        assert fit.values[name] == pytest.approx(value, rel=2e-3, abs=2e-3), name
    assert not any("one direction" in w for w in fit.warnings)
    # one of them alone: the lumped fit
    assert set(fit_rigid(back, force="u", position="x", cutoff_hz=20.0).values) == {"mass", "viscous", "constant"}


def test_automatic_cutoff_follows_the_velocity_spectrum():
    from scipy import signal

    from feedtune.identify.rigid import auto_cutoff_hz

    rng = np.random.default_rng(3)
    fs = 1000.0
    t = np.arange(20000) / fs
    for f_motion in (2.0, 30.0):
        # broadband motion (white noise through a 4th-order low-pass at f_motion, integrated to a position) and
        # 1e-8 m of position noise: the rule must land above the motion's band and far below Nyquist
        b, a = signal.butter(4, f_motion, fs=fs)
        v = signal.lfilter(b, a, rng.standard_normal(t.size))
        sigma_n = 1e-8
        x = np.cumsum(v) / fs * 0.1 + sigma_n * rng.standard_normal(t.size)
        cut, how = auto_cutoff_hz(x, 1 / fs)
        # the rule from the known spectra: signal 0.01 |H|^2 (2 / fs), noise through the central difference
        # (2 sigma_n^2 / fs) (fs sin(w))^2; the band ends where their sum falls to 20 dB above the noise's median
        # over [fs/4, fs/2]; the cut-off is 2.5 times that
        fg = np.linspace(0.01, fs / 2, 200001)
        w = 2 * np.pi * fg / fs
        noise = 2 * sigma_n**2 / fs * (fs * np.sin(w)) ** 2
        sig = 0.01 * np.abs(signal.freqz(b, a, worN=fg, fs=fs)[1]) ** 2 * 2 / fs * (np.sin(w) / w) ** 2
        floor = np.median(noise[fg >= fs / 4])
        edge = fg[np.flatnonzero((sig + noise < 100 * floor) & (fg > f_motion / 2))[0]]
        assert cut == pytest.approx(2.5 * edge, rel=0.1), (f_motion, cut, edge, how)
    # a constant speed has no spectrum above round-off: the EMPS recipe's 100 Hz
    assert auto_cutoff_hz(0.05 * t, 1 / fs)[0] == 100.0
    # slow motion in a log too short to filter and decimate at its bandwidth
    b, a = signal.butter(4, 2.0, fs=fs)
    short = np.cumsum(signal.lfilter(b, a, rng.standard_normal(1000))) / fs * 0.1 + 1e-6 * rng.standard_normal(1000)
    with pytest.raises(DataError, match="too few for the automatic cut-off"):
        auto_cutoff_hz(short, 1 / fs)


# ------------------------------------------------------------------------------------------ bad input
def test_bad_input_gives_one_line_errors():
    truth = RigidBodyModel(mass=12.0, viscous=30.0, coulomb_pos=8.0)
    log = _synthetic(truth, seconds=5.0)
    with pytest.raises(DataError, match="no signal 'nope'"):
        fit_rigid(log, force="nope", position="x")
    with pytest.raises(UsageError, match="cutoff_hz"):
        fit_rigid(log, force="u", position="x", cutoff_hz=600.0)
    with pytest.raises(UsageError, match="decimate"):
        fit_rigid(log, force="u", position="x", decimate=0)
    with pytest.raises(UsageError, match="force_scale"):
        fit_rigid(log, force="u", position="x", force_scale=0.0)
    counts = log.with_signals({"x": log["x"]}, {"x": "counts"})
    with pytest.raises(DataError, match="unit 'counts'"):
        fit_rigid(counts, force="u", position="x")
    t = log.t.copy()
    t[100:] += 0.01
    with pytest.raises(DataError, match="not uniform"):
        fit_rigid(Log(t, dict(log.signals), dict(log.units)), force="u", position="x")
    with pytest.raises(DataError, match="too few"):
        fit_rigid(log.slice(None, 0.2), force="u", position="x", cutoff_hz=100.0)


def test_rigid_model_file_round_trip_and_errors(tmp_path):
    from feedtune.io import load_model, save_model

    sym = RigidBodyModel(mass=95.1, viscous=203.5, coulomb_pos=20.4, offset=-3.16)
    asym = RigidBodyModel(mass=2.0, viscous=3.0, coulomb_pos=5.0, coulomb_neg=7.0, offset=-1.0, viscous_neg=4.0,
                          command_unit="N*m", position_unit="rad")
    for k, model in enumerate((sym, asym)):
        path = tmp_path / f"r{k}.toml"
        save_model(path, model)
        assert load_model(path) == model
    text = (tmp_path / "r1.toml").read_text()
    assert 'kind = "rigid"' in text and 'mass = { value = 2.0, unit = "N*m/(rad/s^2)" }' in text
    bad = tmp_path / "bad.toml"
    for old, new, message in (('position_unit = "rad"', 'position_unit = "mm"', "position_unit = 'mm'"),
                              ("value = 2.0,", "value = 0.0,", "mass must be > 0"),
                              ("[params]\n", "[params]\nspring = 1.0\n", "unknown rigid-body parameter")):
        bad.write_text(text.replace(old, new, 1))
        with pytest.raises(DataError, match=message):
            load_model(bad)


# --------------------------------------------------------------------------------------- data-quality warnings
def _with(log: Log, **signals) -> Log:
    return Log(log.t, {**dict(log.signals), **signals}, dict(log.units), dict(log.meta))


def test_the_real_emps_log_gives_no_warning(emps_fit):
    assert emps_fit.warnings == ()


def test_a_coarsely_quantized_position_is_warned_about(emps):
    """EMPS's position rounded to 0.1 mm (about one step per sample while moving): the mass comes out 16 % low, and
    the fit says why; at 20 um (0.6 % off) it says nothing; at 1 mm the fit is refused and the reason names the
    quantization."""
    from feedtune.errors import IllConditionedError

    def quantized(q):
        return _with(emps, qm=np.round(emps.get("qm") / q) * q)

    fit = fit_rigid(quantized(1e-4), force="vir", position="qm", force_scale=GTAU, cutoff_hz=100.0)
    assert abs(fit.values["mass"] / EMPS_SYMMETRIC["mass"] - 1) > 0.1  # the damage the warning is about
    assert any("quantized to 0.0001 m" in w for w in fit.warnings), fit.warnings
    assert "quantized" in " ".join(fit.to_dict()["warnings"])
    from feedtune.errors import cli_message

    w = next(w for w in fit.to_dict()["warnings"] if "quantized" in w)  # the library's words, the command line's
    assert "a lower cutoff_hz" in w and "--" not in w and "a lower --lpf-hz" in cli_message(w)
    # the automatic cut-off sees the quantization floor and filters below it: the mass is back within 2 %
    auto = fit_rigid(quantized(1e-4), force="vir", position="qm", force_scale=GTAU)
    assert auto.cutoff_hz < 50 and abs(auto.values["mass"] / EMPS_SYMMETRIC["mass"] - 1) < 0.02
    assert fit_rigid(quantized(2e-5), force="vir", position="qm", force_scale=GTAU, cutoff_hz=100.0).warnings == ()
    with pytest.raises(IllConditionedError, match=r"quantized to 0\.001 m") as refused:
        fit_rigid(quantized(1e-3), force="vir", position="qm", force_scale=GTAU, cutoff_hz=100.0)
    assert "a lower --lpf-hz" in cli_message(refused.value)


def test_a_command_clipped_at_30_percent_is_warned_about(emps):
    u = emps.get("vir")
    limit = 0.3 * float(np.max(np.abs(u)))
    fit = fit_rigid(_with(emps, vir=np.clip(u, -limit, limit)), force="vir", position="qm", force_scale=GTAU)
    assert any("clipped" in w for w in fit.warnings), fit.warnings
