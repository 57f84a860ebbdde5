"""Timing of the closed-loop gantry twin: 1 s at 15 kHz (15,000 samples) with a gantry and an x-axis controller.

Run by hand: ``python benchmarks/bench_gantry_sim.py``. The full twin (12 plant states on the 201-point
x grid, structural, pitching and base modes, noise, quantization, saturation, one sample of delay) runs a
200 mm/s back-and-forth y move while the table moves 0.1 m, under

* the MIMO law of eq. 4.30 executed by ``GantryRuntime`` and the loop-shaped x axis by ``AxisRuntime``
  (Python ``step()`` per sample, as a target runs the gains files);
* the built-in holding controllers (a lighter Python ``step()``);
* controllers that return 0 at once, everything at rest: the cost of the plant step and of the loop alone.

Prints the best of a few runs: seconds, microseconds per sample and the real-time factor, per engine.
"""

from __future__ import annotations

import time

import numpy as np

from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.loopshape import design_loopshape
from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
from feedtune.machines import load_runtime
from feedtune.machines.gantry.experiments import AxisHoldingController, HoldingController
from feedtune.machines.gantry.twin import GantryTwin
from feedtune.models.gantry import THESIS_GANTRY
from feedtune.sim.engine import numba_available
from feedtune.sim.trajectory import multi_segment

SECONDS = 1.0


class _Zero:
    """A controller that commands nothing (both interfaces)."""

    fs = 15000.0
    preview_samples = 0
    controller = "zero"
    source = "benchmark"

    def reset(self) -> None:
        pass

    def check_target(self, fs: float) -> None:
        pass

    def step(self, *args) -> tuple[float, float] | float:
        return (0.0, 0.0) if len(args) == 4 else 0.0


def _runtimes():
    h = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                    450.0, 2, 0.7, [LeadStage(154.0, 70.0)])
    gantry = load_runtime(gantry_gains_document(design_gantry_mimo(THESIS_GANTRY, filters=h)))
    x_filters = FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0)
    axis = load_runtime(axis_gains_document(design_loopshape(THESIS_GANTRY.m_x, crossover_hz=130.0, pm_deg=35.0,
                                                             filters=x_filters)))
    return gantry, axis


def _references(fs: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    y = multi_segment([0.0, 0.05, 0.0], v_max=0.2, a_max=2.0, j_max=50.0, fs=fs, dwell=0.05).pos
    x = multi_segment([0.0, 0.1], v_max=0.2, a_max=2.0, j_max=50.0, fs=fs).pos
    pad = [np.r_[a, np.full(max(0, n - a.size), a[-1])][:n] for a in (y, x)]
    return pad[0], pad[1]


def _best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    twin = GantryTwin()
    n = int(SECONDS * twin.fs)
    y_ref, x_ref = _references(twin.fs, n)
    GantryTwin().tables()  # imports scipy.linalg outside the timing
    t0 = time.perf_counter()
    twin.tables()
    print(f"{n} samples ({SECONDS:g} s at {twin.fs:g} Hz); discrete matrices on {twin.params.x_grid().size} grid "
          f"points computed in {time.perf_counter() - t0:.3f} s")
    mimo, axis = _runtimes()
    cases = {"GantryRuntime (MIMO) + AxisRuntime": (mimo, axis),
             "holding controllers": (HoldingController.for_twin(twin), AxisHoldingController.for_twin(twin)),
             "zero controllers (plant step + loop)": (_Zero(), _Zero())}
    engines = ["numba", "python"] if numba_available() else ["python"]
    for engine in engines:
        twin.simulate(_Zero(), _Zero(), y_ref[:100], x_ref=x_ref[:100], engine=engine)  # compile / load cache
        for label, (g, a) in cases.items():
            yr, xr = (y_ref, x_ref) if g.controller != "zero" else (np.zeros(n), 0.05)  # nothing moves: at rest
            run = twin.simulate(g, a, yr, x_ref=xr, engine=engine)
            assert not run.tripped, run.trip_message
            t = _best(lambda g=g, a=a, yr=yr, xr=xr, e=engine: twin.simulate(g, a, yr, x_ref=xr, engine=e),
                      3 if engine == "numba" else 1)
            print(f"  {engine:6s} {label:38s}: {t:.3f} s, {t / run.t.size * 1e6:6.2f} us/sample, "
                  f"{SECONDS / t:5.1f}x real time")


if __name__ == "__main__":
    main()
