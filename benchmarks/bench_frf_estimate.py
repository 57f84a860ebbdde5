"""Timing of FRF estimation on a long log: 60 s at 20 kHz (1.2 M samples), one input, two outputs.

Run by hand: ``python benchmarks/bench_frf_estimate.py``. Prints the best of a few runs per case; the
target is < 1 s per estimate.
"""

from __future__ import annotations

import time

import numpy as np
from scipy import signal

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


def _best(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
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
        print(f"  {name:32s} {_best(fn) * 1e3:8.1f} ms   ({frf.freq_hz.size} lines)")


if __name__ == "__main__":
    main()
