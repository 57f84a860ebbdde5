"""Timing of the closed-loop twin: 10 s at 20 kHz (200,000 steps) with friction and quantization.

Run by hand: ``python benchmarks/bench_sim.py``. The full twin (current loop, torsional modes, pitching,
Stribeck friction with stiction at both masses, 10 nm encoders, noise, saturation, one sample of delay)
tracks a back-and-forth move under MC-PPC. Prints the best of a few runs per engine, the real-time factor
(target: >= 10x, i.e. < 1 s) and, for reference, ``scipy.signal.dlsim`` on the linear part alone (the same
9-state discrete plant driven open-loop by the recorded command, no controller, no friction).
"""

from __future__ import annotations

import numpy as np
from timing import best_of

from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.io.gains import gains_document
from feedtune.machines.ballscrew.runtime import GainsRuntime
from feedtune.machines.ballscrew.twin import BallScrewTwin
from feedtune.models import THESIS_TABLE_3_1
from feedtune.sim.engine import numba_available
from feedtune.sim.trajectory import multi_segment

SECONDS = 10.0


def _reference(twin: BallScrewTwin) -> np.ndarray:
    tr = multi_segment([0.0, 0.15, 0.0, 0.15, 0.0, 0.15, 0.0], v_max=0.5, a_max=5.0, j_max=500.0, fs=twin.fs,
                       dwell=0.3)
    n = int(SECONDS * twin.fs)
    pos = np.r_[tr.pos, np.full(max(0, n - tr.n), tr.pos[-1])][:n]
    return pos / twin.lead



def main() -> None:
    twin = BallScrewTwin()
    rt = GainsRuntime.from_document(gains_document(design_mcppc(THESIS_TABLE_3_1, filters=THESIS_FILTER_PACK)))
    x_ref = _reference(twin)
    n = x_ref.size
    print(f"{n} steps ({SECONDS:g} s at {twin.fs:g} Hz), {twin.n_states} plant states, friction + quantization")
    engines = ["numba", "python"] if numba_available() else ["python"]
    results = {}
    for engine in engines:
        if engine == "numba":
            twin.simulate(rt, x_ref[:1000], engine="numba")  # compile (or load the cache) outside the timing
        run = twin.simulate(rt, x_ref, engine=engine)
        assert not run.tripped, run.trip_message
        results[engine] = best_of(lambda e=engine: twin.simulate(rt, x_ref, engine=e), 3 if engine == "numba" else 1)
        err = (x_ref - run.from_zero().x2) * twin.lead
        print(f"  {engine:6s}: {results[engine]:.3f} s  ({SECONDS / results[engine]:.1f}x real time); "
              f"max tracking error {np.max(np.abs(err)) * 1e6:.2f} um")
    from scipy.signal import dlsim

    u = np.zeros((n, 3))
    u[1:, 0] = run.from_zero().u[:-1]
    sys = (twin.Ad, twin.Bd, np.eye(twin.n_states)[:2], np.zeros((2, 3)), 1.0 / twin.fs)
    t_dlsim = best_of(lambda: dlsim(sys, u), 1)
    print(f"  scipy.signal.dlsim, linear plant only, open loop: {t_dlsim:.3f} s")
    for engine, t in results.items():
        print(f"  ratio dlsim / {engine} closed loop: {t_dlsim / t:.1f}")


if __name__ == "__main__":
    main()
