"""Timing of trajectory generation: ``python benchmarks/bench_trajectory.py``.

Prints the best-of-five wall time of a 10 s point-to-point move at 20 kHz (jerk- and snap-limited) and of a
200-move back-and-forth multi-segment trajectory.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from feedtune.sim.trajectory import Trajectory, multi_segment, point_to_point


def best_time(make: Callable[[], Trajectory], repeat: int = 5) -> tuple[float, Trajectory]:
    """Best wall time [s] of ``repeat`` calls and the last result."""
    best = float("inf")
    result = make()
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = make()
        best = min(best, time.perf_counter() - t0)
    return best, result


def main() -> None:
    """Run the cases and print one line each."""
    limits = {"v_max": 0.2, "a_max": 2.0, "j_max": 50.0}
    cases = {
        "10 s jerk-limited, 20 kHz": lambda: point_to_point(1.9, **limits, dwell_after=0.36),
        "10 s snap-limited, 20 kHz": lambda: point_to_point(1.9, **limits, s_max=2000.0, dwell_after=0.335),
        "200 moves, snap-limited": lambda: multi_segment(
            [0.0, 0.05] * 100 + [0.0], **limits, s_max=2000.0, dwell=0.01
        ),
    }
    for name, make in cases.items():
        seconds, traj = best_time(make)
        print(f"{name:28s} {seconds * 1e3:8.2f} ms  ({traj.n} samples, {traj.duration:.3f} s)")


if __name__ == "__main__":
    main()
