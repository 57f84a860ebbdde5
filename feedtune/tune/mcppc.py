"""MC-PPC at its best under the limits: the rigid-body pole frequency, its damping and the mode's decay multiplier
``beta`` whose edge wins under the objective (:class:`feedtune.tune.search.Objective`: the highest integral gain
``Ki2``, or the highest first crossover) among the designs meeting the limits policy (issue 10: the proposal is tuned
by the same search and under the same limits as the baseline; issue 23: the objective).

Shapes: ``beta`` in :data:`BETAS` (the thesis's drive allowed up to 4, section 3.2.3) and ``zeta`` in :data:`ZETAS`;
bandwidth parameter: the pole frequency ``pole_hz`` (eq. 3.8), searched by :func:`feedtune.tune.search.
highest_feasible` on the checked case (``discrete`` with an FRF, else ``ideal_discrete``), with the filter pack given
(default none); a scale whose peak ``|S|`` on the checked case's lines (a lower bound of the checked ``Ms``) breaks
the limit is skipped unchecked. With several FRFs (the drive measured at several table positions or loads) a
candidate passes only when it meets the limits on every one, and its crossover is its lowest first crossover over them
(the bandwidth it guarantees on all). With a compliance cap a candidate also passes only when its axial-mode
compliance (:class:`feedtune.tune.compliance.AxialCompliance`, which grows with the pole frequency) is within it. The
winner is re-checked in every case on every FRF (:func:`feedtune.analysis.check.check_design`); one on a bound of
the shapes searched is reported in ``tuning["warnings"]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .. import progress
from ..analysis.ballscrew import analyze_case, loop_on_grid
from ..analysis.cases import CHECKED_WITH_FRF, CHECKED_WITHOUT_FRF
from ..analysis.check import check_design, resolve_limits
from ..control.discretize import check_sampling
from ..control.filters import FilterPack
from ..design.mcppc import McppcDesign, design_mcppc
from ..errors import DesignError, FeedtuneError, UsageError
from ..frf import Frf
from ..models.ballscrew import BallScrewModel
from .ballscrew_filters import ballscrew_resonances, ballscrew_sensitivity_peaks, search_cases
from .compliance import AxialCompliance
from .filter_choice import tune_with_own_filters
from .search import (
    REFINE_RTOL,
    Candidate,
    CheckedCases,
    Objective,
    SearchRecord,
    highest_feasible,
    refine_shape,
    robust_frfs,
    shape_bound_warnings,
)

BETAS = (1.0, 2.0, 3.0, 4.0)
"""Multipliers of the axial mode's decay rate searched [-] (thesis: up to 4)."""
ZETAS = (0.5, 0.7, 0.9)
"""Damping of the rigid-body pole pair searched [-] (thesis: 0.7)."""
QUICK_BETAS, QUICK_ZETAS = (1.0, 4.0), (0.7,)
"""The shapes of the quick search that ranks filter candidates when nothing is feasible without filters."""
POLE_RANGE_HZ = (5.0, 500.0)
"""Search bounds of the rigid-body pole frequency [Hz]."""


