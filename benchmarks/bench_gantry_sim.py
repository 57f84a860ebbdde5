"""Timing of the closed-loop gantry twin: 1 s at 15 kHz (15,000 samples) with a gantry and an x-axis controller.

Run by hand: ``python benchmarks/bench_gantry_sim.py``. The full twin (28 linear states on the 201-point
x grid, structural, pitching and base modes, noise, quantization, saturation, one sample of delay) runs a
200 mm/s back-and-forth y move while the table moves 0.1 m, under

* the MIMO law of eq. 4.30 executed by ``GantryRuntime`` and the loop-shaped x axis by ``AxisRuntime`` (with the
  numba engine plant and both laws in one compiled loop, :mod:`feedtune.machines.gantry.law`; with the python
  engine the loop in Python, the runtimes' ``step()`` per sample);
* the built-in holding controllers (a lighter Python ``step()``);
* controllers that return 0 at once, everything at rest: the cost of the plant step and of the loop alone.

Prints the best of a few runs: seconds, microseconds per sample and the real-time factor, per engine; then, for the
compiled loop of the runtimes, the marginal cost per sample (the difference of a 5 s and a 1 s run, without the
run's fixed costs: tables, compilation; with its per-sample ones: the noise drawn by numpy, about 0.1 us, and the
loop) against the issue's target (>= 100x real time, < 0.66 us at 15 kHz) and as a ratio to the ball-screw twin's loop
measured in the same run (``benchmarks/bench_sim.py``'s MC-PPC run). The three runs alternate, round by round, so
that a change in the machine's load affects them alike; each keeps its fastest round.
"""

from __future__ import annotations

import math
import time

import numpy as np
from timing import best_of

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
ROUNDS = 7  # rounds of the marginal-cost runs


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
            t = best_of(lambda g=g, a=a, yr=yr, xr=xr, e=engine: twin.simulate(g, a, yr, x_ref=xr, engine=e),
                      3 if engine == "numba" else 1)
            print(f"  {engine:6s} {label:38s}: {t:.3f} s, {t / run.t.size * 1e6:6.2f} us/sample, "
                  f"{SECONDS / t:5.1f}x real time")


def marginal() -> None:
    """Marginal cost per sample of the compiled gantry loop, with the ball-screw loop as the anchor."""
    from bench_sim import SECONDS as BS_SECONDS
    from bench_sim import _reference

    from feedtune.control.filters import THESIS_FILTER_PACK
    from feedtune.design.mcppc import design_mcppc
    from feedtune.io.gains import gains_document
    from feedtune.machines.ballscrew.twin import BallScrewTwin
    from feedtune.models import THESIS_TABLE_3_1

    twin = GantryTwin()
    mimo, axis = _runtimes()
    runs = {}
    for sec in (1.0, 5.0):
        y, x = _references(twin.fs, int(sec * twin.fs))
        runs[sec] = lambda y=y, x=x: twin.simulate(mimo, axis, y, x_ref=x)
    bs = BallScrewTwin()
    rt = load_runtime(gains_document(design_mcppc(THESIS_TABLE_3_1, filters=THESIS_FILTER_PACK)))
    ref = _reference(bs)
    runs["ball screw"] = lambda: bs.simulate(rt, ref)
    for run in runs.values():
        run()  # compile / load the cache
    times = dict.fromkeys(runs, math.inf)
    for _ in range(ROUNDS):
        for key, run in runs.items():
            times[key] = min(times[key], best_of(run, 1))
    per = (times[5.0] - times[1.0]) / (4.0 * twin.fs)
    t_bs = times["ball screw"] / ref.size
    print(f"compiled gantry loop (MIMO + axis), marginal: {per * 1e6:.3f} us/sample, {1 / (per * twin.fs):.0f}x real "
          f"time at {twin.fs:g} Hz (target >= 100x); ball-screw loop {t_bs * 1e6:.3f} us/sample "
          f"({BS_SECONDS:g} s run): gantry/ball screw = {per / t_bs:.2f}")


if __name__ == "__main__":
    main()
    marginal()
