"""Benchmark: full MIMO gantry analysis on 20,000 frequency points, and the gantry runtime's cost per sample.

Run by hand: ``python benchmarks/bench_mimo_analysis.py``. Prints

* the 2x2 analysis (singular values of L, S and S G, MIMO Nyquist, CoM-loop margins, disturbance bands,
  tracking) of the thesis MIMO design in all four cases (ideal, ideal_discrete, measured, discrete) on a
  20,000-point grid, and ``analyze_mimo`` alone on one 20,000-point loop; for reference, numpy's
  per-frequency ``linalg.svd`` and ``linalg.inv`` on the same matrices;
* the per-sample cost of ``GantryRuntime.step`` (MIMO and PID; table fixed and moving, with and without the
  pre-filter), of ``AxisRuntime.step``, and of the vectorised ``replay`` per sample. At 15 kHz one second of
  twin time needs 15,000 steps.
"""

from __future__ import annotations

import numpy as np
from timing import best_of

from feedtune.analysis.gantry import analyze_gantry
from feedtune.analysis.mimo import analyze_mimo, matmul, sensitivity, singular_values
from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.control.gantry import reference_from_schedule
from feedtune.control.prefilter import PrefilterGains
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.loopshape import design_loopshape
from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
from feedtune.machines.gantry.runtime import AxisRuntime, GantryRuntime
from feedtune.models.gantry import THESIS_GANTRY as MODEL
from feedtune.tune.pid import tune_gantry_pid

N_FREQ = 20000
N_STEPS = 15000
H = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                450.0, 2, 0.7, [LeadStage(154, 70)])



def bench_analysis(mimo) -> None:
    f = np.logspace(np.log10(0.5), np.log10(7499.0), N_FREQ)
    frf = MODEL.frf(f, 0.0)
    ref = reference_from_schedule(mimo.schedule, 0.0, mimo.prefilter_hz)
    t_all = best_of(lambda: analyze_gantry(mimo.law, MODEL, frf=frf, reference=ref, freq_hz=f))
    print(f"gantry analysis, 4 cases, {N_FREQ:,} points: {1e3 * t_all:.0f} ms")
    L = matmul(MODEL.frequency_response(f, 0.0), mimo.law.response(f))
    t_one = best_of(lambda: analyze_mimo(f, L, weights=MODEL.alpha(0.0), integrators=4))
    print(f"analyze_mimo on one {N_FREQ:,}-point loop (SVD of L and S, Nyquist, margins, bands): {1e3 * t_one:.1f} ms")
    t_sv = best_of(lambda: (singular_values(L), singular_values(sensitivity(L))))
    Ln = np.ascontiguousarray(np.moveaxis(L, -1, 0))
    t_np = best_of(lambda: (np.linalg.svd(Ln, compute_uv=False),
                            np.linalg.svd(np.linalg.inv(np.eye(2) + Ln), compute_uv=False)), n=3)
    t_loop = best_of(lambda: [np.linalg.svd(Ln[k], compute_uv=False) for k in range(0, N_FREQ, 10)], n=1) * 10
    print(f"singular values of L and S: closed form {1e3 * t_sv:.1f} ms, numpy batched svd+inv {1e3 * t_np:.1f} ms, "
          f"numpy per-frequency loop (svd of L only, extrapolated) {1e3 * t_loop:.0f} ms")


def _run(rt, n, moving: bool) -> float:
    rng = np.random.default_rng(0)
    r = np.cumsum(rng.standard_normal(n)) * 1e-6
    y1, y2 = r + 1e-7 * rng.standard_normal(n), r + 1e-7 * rng.standard_normal(n)
    x = np.linspace(-0.2, 0.2, n) if moving else np.zeros(n)
    p, y1l, y2l, xl = (a.tolist() for a in (rt.previewed(r), y1, y2, x))

    def go():
        rt.reset()
        step = rt.step
        for k in range(n):
            step(p[k], y1l[k], y2l[k], xl[k])

    return best_of(go, n=3) / n


def bench_runtime(mimo, pid) -> None:
    with_pre = design_gantry_mimo(MODEL, filters=H, prefilter1=PrefilterGains(1e-4, 1e-6, 1e-8, 1e-10),
                                  prefilter2=PrefilterGains(-1e-4, 1e-6, 0, 0))
    for name, design in (("MIMO", mimo), ("PID", pid), ("MIMO + pre-filter", with_pre)):
        rt = GantryRuntime.from_document(gantry_gains_document(design))
        sections = sum(v.shape[0] for v in rt.sos.values())
        for moving in (False, True):
            us = 1e6 * _run(rt, N_STEPS, moving)
            print(f"GantryRuntime.step {name:18s} table {'moving' if moving else 'fixed '}: {us:5.1f} us/sample "
                  f"({sections} sections in the file; {N_STEPS / 1e6 * us:.2f} s per second at 15 kHz)")
    axis = AxisRuntime.from_document(axis_gains_document(design_loopshape(0.6977, crossover_hz=130, pm_deg=35)))
    xr = np.cumsum(np.random.default_rng(1).standard_normal(N_STEPS)) * 1e-6
    p, xl = axis.previewed(xr).tolist(), xr.tolist()

    def go_axis():
        axis.reset()
        for k in range(N_STEPS):
            axis.step(p[k], xl[k])

    print(f"AxisRuntime.step: {1e6 * best_of(go_axis, n=3) / N_STEPS:.1f} us/sample")
    rt = GantryRuntime.from_document(gantry_gains_document(with_pre))
    n = 150000
    r = np.cumsum(np.random.default_rng(2).standard_normal(n)) * 1e-6
    x = np.linspace(-0.2, 0.2, n)
    t = best_of(lambda: rt.replay(r, r, r, x), n=3)
    print(f"GantryRuntime.replay (vectorised, MIMO + pre-filter, moving table): {1e9 * t / n:.0f} ns/sample")


def main() -> None:
    mimo = design_gantry_mimo(MODEL, crossover_hz=60, pm_deg=40, damping_increase=5.9, filters=H)
    ms = analyze_gantry(mimo.law, MODEL).cases["ideal_discrete"].metrics.ms
    pid = tune_gantry_pid(MODEL, ms_max=ms, filters=FilterPack(H.notches, H.lpf_hz, 2, 0.7))
    bench_analysis(mimo)
    bench_runtime(mimo, pid)


if __name__ == "__main__":
    main()
