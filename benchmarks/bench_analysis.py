"""Benchmark: the four-case ball-screw analysis on a 20,000-point grid, its memory, and ``feedtune --help``.

Run by hand: ``python benchmarks/bench_analysis.py``. Targets (issue 11): the analysis of all four cases (FRF given)
<= 10 ms and <= 200 bytes of memory per grid point; ``feedtune --help`` < 0.5 s.

Timings on a shared machine are noisy, so every time is the best of several runs and is also given as a ratio to an
anchor measured in the same run: one batched complex evaluation of the loop ``L = K1 G11 + K2 G21`` on the grid
(numpy: the model's polynomials and the law's zeros-poles-gain paths, the ``ideal`` loop without any figure).

* ``analysis``: :func:`~feedtune.analysis.ballscrew.analyze_ballscrew` from scratch (plant cases, loops and every
  figure of the four cases); the curves besides ``L`` (``S``, tracking, disturbance) are computed when first read.
* ``analysis and every curve``: the same, then every case's ``to_dict()`` (the ``--json`` figures, which read the
  tracking and disturbance curves), as ``feedtune analyze`` runs it.
* ``tuner path``: :func:`~feedtune.analysis.ballscrew.analyze_case` without responses on the four plant cases made
  once, for a new law each call (what the tuners do ~1000 times per design: the plant, hold and filter responses
  are kept on the plant cases).
* python-control: ``frequency_response`` and ``stability_margins`` of the same (rational) ``ideal`` loop.
* memory: the peak traced by ``tracemalloc`` during one fresh analysis, per grid point, in all and beyond the
  returned result (what the caller keeps: the loop ``L`` of four cases and the discrete case's grid, ~72 bytes per
  point; the other curves are computed when read); and the peak of one tuner-path call of the four cases.
"""

from __future__ import annotations

import gc
import subprocess
import sys
import time
import tracemalloc
import warnings

import numpy as np
from timing import best_of

from feedtune.analysis.ballscrew import analyze_ballscrew, analyze_case, plant_cases
from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.models import THESIS_TABLE_3_1 as MODEL

N = 20000


def _nbytes(obj, seen=None) -> int:
    """Bytes of the numpy arrays reachable from ``obj`` (dicts, lists, dataclass fields), each counted once."""
    seen = set() if seen is None else seen
    if id(obj) in seen:
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        base = obj if obj.base is None else obj.base
        if id(base) in seen and base is not obj:
            return 0
        seen.add(id(base))
        return int(base.nbytes) if isinstance(base, np.ndarray) else int(obj.nbytes)
    if isinstance(obj, dict):
        return sum(_nbytes(v, seen) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return sum(_nbytes(v, seen) for v in obj)
    if hasattr(obj, "__dict__"):
        return sum(_nbytes(v, seen) for v in vars(obj).values())
    return 0


def _peak(fn, inputs=()) -> tuple[int, int]:
    """Peak bytes traced during ``fn()`` above the start, and the bytes of the numpy arrays in its result that it
    made (not the ``inputs`` arrays, e.g. the grid a result refers to)."""
    gc.collect()
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    out = fn()
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    seen = {id(a) for a in inputs} | {id(a.base) for a in inputs if a.base is not None}
    return peak, _nbytes(out, seen)


def main() -> None:
    f = np.logspace(0, np.log10(9990), N)
    frf = MODEL.frf(f)
    law = design_mcppc(MODEL, filters=THESIS_FILTER_PACK).law()
    laws = [design_mcppc(MODEL, pole_hz=p, filters=THESIS_FILTER_PACK).law() for p in np.linspace(45, 55, 7)]
    nums, den = MODEL.numerators(), MODEL.denominator()
    s = 2j * np.pi * f

    def anchor():
        return (law.K1().freqresp(f) * np.polyval(nums["G11"], s) + law.K2().freqresp(f) * np.polyval(nums["G21"], s)
                ) / np.polyval(den, s)

    def analysis():
        return analyze_ballscrew(law, MODEL, frf, freq_hz=f)

    pcs = [pc for pc in plant_cases(MODEL, law.fs, law.delay_samples, frf, f).values() if pc is not None]
    it = iter(range(10**9))

    def tuner_path():
        lw = laws[next(it) % len(laws)]
        return [analyze_case(lw, pc, responses=False) for pc in pcs]

    analysis()
    tuner_path()
    t_anchor = best_of(anchor, 20)
    t_ours = best_of(analysis, 15)
    t_tuner = best_of(tuner_path, 15)

    def analysis_and_curves():
        return [c.to_dict() for c in analysis().cases.values()]

    t_all = best_of(analysis_and_curves, 10)
    t_anchor = min(t_anchor, best_of(anchor, 20))
    print(f"anchor: one batched complex evaluation of the loop on {N:,} points: {1e3 * t_anchor:.2f} ms")
    print(f"analysis, 4 cases (ideal, ideal_discrete, measured, discrete), {N:,} points: {1e3 * t_ours:.1f} ms "
          f"({t_ours / t_anchor:.1f} x anchor)")
    print(f"analysis and every curve (to_dict of each case), 4 cases: {1e3 * t_all:.1f} ms "
          f"({t_all / t_anchor:.1f} x anchor)")
    print(f"tuner path (analyze_case, no responses, fixed parts kept), 4 cases: {1e3 * t_tuner:.1f} ms "
          f"({t_tuner / t_anchor:.1f} x anchor)")

    try:
        import control
    except ImportError:
        print("python-control not installed: skipping the comparison")
    else:
        g = law.gains
        K1 = control.tf([g["Kv1"], g["Kx1"]], [1])
        K2 = control.tf([g["Kv2"], g["Kx2"], g["Ki2"]], [1, 0])
        L = K1 * control.tf(nums["G11"], den) + K2 * control.tf(nums["G21"], den)
        w = 2 * np.pi * f

        def pc_run():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # python-control's own nan comparisons
                control.frequency_response(L, w)
                control.stability_margins(L, returnall=True)

        t_ct = best_of(pc_run, 5)
        print(f"python-control frequency_response + stability_margins of one loop (no filters): {1e3 * t_ct:.1f} ms "
              f"({t_ct / t_anchor:.1f} x anchor)")

    peak, kept = _peak(analysis, (f, frf.freq_hz, frf.response))
    print(f"memory, one analysis: peak {peak / N:.0f} bytes/point, of which the returned result {kept / N:.0f}; "
          f"working memory beyond it {(peak - kept) / N:.0f} bytes/point")
    peak_t, kept_t = _peak(tuner_path, (f, frf.freq_hz, frf.response))
    print(f"memory, tuner path (4 cases): peak {peak_t / N:.0f} bytes/point, beyond the returned L "
          f"{(peak_t - kept_t) / N:.0f} bytes/point")

    t0 = time.perf_counter()
    for _ in range(3):
        subprocess.run([sys.executable, "-m", "feedtune.cli.main", "--help"], check=True, capture_output=True)
    print(f"feedtune --help: {(time.perf_counter() - t0) / 3 * 1e3:.0f} ms per call (python -m, mean of 3)")


if __name__ == "__main__":
    main()
