"""Search machinery shared by the tuners: the feasibility edge of a scale and a bounded pattern search over shapes.

A tuner parametrises its controller by a *scale* (a bandwidth or crossover [Hz]: the loop gets faster as it grows)
and a few *shape* parameters. For one shape, :func:`feasibility_edge` finds the largest scale that passes the real
check (:class:`Probe`, from the analysis and the limits policy): a log-spaced scan from the top down to the first
passing point, then a bisection (a secant step on the smallest limit slack when both ends have one) until the
bracket is narrower than ``rtol``. A cheap necessary condition (``admissible``; e.g. the peak sensitivity on the
analysis' base grid, a lower bound of the refined one) skips candidates without a real check; it never accepts
one. :func:`pattern_search` maximises the first crossover at the edge over the shape box: a lattice of start points
(the feasible set may be disconnected) and compass steps halved down to ``min_step`` of the box (log coordinates).
Points are rounded to the lattice of the smallest step, so that equal problems give equal shapes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Probe:
    """One candidate judged by the real check.

    Attributes
    ----------
    scale : float
        The scale parameter of the candidate [Hz].
    ok : bool
        Every limit met and the loop stable in the checked case.
    crossover_hz : float
        First crossover of the loop [Hz] (``metrics.crossovers_hz[0]``; nan without one).
    slack : float or None
        Smallest relative slack of the limits (negative: violated); None when unstable.
    result : object
        What the tuner's check built (law, metrics, limit items).
    """

    scale: float
    ok: bool
    crossover_hz: float
    slack: float | None
    result: object = None


@dataclass
class EdgeResult:
    """The feasibility edge of one shape.

    Attributes
    ----------
    best : Probe or None
        The passing candidate at the edge (None: no scale passed).
    fail_scale : float or None
        The smallest failing scale above it [Hz] (None: the scan's top passed).
    checks : int
        Real checks made.
    """

    best: Probe | None
    fail_scale: float | None
    checks: int

    @property
    def at_top(self) -> bool:
        """The edge is the top of the scan range (the scale bound)."""
        return self.best is not None and self.fail_scale is None


def _slack(p: Probe | None) -> float | None:
    return None if p is None or p.slack is None or not math.isfinite(p.slack) else float(p.slack)


def feasibility_edge(check: Callable[[float], Probe], scan: np.ndarray, *,
                     admissible: Callable[[np.ndarray], np.ndarray] | None = None, rtol: float = 2e-3,
                     start: float | None = None) -> EdgeResult:
    """Largest scale passing ``check`` (module docstring); ``best`` is None when no point passes.

    Parameters
    ----------
    check : callable
        ``check(scale) -> Probe``, the real check.
    scan : ndarray
        Increasing log-spaced scales [Hz]: the range, and the points of the top-down scan when there is no
        ``start`` (or no bracket is found near it).
    admissible : callable, optional
        ``admissible(scales) -> bool array``: a necessary condition (False: certainly failing, no real check).
    rtol : float
        Relative width of the final bracket [-].
    start : float, optional
        A scale expected near the edge (a neighbouring shape's): the bracket is sought around it first.
    """
    scan = np.asarray(scan, float)
    bottom, top = float(scan[0]), float(scan[-1])
    n = 0

    def real(s: float) -> Probe:
        nonlocal n
        n += 1
        return check(float(s))

    def cheap(s: float) -> bool:
        return True if admissible is None else bool(np.asarray(admissible(np.array([s])))[0])

    def cheap_edge(a: float, b: float) -> tuple[float, float]:
        """Narrow ``cheap(a) and not cheap(b)`` to a ratio of ``1 + rtol / 8``."""
        while b / a > 1 + rtol / 8:
            m = math.sqrt(a * b)
            if cheap(m):
                a = m
            else:
                b = m
        return a, b

    def below(a: float, b: float) -> float:
        """The scale just below the cheap edge ``b`` to check."""
        return max(a, b / (1 + 0.5 * rtol))

    def descend(s: float, p: Probe | None) -> tuple[Probe | None, float, Probe | None]:
        """Real steps down from a failing ``s`` until a pass: ``(pass, lowest failing scale, its probe)``.

        The step extrapolates the slack of the last two failures to zero (30 % beyond it); without slacks it is
        15 %, doubling (in log scale) after each failure up to a factor 2.
        """
        prev = None
        grow = math.log(1.15)
        for _ in range(12):
            sl = _slack(p)
            ln_step = grow
            grow = min(2 * grow, math.log(2.0))
            if sl is not None and prev is not None:
                gain = (sl - prev[1]) / (prev[0] - math.log(s))  # slack gained per unit of log scale down
                ln_step = min(max(1.3 * -sl / gain + rtol, rtol), math.log(2.0)) if gain > 0 else math.log(1.5)
            elif sl is not None:
                ln_step = min(max(2 * abs(sl) + rtol, rtol), math.log(1.15))
            if sl is not None:
                prev = (math.log(s), sl)
            t = s / math.exp(ln_step)
            if t < bottom:
                if s <= bottom * (1 + rtol):
                    return None, s, p
                t = bottom
            q = real(t) if cheap(t) else None
            if q is not None and q.ok:
                return q, s, p
            s, p = t, q
        return None, s, p

    lo_p: Probe | None = None
    hi: float | None = None
    hi_p: Probe | None = None
    if start is not None and bottom <= start <= top:
        s, b = float(start), None
        if cheap(s):  # the cheap edge, when it is near above the start, is the first guess
            t = s
            for _ in range(3):
                u = min(t * 1.15, top)
                if u <= t:
                    break
                if not cheap(u):
                    a, b = cheap_edge(t, u)
                    s = below(a, b)
                    break
                t = u
        else:  # down to the cheap edge below the start
            u, t = s, s / 1.15
            while t >= bottom and not cheap(t):
                u, t = t, t / 1.15
            if t >= bottom:
                a, b = cheap_edge(t, u)
                s = below(a, b)
            else:
                s = None
        if s is not None:
            p = real(s)
            if p.ok:
                lo_p, hi = p, b
                step = 1.15
                while hi is None:  # climb to the first failure, the step growing
                    if lo_p.scale >= top:
                        return EdgeResult(lo_p, None, n)
                    u = min(lo_p.scale * step, top)
                    q = real(u) if cheap(u) else None
                    if q is not None and q.ok:
                        lo_p, step = q, min(step * step, 2.0)
                    else:
                        hi, hi_p = u, q
            else:
                lo_p, hi, hi_p = descend(s, p)
            if lo_p is None:
                return EdgeResult(None, None, n)  # no passing scale near a neighbour's edge: not scanned again
    if lo_p is None:  # top-down scan
        hi, hi_p = None, None
        mask = np.ones(scan.size, bool) if admissible is None else np.asarray(admissible(scan), bool)
        for i in range(scan.size - 1, -1, -1):
            if not mask[i]:
                hi, hi_p = float(scan[i]), None
                continue
            p = real(scan[i])
            if p.ok:
                lo_p = p
                break
            hi, hi_p = float(scan[i]), p
        if lo_p is None:
            return EdgeResult(None, None, n)
        if hi is None:
            return EdgeResult(lo_p, None, n)
    if hi_p is None and hi / lo_p.scale > 1 + rtol:  # the cheap edge inside the bracket, a real check below it
        a, hi = cheap_edge(lo_p.scale, hi)
        s = below(a, hi)
        if s > lo_p.scale * (1 + 0.25 * rtol):
            p = real(s)
            if p.ok:
                lo_p = p
            else:
                hi, hi_p = s, p
    lo = lo_p.scale
    while hi / lo > 1 + rtol:
        m = math.sqrt(lo * hi)
        s_lo, s_hi = _slack(lo_p), _slack(hi_p)
        if s_lo is not None and s_hi is not None and s_lo > s_hi:
            t = s_lo / (s_lo - s_hi)  # secant on the slack in log scale, kept inside the bracket
            t = min(max(t, 0.1), 0.9)
            m = math.exp(math.log(lo) + t * math.log(hi / lo))
        if not cheap(m):
            hi, hi_p = m, None
            continue
        p = real(m)
        if p.ok:
            lo, lo_p = m, p
        else:
            hi, hi_p = m, p
    return EdgeResult(lo_p, hi, n)


@dataclass
class SearchResult:
    """Outcome of :func:`pattern_search`.

    Attributes
    ----------
    point : tuple of float
        The best shape.
    edge : EdgeResult
        Its feasibility edge.
    evaluated : dict
        ``{shape: EdgeResult or None}`` of every shape evaluated.
    on_bound : list of str
        ``"name = value (lower|upper bound)"`` for each shape parameter of the winner on a bound of the box.
    """

    point: tuple
    edge: EdgeResult
    evaluated: dict = field(default_factory=dict)
    on_bound: list = field(default_factory=list)

    @property
    def checks(self) -> int:
        """Real checks made over the whole search."""
        return int(sum(e.checks for e in self.evaluated.values() if e is not None))


def _objective(e: EdgeResult | None) -> float:
    if e is None or e.best is None or not math.isfinite(e.best.crossover_hz):
        return -math.inf
    return float(e.best.crossover_hz)


def pattern_search(edge_of: Callable[[tuple, float | None], EdgeResult | None], names: Sequence[str],
                   bounds: Sequence[tuple[float, float]], *, starts: int = 3, min_step: float = 1 / 16,
                   improve: float = 1e-3, initial: Sequence[float] | None = None, initial_scale: float | None = None,
                   initial_step: float = 1 / 8) -> SearchResult | None:
    """Maximise the first crossover at the feasibility edge over a box of shape parameters (log coordinates).

    Parameters
    ----------
    edge_of : callable
        ``edge_of(shape, start_scale) -> EdgeResult`` (:func:`feasibility_edge` of one shape; the
        second argument is the edge scale of a neighbouring shape, or None).
    names : sequence of str
        Names of the shape parameters (for the bound warnings).
    bounds : sequence of (float, float)
        ``(low, high)`` of each parameter (> 0; equal bounds fix it).
    starts : int
        Lattice points per free parameter of the initial scan (>= 2: the corners are included).
    min_step : float
        Smallest compass step as a fraction of each parameter's log range [-].
    improve : float
        Relative gain of the crossover [-] a step must bring to be taken.
    initial : sequence of float, optional
        A local search instead: from this shape (rounded to the lattice), with compass steps from
        ``initial_step`` of the box, the first edge sought from ``initial_scale``.

    Returns
    -------
    SearchResult or None
        None when no shape has a feasible scale.
    """
    lo = np.log([b[0] for b in bounds])
    hi = np.log([b[1] for b in bounds])
    span = hi - lo
    free = span > 0
    unit = np.where(free, span * min_step, 1.0)
    evaluated: dict = {}
    cache: dict = {}

    def point(k: tuple) -> tuple:
        return tuple(float(np.exp(min(max(lo[i] + k[i] * unit[i], lo[i]), hi[i]))) if free[i] else
                     float(bounds[i][0]) for i in range(len(k)))

    last: list = []
    if initial_scale is not None:
        last.append(EdgeResult(Probe(float(initial_scale), True, math.nan, None), None, 0))

    def value(k: tuple, near: EdgeResult | None = None) -> float:
        if k not in cache:
            ref = near if near is not None else (last[-1] if last else None)
            e = edge_of(point(k), None if ref is None else ref.best.scale)
            cache[k] = e
            evaluated[point(k)] = e
            if e is not None and e.best is not None:
                last.append(e)
        return _objective(cache[k])

    n_units = np.where(free, np.round(span / unit), 0).astype(int)
    if initial is not None:
        k0 = tuple(int(min(max(round((math.log(v) - lo[i]) / unit[i]), 0), n_units[i])) if free[i] else 0
                   for i, v in enumerate(initial))
        value(k0)
        best = k0
        step = max(round(initial_step / min_step), 1)
    else:
        axes = [np.unique(np.round(np.linspace(0, n_units[i], starts))).astype(int) if free[i] else np.array([0])
                for i in range(len(bounds))]
        grid = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(bounds), -1).T
        centre = n_units / 2.0
        grid = sorted(grid.tolist(), key=lambda g: (float(np.sum(((np.array(g) - centre) / np.maximum(n_units, 1))
                                                                 ** 2)), g))  # the centre first: the one full scan
        for g in grid:
            value(tuple(int(v) for v in g))
        best = max(cache, key=lambda k: (_objective(cache[k]), k))
        step = max(int(max(np.max(n_units) // max(starts - 1, 1), 1)) // 2, 1)
    if _objective(cache[best]) == -math.inf:
        return None
    while True:
        moved = False
        for i in np.flatnonzero(free):
            for sgn in (1, -1):
                k = list(best)
                k[i] = min(max(k[i] + sgn * step, 0), n_units[i])
                k = tuple(k)
                if k == best:
                    continue
                if value(k, cache[best]) > _objective(cache[best]) * (1 + improve):
                    best, moved = k, True
        if not moved:
            if step == 1:
                break
            step //= 2
    on_bound = []
    for i in np.flatnonzero(free):
        if best[i] == 0:
            on_bound.append(f"{names[i]} = {point(best)[i]:g} (lower bound)")
        elif best[i] == n_units[i]:
            on_bound.append(f"{names[i]} = {point(best)[i]:g} (upper bound)")
    return SearchResult(point(best), cache[best], evaluated, on_bound)
