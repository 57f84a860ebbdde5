"""Timing of FRF estimation on a long log: 60 s at 20 kHz (1.2 M samples), one input, two outputs.

Run by hand: ``python benchmarks/bench_frf_estimate.py [--csv]``. Prints the best of a few runs per case of
the library call, then the ``feedtune frf`` command end to end on the log written as a MATLAB file (and as
CSV with ``--csv``): in a fresh process, minus the start-up of ``feedtune --help`` (Python, typer, the CLI
modules), and in-process with warm imports. Target: < 1 s per estimate and per command.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import signal
from timing import best_of

from feedtune.identify.frf_estimate import estimate_frf
from feedtune.log import Log

FS = 20_000.0
N = int(60 * FS)
PERIOD = 20_000  # 1 s multisine period, 1 Hz lines


def _plant_outputs(u: np.ndarray, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Two position outputs of a resonant plant (motor and load side) with measurement noise."""
    w = 2 * np.pi * np.array([80.0, 300.0]) / FS
    sos = [np.r_[0.0, 1e-3, 0.0, 1.0, -2 * 0.995 * np.cos(wk), 0.995**2] for wk in w]
    x1 = signal.sosfilt(np.array(sos), u)
    x2 = signal.sosfilt(np.array(sos[:1]), u)
    return {"x1": x1 + 1e-6 * rng.standard_normal(N), "x2": x2 + 1e-6 * rng.standard_normal(N)}


def _multisine(rng: np.random.Generator) -> np.ndarray:
    spec = np.zeros(PERIOD // 2 + 1, complex)
    spec[5:2001] = np.exp(2j * np.pi * rng.random(1996))
    one = np.fft.irfft(spec, PERIOD)
    return np.tile(one / np.abs(one).max(), N // PERIOD)



def main() -> Log:
    rng = np.random.default_rng(0)
    t = np.arange(N) / FS
    units = {"u": "V", "x1": "m", "x2": "m"}
    noise_u = rng.standard_normal(N)
    noise_log = Log(t, {"u": noise_u, **_plant_outputs(noise_u, rng)}, units)
    ms_u = _multisine(rng)
    ms_log = Log(t, {"u": ms_u, **_plant_outputs(ms_u, rng)}, units)
    cases = {
        "h1, nperseg 4096, 50 % overlap": lambda: estimate_frf(
            noise_log, input="u", outputs=["x1", "x2"], nperseg=4096),
        "h1, default nperseg": lambda: estimate_frf(noise_log, input="u", outputs=["x1", "x2"]),
        "periodic, period given": lambda: estimate_frf(
            ms_log, input="u", outputs=["x1", "x2"], method="periodic", period_samples=PERIOD),
        "periodic, period detected": lambda: estimate_frf(
            ms_log, input="u", outputs=["x1", "x2"], method="periodic"),
    }
    print(f"{N} samples at {FS:g} Hz, 2 outputs")
    for name, fn in cases.items():
        frf = fn()
        print(f"  {name:32s} {best_of(fn, 3) * 1e3:8.1f} ms   ({frf.freq_hz.size} lines)")
    return ms_log


def _wall(cmd: list[str], repeat: int = 3) -> float:
    """Best wall time [s] of a subprocess."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_cli(log: Log, csv: bool) -> None:
    """``feedtune frf`` end to end on the log written to disk (.mat, and .csv when asked)."""
    from scipy.io import savemat
    from typer.testing import CliRunner

    from feedtune.cli.main import app
    from feedtune.io import write_log_csv

    exe = [sys.executable, "-m", "feedtune.cli.main"]
    startup = _wall([*exe, "--help"])
    print(f"feedtune frf end to end (python start-up + CLI import {startup * 1e3:.0f} ms subtracted)")
    with tempfile.TemporaryDirectory() as d:
        paths = [Path(d) / "multisine.mat"]
        savemat(paths[0], {"t": log.t, **log.signals})
        if csv:
            paths.append(Path(d) / "multisine.csv")
            write_log_csv(log, paths[1])
        for path in paths:
            for method in (["--method", "periodic"], ["--method", "h1"]):
                args = ["frf", str(path), "--input", "u", "--output", "x1,x2", *method,
                        "--out", str(Path(d) / "frf.csv"), "--force", "--json"]
                fresh = _wall([*exe, *args]) - startup
                runner = CliRunner()
                runner.invoke(app, args)
                t0 = time.perf_counter()
                res = runner.invoke(app, args)
                warm = time.perf_counter() - t0
                assert res.exit_code == 0, res.output
                print(f"  {path.suffix} {method[1]:9s} fresh process {fresh * 1e3:8.1f} ms, warm {warm * 1e3:8.1f} ms")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--csv", action="store_true", help="also time the command on a 108 MB CSV log")
    bench_cli(main(), parser.parse_args().csv)
