"""Benchmark: full ball-screw analysis on a 20,000-point grid, and `feedtune --help` start-up time.

Run by hand: ``python benchmarks/bench_analysis.py``. Prints wall times; the targets are < 50 ms for the
analysis (all cases, FRF given) and < 0.5 s for ``feedtune --help``. Also reports the ratio against
python-control's ``frequency_response`` on the same (filter-free, rational) loop.
"""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
from timing import best_of

from feedtune.analysis.ballscrew import analyze_ballscrew
from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.models import THESIS_TABLE_3_1 as MODEL


def main() -> None:
    f = np.logspace(0, np.log10(9990), 20000)
    frf = MODEL.frf(f)
    law = design_mcppc(MODEL, filters=THESIS_FILTER_PACK).law()
    t_ours = best_of(lambda: analyze_ballscrew(law, MODEL, frf, freq_hz=f))
    print(f"analysis, 4 cases (ideal, ideal_discrete, measured, discrete), 20,000 points: {1e3 * t_ours:.1f} ms")

    try:
        import control
    except ImportError:
        print("python-control not installed: skipping the comparison")
    else:
        g = law.gains
        nums, den = MODEL.numerators(), MODEL.denominator()
        K1 = control.tf([g["Kv1"], g["Kx1"]], [1])
        K2 = control.tf([g["Kv2"], g["Kx2"], g["Ki2"]], [1, 0])
        L = K1 * control.tf(nums["G11"], den) + K2 * control.tf(nums["G21"], den)
        w = 2 * np.pi * f
        t_ct = best_of(lambda: control.frequency_response(L, w), n=3)
        from feedtune.analysis.loop import analyze_loop

        s = 2j * np.pi * f
        t_loop = best_of(
            lambda: analyze_loop(f, law.K1().freqresp(f) * np.polyval(nums["G11"], s) / np.polyval(den, s))
        )
        print(
            f"python-control frequency_response of one loop: {1e3 * t_ct:.1f} ms "
            f"(ratio to our whole 4-case analysis: {t_ct / t_ours:.1f}x; our single loop + metrics: "
            f"{1e3 * t_loop:.1f} ms)"
        )

    t0 = time.perf_counter()
    for _ in range(3):
        subprocess.run([sys.executable, "-m", "feedtune.cli.main", "--help"], check=True, capture_output=True)
    print(f"feedtune --help: {(time.perf_counter() - t0) / 3 * 1e3:.0f} ms per call (python -m, mean of 3)")


if __name__ == "__main__":
    main()
