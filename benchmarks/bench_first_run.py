"""Benchmark: a new user's first run against the next ones (issue 27: first-run wall time within 1.3x of the warm
run for both demos), and ``tune ppi`` against ``tune mcppc`` on the three example FRFs (within 2x, CPU).

Run by hand: ``python benchmarks/bench_first_run.py [--machine ballscrew|gantry] [--skip-tune] [--skip-warmup]``.

* Per demo, the command a user runs (``python -m feedtune demo [gantry] --out DIR --force``) in fresh processes with
  a fresh kernel cache (``XDG_CACHE_HOME`` a new empty folder, so numba finds nothing compiled):

  - cold: the first run (it compiles the kernels it needs, as its own step), then warm: the next run (best of two);
  - after warm-up: in another fresh cache folder, ``feedtune warmup`` (every kernel, side by side on the cores), then
    the first demo run.

  The ratios cold / warm and first-after-warm-up / warm are the figures; the wall time of ``feedtune warmup`` is
  printed too, and the CPU time of the cold and warm runs (every worker included): on a machine shared with other
  work the wall ratio follows the CPU ratio, since no core is left idle for the compile to fill.
  ``--skip-warmup`` measures cold and warm only. Bytecode is written by a first, unmeasured ``--version`` run (an
  installed package has its bytecode).
* The two tuners as commands on the example model and the three example FRFs (``--filters own`` and ``identical``),
  CPU time of the child processes (``os.wait4``: every worker included), one run each, interleaved.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_demo import _command, user_env

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
RATIO_TARGET = 1.3
"""First run over warm run, wall [-] (issue 27)."""
TUNE_TARGET = 2.0
"""``tune ppi`` over ``tune mcppc``, CPU [-] (issue 27)."""


def timed(args: list[str], env: dict[str, str], cwd: str | None = None) -> tuple[float, float]:
    """``(wall, cpu)`` [s] of ``args`` in a fresh process (CPU of it and its children)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(args, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{err[-2000:]}")
    return wall, usage.ru_utime + usage.ru_stime


def first_runs(machine: str, repeat: int) -> dict[str, float]:
    """:func:`first_run` without the warm-up ``repeat`` times, each in a fresh cache folder (cold, then warm, runs
    interleaved): the medians of ``cold``, ``warm``, ``cold_cpu``, ``warm_cpu`` [s] (one run on a machine shared
    with other work can be off by half)."""
    import statistics

    runs = [first_run(machine, warmup=False) for _ in range(repeat)]
    return {k: statistics.median(r[k] for r in runs) for k in runs[0]}


def first_run(machine: str, warmup: bool = True) -> dict[str, float]:
    """Wall times [s]: ``cold``, ``warm`` (best of two), ``warmup`` and ``after_warmup`` (module docstring; the last
    two without ``warmup``: nan), and the CPU times [s] ``cold_cpu`` and ``warm_cpu`` (the warm run's of the best)."""
    out = {"warmup": float("nan"), "after_warmup": float("nan")}
    with tempfile.TemporaryDirectory() as tmp:
        demo = _command(machine, Path(tmp) / "demo")
        env = user_env(XDG_CACHE_HOME=str(Path(tmp) / "cache_a"))
        env.pop("NUMBA_CACHE_DIR", None)
        timed([sys.executable, "-m", "feedtune", "--version"], env)  # bytecode
        out["cold"], out["cold_cpu"] = timed(demo, env)
        out["warm"], out["warm_cpu"] = min(timed(demo, env) for _ in range(2))
        if not warmup:
            return out
        env_b = {**env, "XDG_CACHE_HOME": str(Path(tmp) / "cache_b")}
        out["warmup"] = timed([sys.executable, "-m", "feedtune", "warmup"], env_b)[0]
        out["after_warmup"] = timed(demo, env_b)[0]
    return out


def tuners() -> dict[str, float]:
    """CPU [s] of ``tune mcppc`` and ``tune ppi`` (``--filters own`` and ``identical``) on the three example FRFs."""
    frfs = [a for m in (70, 100, 130) for a in ("--frf", str(EXAMPLES / f"ballscrew_frf_m{m}.csv"))]
    env = user_env()
    cpu = {}
    with tempfile.TemporaryDirectory() as tmp:
        ft = [sys.executable, "-m", "feedtune"]
        timed([*ft, "identify", "ballscrew", str(EXAMPLES / "ballscrew_frf.csv"), "--out", "model.toml"], env, tmp)
        for filters in ("own", "identical"):
            for tuner in ("mcppc", "ppi"):
                cpu[f"{tuner} --filters {filters}"] = timed(
                    [*ft, "tune", tuner, "model.toml", *frfs, "--filters", filters, "--out", f"{tuner}.toml",
                     "--force", "-q"], env, tmp)[1]
    return cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--machine", choices=("ballscrew", "gantry"), action="append", help="only this demo")
    parser.add_argument("--skip-tune", action="store_true", help="only the demos")
    parser.add_argument("--skip-demos", action="store_true", help="only the tuners")
    parser.add_argument("--skip-warmup", action="store_true", help="the demos cold and warm only (no warmup run)")
    parser.add_argument("--repeat", type=int, default=1, metavar="N",
                        help="with --skip-warmup: N cold/warm pairs, each in a fresh cache folder; their medians")
    args = parser.parse_args()
    if args.repeat < 1 or (args.repeat > 1 and not args.skip_warmup):
        parser.error("--repeat N needs N >= 1, and N > 1 needs --skip-warmup")
    if not args.skip_demos:
        for machine in args.machine or ["ballscrew", "gantry"]:
            t = (first_runs(machine, args.repeat) if args.skip_warmup and args.repeat > 1
                 else first_run(machine, warmup=not args.skip_warmup))
            after = ("" if args.skip_warmup else f"; feedtune warmup {t['warmup']:.1f} s, then the first run "
                     f"{t['after_warmup']:.1f} s: ratio {t['after_warmup'] / t['warm']:.2f}")
            print(f"demo {machine}: cold {t['cold']:.1f} s, warm {t['warm']:.1f} s: ratio {t['cold'] / t['warm']:.2f}"
                  f" (target <= {RATIO_TARGET}); CPU cold {t['cold_cpu']:.1f} s, warm {t['warm_cpu']:.1f} s: ratio "
                  f"{t['cold_cpu'] / t['warm_cpu']:.2f}{after}")
    if not args.skip_tune:
        cpu = tuners()
        for filters in ("own", "identical"):
            ppi, mcppc = cpu[f"ppi --filters {filters}"], cpu[f"mcppc --filters {filters}"]
            print(f"tune on the three example FRFs, --filters {filters}: ppi {ppi:.1f} s CPU, mcppc {mcppc:.1f} s CPU:"
                  f" ratio {ppi / mcppc:.2f} (target <= {TUNE_TARGET})")


if __name__ == "__main__":
    main()
