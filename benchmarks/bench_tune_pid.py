"""Benchmark: the gantry PID tuner and the x-axis loop-shaping tuner, as ratios to one analysis in the same run.

Run by hand: ``python benchmarks/bench_tune_pid.py``. The anchor is one ``analyze_gantry`` of the tuned PID (all
four cases on the model and the twin's measured FRF); every figure is the best of a few runs, in CPU seconds
(``time.process_time``, so that other work on a shared machine does not count) and in multiples of the anchor.
Prints, per case, the tuner's time, its number of real checks (``analyze_gantry_case`` in the checked case) and the
time per check:

* the PID with the thesis MIMO design's notches and low-pass (``filter_choice="identical"``) on the model and on the
  twin's FRF, and with its own filters (``"own"``) on the model, on the twin's FRF, and on a plant with a lightly
  damped mode in series (where it keeps a notch);
* the x-axis loop shaping on ``1/(m_x s^2)`` with the thesis' axis filters and without filters.
"""

from __future__ import annotations

import time

import numpy as np

from feedtune.analysis.gantry import analyze_gantry, analyze_gantry_case, gantry_plant_cases
from feedtune.control.filters import FilterPack, Notch
from feedtune.frf import Frf
from feedtune.models.gantry import THESIS_GANTRY as MODEL
from feedtune.tune.loopshape import tune_loopshape
from feedtune.tune.pid import tune_gantry_pid

NOTCH_LPF = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                        450.0, 2, 0.7)
AXIS_FILTERS = FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0)


def cpu_best(fn, n: int = 3) -> tuple[float, object]:
    """Smallest CPU time [s] of ``n`` calls and the last result."""
    best, out = np.inf, None
    for _ in range(n):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def series_mode_frf(freq_hz: float = 150.0, zeta: float = 0.02) -> Frf:
    f = np.arange(1.0, 2001.0)
    base = MODEL.frf(f, 0.0)
    s, w = 2j * np.pi * f, 2 * np.pi * freq_hz
    return Frf(f, base.response * (w * w / (s * s + 2 * zeta * w * s + w * w)), base.outputs, base.inputs,
               "position", meta={"source": "series mode"})


def main() -> None:
    from feedtune.machines.gantry.experiments import measure_gantry_frf
    from feedtune.machines.gantry.twin import GantryTwin

    twin_frf = measure_gantry_frf(GantryTwin(), 0.0, f_lo=2.0, f_hi=1000.0, seed=3).frf
    ref = tune_gantry_pid(MODEL, filters=NOTCH_LPF)
    anchor, _ = cpu_best(lambda: analyze_gantry(ref.law, MODEL, frf=twin_frf), n=5)
    pc = gantry_plant_cases(MODEL, 0.0, 15000.0, 1)["ideal_discrete"]
    one_check, _ = cpu_best(lambda: analyze_gantry_case(ref.law, pc, MODEL.alpha(0.0)), n=5)
    print(f"anchor: analyze_gantry (4 cases, twin FRF) {1e3 * anchor:.0f} ms CPU; one check (ideal_discrete case) "
          f"{1e3 * one_check:.0f} ms = {one_check / anchor:.2f} anchor")
    cases = {
        "PID identical, model": dict(filters=NOTCH_LPF),
        "PID identical, twin FRF": dict(filters=NOTCH_LPF, frf=twin_frf),
        "PID own, model": dict(filter_choice="own"),
        "PID own, twin FRF": dict(filter_choice="own", frf=twin_frf),
        "PID own, series mode 150 Hz": dict(filter_choice="own", frf=series_mode_frf()),
    }
    for name, kw in cases.items():
        t, d = cpu_best(lambda kw=kw: tune_gantry_pid(MODEL, **kw))
        n = d.tuning["search"]["checks"]
        print(f"{name:30s} {t:5.2f} s CPU = {t / anchor:5.0f} anchors; {n:4d} checks, {1e3 * t / n:4.1f} ms/check; "
              f"first crossover {d.tuning['com_crossover_hz']:.4g} Hz")
    for name, filt in (("loop shaping, axis filters", AXIS_FILTERS), ("loop shaping, no filters", FilterPack())):
        t, d = cpu_best(lambda filt=filt: tune_loopshape(MODEL.m_x, filters=filt))
        n = d.tuning["search"]["checks"]
        print(f"{name:30s} {t:5.2f} s CPU = {t / anchor:5.0f} anchors; {n:4d} checks, {1e3 * t / n:4.1f} ms/check; "
              f"first crossover {d.tuning['crossover_hz']:.4g} Hz")


if __name__ == "__main__":
    main()
