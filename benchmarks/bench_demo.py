"""Benchmark: both demos end to end, report included (issue 11: ``feedtune demo --out D`` <= 4 s and
``feedtune demo gantry --out D`` <= 8 s wall on a 2-core machine).

Run by hand: ``python benchmarks/bench_demo.py [--repeat N] [--machine ballscrew|gantry]``.

* Anchor: a fixed single-threaded workload that does not use feedtune (FFTs and a pure-Python loop), best of five,
  measured in the same run: the demos' times are also printed as multiples of it, which move less with the machine's
  load than the seconds do.
* The command a user runs, ``python -m feedtune demo [gantry] --out DIR --force``, in a fresh process (imports,
  loading numba's cached kernels, the tuners side by side on the cores, the report): wall time, best of ``N``
  after one unmeasured run that fills numba's cache (feedtune's cache folder is named after a digest of its sources:
  the first run after an edit compiles the kernels again) and writes Python's bytecode (``PYTHONDONTWRITEBYTECODE``
  is dropped from the environment: an installed package has its bytecode).
* The same command in a fresh process with the time split per step: each step's own time (the steps it calls
  excluded), the tuners one by one (``FEEDTUNE_JOBS=1``, so that each tuner's time shows) and, last, the import of
  the command line (the other imports happen lazily inside the steps that need them).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGETS_S = {"ballscrew": 4.0, "gantry": 8.0}

STEPS = {
    "ballscrew": [
        ("feedtune.machines.ballscrew.experiments", "measure_frf", "measure the FRF (twin)"),
        ("feedtune.identify.ballscrew", "fit_ballscrew", "identify the model"),
        ("feedtune.tune.mcppc", "tune_mcppc", "tune MC-PPC"),
        ("feedtune.tune.ppi", "tune_ppi", "tune P-PI"),
        ("feedtune.workflows.ballscrew_demo", "_tests", "tests on the twin (rope snap, tracking, cut)"),
        ("feedtune.workflows.ballscrew_demo", "_prefilter_tests", "pre-filter: fit and tracking"),
        ("feedtune.workflows.ballscrew_demo", "run_demo", "demo pipeline, the rest (checks, export, logs as text)"),
        ("feedtune.workflows.files", "write_texts", "write the files"),
        ("feedtune.report.build", "build_report", "report: build"),
        ("feedtune.report.build", "write_report", "report: write"),
    ],
    "gantry": [
        ("feedtune.workflows.gantry_demo", "_measure", "measure FRFs and mass runs (twin)"),
        ("feedtune.workflows.gantry_demo", "_identify", "identify mass and model"),
        ("feedtune.tune.gantry", "tune_gantry_mimo", "tune MIMO"),
        ("feedtune.tune.pid", "tune_gantry_pid", "tune PID (same filters, then own filters)"),
        ("feedtune.tune.loopshape", "tune_loopshape", "tune x axis (loop shaping)"),
        ("feedtune.workflows.gantry_demo", "_design", "designs: analysis at x = 0, export"),
        ("feedtune.workflows.gantry_demo", "_tests", "tests on the twin (rope snap, tracking, contours)"),
        ("feedtune.workflows.gantry_demo", "run_gantry_demo", "demo pipeline, the rest"),
        ("feedtune.workflows.files", "write_texts", "write the files"),
        ("feedtune.report.build", "build_report", "report: build"),
        ("feedtune.report.build", "write_report", "report: write"),
    ],
}
"""Per demo: ``(module, function, label)`` of the steps timed (each its own time, without the timed steps it calls)."""


def anchor() -> float:
    """Best of five runs of a fixed single-threaded workload independent of feedtune (FFTs and a Python loop) [s]."""
    import numpy as np

    x = np.random.default_rng(0).standard_normal(1 << 14)

    def work():
        for _ in range(200):
            np.fft.rfft(x)
        s = 0
        for i in range(1_000_000):
            s += i * i % 7
        return s

    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        work()
        best = min(best, time.perf_counter() - t0)
    return best


OBJECTIVE: list[str] = []
"""``["--objective", NAME]`` when ``--objective`` is given (the demos' tuning under another objective)."""


def _command(machine: str, out: Path) -> list[str]:
    return [sys.executable, "-m", "feedtune", "demo", *([machine] if machine != "ballscrew" else []), "--out",
            str(out), "--force", *OBJECTIVE]


def user_env(**extra: str) -> dict[str, str]:
    """The environment of a user's shell: this one without ``PYTHONDONTWRITEBYTECODE`` (some sandboxes and CI
    images set it; an installed feedtune has its bytecode, ``pip install`` compiles it, and a checkout gets it
    from the unmeasured first run), plus ``extra``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return {**env, **extra}


def wall(machine: str, repeat: int) -> list[float]:
    """Wall times [s] of the command in fresh processes (after one unmeasured run)."""
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "demo"
        for i in range(repeat + 1):
            t0 = time.perf_counter()
            subprocess.run(_command(machine, out), check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           env=user_env())
            if i:
                times.append(time.perf_counter() - t0)
    return times


def split(machine: str) -> dict[str, float]:
    """The time per step of one run of the command in a fresh process (tuners one by one)."""
    with tempfile.TemporaryDirectory() as tmp:
        env = user_env(FEEDTUNE_JOBS="1")
        res = subprocess.run([sys.executable, __file__, "--inner", machine, str(Path(tmp) / "demo"), *OBJECTIVE],
                             env=env,
                             check=True, capture_output=True, text=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def _inner(machine: str, out: str) -> None:
    """In a fresh process: import the command line, time every step of one demo run, print the times as JSON."""
    import importlib

    t0 = time.perf_counter()
    from feedtune.cli.main import app

    t_import = time.perf_counter() - t0
    own: dict[str, float] = {}
    stack: list[float] = []  # time spent in timed callees of each open step

    def timed(fn, label):
        def wrapper(*args, **kwargs):
            stack.append(0.0)
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                total = time.perf_counter() - start
                inner = stack.pop()
                own[label] = own.get(label, 0.0) + total - inner
                if stack:
                    stack[-1] += total
        return wrapper

    for module, name, label in STEPS[machine]:
        mod = importlib.import_module(module)
        setattr(mod, name, timed(getattr(mod, name), label))
    from typer.testing import CliRunner

    args = ["demo", *([machine] if machine != "ballscrew" else []), "--out", out, "--force", *OBJECTIVE]
    t1 = time.perf_counter()
    res = CliRunner().invoke(app, args)
    total = time.perf_counter() - t1
    if res.exit_code != 0:
        raise SystemExit(f"demo failed: {res.output}{res.exception!r}")
    timed_sum = sum(own.values())
    out_times = {"import of the command line": t_import, **own, "other (CLI, staging folder)": total - timed_sum,
                 "total in process": t_import + total}
    print(json.dumps(out_times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="measured runs of each command (best taken)")
    parser.add_argument("--machine", choices=sorted(STEPS), action="append", help="only this demo (repeatable)")
    parser.add_argument("--inner", nargs=2, metavar=("MACHINE", "OUT"), help=argparse.SUPPRESS)
    parser.add_argument("--objective", choices=("stiffness", "bandwidth", "pareto"),
                        help="the demos' tuning objective (default: the tuners' default)")
    args = parser.parse_args()
    if args.objective:
        OBJECTIVE[:] = ["--objective", args.objective]
    if args.inner:
        _inner(*args.inner)
        return
    a = anchor()
    print(f"anchor (FFTs + a Python loop, best of 5): {a:.3f} s")
    for machine in args.machine or ["ballscrew", "gantry"]:
        times = wall(machine, args.repeat)
        best = min(times)
        print(f"\nfeedtune demo{' ' + machine if machine != 'ballscrew' else ''} --out DIR: best {best:.2f} s wall "
              f"of {', '.join(f'{t:.2f}' for t in times)} (target {TARGETS_S[machine]:g} s; {best / a:.1f} anchors)")
        parts = split(machine)
        print("  time per step, tuners one by one (FEEDTUNE_JOBS=1) [s]:")
        for label, t in parts.items():
            print(f"    {label:58s} {t:7.3f}")


if __name__ == "__main__":
    main()
