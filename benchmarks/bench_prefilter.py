"""Benchmark: least-squares pre-filter fit on a long high-rate tracking log, and the discretization choice.

    python benchmarks/bench_prefilter.py [--seconds 60] [--fs 20000] [--repeat 3]

A synthetic tracking log (default 60 s at 20 kHz = 1.2 million samples) holds back-and-forth snap-limited
moves (``multi_segment``) and the error of a known error transfer function ``G_e = 1 - 1/(1 + s/w0)^2``
(``w0 = 2 pi 100 Hz``, filtered with scipy's ``lsim``) plus 5 nm white noise. It times

* ``fit_prefilter`` using the logged derivatives ``v_ref .. s_ref`` (imports warmed up; best and median of
  ``--repeat`` runs),
* ``fit_prefilter`` from ``x_ref`` alone (filtered differentiation),

and prints the recovered Maclaurin coefficients against the closed form ``c_k = (-1)^(k+1) (k+1) / w0^k``
(the moves are fast for ``w0``, so ``c3`` and ``c4`` carry a few percent of the truncated higher-order terms of
eq. 3.16). Target: < 1 s per fit.

It also compares discretizations of the pre-filter correction ``F(s) - 1`` (gains of the MC-PPC twin fit,
80 Hz) at 20 kHz: the largest error of ``F(e^{jwT})`` against ``F(jw)`` up to 200 Hz, relative to ``|F - 1|``,
for the bilinear transform used by feedtune, pole-zero matching (``feedtune.control.discretize.matched``) and
scipy's zero- and first-order holds.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from feedtune.control.prefilter import ORDERS, correction_sos, prefilter_response
from feedtune.design.prefilter import fit_prefilter
from feedtune.sim.trajectory import multi_segment

W0 = 2 * np.pi * 100.0
TWIN_GAINS = {"K_vel": -3.9e-09, "K_acc": -1.957e-07, "K_jerk": -2.42e-10, "K_snap": 1.44e-11}
"""Pre-filter fitted on the MC-PPC twin at 500 mm/s (tests/test_prefilter.py) [s .. s^4]."""


def synthetic_log(seconds: float, fs: float):
    """Back-and-forth moves for about ``seconds`` with the error of the known ``G_e`` [m]."""
    from scipy.signal import lsim

    one = multi_segment([0.0, 0.15, 0.05, 0.2, 0.0], v_max=0.4, a_max=4.0, j_max=200.0, s_max=2e4, fs=fs,
                        dwell=0.1)
    reps = max(1, int(np.ceil(seconds / one.duration)))
    waypoints = [0.0] + [0.15, 0.05, 0.2, 0.0] * reps
    tr = multi_segment(waypoints, v_max=0.4, a_max=4.0, j_max=200.0, s_max=2e4, fs=fs, dwell=0.1)
    _, x2, _ = lsim(([1.0], np.polymul([1 / W0, 1.0], [1 / W0, 1.0])), tr.pos, tr.t)
    noise = 5e-9 * np.random.default_rng(0).standard_normal(tr.n)
    return tr.to_log().with_signals({"e2": tr.pos - x2 + noise}, {"e2": "m"})


def time_fit(log, repeat: int) -> tuple[float, float, object]:
    times, fit = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        fit = fit_prefilter(log)
        times.append(time.perf_counter() - t0)
    return min(times), float(np.median(times)), fit


def discretization_errors(fs: float, lpf_hz: float = 80.0, f_max: float = 200.0) -> dict:
    """Largest ``|F_d - F| / |F - 1|`` on 1..f_max Hz for four discretizations of the correction."""
    from scipy.signal import cont2discrete, freqz

    from feedtune.control.discretize import matched
    from feedtune.lti import Zpk

    f = np.geomspace(1.0, f_max, 400)
    cont = prefilter_response(TWIN_GAINS, lpf_hz, f)
    w = 2 * np.pi * lpf_hz
    K = [TWIN_GAINS[f"K_{o}"] for o in ORDERS]
    num = np.zeros(6)
    for k in range(1, 5):
        term = K[k - 1] * w ** (k + 1) * np.polymul(np.r_[1.0, np.zeros(k)], np.poly(-w * np.ones(4 - k)))
        num[-term.size:] += term
    den = np.poly(-w * np.ones(5))
    ref = np.abs(cont - 1)
    out = {"bilinear (feedtune)": 1.0 + _sos_resp(correction_sos(TWIN_GAINS, lpf_hz, fs), f, fs)}
    roots = np.roots(num)
    m = matched(Zpk(roots, -w * np.ones(5), num[np.flatnonzero(num)[0]]), fs)
    out["pole-zero matched"] = 1.0 + m.tf.freqresp(f) * np.exp(2j * np.pi * f * m.delay_samples / fs)
    for method in ("zoh", "foh"):
        with warnings.catch_warnings():  # scipy warns about the five-fold pole's polynomial, as expected
            warnings.simplefilter("ignore")
            b, a, _ = cont2discrete((num, den), 1 / fs, method=method)
        _, h = freqz(np.ravel(b), a, worN=f, fs=fs)
        out[method] = 1.0 + h
    return {k: float(np.max(np.abs(v - cont) / ref)) for k, v in out.items()}


def _sos_resp(sos, f, fs):
    from feedtune.lti import sos_freqresp

    return sos_freqresp(sos, f, fs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--fs", type=float, default=20000.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    log = synthetic_log(args.seconds, args.fs)
    print(f"log: {log.n} samples ({log.t[-1]:.1f} s at {log.fs:g} Hz)")
    fit_prefilter(log.slice(0, 1.0))  # warm up imports
    best, med, fit = time_fit(log, args.repeat)
    print(f"fit_prefilter with v_ref..s_ref: best {best:.3f} s, median {med:.3f} s")
    x_only = log.__class__(log.t, {"x_ref": log["x_ref"], "e2": log["e2"]}, {"x_ref": "m", "e2": "m"})
    best_x, med_x, fit_x = time_fit(x_only, args.repeat)
    print(f"fit_prefilter with x_ref only:  best {best_x:.3f} s, median {med_x:.3f} s")
    expected = [(-1) ** (k + 1) * (k + 1) / W0**k for k in range(1, 5)]
    for name, fx in (("derivatives", fit), ("x_ref only", fit_x)):
        got = fx.maclaurin()
        rel = ", ".join(f"c{k} {got[f'c{k}'] / expected[k - 1] - 1:+.2e}" for k in range(1, 5))
        print(f"  {name}: Maclaurin relative error {rel}; condition number {fx.condition_number:.3g}; "
              f"predicted reduction {100 * fx.predicted_reduction:.3f} %")
    print(f"discretization of F(s) - 1 at {args.fs:g} Hz (twin gains, 80 Hz low-pass), max |F_d - F| / |F - 1| "
          "on 1..200 Hz:")
    for name, err in discretization_errors(args.fs).items():
        print(f"  {name:22s} {err:.2e}")


if __name__ == "__main__":
    main()
