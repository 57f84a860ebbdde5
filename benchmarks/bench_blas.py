"""BLAS threads around tiny dense-matrix work (issue 11): with the default thread pool and with one thread.

Run by hand: ``python benchmarks/bench_blas.py``. Each workload is timed in fresh worker processes (the thread pool
is per process), first alone, then with ``--busy`` extra processes keeping the cores loaded (as on a shared
machine or a CI runner: the pool's threads then wait for cores). Workloads: ``scipy.linalg.expm`` of a 7 x 7
matrix, the gantry twin's ZOH tables (a batched ``expm`` over the position grid) and the Kalman model of the friction
identification. "default" turns the library's own limits off (:mod:`feedtune.blas`), "1 thread" runs the workload
inside ``single_threaded_blas()``. The anchor is the same ``expm`` with one BLAS thread in an idle process: every
figure is printed as a ratio to it.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time

import numpy as np


def _workload(name: str):
    import scipy.linalg as sl

    if name == "expm 7x7":
        a = np.random.default_rng(0).normal(size=(7, 7))
        return lambda: sl.expm(a), 400
    if name == "gantry twin tables":
        from feedtune.machines.gantry.twin import GantryTwin

        def tables():
            t = GantryTwin()
            t._tables = None
            t.tables()

        return tables, 5
    if name == "Kalman model + gain":
        from feedtune.identify.kalman import discrete_model, steady_state_gain

        def kalman():
            F, _, Q = discrete_model(2.0, 5.0, 1e-4, 1e3)
            steady_state_gain(F, Q, 1e-12, 2.0, 1e-4)

        return kalman, 100
    raise ValueError(name)


def _time(name: str, single: bool, out) -> None:
    import contextlib

    import feedtune.blas

    single_threaded_blas = feedtune.blas.single_threaded_blas
    if not single:  # the library's own limits off: the default thread pool everywhere
        feedtune.blas.single_threaded_blas = contextlib.nullcontext
    fn, n = _workload(name)
    fn()
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        if single:
            with single_threaded_blas():
                for _ in range(n):
                    fn()
        else:
            for _ in range(n):
                fn()
        best = min(best, (time.perf_counter() - t0) / n)
    out.put(best)


def _busy(stop) -> None:
    x = np.random.default_rng(1).normal(size=(300, 300))
    while not stop.is_set():
        x = np.tanh(x @ x.T / 300)


def _measure(name: str, single: bool, busy: int) -> float:
    ctx = mp.get_context("spawn")
    stop = ctx.Event()
    loaders = [ctx.Process(target=_busy, args=(stop,)) for _ in range(busy)]
    for p in loaders:
        p.start()
    q = ctx.Queue()
    p = ctx.Process(target=_time, args=(name, single, q))
    p.start()
    t = q.get()
    p.join()
    stop.set()
    for lp in loaders:
        lp.join()
    return t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--busy", type=int, default=2, help="processes keeping the cores busy in the loaded runs")
    args = ap.parse_args()
    anchor = _measure("expm 7x7", True, 0)
    print(f"anchor: expm 7x7, one BLAS thread, idle: {1e6 * anchor:.1f} us")
    print(f"{'workload':24s} {'load':>6s} {'default':>12s} {'1 thread':>12s} {'default/1':>10s}  (x anchor)")
    for name in ("expm 7x7", "gantry twin tables", "Kalman model + gain"):
        for busy in (0, args.busy):
            d = _measure(name, False, busy)
            s = _measure(name, True, busy)
            print(f"{name:24s} {busy:>6d} {d / anchor:>12.1f} {s / anchor:>12.1f} {d / s:>10.2f}")


if __name__ == "__main__":
    main()
