"""Benchmark: ``feedtune tune`` over several FRFs: time per objective evaluation against the number of FRFs, and
whole tunes against the issue's targets.

Run by hand: ``python benchmarks/bench_tune.py``. The anchor is one full analysis (all four cases) of the thesis'
MC-PPC on one FRF of 2000 lines, measured in the same run, so the ratios do not depend on the machine's load.

* Per objective evaluation (one candidate judged on every FRF, all passing: the most expensive case; a failing
  candidate stops at the first FRF that fails, which is checked first the next time), for 1 to 4 FRFs of a ball-screw
  family (Table 3.1 with the table mass at 0.7-1.3 times its value, 2000 lines each): MC-PPC (design + the
  ``discrete`` case on each FRF) and, on the gantry twin's model at 1 to 4 table positions, the MIMO law.
* Whole tunes: ``tune mcppc`` on 3 FRFs with filter placement (an unmodelled mode between lines that needs a
  notch; target < 20 s on 2 cores) and ``tune ppi`` on 3 FRFs (target < 5 s).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from timing import best_of

from feedtune.analysis.ballscrew import analyze_ballscrew, analyze_case, plant_cases
from feedtune.analysis.gantry import analyze_gantry_case, gantry_plant_cases
from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.control.gantry import law_at
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.mcppc import design_mcppc
from feedtune.frf import Frf
from feedtune.models import THESIS_TABLE_3_1 as MODEL
from feedtune.models.gantry import THESIS_GANTRY
from feedtune.tune.mcppc import tune_mcppc
from feedtune.tune.ppi import tune_ppi

F = np.logspace(0, np.log10(9000.0), 2000)
SCALES = (0.7, 0.9, 1.1, 1.3)
MODE_HZ, MODE_ZETA, MODE_GAIN = 703.3, 0.005, 0.5


def with_mode(frf: Frf) -> Frf:
    """The FRF with a lightly damped mode between two lines (the filter placement needs a notch there)."""
    s, w = 2j * np.pi * F, 2 * np.pi * MODE_HZ
    m = (s * s + 2 * MODE_ZETA * w * s + (1 + MODE_GAIN) * w * w) / (s * s + 2 * MODE_ZETA * w * s + w * w)
    return Frf(F, frf.response * m, frf.outputs, frf.inputs, "position", None, "V", "rad", {"source": "mode"})


def main() -> None:
    family = [replace(MODEL, m2=MODEL.m2 * k).frf(F) for k in SCALES]
    thesis = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK)
    anchor = best_of(lambda: analyze_ballscrew(thesis.law(), MODEL, family[0]))
    print(f"anchor: analyze_ballscrew (4 cases) of the thesis MC-PPC on one FRF of {F.size} lines: "
          f"{1e3 * anchor:.1f} ms")

    print("time per objective evaluation (every FRF passing):")
    pcs = [plant_cases(MODEL, 20000.0, 1, f)["discrete"] for f in family]
    base = None
    for n in range(1, len(family) + 1):
        def mcppc_eval(n=n):
            law = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK).law()
            return [analyze_case(law, pc, responses=False).metrics for pc in pcs[:n]]

        t = best_of(mcppc_eval, n=10)
        base = base or t
        print(f"  MC-PPC, {n} FRF(s): {1e3 * t:.2f} ms = {t / anchor:.2f} x anchor ({t / base:.2f} x one FRF)")
    xs = (-0.3, -0.1, 0.1, 0.3)
    gpcs = [gantry_plant_cases(THESIS_GANTRY, x, 15000.0, 1, THESIS_GANTRY.frf(np.arange(2.0, 1001.0, 2.0), x))
            ["discrete"] for x in xs]
    base = None
    for n in range(1, len(xs) + 1):
        def mimo_eval(n=n):
            d = design_gantry_mimo(THESIS_GANTRY, crossover_hz=60, pm_deg=40, damping_increase=5.9, filters=None)
            return [analyze_gantry_case(law_at(d.law, d.schedule, x), pc, THESIS_GANTRY.alpha(x)).metrics
                    for x, pc in zip(xs[:n], gpcs[:n], strict=True)]

        t = best_of(mimo_eval, n=5)
        base = base or t
        print(f"  gantry MIMO, {n} position(s): {1e3 * t:.2f} ms = {t / anchor:.2f} x anchor ({t / base:.2f} x one)")

    print("whole tunes (3 FRFs):")
    three = [family[0], family[1], family[3]]
    box = {}
    t = best_of(lambda: box.setdefault("m", tune_mcppc(MODEL, frf=[with_mode(f) for f in three],
                                                       filter_choice="own")), n=1)
    d = box["m"]
    print(f"  tune mcppc, filter placement: {t:.2f} s = {t / anchor:.0f} x anchor (target < 20 s); "
          f"{d.tuning['evaluations']} checks in the last search; notches "
          f"{[round(n.freq_hz, 1) for n in d.filters.notches]} Hz; first crossover "
          f"{d.tuning['first_crossover_hz']:.1f} Hz")
    t = best_of(lambda: box.setdefault("p", tune_ppi(MODEL, frf=three)), n=1)
    d = box["p"]
    print(f"  tune ppi: {t:.2f} s = {t / anchor:.0f} x anchor (target < 5 s); first crossover "
          f"{d.tuning['first_crossover_hz']:.1f} Hz")


if __name__ == "__main__":
    main()
