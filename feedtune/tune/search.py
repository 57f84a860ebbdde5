"""Search machinery shared by the tuners: the feasibility edge of a scale and a bounded pattern search over shapes.

A tuner parametrises its controller by a *scale* (a bandwidth or crossover [Hz]: the loop gets faster as it grows,
and its first crossover with it) and a few *shape* parameters.

:func:`feasibility_edge` finds, for one shape, the largest scale that passes the real check (:class:`Probe`: the
analysis and the limits policy). Without a start it scans log-spaced scales from the top down to the first pass
(a feasible range above a failing one is found); from a start (a neighbouring shape's edge) it steps up or down
to a bracket, assuming the passing scales of a shape form one range from below. The bracket is then narrowed to
``rtol`` by bisection, or by a secant step on the smallest limit slack when both ends have one. A cheap necessary
condition (``admissible``: e.g. the peak sensitivity on the analysis' base grid, a lower bound of the refined one)
rejects scales without a real check; it never accepts one. With ``beat`` (a crossover the shape must exceed to
matter) the first check is at the start, chosen by the tuner to give about that crossover: if it fails with a
crossover at or below ``beat``, the shape's edge lies below the start and its crossover cannot exceed ``beat``, so
the shape is pruned after one check (after none when the start fails the cheap condition and the crossover
estimated on the base grid is clearly below ``beat``); later in the search, as soon as a failing scale has a first
crossover at or below ``beat`` while no passing scale has one above it (the edge lies below that scale, its crossover
too).

:func:`highest_feasible` runs the edge search over a fixed list of shapes (the MC-PPC and gantry-MIMO tuners), coarse
to fine: every shape scanned down to its highest passing scale, then only the brackets that can still win or tie
bisected (the winner is the plain search's).

Which edge wins is the objective, one ranking for every tuner (:class:`Objective`): the highest integral gain
(``stiffness``, the default), the highest first crossover (``bandwidth``), or the stiffness winner with the front of
both (``pareto``). The searches below maximise its *merit* at the edge (the integral gain or the first crossover:
both grow with the scale); a shape asked to beat a merit is pruned as above with the merit in place of the crossover.

:func:`pattern_search` maximises the merit at the edge over the box of shapes, in log coordinates: a
lattice of starts (3 per parameter, the corners included), then a local search from the best lattice points
(``restarts``) moving to the best improving neighbour, diagonals included (ridges where two limits meet run
diagonally), with steps halved down to ``min_step`` of the box. Shapes are points of the lattice of the smallest
step, so that equal problems give equal shapes. :func:`refine_shape` runs it from the winner of a fixed list (the
stiffness objective: the integral gain varies between a list's values by tens of percent).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .. import progress

BOUND_SLACK = 1e-9
"""Relative slack of a cheap necessary condition against the check's own figures [-] (rounding)."""
CHEAP_MARGIN = 5e-3
"""Relative margin [-] by which a crossover estimated on the base grid must lie below ``beat`` to prune."""


def robust_frfs(frf) -> list:
    """The FRFs a tuner checks: ``[]`` for None, ``[frf]`` for one, the list for a sequence (several positions or
    loads of one drive)."""
    if frf is None:
        return []
    if isinstance(frf, (list, tuple)):
        return list(frf)
    return [frf]


class CheckedCases:
    """The plant cases a candidate must pass (one per FRF), checked in turn with the last one to fail first: most
    failing candidates fail on the same FRF, so a failure usually costs one analysis.

    Parameters
    ----------
    cases : sequence
        The plant cases.
    """

    def __init__(self, cases):
        self.cases = list(cases)

    def guaranteed(self, metrics_of, policy, case: str):
        """The figures with the lowest first crossover (the bandwidth guaranteed on all cases) when every case's
        ``metrics_of(plant case)`` meets the limits and has a crossover; None at the first that does not (or
        returns None)."""
        return self.judge(metrics_of, policy, case)[0]

    def judge(self, metrics_of, policy, case: str, refuse=None) -> tuple:
        """``(figures, crossover)``: as :meth:`guaranteed` (``refuse(plant case, metrics)`` -> True also fails a
        case), and the lowest first crossover [Hz] of the cases analysed, which bounds the guaranteed one from
        above when the candidate fails (nan when none has one)."""
        found = []
        xs = []
        for k, pc in enumerate(self.cases):
            m = metrics_of(pc)
            if m is not None and m.crossovers_hz:
                xs.append(float(m.crossovers_hz[0]))
            if (m is None or not m.crossovers_hz or not all(i.ok for i in policy.check(m, case))
                    or (refuse is not None and refuse(pc, m))):
                if k:
                    self.cases.insert(0, self.cases.pop(k))
                return None, (min(xs) if xs else math.nan)
            found.append(m)
        best = min(found, key=lambda m: m.crossovers_hz[0])
        return best, float(best.crossovers_hz[0])


def unreliable(warnings) -> str | None:
    """The analysis' warning that its Nyquist count is unreliable (winding not close to an integer), or None."""
    return next((w for w in warnings or [] if "not close to an integer" in w), None)


