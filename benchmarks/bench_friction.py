"""Benchmark: Kalman disturbance estimation + Stribeck fit on a long high-rate log (run by hand).

    python benchmarks/bench_friction.py [--seconds 60] [--fs 20000] [--slice 50000] [--repeat 5]

A synthetic tracking log (default 60 s at 20 kHz = 1.2 million samples) is built by inverse dynamics of a
rigid axis with known Stribeck friction (``u = m a + b v + d(v)``, position quantised to 0.1 um) along a
back-and-forth trajectory with several speeds. It times

* the steady-state path: ``estimate_disturbance(method="steady-state")`` and the full
  ``identify_friction`` (estimate + Stribeck fit) on the whole log (imports warmed up first; best and
  median of ``--repeat`` runs);
* the per-sample filterpy predict/update loop on the first ``--slice`` samples, extrapolated linearly to
  the whole log (the loop costs the same per sample, so this is a fair estimate without waiting minutes);
* the joint fit of mass, viscous friction and the law (``fit_joint_friction``, the default of ``identify friction``:
  the law's columns evaluated at the full rate at every step of the fit), with and without the law comparison,
  against the IDIM-LS rigid fit of the same log as the anchor.

Targets: estimate + fit < 1 s, and >= 200x faster than the extrapolated filterpy loop (issue 11); the joint fit
(with the law comparison) within 3x the rigid fit (issue 25).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from feedtune.identify.friction import identify_friction
from feedtune.identify.friction_joint import fit_joint_friction
from feedtune.identify.kalman import estimate_disturbance
from feedtune.identify.rigid import fit_rigid
from feedtune.log import Log
from feedtune.models.friction import StribeckFriction

TRUTH = StribeckFriction(dc_pos=12.0, ds_pos=20.0, dc_neg=-10.0, ds_neg=-17.0, omega_pos=0.008)
MASS = 20.0
VISCOUS = 40.0
SPEEDS = (0.004, 0.01, 0.02, 0.04, 0.08)
ACCELERATION = 0.1
HOLD_S = 0.3
QUANT = 1e-7


def velocity_profile(seconds: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Trapezoids to +v and -v for each speed, repeated to fill ``seconds``: time [s], velocity [m/s]."""
    tb, vb = [0.0], [0.0]
    while tb[-1] < seconds:
        for v in SPEEDS:
            for sign in (1.0, -1.0):
                ramp = v / ACCELERATION
                t0 = tb[-1]
                tb += [t0 + ramp, t0 + ramp + HOLD_S, t0 + 2 * ramp + HOLD_S, t0 + 2 * ramp + HOLD_S + 0.1]
                vb += [sign * v, sign * v, 0.0, 0.0]
    t = np.arange(round(seconds * fs)) / fs
    return t, np.interp(t, tb, vb)


def synthetic_log(seconds: float, fs: float) -> Log:
    """Inverse-dynamics log with columns ``x`` [m] (quantised) and ``u`` [N]."""
    t, v = velocity_profile(seconds, fs)
    x = np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2.0) / fs])
    a = np.gradient(v, 1.0 / fs)
    u = MASS * a + VISCOUS * v + TRUTH.force(v)
    return Log(t, {"x": np.round(x / QUANT) * QUANT, "u": u}, {"x": "m", "u": "N"}, {"source": "synthetic"})


def timed(fn, *args, repeat: int = 1, **kwargs):
    """Result of the last call, best and median wall time [s] over ``repeat`` calls."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn(*args, **kwargs)
        times.append(time.perf_counter() - t0)
    return out, min(times), float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--fs", type=float, default=20_000.0)
    parser.add_argument("--slice", type=int, default=50_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()

    log = synthetic_log(args.seconds, args.fs)
    opts = {"position": "x", "command": "u", "mass": MASS, "viscous": VISCOUS}
    warm = log.slice(None, 2.0)
    identify_friction(warm, **opts)  # imports scipy.signal/linalg/optimize once
    estimate_disturbance(warm.slice(None, warm.t[100]), method="filterpy", **opts)

    est, t_est, t_est_med = timed(estimate_disturbance, log, repeat=args.repeat, **opts)
    result, t_total, t_total_med = timed(identify_friction, log, repeat=args.repeat, **opts)
    part = log.slice(None, log.t[args.slice - 1])
    _, t_part, _ = timed(estimate_disturbance, part, method="filterpy", **opts)
    t_filterpy = t_part * log.n / part.n

    f = result.friction
    print(f"log: {log.n:,} samples ({args.seconds:g} s at {args.fs:g} Hz), observer poles "
          f"{', '.join(f'{p:.1f}' for p in est.observer_poles_hz)} Hz")
    print(f"times: best (median) of {args.repeat} runs; the machine may be shared, the best is the cost")
    print(f"steady-state estimate                : {t_est * 1e3:8.1f} ms ({t_est_med * 1e3:.1f} ms)")
    print(f"steady-state estimate + Stribeck fit : {t_total * 1e3:8.1f} ms ({t_total_med * 1e3:.1f} ms)   "
          f"target < 1000 ms: {'PASS' if t_total < 1.0 else 'FAIL'}")
    print(f"filterpy loop, {part.n:,} samples       : {t_part * 1e3:8.1f} ms "
          f"({t_part / part.n * 1e6:.1f} us/sample)")
    print(f"filterpy loop, extrapolated linearly : {t_filterpy:8.2f} s   (whole log: {log.n:,} samples)")
    print(f"speed-up, estimate only              : {t_filterpy / t_est:8.0f} x")
    print(f"speed-up, estimate + Stribeck fit    : {t_filterpy / t_total:8.0f} x   target >= 200 x: "
          f"{'PASS' if t_filterpy / t_total >= 200 else 'FAIL'}")
    fit_joint_friction(warm, position="x", command="u")
    _, t_rigid, _ = timed(fit_rigid, log, force="u", position="x", repeat=args.repeat)
    _, t_joint_plain, _ = timed(fit_joint_friction, log, position="x", command="u", compare_laws=False,
                                repeat=args.repeat)
    joint, t_joint, _ = timed(fit_joint_friction, log, position="x", command="u", repeat=args.repeat)
    print(f"IDIM-LS rigid fit (anchor)           : {t_rigid * 1e3:8.1f} ms")
    print(f"joint fit, no law comparison         : {t_joint_plain * 1e3:8.1f} ms ({t_joint_plain / t_rigid:.2f} x)")
    print(f"joint fit (identify friction)        : {t_joint * 1e3:8.1f} ms ({t_joint / t_rigid:.2f} x)   target "
          f"<= 3 x: {'PASS' if t_joint <= 3 * t_rigid else 'FAIL'}")
    d = joint.law_fit.directions["pos"]
    print(f"  joint fit: mass {joint.mass:.5g} (truth {MASS}), dc_pos {d.dc:.5g}, ds_pos {d.ds:.5g}, omega "
          f"{d.omega:.5g} (truth {TRUTH.omega_pos})")
    print("identified vs truth:")
    for name in ("dc_pos", "ds_pos", "dc_neg", "ds_neg", "omega_pos"):
        got, true = getattr(f, name), getattr(TRUTH, name)
        print(f"  {name:10s} {got:10.5g} {true:10.5g}  ({100 * (got - true) / true:+.2f} %)")


if __name__ == "__main__":
    main()