def tune_mcppc(model: BallScrewModel, *, limits=None, filters: FilterPack | None = None, fs: float = 20000.0,
               delay_samples: int = 1, frf: Frf | Sequence[Frf] | None = None, betas=BETAS, zetas=ZETAS,
               pole_range_hz: tuple[float, float] = POLE_RANGE_HZ, filter_choice: str = "identical",
               objective: str | Objective | None = None, compliance_max: float | None = None) -> McppcDesign:
    """The MC-PPC that wins under ``objective`` among those that meet ``limits`` (module docstring).

    Parameters
    ----------
    model : BallScrewModel
    limits : Limits, optional
        The policy (default: ``textbook``).
    filters : FilterPack, optional
        Filter pack (kept fixed).
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    frf : Frf or sequence of Frf, optional
        Measured FRF(s): the ``discrete`` case on each is checked (all must pass).
    betas, zetas : sequence of float
        Shapes searched.
    pole_range_hz : (float, float)
        Bounds of the pole frequency [Hz].
    filter_choice : {"identical", "own"}
        ``identical``: the filter pack as given; ``own``: the tuner chooses notches and a low-pass
        (:mod:`feedtune.tune.filter_choice`; the given filters are candidates), recorded in ``tuning["filters"]``.
    objective : {"stiffness", "bandwidth", "pareto"} or Objective, optional
        Which edge wins (default :data:`feedtune.tune.search.DEFAULT_OBJECTIVE`).
    compliance_max : float, optional
        Cap of the axial-mode compliance [rad/V] (minus the most negative real part of ``x2/d2``, ideal case).

    Raises
    ------
    DesignError
        No candidate meets the limits.
    """
    policy = resolve_limits(limits)
    obj = Objective.of(objective, compliance_max)
    filters = filters or FilterPack()
    check_sampling(fs, delay_samples)
    filters.check_nyquist(fs)  # bad input is refused before the search, not turned into "no design"
    frfs = robust_frfs(frf)
    case = CHECKED_WITH_FRF if frfs else CHECKED_WITHOUT_FRF
    if filter_choice not in ("identical", "own"):
        raise UsageError(f"filter_choice must be 'identical' or 'own', got {filter_choice!r}")
    with progress.search("tuning MC-PPC"):
        cases = search_cases(model, fs, delay_samples, frfs, obj.by_gain)  # once: every search shares them
        pcs = [c[case] for c in cases]

        def tune(filters: FilterPack, **shapes) -> McppcDesign:
            return _search(model, filters, cases, frfs, case, policy, obj, fs, delay_samples, pole_range_hz,
                           **({"betas": betas, "zetas": zetas} | shapes))

        if filter_choice == "identical":
            return tune(filters)
        design, record = tune_with_own_filters(
            tune, lambda d: {"betas": (d.beta,), "zetas": (d.zeta,)}, filters, ballscrew_resonances(pcs, fs),
            lambda d: ballscrew_sensitivity_peaks(d.law(), pcs, d.tuning["first_crossover_hz"]), fs,
            {"betas": QUICK_BETAS, "zetas": QUICK_ZETAS}, objective=obj)
    if design is None:
        raise DesignError(f"no MC-PPC meets the limits ({policy.describe()}) in the {case} case with or without "
                          "the filters tried")
    return replace(design, tuning={**design.tuning, "filters": record,
                                   "rule": design.tuning["rule"] + " (own filters)"})


