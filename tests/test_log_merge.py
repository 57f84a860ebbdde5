"""merge_logs against signals known in closed form: two instruments at 2 kHz and 1.5 kHz, one started late, an
offset to remove, a speed to integrate."""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.errors import DataError, UsageError
from feedtune.log import Log
from feedtune.log_merge import merge_logs


def force(t):  # [V]: 0.5 V of sensor offset, at rest until 0.1 s, then a 3 Hz force
    return 0.5 + np.where(t > 0.1, np.sin(2 * np.pi * 3 * (t - 0.1)) ** 2, 0.0)


def speed(t):  # [rpm]
    return 600 * np.sin(2 * np.pi * 2 * t)


def _instruments(lag=0.004):
    t_daq = np.arange(0, 1.0, 1 / 2000)
    daq = Log(t_daq, {"f": force(t_daq)}, {"f": "V"}, {"source": "daq.csv"})
    # the amplifier's clock reads lag seconds less than the DAQ's at the same instant
    t_amp = np.arange(0, 0.99, 1 / 1500)
    amp = Log(t_amp, {"n": speed(t_amp + lag)}, {"n": "rpm"}, {"source": "amp.csv"})
    return daq, amp


def test_merge_resamples_shifts_offsets_scales_and_integrates():
    daq, amp = _instruments()
    to_ms = 20e-3 / 60  # m/s per rpm
    out = merge_logs([daq, amp], shift_s={"n": 0.004}, offset={"f": "mean:10"}, scale={"f": -200.0, "n": to_ms},
                     units={"f": "N", "n": "m/s"}, integrate={"x": "n"})
    assert out.fs == pytest.approx(1500.0)
    assert out.t[0] == pytest.approx(0.004) and out.t[-1] <= 0.99 + 0.004 + 1e-12
    assert out.units == {"f": "N", "n": "m/s", "x": "m"}
    t = out.t
    inner = (t > 0.02) & (t < t[-1] - 0.02)  # the zero-phase filter's edges aside
    np.testing.assert_allclose(out["f"][inner], -200 * (force(t[inner]) - 0.5), atol=0.05)  # N, of +-200
    np.testing.assert_allclose(out["n"][inner], speed(t[inner]) * to_ms, atol=2e-4)  # m/s, of +-0.2
    x_true = 600 * to_ms * (np.cos(2 * np.pi * 2 * t[0]) - np.cos(2 * np.pi * 2 * t)) / (2 * np.pi * 2)
    np.testing.assert_allclose(out["x"], x_true, atol=1e-5)  # m
    assert "offset 0.5 V removed (mean:10)" in out.meta["merge"]["f"]


def test_the_faster_signal_is_low_passed_before_it_is_sampled_slower():
    t = np.arange(0, 1.0, 1 / 2000)
    fast = Log(t, {"a": np.sin(2 * np.pi * 5 * t) + np.sin(2 * np.pi * 900 * t)}, {"a": "V"})
    slow = Log(np.arange(0, 1.0, 1 / 1000), {"b": np.zeros(1000)}, {"b": "V"})
    out = merge_logs([fast, slow])
    inner = (out.t > 0.05) & (out.t < 0.9)
    # 900 Hz would alias to 100 Hz at 1 kHz; after the anti-alias filter only the 5 Hz part is left
    np.testing.assert_allclose(out["a"][inner], np.sin(2 * np.pi * 5 * out.t[inner]), atol=1e-3)


def test_bad_merges_are_named():
    daq, amp = _instruments()
    with pytest.raises(DataError, match=r"'f' is in daq\.csv and in"):
        merge_logs([daq, daq])
    with pytest.raises(DataError, match="offset: no signal 'g'"):
        merge_logs([daq, amp], offset={"g": 1.0})
    with pytest.raises(UsageError, match="'mean:N'"):
        merge_logs([daq, amp], offset={"f": "median:3"})
    with pytest.raises(DataError, match="do not overlap"):
        merge_logs([daq, amp], shift_s={"n": 5.0})
    with pytest.raises(DataError, match="not a rate"):
        merge_logs([daq, amp], integrate={"x": "n"})


def test_cli_convert_and_merge(tmp_path):
    import json

    from typer.testing import CliRunner

    from feedtune.cli.main import app
    from feedtune.io import read_log, write_log_csv

    daq, amp = _instruments()
    write_log_csv(daq, tmp_path / "daq.csv")
    # the amplifier's export: time in ms, the speed in a column named after the channel
    raw = Log(amp.t * 1e3, {"Analog 1": amp["n"], "other": np.zeros(amp.n)}, {}, {"source": "amp"})
    write_log_csv(raw, tmp_path / "amp_raw.csv")
    run = CliRunner()
    res = run.invoke(app, ["log", "convert", str(tmp_path / "amp_raw.csv"), "--scale", "t=1e-3", "--map",
                           "n=Analog 1", "--unit", "n=rpm", "--keep", "n", "--out", str(tmp_path / "amp.csv")])
    assert res.exit_code == 0, res.output
    assert read_log(tmp_path / "amp.csv").units == {"n": "rpm"}
    out = tmp_path / "merged.csv"
    res = run.invoke(app, ["log", "merge", str(tmp_path / "daq.csv"), str(tmp_path / "amp.csv"), "--shift",
                           "n=0.004", "--offset", "f=mean:10", "--scale", "f=-200", "--scale", f"n={20e-3 / 60}",
                           "--unit", "f=N", "--unit", "n=m/s", "--integrate", "x=n", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.stdout)
    assert info["signals"] == {"f": "N", "n": "m/s", "x": "m"} and info["fs_hz"] == pytest.approx(1500, rel=1e-6)
    merged = read_log(out)
    inner = (merged.t > 0.02) & (merged.t < merged.t[-1] - 0.02)
    np.testing.assert_allclose(merged["f"][inner], -200 * (force(merged.t[inner]) - 0.5), atol=0.05)
    with pytest.raises(UsageError, match="two or more logs"):  # exit 2 through main()
        run.invoke(app, ["log", "merge", str(tmp_path / "daq.csv"), "--out", str(tmp_path / "x.csv")],
                   catch_exceptions=False)


def test_a_vendor_log_with_a_units_row_under_the_names(tmp_path):
    from feedtune.io import read_log

    # an amplifier trace: a preamble, the names, a row of units and descriptions, then numbers (time in ms)
    text = ("Axis1\nSampling time interval(ms),0.5\nTime,Analog 1,Analog 2\nms,Servo motor speed,V\n"
            + "".join(f"{0.5 * k},{10.0 * k},{0.1 * k}\n" for k in range(40)))
    (tmp_path / "amp.csv").write_text(text)
    log = read_log(tmp_path / "amp.csv", skip_rows=2, time="Time", mapping={"n": "Servo motor speed"})
    assert log.fs == pytest.approx(2000.0)  # ms converted: the units row is read
    assert log.unit("Analog 2") == "V" and log["n"][3] == 30.0
    # the first data row is line 5 of the file: a bad cell there is named with its line
    (tmp_path / "bad.csv").write_text(text.replace("1.5,30.0,0.3", "1.5,x,0.3"))
    with pytest.raises(DataError, match="line 8"):
        read_log(tmp_path / "bad.csv", skip_rows=2, time="Time")
