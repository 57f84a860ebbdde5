"""Column picking of analyze_tracking_log / analyze_ropesnap_log against closed-form metrics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedtune.analysis.log_analysis import analyze_ropesnap_log, analyze_tracking_log
from feedtune.errors import DataError
from feedtune.io import read_log, write_log_csv
from feedtune.log import Log

FS = 1000.0
A_CRUISE = 1e-6  # m, amplitude of the error sine while cruising
E_ACCEL = 5e-6  # m, constant error while accelerating
F_ERR = 50.0  # Hz


def _trapezoid_log() -> tuple[Log, np.ndarray, np.ndarray]:
    """x_ref: 0.1 s at rest, 0.2 s at 1 m/s^2, 0.6 s at 0.2 m/s, 0.2 s at -1 m/s^2, 0.1 s at rest.

    Error: E_ACCEL while accelerating, A_CRUISE sin(2 pi 50 t) elsewhere. Returns the log (x_ref, v_ref,
    a_ref, e2, x2_table) and the boolean masks of the cruise and acceleration samples.
    """
    t = np.arange(1200) / FS
    a = np.where((t >= 0.1) & (t < 0.3), 1.0, 0.0) - np.where((t >= 0.9) & (t < 1.1), 1.0, 0.0)
    v = np.concatenate([[0.0], np.cumsum(a[:-1]) / FS])
    x = np.concatenate([[0.0], np.cumsum(v[:-1]) / FS])
    accel = a != 0
    cruise = np.isclose(v, 0.2) & ~accel
    e = np.where(accel, E_ACCEL, A_CRUISE * np.sin(2 * np.pi * F_ERR * t))
    sig = {"x_ref": x, "v_ref": v, "a_ref": a, "e2": e, "x2_table": x - e}
    units = {"x_ref": "m", "v_ref": "m/s", "a_ref": "m/s^2", "e2": "m", "x2_table": "m"}
    return Log(t, sig, units, {"source": "trapezoid"}), cruise, accel


def test_tracking_parts_are_the_hand_values():
    log, cruise, accel = _trapezoid_log()
    m = analyze_tracking_log(log)
    e = log["e2"]
    assert int(accel.sum()) == 400
    assert m.overall.max_abs == pytest.approx(E_ACCEL, rel=1e-12)
    assert m.overall.rms == pytest.approx(math.sqrt(np.mean(e**2)), rel=1e-12)
    assert m.acceleration.n_samples == 400 and m.acceleration.max_abs == pytest.approx(E_ACCEL, rel=1e-12)
    assert m.constant_velocity.n_samples == int(cruise.sum()) == 600
    # 600 samples at 1 kHz = 30 whole periods of 50 Hz: max A, RMS A/sqrt(2)
    assert m.constant_velocity.max_abs == pytest.approx(A_CRUISE, rel=1e-9)
    assert m.constant_velocity.rms == pytest.approx(A_CRUISE / math.sqrt(2), rel=1e-9)


def test_gantry_logs_use_their_y_reference_derivatives():
    # the gantry twin logs y_ref, vy_ref, ay_ref: the motion phases come from them, as from v_ref/a_ref
    log, cruise, accel = _trapezoid_log()
    rename = {"x_ref": "y_ref", "v_ref": "vy_ref", "a_ref": "ay_ref"}
    gantry = Log(log.t, {rename.get(k, k): v for k, v in log.signals.items()},
                 {rename.get(k, k): u for k, u in log.units.items()})
    m = analyze_tracking_log(gantry)
    assert m.acceleration.n_samples == int(accel.sum()) == 400
    assert m.constant_velocity.n_samples == int(cruise.sum()) == 600
    assert m.constant_velocity.max_abs == pytest.approx(A_CRUISE, rel=1e-9)


def test_tracking_error_from_reference_minus_position_is_the_same():
    log, _, _ = _trapezoid_log()
    direct = analyze_tracking_log(log).to_dict()
    no_e2 = Log(log.t, {k: v for k, v in log.signals.items() if k != "e2"}, log.units)
    derived = analyze_tracking_log(no_e2).to_dict()  # x_ref - (x_ref - e) = e up to rounding
    for part in ("overall", "constant_velocity", "acceleration"):
        assert derived[part] == pytest.approx(direct[part], rel=1e-9, abs=1e-15), part
    assert [p["freq_hz"] for p in derived["peaks"]] == [p["freq_hz"] for p in direct["peaks"]]
    # explicit position wins over e2; a generic position column in m is found when alone
    assert analyze_tracking_log(log, position="x2_table").overall.max_abs == pytest.approx(E_ACCEL)
    renamed = Log(log.t, {"x_ref": log["x_ref"], "x": log["x2_table"]}, {"x_ref": "m", "x": "m"})
    assert analyze_tracking_log(renamed).overall.max_abs == pytest.approx(E_ACCEL, rel=1e-9)


def test_tracking_velocity_derived_from_the_reference():
    log, cruise, accel = _trapezoid_log()
    bare = Log(log.t, {"x_ref": log["x_ref"], "e2": log["e2"]}, {"x_ref": "m", "e2": "m"})
    m = analyze_tracking_log(bare)
    # np.gradient smears each velocity corner over one sample: the parts differ by a few samples only
    assert abs(m.acceleration.n_samples - int(accel.sum())) <= 4
    assert abs(m.constant_velocity.n_samples - int(cruise.sum())) <= 4
    assert m.acceleration.max_abs == pytest.approx(E_ACCEL, rel=1e-12)
    assert m.constant_velocity.max_abs == pytest.approx(A_CRUISE, rel=1e-6)
    only_error = Log(log.t, {"err": log["e2"]}, {"err": "m"})
    m = analyze_tracking_log(only_error, error="err")
    assert m.constant_velocity is None and m.acceleration is None
    assert m.overall.max_abs == pytest.approx(E_ACCEL)


def test_tracking_column_errors_are_one_line_data_errors():
    log, _, _ = _trapezoid_log()
    in_um = log.with_signals({"e2": log["e2"] * 1e6}, {"e2": "um"})
    with pytest.raises(DataError, match=r"'e2' is in 'um', expected m; convert it with scale=e2=FACTOR units=e2=m"):
        analyze_tracking_log(in_um)
    two = Log(log.t, {"x_ref": log["x_ref"], "xa": log["x2_table"], "xb": log["x2_table"]},
              {"x_ref": "m", "xa": "m", "xb": "m"})
    with pytest.raises(DataError, match=r"several position columns in m \(xa, xb\); choose one with position="):
        analyze_tracking_log(two)
    with pytest.raises(DataError, match="no tracking error 'e2' and no reference 'x_ref'"):
        analyze_tracking_log(Log(log.t, {"x": log["x2_table"]}, {"x": "m"}))
    with pytest.raises(DataError, match="no signal 'nope'"):
        analyze_tracking_log(log, error="nope")


# ------------------------------------------------------------------------------------------ rope snap
T_RELEASE, X0, TAU = 0.2, 20e-6, 0.01  # s, m, s


def _decay_log(meta: dict | None = None) -> Log:
    """Quiet until T_RELEASE, then X0 exp(-(t - T_RELEASE) / TAU): peak X0 at the release, 5 % after TAU ln 20."""
    t = np.arange(1000) / FS
    tau = t - T_RELEASE
    x = np.where(tau >= 0, X0 * np.exp(-np.maximum(tau, 0) / TAU), 0.0)
    return Log(t, {"x2_table": x, "x2": x / 1e-3}, {"x2_table": "m", "x2": "rad"}, meta or {})


def test_ropesnap_peak_and_settling_are_closed_form():
    m = analyze_ropesnap_log(_decay_log({"t_release_s": T_RELEASE}))
    assert not m.release_detected and m.t_release == pytest.approx(T_RELEASE)
    assert m.peak == pytest.approx(X0, rel=1e-12) and m.peak_time == pytest.approx(0.0, abs=1e-12)
    final = X0 * np.mean(np.exp(-(np.arange(900, 1000) / FS - T_RELEASE) / TAU))  # last 10 % of the log
    assert m.final == pytest.approx(final, rel=1e-9)
    # |x - final| < 0.05 X0 from tau = TAU ln(X0 / (0.05 X0 + final)); the next sample counts
    t_settle = TAU * math.log(X0 / (0.05 * X0 + final))
    assert m.settling_time == pytest.approx(math.ceil(t_settle * FS) / FS, abs=1e-9)


def test_ropesnap_release_from_csv_meta_or_detected(tmp_path):
    path = tmp_path / "rs.csv"
    write_log_csv(_decay_log({"source": "decay", "t_release_s": T_RELEASE}), path)
    log = read_log(path)
    assert log.meta["t_release_s"] == "0.2"  # CSV metadata arrives as text
    m = analyze_ropesnap_log(log)
    assert not m.release_detected and m.t_release == pytest.approx(T_RELEASE)
    detected = analyze_ropesnap_log(_decay_log())
    assert detected.release_detected and detected.t_release == pytest.approx(T_RELEASE, abs=1.5 / FS)
    given = analyze_ropesnap_log(log, t_release=0.1)
    assert given.t_release == pytest.approx(0.1) and not given.release_detected


def test_ropesnap_column_errors():
    log = _decay_log()
    rad_only = Log(log.t, {"x2": log["x2"]}, {"x2": "rad"})
    with pytest.raises(DataError, match=r"no position column \('x2_table' or a signal in m\)"):
        analyze_ropesnap_log(rad_only)
    with pytest.raises(DataError, match=r"position 'x2' is in 'rad', expected m"):
        analyze_ropesnap_log(log, position="x2")
    with pytest.raises(DataError, match="t_release_s = 'soon' is not a time in s"):
        analyze_ropesnap_log(Log(log.t, log.signals, log.units, {"t_release_s": "soon"}))
