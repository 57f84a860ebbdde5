"""The formats of issue 25 on the real data sets (skipped without ../shared/data/real).

* The two-mass bench as a drive's analyser would export it, one Bode file per encoder (the load one sign-inverted),
  built here from the bench's FRF: one command identifies the model of the log-based FRF within 1 %; the same pair
  without channel names is refused, naming both files.
* The ODrive logs read as they are: the rows the reader drops are the ``nan`` rows and the stopped counter's rows
  counted in the files themselves, the time is the README's ``timestep / 8000`` s, and every log resamples onto a
  uniform base on which the FRF and the rigid-body fit run.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_run import run

from feedtune.io import read_frf, read_log

pytestmark = pytest.mark.slow

BENCH = "twomass_motor_bench_FdiTools/MultisineTypeA.mat"
ODRIVE = "odrive_motor_characterization"
PARAMS = ("m1", "m2", "b1", "b2", "k", "c")


def _json(args, capsys, monkeypatch) -> dict:
    code, out, err = run([*args, "--json"], capsys, monkeypatch)
    assert code == 0, err
    return json.loads(out)


def _bode(path, frf, channel, sign=1.0):
    h = sign * frf.channel(channel)
    rows = ["Frequency [Hz],Magnitude [dB],Phase [deg]"]
    rows += [f"{f!r},{float(20 * np.log10(abs(v)))!r},{float(np.degrees(np.angle(v)))!r}"
             for f, v in zip(frf.freq_hz.tolist(), h, strict=True)]
    path.write_text("\n".join(rows) + "\n")
    return path


def test_the_bench_as_one_bode_file_per_encoder_identifies_as_its_log(real_data_dir, tmp_path, capsys, monkeypatch):
    frf_file = tmp_path / "tm_frf.csv"
    _json(["frf", real_data_dir / BENCH, "--map", "u=iq_adx", "--map", "x1=theta_mx", "--map", "x2=theta_my",
           "--scale", "x2=-1", "--scale", "time=1e-6", "--unit", "u=A", "--unit", "x1=rad", "--unit", "x2=rad",
           "-y", "x1,x2", "--method", "periodic", "--period-samples", "2500", "--out", frf_file], capsys, monkeypatch)
    reference = _json(["identify", "ballscrew", frf_file], capsys, monkeypatch)["params"]
    frf = read_frf(frf_file)
    motor = _bode(tmp_path / "motor.csv", frf, "x1/u")
    load = _bode(tmp_path / "load.csv", frf, "x2/u", sign=-1.0)  # the load encoder counting the other way
    pieces = _json(["identify", "ballscrew", f"{motor}:x1/u,in=A+{load}:x2/u,scale=-1,in=A"], capsys,
                   monkeypatch)["params"]
    for name in PARAMS:
        assert pieces[name]["value"] == pytest.approx(reference[name]["value"], rel=0.01), name
        assert pieces[name]["unit"] == reference[name]["unit"], name
    code, _, err = run(["identify", "ballscrew", motor, load], capsys, monkeypatch)
    assert code == 2 and str(motor) in err and str(load) in err and "name the channel" in err


def _counted(path):
    """NaN rows and trailing zero-counter rows of an ODrive file, counted in its text."""
    rows = [line for line in path.read_text().splitlines() if line and not line.startswith("%")]
    nan = sum(line.startswith("nan") for line in rows)
    trailing = 0
    for line in reversed(rows):
        if not line.startswith("0.0,"):
            break
        trailing += 1
    return nan, trailing, [line for line in rows if not line.startswith("nan")][:len(rows) - nan - trailing]


@pytest.mark.parametrize("name", ["step1", "step2", "step3", "chirp1", "chirp2", "chirp3", "noise1"])
def test_odrive_logs_read_as_written_and_resample(real_data_dir, name, tmp_path, capsys, monkeypatch):
    path = real_data_dir / ODRIVE / f"{name}.csv"
    log = read_log(path)
    nan, trailing, rows = _counted(path)
    assert log.n == len(rows)
    assert f"{nan} row(s) NaN in every column" in log.meta["dropped_rows"]
    assert f"{trailing} trailing row(s) with timestep 0" in log.meta["dropped_rows"]
    ticks = np.array([float(r.split(",")[0]) for r in rows])
    assert np.array_equal(log.t, ticks / 8000.0)  # README: time = timestep / 8000 s
    assert np.array_equal(log["position"], [float(r.split(",")[2]) for r in rows])
    assert log.units == {"voltage": "V", "position": "turns", "velocity": "turns/s"}
    out = tmp_path / "u.csv"
    done = _json(["log", "resample", path, "--max-gap", "5", "--map", "u=voltage", "--map", "x=position",
                  "--scale", "x=6.283185307179586", "--unit", "x=rad", "--out", out], capsys, monkeypatch)
    assert 5e-3 < done["time_base"]["median_s"] < 6.5e-3  # the README: median about 5.5 ms (6.25 in chirp3)
    assert read_log(out).is_uniform()
    if name.startswith("chirp"):
        est = _json(["frf", out, "--input", "u", "--output", "x", "--nperseg", "256"], capsys, monkeypatch)
        assert est["unit"] == "rad/V" and est["channels"]["x/u"]["coherence"]["median"] > 0.7
    if name.startswith("step"):  # the rigid-body fit runs on the resampled step (its numbers: identify/rigid's tests)
        fit = _json(["identify", "rigid", out, "--position", "x", "--input", "u"], capsys, monkeypatch)
        assert fit["units"]["viscous"] == "V/(rad/s)"