def band_top_doubt(sigma_l_top: float, top_hz: float, fs: float, ms_max: float | None) -> str | None:
    """Why a loop on a band-limited FRF cannot be accepted, or None.

    Above the FRF's last line (``top_hz`` below ``fs / 2``) the loop is unknown. Assuming only that it rolls off
    there (``sigma_max(L)`` no larger than at the last line), the sensitivity above the band stays within
    ``ms_max`` when ``sigma_max(L) <= 1 - 1/ms_max`` at the last line (``sigma_max(S) <= 1 / (1 - sigma_max(L))``);
    without an ``Ms`` limit, ``sigma_max(L) < 1``.
    """
    if top_hz >= 0.999 * fs / 2:
        return None
    allowed = 1.0 if ms_max is None else 1.0 - 1.0 / ms_max
    if sigma_l_top > allowed:
        return (f"sigma_max(L) = {sigma_l_top:.3g} at the last line of the band ({top_hz:g} Hz) exceeds {allowed:.3g}: "
                "the loop above the band could break the limits")
    return None


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


def crossover_merit(p: Probe) -> float:
    """The first crossover [Hz] of a probe: what the bandwidth objective maximises at the edge."""
    return float(p.crossover_hz)


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
    pruned : bool
        Given up early: the shape cannot beat the crossover it was asked to beat.
    bound_hz : float or None
        When pruned by a failing check: that check's merit (first crossover [Hz], or integral gain), above the
        edge's.
    """

    best: Probe | None
    fail_scale: float | None
    checks: int
    pruned: bool = False
    bound_hz: float | None = None

    @property
    def at_top(self) -> bool:
        """The edge is the top of the scan range (the scale bound)."""
        return self.best is not None and self.fail_scale is None


class _PrunedError(Exception):
    """Raised inside :func:`feasibility_edge` when a failing scale shows that the edge cannot beat ``beat``."""

    def __init__(self, scale: float, crossover_hz: float) -> None:
        super().__init__(scale)
        self.scale, self.crossover_hz = scale, crossover_hz


def _slack(p: Probe | None) -> float | None:
    return None if p is None or p.slack is None or not math.isfinite(p.slack) else float(p.slack)


def feasibility_edge(check: Callable[[float], Probe], scan: np.ndarray, *,
                     admissible: Callable[[np.ndarray], np.ndarray] | None = None, rtol: float = 2e-3,
                     start: float | None = None, beat: float | None = None,
                     cheap_crossover: Callable[[float], float] | None = None,
                     merit: Callable[[Probe], float] | None = None, step: float | None = None) -> EdgeResult:
    """Largest scale passing ``check`` (module docstring); ``best`` is None when no point passes.

    Parameters
    ----------
    check : callable
        ``check(scale) -> Probe``, the real check.
    scan : ndarray
        Increasing log-spaced scales [Hz]: the range, and the points of the top-down scan when there is no
        ``start``.
    admissible : callable, optional
        ``admissible(scales) -> bool array``: a necessary condition (False: certainly failing, no real check).
    rtol : float
        Relative width of the final bracket [-].
    start : float, optional
        A scale expected near the edge (a neighbouring shape's): the bracket is sought around it.
    beat : float, optional
        With ``start``: prune the shape as soon as a failing scale has a first crossover at or below ``beat`` [Hz]
        while no passing one has a crossover above it (the first check is at ``start``).
    cheap_crossover : callable, optional
        ``cheap_crossover(scale)`` -> an estimate of the merit (the first crossover [Hz] on the analysis' base
        grid; the integral gain itself, known without a check, under the stiffness objective): when ``start``
        fails the cheap condition and the estimate is ``CHEAP_MARGIN`` below ``beat``, the shape is pruned without
        a real check.
    merit : callable, optional
        ``merit(probe)``: the figure ``beat`` is compared with, growing with the scale (default the first crossover
        [Hz]; the integral gain under the stiffness objective, :class:`Objective`).
    step : float, optional
        First step up from a passing ``start`` [-] (squared after each pass, up to 2; default 1.15): given, the
        search climbs from a passing ``start`` by it before it tries the cheap edge (the start is known to lie close
        below the edge).
    """
    merit = merit or crossover_merit
    scan = np.asarray(scan, float)
    bottom, top = float(scan[0]), float(scan[-1])
    n = 0
    early = beat is not None and start is not None and bottom <= start <= top
    beaten = False  # a passing scale's first crossover exceeds ``beat``

    def real(s: float) -> Probe:
        nonlocal n, beaten
        n += 1
        p = check(float(s))
        progress.judged(merit(p) if p.ok else None)
        if early:
            v = merit(p)
            if p.ok and v > beat:
                beaten = True
            elif not p.ok and not beaten and math.isfinite(v) and v <= beat:
                raise _PrunedError(p.scale, v)
        return p

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

    def climb(p: Probe) -> tuple[Probe, float | None, Probe | None]:
        """Real steps up from a passing ``p`` (``step``, squared after each pass up to a factor 2) to the first
        failure: ``(last pass, first failing scale or None at the top, its probe)``."""
        up = step or 1.15
        while True:
            if p.scale >= top:
                return p, None, None
            u = min(p.scale * up, top)
            q = real(u) if cheap(u) else None
            if q is None or not q.ok:
                return p, u, q
            p, up = q, min(up * up, 2.0)

    try:
        lo_p: Probe | None = None
        hi: float | None = None
        hi_p: Probe | None = None
        if start is not None and bottom <= start <= top:
            s = float(start)
            if beat is not None and cheap_crossover is not None and not cheap(s):
                xc = cheap_crossover(s)
                if math.isfinite(xc) and xc <= beat * (1 - CHEAP_MARGIN):
                    return EdgeResult(None, s, n, pruned=True)
            p = real(s) if beat is not None and cheap(s) else None  # not cheap: certainly failing, see below
            if p is not None and not p.ok:
                c = merit(p)
                t = s * beat / c * (1 - 0.5 * rtol) if math.isfinite(c) and c <= beat * 1.15 else bottom
                if t > bottom and cheap(t):  # just above ``beat``: the scale of a crossover just below it decides
                    q = real(t)  # failing: pruned (its crossover is below ``beat`` as the scale is)
                    lo_p, hi, hi_p = (q, s, p) if q.ok else descend(t, q)
                else:
                    lo_p, hi, hi_p = descend(s, p)
            else:
                target, b = s, None
                if cheap(s):  # the cheap edge above the start is the first guess
                    ups = s * 1.15 ** np.arange(1, max(math.ceil(math.log(top / s) / math.log(1.15)), 0) + 1)
                    ups = np.minimum(ups, top)
                    for i in range(0, ups.size if admissible is not None else 0, 4):  # four at a time, upwards
                        refused = np.flatnonzero(~np.asarray(admissible(ups[i:i + 4]), bool))
                        if refused.size:
                            j = i + int(refused[0])
                            a, b = cheap_edge(s if j == 0 else float(ups[j - 1]), float(ups[j]))
                            target = below(a, b)
                            break
                else:  # down to the cheap edge below the start
                    u, t = s, s / 1.15
                    while t >= bottom and not cheap(t):
                        u, t = t, t / 1.15
                    if t < bottom:
                        return EdgeResult(None, None, n)
                    a, b = cheap_edge(t, u)
                    target = below(a, b)
                if step is not None and p is not None and p.ok and target > s * step:  # the edge is near: climb
                    target, b = s * step, None
                q = p if p is not None and target == s else real(target)
                if q.ok:
                    lo_p, hi, hi_p = (q, b, None) if b is not None else climb(q)
                    if hi is None:
                        return EdgeResult(lo_p, None, n)
                elif p is not None and p.ok:
                    lo_p, hi, hi_p = p, target, q
                else:
                    lo_p, hi, hi_p = descend(target, q)
            if lo_p is None:
                return EdgeResult(None, None, n)  # no passing scale near a neighbour's edge: not scanned again
        else:  # top-down scan
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
    except _PrunedError as stop:  # a failing scale below ``beat``: the edge's crossover is too
        return EdgeResult(None, stop.scale, n, pruned=True, bound_hz=stop.crossover_hz)


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
        ``{shape: EdgeResult}`` of every shape evaluated (pruned ones included).
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

    def edges(self) -> list:
        """``[(shape, Probe)]`` of every shape's passing edge (the candidates the objective ranks)."""
        return [(shape, e.best) for shape, e in self.evaluated.items() if e is not None and e.best is not None]


def _objective(e: EdgeResult | None, merit: Callable[[Probe], float] = crossover_merit) -> float:
    if e is None or e.best is None:
        return -math.inf
    v = merit(e.best)
    return float(v) if math.isfinite(v) else -math.inf


EdgeOf = Callable[[tuple, "tuple | None", "float | None"], EdgeResult]


def pattern_search(edge_of: EdgeOf, names: Sequence[str], bounds: Sequence[tuple[float, float]], *,
                   starts: int = 3, restarts: int = 2, min_step: float = 1 / 16, improve: float = 1e-3,
                   initial: Sequence[float] | None = None, ref: tuple | None = None,
                   initial_step: float = 1 / 8,
                   merit: Callable[[Probe], float] = crossover_merit, diagonal: bool = True) -> SearchResult | None:
    """Maximise the merit (the first crossover, or the integral gain) at the feasibility edge over a box of shape
    parameters (module docstring).

    Parameters
    ----------
    edge_of : callable
        ``edge_of(shape, ref, beat) -> EdgeResult``: :func:`feasibility_edge` of one shape. ``ref`` is
        ``(shape, Probe)`` of a neighbouring shape's edge (None for the first shape: a full scan); ``beat`` is the
        merit a local move must exceed (None on the lattice).
    names : sequence of str
        Names of the shape parameters (for the bound warnings).
    bounds : sequence of (float, float)
        ``(low, high)`` of each parameter (> 0; equal bounds fix it).
    starts : int
        Lattice points per free parameter of the initial scan (>= 2: the corners are included).
    restarts : int
        Local searches, from the best distinct lattice points.
    min_step : float
        Smallest step as a fraction of each parameter's log range [-].
    improve : float
        Relative gain of the crossover [-] a move must bring to be taken.
    initial : sequence of float, optional
        A single local search instead: from this shape (rounded to the lattice), with steps from ``initial_step``
        of the box.
    ref : (shape, Probe), optional
        A passing probe of a similar design: the first edge is sought from it instead of by a full scan.
    initial_step : float
        First step of the single local search from ``initial`` [-] (fraction of the box).
    merit : callable
        ``merit(probe)`` maximised at the edge: the first crossover [Hz] (bandwidth objective) or the integral gain
        (stiffness, :meth:`Objective.merit`); it must grow with the scale.
    diagonal : bool
        Moves along the diagonals too (else along one parameter at a time: ``2 n`` neighbours instead of
        ``3^n - 1``).

    Returns
    -------
    SearchResult or None
        None when no shape has a feasible scale.
    """
    lo = np.log([b[0] for b in bounds])
    hi = np.log([b[1] for b in bounds])
    span = hi - lo
    free = span > 0
    dims = len(bounds)
    unit = np.where(free, span * min_step, 1.0)
    n_units = np.where(free, np.round(span / unit), 0).astype(int)
    evaluated: dict = {}
    cache: dict = {}
    last: list = [] if ref is None else [ref]  # (shape, probe) of the latest feasible edge

    def coordinate(i: int, k: int) -> float:
        if not free[i] or k <= 0:
            return float(bounds[i][0])
        if k >= n_units[i]:
            return float(bounds[i][1])
        return float(np.exp(lo[i] + k * unit[i]))

    def point(k: tuple) -> tuple:
        return tuple(coordinate(i, k[i]) for i in range(dims))

    beaten: dict = {}  # a pruned shape's crossover is at most this (the beat it was asked, or a failing check's)

    def value(k: tuple, ref: tuple | None = None, beat: float | None = None) -> float:
        if k not in cache or (cache[k].pruned and (beat is None or beat < beaten[k])):
            e = edge_of(point(k), ref if ref is not None else (last[-1] if last else None), beat)
            cache[k] = e
            beaten[k] = e.bound_hz if e.pruned and e.bound_hz is not None else beat
            evaluated[point(k)] = e
            if e.best is not None:
                last.append((point(k), e.best))
        return _objective(cache[k], merit)

    moves = [d for d in np.array(np.meshgrid(*[[-1, 0, 1] if f else [0] for f in free], indexing="ij"))
             .reshape(dims, -1).T if np.any(d != 0) and (diagonal or np.count_nonzero(d) == 1)]

    def local(k: tuple, step: int) -> tuple:
        while True:
            here = _objective(cache[k], merit)
            target = here * (1 + improve)
            ref = (point(k), cache[k].best)
            best_k, best_v = None, target
            for d in moves:
                j = tuple(int(min(max(k[i] + d[i] * step, 0), n_units[i])) for i in range(dims))
                if j == k:
                    continue
                v = value(j, ref, target)
                if v > best_v:
                    best_k, best_v = j, v
            if best_k is not None:
                k = best_k
            elif step > 1:
                step //= 2
            else:
                return k

    if initial is not None:
        k0 = tuple(int(min(max(round((math.log(v) - lo[i]) / unit[i]), 0), n_units[i])) if free[i] else 0
                   for i, v in enumerate(initial))
        value(k0)
        if _objective(cache[k0], merit) == -math.inf:
            return None
        best = local(k0, max(round(initial_step / min_step), 1))
    else:
        axes = [np.unique(np.round(np.linspace(0, n_units[i], starts))).astype(int) if free[i] else np.array([0])
                for i in range(dims)]
        grid = np.array(np.meshgrid(*axes, indexing="ij")).reshape(dims, -1).T
        centre = n_units / 2.0
        grid = sorted(grid.tolist(), key=lambda g: (float(np.sum(((np.array(g) - centre) / np.maximum(n_units, 1))
                                                                 ** 2)), g))  # the centre first: the one full scan
        for g in grid:
            value(tuple(int(v) for v in g))
        lattice = sorted((k for k in cache if _objective(cache[k], merit) > -math.inf),
                         key=lambda k: -_objective(cache[k], merit))
        if not lattice:
            return None
        step = max(int(np.max(n_units) // max(starts - 1, 1)) // 2, 1)
        ends = [local(k, step) for k in lattice[:restarts]]
        best = max(ends, key=lambda k: (_objective(cache[k], merit), k))
    on_bound = []
    for i in np.flatnonzero(free):
        if best[i] == 0:
            on_bound.append(f"{names[i]} = {point(best)[i]:g} (lower bound)")
        elif best[i] == n_units[i]:
            on_bound.append(f"{names[i]} = {point(best)[i]:g} (upper bound)")
    return SearchResult(point(best), cache[best], evaluated, on_bound)


# ------------------------------------------------------------------------------------------ the objective
CROSSOVER_TIE = 0.02
"""Shapes whose best first crossover is within this fraction of the highest count as equal [-] (the P-PI tuner's
rule, :data:`feedtune.tune.ppi.CROSSOVER_TIE`): the first crossover is nearly flat over the shapes."""
OBJECTIVES = ("stiffness", "bandwidth", "pareto")
"""The tuning objectives (:class:`Objective`)."""
DEFAULT_OBJECTIVE = "stiffness"
"""The objective of every tuner unless told otherwise (docs/verdicts.md, "How designs are tuned": on the ball-screw
twin the stiffness winner has a lower rope-snap IAE and tracking error than the bandwidth winner)."""


@dataclass(frozen=True)
class Objective:
    """Which feasibility edge wins: every tuner finds, per shape, the largest scale that meets the limits (the edge),
    then ranks the edges by this one rule.

    * ``stiffness``: the highest integral gain (the low-frequency dynamic stiffness against a force: ``Ki2`` of the
      ball-screw law, MC-PPC and P-PI alike; ``ki`` of the gantry MIMO and PID laws; ``K`` of the x axis'
      ``K (Ti s + 1)/s``), the first crossover breaking ties;
    * ``bandwidth``: the highest first crossover; edges within :data:`CROSSOVER_TIE` of it count as equal and the
      highest integral gain among them wins;
    * ``pareto``: the stiffness winner, with the front of both figures over every edge evaluated recorded
      (:meth:`front`) and drawn in the report.

    ``compliance_max`` [rad/V] caps the axial-mode compliance of the ball screw (minus the most negative real part of
    ``x2/d2`` in the ``ideal`` case, the thesis' chatter indicator, Fig. 3.12) under every objective: an edge above
    the cap does not win.

    Parameters
    ----------
    name : {"stiffness", "bandwidth", "pareto"}
    compliance_max : float, optional
        The cap [rad/V] (> 0); None: no cap.
    tie : float
        Relative tie of the first crossover under ``bandwidth`` [-].
    """

    name: str = DEFAULT_OBJECTIVE
    compliance_max: float | None = None
    tie: float = CROSSOVER_TIE

    @classmethod
    def of(cls, objective: str | Objective | None = None, compliance_max: float | None = None) -> Objective:
        """The objective named (default :data:`DEFAULT_OBJECTIVE`), checked.

        Raises
        ------
        UsageError
            An unknown name, or a cap that is not a positive number.
        """
        from ..errors import UsageError

        if isinstance(objective, Objective):
            return objective if compliance_max is None else replace(objective, compliance_max=float(compliance_max))
        name = DEFAULT_OBJECTIVE if objective is None else str(objective)
        if name not in OBJECTIVES:
            raise UsageError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}",
                             parameter="objective")
        if compliance_max is not None and not (math.isfinite(float(compliance_max)) and float(compliance_max) > 0):
            raise UsageError(f"compliance_max must be a positive compliance [rad/V], got {compliance_max!r}",
                             parameter="compliance_max")
        return cls(name, None if compliance_max is None else float(compliance_max))

    @property
    def by_gain(self) -> bool:
        """The integral gain is maximised (``stiffness``, ``pareto``)."""
        return self.name != "bandwidth"

    def merit(self, crossover_hz: float, gain: float) -> float:
        """The figure maximised at an edge: the integral gain or the first crossover [Hz]."""
        return float(gain) if self.by_gain else float(crossover_hz)

    def order(self, items, crossover: Callable, gain: Callable) -> list:
        """``items`` best first (class docstring), ``crossover(item)`` [Hz] and ``gain(item)`` their figures; the
        order of equal items is kept."""
        items = list(items)
        if not items:
            return []
        if self.by_gain:
            return sorted(items, key=lambda c: (-gain(c), -crossover(c)))
        top = max(crossover(c) for c in items)
        tied = [c for c in items if crossover(c) >= (1 - self.tie) * top]
        rest = [c for c in items if not any(c is t for t in tied)]
        return sorted(tied, key=lambda c: -gain(c)) + sorted(rest, key=lambda c: -crossover(c))

    @staticmethod
    def front(items, crossover: Callable, gain: Callable) -> list:
        """The items no other beats in both the first crossover and the integral gain, by rising crossover."""
        items = sorted(items, key=lambda c: (-crossover(c), -gain(c)))
        out, best = [], -math.inf
        for c in items:
            if gain(c) > best:
                out.append(c)
                best = gain(c)
        return out[::-1]

    def rule(self, gain_name: str) -> str:
        """The rule in words (``tuning["objective_rule"]``)."""
        cap = "" if self.compliance_max is None else (f"; edges whose axial-mode compliance exceeds "
                                                      f"{self.compliance_max:.4g} rad/V do not win")
        if self.name == "bandwidth":
            return (f"bandwidth: the highest first crossover at the edge; within {100 * self.tie:g} % of it the "
                    f"highest {gain_name} wins{cap}")
        what = ("stiffness" if self.name == "stiffness" else
                "pareto (the front of first crossover and integral gain recorded; the stiffness winner chosen)")
        return f"{what}: the highest integral gain {gain_name} at the edge, ties by the first crossover{cap}"

    def record(self, gain_name: str, gain_unit: str, gain: float, front: list | None = None) -> dict:
        """What ``tuning`` records of the objective: its name and rule, the winner's integral gain with its name and
        unit, the cap, and under ``pareto`` the front ``[{"shape", "first_crossover_hz", "integral_gain"}]``."""
        out = {"objective": self.name, "objective_rule": self.rule(gain_name),
               "integral_gain": {"name": gain_name, "value": float(gain), "unit": gain_unit},
               "compliance_max_rad_per_V": self.compliance_max}
        if front is not None:
            out["pareto_front"] = front
        return out


def shape_bound_warnings(shape: dict, shapes: Sequence[dict]) -> list[str]:
    """``"the winner sits on a search bound: beta = 4 (upper bound of 1-4)"`` for each parameter of ``shape`` at the
    lowest or highest value searched (parameters with a single value are fixed, not searched)."""
    out = []
    for key, v in shape.items():
        values = sorted({float(s[key]) for s in shapes if key in s})
        if len(values) < 2:
            continue
        side = "lower" if float(v) <= values[0] else "upper" if float(v) >= values[-1] else None
        if side is not None:
            out.append(f"the winner sits on a search bound: {key} = {float(v):g} ({side} bound of the values searched, "
                       f"{values[0]:g}-{values[-1]:g}); the best design may lie beyond it")
    return out


# ------------------------------------------------------------------------------------------ fixed shape lists
COARSE_POINTS = 16
"""Log-spaced scales of the top-down scan per shape in :func:`highest_feasible`."""


@dataclass(frozen=True)
class Candidate:
    """A design judged by the tuner's check.

    Attributes
    ----------
    shape : dict
        The shape parameters.
    bandwidth : float
        The scale parameter [Hz].
    design : object
        The design object.
    metrics : object
        The figures of the checked case (``LoopMetrics`` or ``MimoMetrics``).
    objective : float
        What is maximised: the first crossover [Hz]; for a failing candidate, an upper bound of it (nan: unknown).
    passed : bool
        False: the candidate failed; returned only to bound the crossover at its scale.
    """

    shape: dict
    bandwidth: float
    design: object
    metrics: object
    objective: float
    passed: bool = True


@dataclass
class SearchRecord:
    """What :func:`highest_feasible` did: real checks, every bisected shape's edge (``per_shape``, and the candidates
    there, ``found``), the shapes not bisected (their merit below what could tie with the best) and warnings."""

    evaluations: int = 0
    per_shape: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    found: list = field(default_factory=list)
    """The candidate at every bisected shape's edge (the points of the Pareto front)."""


def highest_feasible(check: Callable[[dict, float], Candidate | None], shapes, lo: float, hi: float,
                     record: SearchRecord | None = None, *, bound_name: str = "bandwidth", unit: str = "Hz",
                     gain: Callable[[Candidate], float] | None = None, objective: Objective | None = None,
                     accept: Callable[[Candidate], bool] | None = None,
                     admissible: Callable[[dict, np.ndarray], np.ndarray] | None = None,
                     rtol: float = 2e-3) -> Candidate | None:
    """The best candidate over a fixed list of shapes: each shape's :func:`feasibility_edge` in the scale (a top-down
    scan of :data:`COARSE_POINTS` log-spaced scales in ``[lo, hi]``, then bisection to 0.2 %), the edges ranked by
    the ``objective`` (:meth:`Objective.order`: the highest first crossover, ties by ``gain``; or the highest
    ``gain``).

    Coarse to fine: every shape is first scanned down to its highest passing scale, which brackets its edge between
    that scale and the failing one above it, and so its merit (first crossover, or integral gain: both grow with the
    scale) between theirs. The brackets are then bisected from the highest upper end down; a shape whose upper end
    lies below what the best found can still tie with is not bisected (it can neither win nor tie; under ``pareto``
    every shape is bisected: each edge is a point of the front). Every shape that is bisected is bisected as in the
    plain search, so the winner and its edge are the plain search's; a refused winner (``accept``) has the skipped
    shapes bisected too before the next in the ranking is taken.

    Parameters
    ----------
    check : callable
        ``check(shape, scale)`` -> the :class:`Candidate` when it passes the tuner's check (the analysis and the
        limits), else None or a :class:`Candidate` with ``passed=False`` whose ``objective`` bounds the first
        crossover at that scale from above (the failing case's, nan when unknown).
    shapes : iterable of dict
    lo, hi : float
        Bounds of the scale (> 0).
    record : SearchRecord, optional
        Filled with the checks, every shape's edge and the warnings (winner on a bound of the scale or of the
        shapes).
    bound_name, unit : str
        Name and unit of the scale in the warnings.
    gain : callable, optional
        ``gain(candidate)``: its integral gain (needed unless the objective is ``bandwidth``; without it the
        bandwidth objective has no tie-breaker).
    objective : Objective, optional
        The ranking (default ``bandwidth``, with ``gain`` as the tie-breaker).
    accept : callable, optional
        ``accept(candidate)`` -> False when the full verification (e.g. stability in every case, or the compliance
        cap) refuses a shape's best: the next one in the ranking is taken (at most five are tried), with a warning.
    admissible : callable, optional
        ``admissible(shape, scales) -> bool array``: a necessary condition (False: the check certainly fails). The
        scan skips the scales it refuses without a check, save the one just above a shape's highest passing scale
        (checked: its figures bound the merit and start the bisection, as in the plain scan).
    rtol : float
        Relative width of each bisected bracket [-] (looser when :func:`refine_shape` follows: it bisects its
        winner to 0.2 %).
    """
    rec = record if record is not None else SearchRecord()
    obj = objective or Objective("bandwidth")
    if gain is None:
        if obj.by_gain:
            raise ValueError("highest_feasible: the stiffness and pareto objectives need gain=")
        obj = replace(obj, tie=0.0)
        gain = _no_gain
    scan = np.geomspace(lo, hi, COARSE_POINTS)
    shapes = [dict(sh) for sh in shapes]
    probes: list[dict] = [{} for _ in shapes]  # scale -> Probe, per shape

    def merit_of(c: Candidate | None) -> float:
        if c is None:
            return math.nan
        return obj.merit(c.objective, gain(c) if c.design is not None else math.nan)

    def probe(k: int, scale: float) -> Probe:
        memo = probes[k]
        if scale not in memo:
            rec.evaluations += 1
            try:
                c = check(shapes[k], scale)
            except ArithmeticError:
                c = None
            ok = c is not None and c.passed
            memo[scale] = Probe(scale, ok, math.nan if c is None else c.objective, None, c)
            progress.judged(merit_of(c) if ok else None)
        return memo[scale]

    brackets: dict[int, tuple] = {}  # shape -> (pass, fail above or None)
    for k, shape in enumerate(shapes):  # coarse: every shape down to its highest passing scale
        for i in range(scan.size - 1, -1, -1):
            if admissible is not None and not bool(np.asarray(admissible(shape, scan[i:i + 1]))[0]):
                continue
            p = probe(k, float(scan[i]))
            if p.ok:
                above = None if i == scan.size - 1 else probe(k, float(scan[i + 1]))
                brackets[k] = (p, above)
                break

    def upper(k: int) -> float:
        p, above = brackets[k]
        here = merit_of(p.result)
        if above is None:
            return here
        c = merit_of(above.result)
        return c if math.isfinite(c) and c >= here else math.inf  # not growing here: no bound

    found: dict[int, Candidate] = {}
    skipped: list[int] = []

    def fine(k: int) -> None:
        p, above = brackets[k]
        pts = [p.scale] if above is None else [p.scale, above.scale]
        edge = feasibility_edge(lambda s, k=k: probe(k, s), np.array(pts), rtol=rtol)
        found[k] = edge.best.result

    def least_to_tie() -> float:
        if not found or obj.name == "pareto":
            return -math.inf
        top = max(merit_of(c) for c in found.values())
        return top if obj.by_gain else (1 - obj.tie) * top

    for k in sorted(brackets, key=lambda k: (-upper(k), k)):  # fine: the highest upper ends first
        if upper(k) < least_to_tie():
            skipped.append(k)
        else:
            fine(k)
    if not found:
        return None

    def ranking() -> list[Candidate]:
        return obj.order([found[k] for k in sorted(found)], lambda c: c.objective, gain)

    order = ranking()
    best = order[0]
    if accept is not None and not accept(best):
        for k in skipped:  # the next in the ranking may be one not bisected
            fine(k)
        order = ranking()
        best = next((c for c in order[:5] if accept(c)), None)
        if best is None:
            return None
        u = "" if obj.by_gain else " Hz"
        rec.warnings.append(f"the {order.index(best)} best shape(s) failed the full verification; the next best was "
                            f"taken ({merit_of(best):.4g}{u} instead of {merit_of(order[0]):.4g}{u})")
    for k in sorted(found):
        c = found[k]
        rec.per_shape.append({"shape": dict(shapes[k]), bound_name: c.bandwidth, "objective": c.objective,
                              "first_crossover_hz": c.objective, "integral_gain": gain(c)})
    for k in sorted(set(skipped) - set(found)):
        rec.skipped.append({"shape": dict(shapes[k]), "merit_below" if obj.by_gain else "first_crossover_below_hz":
                            upper(k)})
    if best.bandwidth >= hi * (1 - 2e-3):
        rec.warnings.append(f"the best design sits on the upper search bound {bound_name} = {hi:.4g} {unit}; the "
                            "limits may allow more")
    if best.bandwidth <= lo * (1 + 2e-3):
        rec.warnings.append(f"the best design sits on the lower search bound {bound_name} = {lo:.4g} {unit}")
    rec.found = [found[k] for k in sorted(found)]
    return best


def _no_gain(c: Candidate) -> float:
    return 0.0


REFINE_RTOL = 1e-2
"""Relative bracket of the edges [-] while :func:`refine_shape` still moves (its winner is then bisected to 0.2 %)."""
GAIN_EXPONENT = 3.0
"""How the integral gain grows with the scale at a fixed shape [-]: ``Ki2 ~ pole^3`` (MC-PPC), ``ki ~ wc^3`` (MIMO,
PID), ``K ~ wc^3`` (the x axis: ``K = m wc^3 tan(lag)`` on a mass), the integral gain of a loop on a mass; used only to
place the first check of a neighbouring shape's edge."""


def refine_shape(check: Callable[[dict, float], Candidate | None], best: Candidate, names: Sequence[str],
                 bounds: Sequence[tuple[float, float]], lo: float, hi: float, *, gain: Callable[[Candidate], float],
                 objective: Objective, gain_at: Callable[[dict, float], float] | None = None,
                 admissible: Callable[[dict, np.ndarray], np.ndarray] | None = None, min_step: float = 1 / 16,
                 accept: Callable[[Candidate], bool] | None = None, diagonal: bool = True,
                 rtol: float = REFINE_RTOL) -> tuple[Candidate, SearchResult | None]:
    """A local search over continuous shapes from the best of a fixed list (:func:`highest_feasible`'s winner):
    :func:`pattern_search` over ``names`` in ``bounds`` from ``best.shape``, each shape's edge in the scale by
    :func:`feasibility_edge` with ``check`` (pruned as soon as it cannot beat the merit to beat), ranked by the
    ``objective``. A fixed list of shapes holds a few values per parameter; the integral gain at the edge varies
    between them by tens of percent (MC-PPC on the example family: ``Ki2`` 171k at zeta 0.5, 182k at 0.55, 166k at
    0.6), so the stiffness objective refines.

    Parameters
    ----------
    check, lo, hi, gain, objective, admissible, accept
        As for :func:`highest_feasible` (``accept`` refuses a refined winner: the best of the list is kept).
    best : Candidate
        The winner of the fixed list (its shape's other keys are kept fixed).
    names, bounds : sequence
        The shape parameters refined and their ``(low, high)`` bounds (> 0).
    gain_at : callable, optional
        ``gain_at(shape, scale)``: the integral gain of a design without checking it (the first check of a shape is
        placed where it reaches the merit to beat, :data:`GAIN_EXPONENT`).
    min_step : float
        Smallest step of the search as a fraction of each parameter's log range [-].
    diagonal : bool
        Diagonal moves too (:func:`pattern_search`).
    rtol : float
        Relative width of each shape's bracket in the scale during the search [-]; the winner's is then bisected to
        0.2 % (as the fixed list's).

    Returns
    -------
    (Candidate, SearchResult or None)
        The better of ``best`` and the refined winner under the objective, and the search (its ``evaluated`` edges:
        points of the Pareto front).
    """
    scan = np.geomspace(lo, hi, COARSE_POINTS)

    def merit(p: Probe) -> float:
        c = p.result
        return math.nan if c is None or c.design is None else objective.merit(c.objective, gain(c))

    def shape_at(point: tuple) -> dict:
        return {**best.shape, **dict(zip(names, (float(v) for v in point), strict=True))}

    def prober(shape: dict) -> Callable[[float], Probe]:
        def probe(scale: float) -> Probe:
            try:
                c = check(shape, scale)
            except ArithmeticError:
                c = None
            return Probe(scale, c is not None and c.passed, math.nan if c is None else c.objective, None, c)
        return probe

    def edge_of(point: tuple, ref: tuple | None, beat: float | None) -> EdgeResult:
        shape = shape_at(point)
        probe = prober(shape)

        start = None if ref is None else ref[1].scale
        if start is not None and beat is not None and gain_at is not None and objective.by_gain:
            g0 = gain_at(shape, start)
            if math.isfinite(g0) and g0 > 0:
                start = float(np.clip(start * (beat / g0) ** (1 / GAIN_EXPONENT), lo, hi))
        cheap = None
        if gain_at is not None and objective.by_gain:
            def cheap(s: float) -> float:
                return gain_at(shape, s)
        return feasibility_edge(probe, scan, rtol=rtol, start=start, beat=beat if start is not None else None,
                                step=1 + 3 * rtol,
                                admissible=None if admissible is None else (lambda s: admissible(shape, s)),
                                cheap_crossover=cheap, merit=merit)

    point = tuple(float(best.shape[n]) for n in names)
    ref = Probe(best.bandwidth, True, best.objective, None, best)
    r = pattern_search(edge_of, names, bounds, initial=point, ref=(point, ref), merit=merit, min_step=min_step,
                       diagonal=diagonal)
    if r is None or r.edge.best is None:
        return best, r
    found = r.edge.best.result
    top = r.edge.fail_scale
    if found is not best and top is not None and top / found.bandwidth > 1 + 2e-3:  # the winner's bracket to 0.2 %
        fine = feasibility_edge(prober(found.shape), np.array([found.bandwidth, top]), rtol=2e-3)
        found = fine.best.result if fine.best is not None else found
    if accept is not None and found is not best and not accept(found):
        return best, r
    return objective.order([best, found], lambda c: c.objective, gain)[0], r
