"""Logs as loggers write them (``%`` headers, ``;`` rows, NaN rows, time in ticks), the resampler for irregular time
bases, and MATLAB objects named with their re-export.

The files are built here from the facts of each layout (an ODrive tool's, from the real files' README); the numbers
they must give are the ones written into them (the signals, the tick rate), and the resampler is held to the signal it
sampled (a sine known at every instant) and to what an anti-alias filter must do (a tone above the new Nyquist
frequency removed).
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from cli_run import run

from feedtune.errors import DataError, UsageError
from feedtune.io import read_frf, read_log
from feedtune.log import Log
from feedtune.log_resample import resample_log, time_base_report

TICK_HZ = 8000.0


def _odrive_file(path, ticks, cols, *, nan_rows=(), trailing_zero=0, header_rate="8Hz", comment_rate="8kHz"):
    """An ODrive characterisation log: the tool's comment header, ``;`` at every row's end, ``nan`` rows."""
    lines = ["%Motor characterization data", "%Each row's values were recorded on the same timestep"]
    if comment_rate:
        lines.append(f"%Timestep increments at {comment_rate}")
    lines += ["", "%Operator:", "%ODrive axis: axis0", "%Date:,29/04/2021", "",
              f"%timestep ({header_rate}),voltage,position,velocity", "%[#],[V],[turns],[turns/s]"]
    for k, tick in enumerate(ticks):
        if k in nan_rows:
            lines.append("nan,nan,nan,nan;")
        lines.append(",".join(repr(float(v)) for v in (tick, *(c[k] for c in cols))) + ";")
    lines += ["0.0,0.0,1.5,0.0;"] * trailing_zero
    path.write_text("\n".join(lines) + "\n")
    return path


def _irregular_ticks(n, seed=0):
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.integers(37, 77, n)).astype(float)  # 4.6-9.6 ms between rows at 8 kHz


def test_an_odrive_log_reads_as_written(tmp_path):
    ticks = _irregular_ticks(500)
    t = ticks / TICK_HZ
    volts, pos = 0.25 * (t > 1.0), np.sin(t)
    path = _odrive_file(tmp_path / "step.csv", ticks, [volts, pos, np.cos(t)], nan_rows=(0, 40, 41, 300),
                        trailing_zero=11)
    log = read_log(path)
    assert list(log.signals) == ["voltage", "position", "velocity"]
    assert log.units == {"voltage": "V", "position": "turns", "velocity": "turns/s"}
    assert np.array_equal(log.t, t) and np.array_equal(log["position"], pos)
    lines = path.read_text().splitlines()
    nan_lines = [k + 1 for k, line in enumerate(lines) if line.startswith("nan")]
    assert log.meta["dropped_rows"].startswith(f"4 row(s) NaN in every column (a failed read) dropped: line(s) "
                                               f"{', '.join(map(str, nan_lines))}")
    assert "11 trailing row(s) with timestep 0 (the counter stopped)" in log.meta["dropped_rows"]
    assert log.meta["time_base"].startswith("t = timestep / 8000 Hz (from the comment 'Timestep increments at 8kHz')")
    assert "the header's timestep (8Hz) says 8 Hz" in log.meta["time_base"]
    assert log.meta["odrive axis"] == "axis0" and log.meta["date"] == "29/04/2021"


def test_the_tick_rate_the_header_states_when_no_comment_does(tmp_path):
    ticks = _irregular_ticks(300)
    path = _odrive_file(tmp_path / "a.csv", ticks, [ticks * 0, ticks * 0, ticks * 0], header_rate="8 kHz",
                        comment_rate=None)
    assert np.array_equal(read_log(path).t, ticks / TICK_HZ)


@pytest.mark.parametrize(("header_rate", "comment_rate", "fragment"), [
    ("#", None, "the file states no tick rate"),
    ("8kHz", "16kHz", "give no one plausible sample rate"),
])
def test_no_rate_or_two_plausible_ones_ask_for_the_scale(tmp_path, header_rate, comment_rate, fragment, capsys,
                                                          monkeypatch):
    ticks = _irregular_ticks(300)
    path = _odrive_file(tmp_path / "a.csv", ticks, [ticks * 0] * 3, header_rate=header_rate, comment_rate=comment_rate)
    with pytest.raises(DataError, match=fragment):
        read_log(path)
    code, _, err = run(["log", "convert", path, "--out", tmp_path / "o.csv"], capsys, monkeypatch)
    assert code == 1 and "--scale timestep=S" in err
    assert np.allclose(read_log(path, scale={"timestep": 1 / TICK_HZ}).t, ticks / TICK_HZ, rtol=1e-15, atol=0)


def test_a_nan_among_numbers_stays_an_error_and_a_large_file_reads_the_same(tmp_path):
    ticks = _irregular_ticks(6000)
    data = [np.sin(ticks), np.cos(ticks), ticks * 1e-3]
    big = _odrive_file(tmp_path / "big.csv", ticks, data, nan_rows=(10, 5000))  # > 64 kB: the whole-file parser
    assert big.stat().st_size > 1 << 16
    log = read_log(big)
    assert log.n == 6000 and np.array_equal(log["voltage"], data[0])
    text = big.read_text().replace(f"{float(data[2][20])!r};", "nan;", 1)
    (tmp_path / "bad.csv").write_text(text)
    with pytest.raises(DataError, match="empty or NaN cell"):
        read_log(tmp_path / "bad.csv")


def test_a_commented_header_with_a_units_row_and_plain_hash_comments(tmp_path):
    path = tmp_path / "daq.txt"
    path.write_text("# DAQ\n# t [s],u,x\n0,1,2\n0.001,1,3\n0.002,1,4\n")
    log = read_log(path)
    assert list(log.signals) == ["u", "x"] and log.dt == pytest.approx(1e-3)


# ------------------------------------------------------------------------------------------ resampling
def _irregular_log(n=4000, seed=2, tones=((3.0, 1.0),)):
    rng = np.random.default_rng(seed)
    t = np.cumsum(np.r_[0.0, rng.uniform(4.6e-3, 9.6e-3, n - 1)])
    x = sum(a * np.sin(2 * np.pi * f * t) for f, a in tones)
    return Log(t, {"x": x}, {"x": "rad"}, {"source": "odrive.csv"})


def test_the_time_base_report_is_the_intervals():
    log = _irregular_log()
    d = np.diff(log.t)
    r = time_base_report(log.t)
    assert (r.min_s, r.max_s, r.median_s, r.jitter_s) == (d.min(), d.max(), np.median(d), d.std())
    assert r.largest_gap == d.max() / np.median(d) and not r.uniform
    assert "jitter" in str(r) and r.to_dict()["units"]["median_rate_hz"] == "Hz"


def test_resampling_keeps_the_signal_and_removes_what_the_new_rate_would_alias():
    """A 3 Hz sine sampled at irregular instants (4.6-9.6 ms), resampled at 50 Hz (below the median rate, ~140 Hz):
    within 1e-3 of the sine at the new instants (linear interpolation would be 4e-3 off). A 40 Hz tone added,
    above the new Nyquist frequency (25 Hz), is removed instead of folded to 10 Hz: taken at the new instants
    without the low-pass it stays whole (amplitude 1); with it, what is left is under a tenth (the interpolation of
    a tone of 3.5 samples per period between irregular instants leaves some of it at low frequencies)."""
    from feedtune.log_resample import uniform_instants

    clean = resample_log(_irregular_log(), 50.0)
    assert clean.is_uniform() and clean.fs == pytest.approx(50.0)
    mid = slice(20, -20)  # the zero-phase filter's ends
    assert np.max(np.abs(clean["x"][mid] - np.sin(2 * np.pi * 3.0 * clean.t[mid]))) < 1e-3
    noisy = _irregular_log(tones=((3.0, 1.0), (40.0, 1.0)))
    tone = resample_log(noisy, 50.0)
    t = uniform_instants(noisy.t[0], noisy.t[-1], 50.0)
    folded = np.interp(t, noisy.t, noisy["x"]) - np.sin(2 * np.pi * 3.0 * t)
    assert np.max(np.abs(folded[mid])) > 0.9
    assert np.max(np.abs(tone["x"][mid] - clean["x"][mid])) < 0.1
    up = resample_log(_irregular_log(), 500.0)  # above the median rate: interpolation only
    assert np.max(np.abs(up["x"] - np.sin(2 * np.pi * 3.0 * up.t))) < 2e-3  # linear: 4e-3
    assert "low-passed" in clean.meta["resample"] and "low-passed" not in up.meta["resample"]


def test_a_gap_is_refused_unless_allowed_and_the_fit_commands_name_the_resampler(tmp_path, capsys, monkeypatch):
    log = _irregular_log()
    t = log.t.copy()
    t[2000:] += 0.05
    gappy = Log(t, log.signals, log.units, log.meta)
    with pytest.raises(DataError, match="longer than the max_gap of 3 median intervals") as err:
        resample_log(gappy, 100.0)
    assert err.value.parameter == "max_gap"
    assert resample_log(gappy, 100.0, max_gap=20).is_uniform()
    with pytest.raises(UsageError):
        resample_log(log, -1.0)
    path = tmp_path / "irregular.csv"
    from feedtune.io import write_log_csv

    write_log_csv(Log(log.t, {"u": log["x"], "x": log["x"]}, {"u": "V", "x": "rad"}), path)
    for args in (["frf", path, "--output", "x"], ["identify", "rigid", path]):
        code, _, err = run(args, capsys, monkeypatch)
        assert code == 1 and f"resample the log first: feedtune log resample {path} --fs HZ" in err, err
    code, out, err = run(["log", "resample", path, "--out", tmp_path / "u.csv"], capsys, monkeypatch)
    assert code == 0 and "time base of" in out and "jitter" in out, err
    assert read_log(tmp_path / "u.csv").is_uniform()


# ------------------------------------------------------------------------------------------ MATLAB objects
def _element(tag: int, data: bytes) -> bytes:
    return struct.pack("<II", tag, len(data)) + data + b"\0" * (-len(data) % 8)


def _text(s: str) -> bytes:
    b = s.encode()
    return struct.pack("<HH", 1, len(b)) + b + b"\0" * (4 - len(b)) if len(b) <= 4 else _element(1, b)


def _matrix(cls: int, name: str, dims, data: bytes) -> bytes:
    return _element(14, _element(6, struct.pack("<II", cls, 0)) + _element(5, struct.pack(f"<{len(dims)}i", *dims))
                    + _text(name) + data)


def _object(name: str, cls: str) -> bytes:
    """A MATLAB class object as MATLAB saves it: an opaque matrix (class 17) of type system MCOS, compressed."""
    ids = _matrix(13, "", [6, 1], _element(6, struct.pack("<6I", 0xDD000000, 2, 1, 1, 1, 1)))
    opaque = _element(14, _element(6, struct.pack("<II", 17, 0)) + _text(name) + _text("MCOS") + _text(cls) + ids)
    packed = zlib.compress(opaque)
    return struct.pack("<II", 15, len(packed)) + packed


def _mat(path, *elements):
    header = b"MATLAB 5.0 MAT-file, written by the test".ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x100)
    workspace = _matrix(9, "", [1, 16], _element(2, bytes(16)))  # the __function_workspace__ of the objects
    path.write_bytes(header + b"IM" + b"".join(elements) + workspace)
    return path


def test_matlab_objects_are_named_with_their_class_and_the_reexport(tmp_path, capsys, monkeypatch):
    path = _mat(tmp_path / "G.mat", _object("G", "frd"), _object("P", "zpk"))
    for reader in (read_frf, read_log):
        with pytest.raises(DataError) as err:
            reader(path)
        msg = str(err.value)
        assert "G (class frd)" in msg and "P (class zpk)" in msg and "only MATLAB can decode" in msg
        assert "chgFreqUnit(G, 'Hz')" in msg and "freqresp(P, 2*pi*f)" in msg
    code, _, err = run(["identify", "ballscrew", path], capsys, monkeypatch)
    assert code == 1 and "G (class frd)" in err and err.count("\n") == 1 and "MatReadWarning" not in err


def test_a_file_with_arrays_beside_an_object_reads_the_arrays(tmp_path):
    f = np.array([1.0, 2.0, 3.0])
    arrays = _matrix(6, "freq_hz", [3, 1], _element(9, struct.pack("<3d", *f)))
    complex_flags = _element(6, struct.pack("<II", 6 | 0x800, 0))  # double, complex
    h = _element(14, complex_flags + _element(5, struct.pack("<2i", 3, 1)) + _text("x1_u")
                 + _element(9, struct.pack("<3d", 1, 2, 3)) + _element(9, struct.pack("<3d", 0, 0, 1)))
    path = _mat(tmp_path / "mixed.mat", arrays, h, _object("G", "frd"))
    assert read_frf(path).channel("x1/u").tolist() == [1, 2, 3 + 1j]
