"""Benchmark: the full demo report (``feedtune report demo_out --out report.html``).

Run by hand: ``python benchmarks/bench_report.py``. Writes the default ``feedtune demo`` files into a temporary
folder (not timed), then times

* ``build_report(render=False)`` in this process (the sections, tables and data; the figures are drawn where they
  are rendered), with the identification and design functions replaced by ones that raise (the report must use the
  results stored in the files, not recompute them);
* drawing every figure once (``render_pngs``) in this process alone and split over the available CPUs (forked
  children, the default), each the best of three, with the CPU time of this process;
* the command ``feedtune report DIR --out report.html`` in a fresh process (imports included), with one process
  (``FEEDTUNE_REPORT_PROCESSES=1``) and the default, and with ``--pdf``.

Timings on a shared machine are noisy: every figure is the minimum of three runs. Targets: under 10 s for the full
demo report, HTML under 10 MB.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 10.0
TARGET_BYTES = 10e6


def _refuse(*args, **kwargs):
    raise AssertionError("the report recomputed an identification or design stored in its input files")


def _forbid_recomputation() -> None:
    import feedtune.design.mcppc
    import feedtune.design.prefilter
    import feedtune.identify.ballscrew
    import feedtune.tune.ppi

    feedtune.identify.ballscrew.fit_ballscrew = _refuse
    feedtune.design.mcppc.design_mcppc = _refuse
    feedtune.tune.ppi.tune_ppi = _refuse
    feedtune.design.prefilter.fit_prefilter = _refuse


def _cli(args: list[str], env: dict | None = None) -> float:
    import os

    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "feedtune.cli.main", *args], check=True, stdout=subprocess.DEVNULL,
                       env={**os.environ, **(env or {})})
        best = min(best, time.perf_counter() - t0)
    return best


def _best(fn, repeat: int = 3) -> tuple[float, float, object]:
    """``(wall [s], CPU of this process [s], result)`` of the fastest of ``repeat`` calls."""
    runs = []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        runs.append((time.perf_counter() - t0, time.process_time() - c0, out))
    return min(runs, key=lambda r: r[0])


def main() -> int:
    from feedtune.workflows.ballscrew_demo import run_demo
    from feedtune.workflows.files import write_texts

    with tempfile.TemporaryDirectory() as tmp:
        demo = Path(tmp) / "demo_out"
        write_texts(run_demo(seed=0).texts, out_dir=demo)
        n_files = len(list(demo.iterdir()))
        size_in = sum(p.stat().st_size for p in demo.iterdir()) / 1e6
        print(f"demo files: {n_files} ({size_in:.1f} MB)")

        _forbid_recomputation()
        from feedtune.report.build import build_report, write_report
        from feedtune.report.html import render_pngs, render_processes

        build_report([demo], render=False)  # imports
        t_build, c_build, report = _best(lambda: build_report([demo], render=False))
        n_fig = len(report.figures())
        t_one, c_one, _ = _best(lambda: render_pngs(build_report([demo], render=False), processes=1))
        t_all, c_all, _ = _best(lambda: render_pngs(build_report([demo], render=False)))
        print(f"build_report(render=False) (recomputation forbidden): {t_build:.2f} s (CPU {c_build:.2f} s); "
              f"{n_fig} figures, {len(report.tables())} tables")
        print(f"draw the {n_fig} figures: {t_one:.2f} s in one process (CPU {c_one:.2f} s), {t_all:.2f} s in "
              f"{render_processes(n_fig)} (CPU of this process {c_all:.2f} s)")
        full = build_report([demo])
        out = Path(tmp) / "report.html"
        t0 = time.perf_counter()
        write_report(full, out)
        size = out.stat().st_size
        print(f"write: {1e3 * (time.perf_counter() - t0):.0f} ms; HTML {size / 1e6:.2f} MB")

        t_cli1 = _cli(["report", str(demo), "--out", str(Path(tmp) / "cli1.html"), "--force"],
                      {"FEEDTUNE_REPORT_PROCESSES": "1"})
        t_cli = _cli(["report", str(demo), "--out", str(Path(tmp) / "cli.html"), "--force"])
        t_pdf = _cli(["report", str(demo), "--out", str(Path(tmp) / "cli_pdf.html"), "--pdf", "--force"])
        pdf_size = (Path(tmp) / "cli_pdf.pdf").stat().st_size
        print(f"feedtune report DIR --out report.html (fresh process): {t_cli:.2f} s ({t_cli1:.2f} s in one process)")
        print(f"feedtune report DIR --out report.html --pdf (fresh process): {t_pdf:.2f} s, "
              f"PDF {pdf_size / 1e6:.2f} MB")
    ok = t_cli < TARGET_S and size < TARGET_BYTES
    print(f"target: < {TARGET_S:g} s and < {TARGET_BYTES / 1e6:g} MB: {'met' if ok else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
