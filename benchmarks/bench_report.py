"""Benchmark: the full demo report (``feedtune report demo_out --out report.html``).

Run by hand: ``python benchmarks/bench_report.py``. Writes the default ``feedtune demo`` files into a temporary
folder (not timed), then times

* ``build_report`` + ``write_report`` in this process, with the identification and design functions replaced by
  ones that raise (the report must use the results stored in the files, not recompute them);
* the command ``feedtune report DIR --out report.html`` in a fresh process (imports included) and with ``--pdf``.

Targets: under 10 s for the full demo report, HTML under 10 MB.
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


def _cli(args: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "feedtune.cli.main", *args], check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


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

        t0 = time.perf_counter()
        report = build_report([demo])
        t_build = time.perf_counter() - t0
        out = Path(tmp) / "report.html"
        t0 = time.perf_counter()
        write_report(report, out)
        t_write = time.perf_counter() - t0
        size = out.stat().st_size
        print(f"build_report (recomputation forbidden): {t_build:.2f} s; write: {1e3 * t_write:.0f} ms; "
              f"{len(report.figures())} figures, {len(report.tables())} tables, HTML {size / 1e6:.2f} MB")

        t_cli = _cli(["report", str(demo), "--out", str(Path(tmp) / "cli.html")])
        t_pdf = _cli(["report", str(demo), "--out", str(Path(tmp) / "cli_pdf.html"), "--pdf"])
        pdf_size = (Path(tmp) / "cli_pdf.pdf").stat().st_size
        print(f"feedtune report DIR --out report.html (fresh process): {t_cli:.2f} s")
        print(f"feedtune report DIR --out report.html --pdf (fresh process): {t_pdf:.2f} s, "
              f"PDF {pdf_size / 1e6:.2f} MB")
    ok = t_cli < TARGET_S and size < TARGET_BYTES
    print(f"target: < {TARGET_S:g} s and < {TARGET_BYTES / 1e6:g} MB: {'met' if ok else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