def _search(model: BallScrewModel, filters: FilterPack, cases: list[dict], frfs: list, case: str, policy,
            obj: Objective, fs: float, delay_samples: int, pole_range_hz: tuple[float, float], *, betas,
            zetas) -> McppcDesign:
    """The search of the module docstring with one filter pack over the shapes ``betas`` x ``zetas``, on the plant
    cases ``cases`` (one dict per FRF, of :func:`~feedtune.analysis.ballscrew.plant_cases`)."""
    pcs = [c[case] for c in cases]
    designs: dict = {}

    def design_of(shape: dict, pole_hz: float) -> tuple | None:
        """``(design, law)`` of a candidate, made once (the cheap condition and the check share it)."""
        key = (shape["beta"], shape["zeta"], pole_hz)
        if key not in designs:
            try:
                d = design_mcppc(model, beta=shape["beta"], pole_hz=pole_hz, zeta=shape["zeta"], filters=filters,
                                 fs=fs, delay_samples=delay_samples)
                designs[key] = (d, d.law())
            except FeedtuneError:
                designs[key] = None
        return designs[key]

    compliance = None if obj.compliance_max is None else AxialCompliance(model, fs, delay_samples)

    def check(shape: dict, pole_hz: float) -> Candidate | None:
        made = design_of(shape, pole_hz)
        if made is None:
            return None
        design, law = made
        m, xo = checked.judge(lambda pc: analyze_case(law, pc, responses=False).metrics, policy, case)
        ok = m is not None and (compliance is None or compliance(law) <= obj.compliance_max)
        return Candidate(shape, pole_hz, design, m, xo, passed=ok)

    def admissible(shape: dict, poles_hz) -> list[bool]:
        """Peak |S| on the checked cases' lines within the limit: a necessary condition (the analysis' Ms is the
        peak over a contour holding every line)."""
        out = []
        for pole_hz in poles_hz:
            made = design_of(shape, float(pole_hz))
            if made is None:
                out.append(False)
                continue
            out.append(all(np.max(np.abs(1.0 / (1.0 + loop_on_grid(made[1], pc)))) <= policy.ms_max
                           for pc in pcs))
        return out

    checked = CheckedCases(pcs)
    record = SearchRecord()
    shapes = [{"beta": float(b), "zeta": float(z)} for b in betas for z in zetas]
    box = ((min(betas), max(betas)), (min(zetas), max(zetas)))
    refine = obj.by_gain and any(b[1] > b[0] for b in box)  # the integral gain varies between the listed shapes
    verdicts: dict = {}  # id(design) -> check_design on every FRF (the designs are kept: an id names one)

    def full_check(design) -> list:
        if id(design) not in verdicts:
            verdicts[id(design)] = (design, [check_design(design, frf=f, limits=policy, cases=cs)
                                             for f, cs in zip(frfs or [None], cases, strict=True)])
        return verdicts[id(design)][1]

    def accept(c: Candidate) -> bool:
        """The limits on every FRF and stability in every case (the next in the ranking is taken otherwise)."""
        return all(v.ok for v in full_check(c.design))

    best = highest_feasible(check, shapes, *pole_range_hz, record, bound_name="pole_hz", gain=_ki2, objective=obj,
                            admissible=admissible if policy.ms_max is not None else None,
                            rtol=3 * REFINE_RTOL if refine else 2e-3, accept=accept)
    if best is None and verdicts:  # every candidate tried met the limits in the checked case, none the full check
        first = next(iter(verdicts.values()))[1]
        bad = next(i for i, v in enumerate(first) if not v.ok)
        on = f" on FRF {bad + 1} of {len(frfs)}" if len(frfs) > 1 else ""
        raise DesignError(f"the best MC-PPC designs in the {case} case fail the full check{on}: "
                          f"{'; '.join(first[bad].violations)}")
    if best is None:
        cap = "" if obj.compliance_max is None else f" and the compliance cap {obj.compliance_max:.4g} rad/V"
        raise DesignError(f"no MC-PPC (beta {', '.join(f'{b:g}' for b in betas)}; zeta "
                          f"{', '.join(f'{z:g}' for z in zetas)}; pole {pole_range_hz[0]:g}-{pole_range_hz[1]:g} Hz) "
                          f"meets the limits ({policy.describe()}){cap} in the {case} case")
    refined = None
    if refine:

        def gain_at(shape: dict, pole_hz: float) -> float:
            made = design_of(shape, pole_hz)
            return float("nan") if made is None else float(made[0].gains["Ki2"])

        best, refined = refine_shape(check, best, ("beta", "zeta"), box, *pole_range_hz, gain=_ki2, objective=obj,
                                     gain_at=gain_at, admissible=admissible if policy.ms_max is not None else None,
                                     min_step=1 / 8, accept=accept)
        record.evaluations += 0 if refined is None else refined.checks
    finals = full_check(best.design)  # accepted: the limits on every FRF, stable in every case
    actives = [a for a in (f.limit_check.active() for f in finals) if a is not None]
    active = min(actives, key=lambda a: a.slack) if actives else None
    front = None
    if obj.name == "pareto":
        edges = [best, *record.found, *([] if refined is None else [p.result for _, p in refined.edges()])]
        front = [{"shape": dict(c.shape), "pole_hz": c.bandwidth, "first_crossover_hz": c.objective,
                  "integral_gain": _ki2(c)} for c in obj.front(edges, lambda c: c.objective, _ki2)]
    tuning = {
        "method": "the edge of every shape (beta, zeta) in the pole frequency (bisected to the largest pole "
                  "frequency meeting the limits in the checked case), ranked by the objective; under stiffness and "
                  "pareto the winner's shape refined by a local search over continuous beta and zeta within the "
                  "values listed; the winner stable in every case",
        **obj.record("Ki2", f"{model.input_unit}/(rad s)", _ki2(best), front),
        "rule": f"MC-PPC tuned by feedtune.tune.mcppc for {obj.name} under {policy.describe()}",
        "limits": policy.to_dict(),
        "checked_case": case,
        "frfs": len(frfs),
        "first_crossover_hz": best.objective,
        "active_limit": None if active is None else active.to_dict(),
        "evaluations": record.evaluations,
        "per_shape": record.per_shape,
        "warnings": shape_bound_warnings(best.shape, shapes) + record.warnings,
    }
    if compliance is not None:
        tuning["axial_compliance_rad_per_V"] = compliance(best.design.law())
    return replace(best.design, tuning=tuning)


def _ki2(c: Candidate) -> float:
    """The integral gain ``Ki2`` [V/(rad s)] of a candidate (the stiffness objective's figure)."""
    return float(c.design.gains["Ki2"])
