"""What the benchmark scripts share: the best of several timed runs."""

from __future__ import annotations

import time


def best_of(fn, n: int = 5) -> float:
    """The shortest of ``n`` runs of ``fn()`` [s] (the least disturbed by the machine's load)."""
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)
