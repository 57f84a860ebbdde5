"""Benchmark: the P-PI tuner per tune and per candidate evaluation, as ratios to one ``analyze_ballscrew``.

Run by hand: ``python benchmarks/bench_tune_ppi.py``. The anchor is one full analysis (all four cases) of a P-PI on
the example FRF, measured in the same run, so the ratios do not depend on the machine's load; the target is a tune on
the example FRF in < 5 s (2 shared cores). Per tune it prints wall time, the number of surrogate shapes and analysis
checks, and the ratio to the anchor; per evaluation the cost of one surrogate shape (the whole gain-feasibility edge
of a shape) and of one analysis check (``analyze_case`` on the checked case).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from timing import best_of

from feedtune.analysis.ballscrew import analyze_ballscrew, analyze_case, plant_cases
from feedtune.analysis.check import resolve_limits
from feedtune.analysis.limits import PROFILES
from feedtune.control.filters import THESIS_FILTER_PACK, FilterPack
from feedtune.design.ppi import design_ppi
from feedtune.identify.ballscrew import fit_ballscrew
from feedtune.io import read_frf
from feedtune.models import THESIS_TABLE_3_1
from feedtune.tune.ppi import Surrogate, tune_ppi

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "ballscrew_frf.csv"



def main() -> None:
    frf = read_frf(EXAMPLE)
    model = fit_ballscrew([frf]).model
    design = design_ppi(model, Kpx=30.0, Kpv=2.3, Kiv=1200.0)
    anchor = best_of(lambda: analyze_ballscrew(design.law(), model, frf))
    print(f"anchor: analyze_ballscrew (4 cases) of a P-PI on the example FRF: {1e3 * anchor:.1f} ms")

    limits = resolve_limits(None, ms_max=3.25)
    pc = plant_cases(model, 20000.0, 1, frf)["discrete"]
    t_check = best_of(lambda: analyze_case(design.law(), pc, responses=False), n=20)
    M = model.total_inertia
    sur = Surrogate(pc, FilterPack(), 20000.0, limits, (M * 2 * np.pi * 0.1, M * 2 * np.pi * 1e4))
    shapes = 2 * np.pi * np.exp(np.random.default_rng(0).uniform(np.log(0.1), np.log(300.0), (50, 2)))
    t_shape = best_of(lambda: [sur.edge(a, b) for a, b in shapes], n=3) / len(shapes)
    print(f"per evaluation: analysis check {1e3 * t_check:.2f} ms ({t_check / anchor:.2f} x anchor), "
          f"surrogate shape (its whole Kpv edge) {1e3 * t_shape:.2f} ms ({t_shape / anchor:.3f} x anchor)")

    runs = {
        "example FRF, --ms-max 3.25": dict(model=model, limits=limits, frf=frf),
        "example FRF from 20 Hz, --ms-max 3.25": dict(model=model, limits=limits, frf=frf.select(20.0)),
        "Table 3.1 model, thesis filters, --ms-max 3.25": dict(model=THESIS_TABLE_3_1, limits=limits,
                                                               filters=THESIS_FILTER_PACK),
        "example FRF, textbook": dict(model=model, limits=PROFILES["textbook"], frf=frf),
    }
    for name, kw in runs.items():
        kw = dict(kw)
        m = kw.pop("model")
        box = {}

        def tune(m=m, kw=kw, box=box):
            box["d"] = tune_ppi(m, **kw)

        t = best_of(tune, n=3)
        ev = box["d"].tuning["evaluations"]
        print(f"tune ({name}): {t:.2f} s = {t / anchor:.0f} x anchor; {ev['surrogate_shapes']} surrogate shapes, "
              f"{ev['analysis_checks']} analysis checks; first crossover "
              f"{box['d'].tuning['first_crossover_hz']:.2f} Hz")


if __name__ == "__main__":
    main()
