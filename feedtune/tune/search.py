"""The search shared by the tuners: the highest feasible value of a bandwidth-like parameter, per design shape.

A tuner describes a family of designs by a few *shape* parameters and one *bandwidth* parameter that moves the
loop's crossover up (MC-PPC: the rigid-body pole frequency; gantry MIMO: the CoM crossover). For each shape the
feasible bandwidths are scanned from the top down on a log grid (so the highest feasible region is found even when
the feasible set is not an interval) and the edge above the highest feasible point is bisected to a relative width
of :data:`EDGE_REL_TOL`. A candidate is feasible when the caller's check — exactly the analysis and limits the result
is judged by — passes. The best shape is the one with the highest objective (the first crossover).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np

EDGE_REL_TOL = 2e-3
"""Relative width [-] to which the feasibility edge is bisected."""
COARSE_POINTS = 16
"""Log-spaced bandwidths scanned per shape before the bisection."""


@dataclass(frozen=True)
class Candidate:
    """A checked design.

    Attributes
    ----------
    shape : dict
        The shape parameters.
    bandwidth : float
        The bandwidth parameter (unit of the tuner).
    design : object
        The design object.
    metrics : object
        The figures of the checked case (``LoopMetrics`` or ``MimoMetrics``).
    objective : float
        What is maximised: the first crossover [Hz].
    """

    shape: dict
    bandwidth: float
    design: object
    metrics: object
    objective: float


@dataclass
class SearchRecord:
    """What the search did: evaluations, every shape's best and warnings."""

    evaluations: int = 0
    per_shape: list = field(default_factory=list)
    warnings: list = field(default_factory=list)


CROSSOVER_TIE = 0.02
"""Shapes whose best first crossover is within this fraction of the highest count as equal [-] (the P-PI tuner's
rule, :data:`feedtune.tune.ppi.CROSSOVER_TIE`): the first crossover is nearly flat over the shapes."""


def highest_feasible(check: Callable[[dict, float], Candidate | None], shapes: Iterable[dict], lo: float, hi: float,
                     record: SearchRecord | None = None, *, bound_name: str = "bandwidth", unit: str = "Hz",
                     secondary: Callable[[Candidate], float] | None = None,
                     tie: float = CROSSOVER_TIE) -> Candidate | None:
    """The feasible candidate with the highest objective over the shapes (module docstring).

    Parameters
    ----------
    check : callable
        ``check(shape, bandwidth)`` -> the :class:`Candidate` when it passes the tuner's check, else None.
    shapes : iterable of dict
        The shapes to search.
    lo, hi : float
        Search bounds of the bandwidth parameter (> 0).
    record : SearchRecord, optional
        Filled with the evaluations, the best of every shape and warnings (winner at a search bound).
    bound_name, unit : str
        Name and unit of the bandwidth parameter in the warnings.
    secondary : callable, optional
        ``secondary(candidate)`` -> the tie-breaker: among the shapes whose best objective is within ``tie`` of the
        highest, the one with the highest ``secondary`` wins (e.g. the integral gain: stiffness against slow
        disturbances). Without it the highest objective wins.
    tie : float
        Relative tie of the objective [-].
    """
    rec = record if record is not None else SearchRecord()
    grid = np.geomspace(lo, hi, COARSE_POINTS)

    def run(shape, b):
        rec.evaluations += 1
        try:
            return check(shape, float(b))
        except ArithmeticError:
            return None

    bests: list[Candidate] = []
    for shape in shapes:
        found, i_found = None, None
        for i in range(grid.size - 1, -1, -1):  # top down: the highest feasible point first
            found = run(shape, grid[i])
            if found is not None:
                i_found = i
                break
        if found is None:
            continue
        if i_found + 1 < grid.size:
            a, b = grid[i_found], grid[i_found + 1]
            while b / a > 1 + EDGE_REL_TOL:
                mid = float(np.sqrt(a * b))
                c = run(shape, mid)
                if c is not None:
                    a, found = mid, c
                else:
                    b = mid
        rec.per_shape.append({"shape": dict(shape), bound_name: found.bandwidth, "objective": found.objective})
        bests.append(found)
    best = None
    if bests:
        top = max(c.objective for c in bests)
        best = max(bests, key=lambda c: c.objective)
        if secondary is not None:
            best = max((c for c in bests if c.objective >= (1 - tie) * top), key=secondary)
    if best is not None and best.bandwidth >= hi * (1 - EDGE_REL_TOL):
        rec.warnings.append(f"the best design sits on the upper search bound {bound_name} = {hi:.4g} {unit}; the "
                            "limits may allow more")
    if best is not None and best.bandwidth <= lo * (1 + EDGE_REL_TOL):
        rec.warnings.append(f"the best design sits on the lower search bound {bound_name} = {lo:.4g} {unit}")
    return best
