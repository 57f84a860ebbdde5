"""The gantry MIMO law (thesis section 4.4.2) at its best under the limits: the CoM crossover, its phase margin
target and the active-damping increase that give the highest first CoM crossover meeting the limits policy.

Shapes: the phase-margin target ``pm_deg`` in :data:`PM_TARGETS_DEG` and the damping increase in
:data:`DAMPING_INCREASES` (thesis: 40 deg and +590 %); bandwidth parameter: the CoM crossover target (eq. 4.26),
searched by :func:`feedtune.tune.search.highest_feasible` on the checked case (``discrete`` with an FRF, else
``ideal_discrete``) with the filter pack given (the thesis' h(s) in the demos). The winner is re-checked in every case.
"""

from __future__ import annotations

from dataclasses import replace

from ..analysis.gantry import analyze_gantry, analyze_gantry_case, gantry_plant_cases
from ..analysis.limits import DEFAULT_LIMITS, check_analysis
from ..control.discretize import check_sampling
from ..control.filters import FilterPack
from ..design.gantry_mimo import GantryMimoDesign, design_gantry_mimo
from ..errors import DesignError, FeedtuneError
from ..frf import Frf
from ..models.gantry import GantryModel
from .search import CROSSOVER_TIE, Candidate, SearchRecord, highest_feasible

PM_TARGETS_DEG = (30.0, 40.0, 50.0)
"""CoM phase-margin targets searched [deg] (thesis: 40)."""
DAMPING_INCREASES = (2.0, 4.0, 5.9, 8.0)
"""Increases of the torsional damping by active damping searched [-] (thesis: 5.9 = +590 %)."""
CROSSOVER_RANGE_HZ = (5.0, 250.0)
"""Search bounds of the CoM crossover target [Hz]."""


def tune_gantry_mimo(model: GantryModel, *, limits=None, filters: FilterPack | None = None, fs: float = 15000.0,
                     delay_samples: int = 1, x: float = 0.0, frf: Frf | None = None, pm_targets=PM_TARGETS_DEG,
                     damping_increases=DAMPING_INCREASES, crossover_range_hz=CROSSOVER_RANGE_HZ,
                     **design_options) -> GantryMimoDesign:
    """The MIMO design with the highest first CoM crossover that meets ``limits`` (module docstring).

    Parameters
    ----------
    model : GantryModel
    limits : Limits, optional
        The policy (default: ``textbook``).
    filters : FilterPack, optional
        The filter pack h(s) (kept fixed).
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    x : float
        Design table position [m].
    frf : Frf, optional
        Measured 2x2 position FRF at ``x``: the ``discrete`` case on it is the checked case.
    pm_targets, damping_increases : sequence of float
        Shapes searched [deg, -].
    crossover_range_hz : (float, float)
        Bounds of the CoM crossover target [Hz].
    **design_options
        Passed to :func:`~feedtune.design.gantry_mimo.design_gantry_mimo` (schedule grid, pre-filters).

    Raises
    ------
    DesignError
        No candidate meets the limits.
    """
    policy = limits or DEFAULT_LIMITS
    check_sampling(fs, delay_samples)
    (filters or FilterPack()).check_nyquist(fs)  # bad input is refused before the search, not turned into "no design"
    case = "discrete" if frf is not None else "ideal_discrete"
    pc = gantry_plant_cases(model, x, fs, delay_samples, frf)[case]
    weights = model.alpha(x)

    def check(shape: dict, crossover_hz: float) -> Candidate | None:
        try:
            design = design_gantry_mimo(model, crossover_hz=crossover_hz, pm_deg=shape["pm_deg"],
                                        damping_increase=shape["damping_increase"], filters=filters, fs=fs,
                                        delay_samples=delay_samples, x=x, **design_options)
        except FeedtuneError:
            return None
        m = analyze_gantry_case(design.law, pc, weights).metrics
        if not all(i.ok for i in policy.check(m, case)) or not m.crossovers_hz:
            return None
        return Candidate(shape, crossover_hz, design, m, m.crossovers_hz[0])

    record = SearchRecord()
    shapes = [{"pm_deg": float(p), "damping_increase": float(d)} for p in pm_targets for d in damping_increases]
    best = highest_feasible(check, shapes, *crossover_range_hz, record, bound_name="crossover_hz",
                            secondary=lambda c: c.design.law.ki)
    if best is None:
        raise DesignError(f"no gantry MIMO design meets the limits ({policy.describe()}) in the {case} case")
    final, _ = check_analysis(analyze_gantry(best.design.law, model, x=x, frf=frf), policy)
    if not final.ok:
        raise DesignError(f"the best MIMO design in the {case} case fails the full check: "
                          f"{'; '.join(final.violations)}")
    active = final.active()
    tuning = {
        "method": "highest first CoM crossover over the PM target, the damping increase and the crossover target "
                  "(bisected to the edge) with the limits in the checked case and stability in every case; shapes "
                  f"within {100 * CROSSOVER_TIE:g} % of the highest first crossover count as equal and the highest "
                  "actuator-level integral gain ki wins",
        "rule": f"gantry MIMO tuned by feedtune.tune.gantry under {policy.describe()}",
        "limits": policy.to_dict(),
        "checked_case": case,
        "first_crossover_hz": best.objective,
        "active_limit": None if active is None else active.to_dict(),
        "evaluations": record.evaluations,
        "per_shape": record.per_shape,
        "warnings": record.warnings,
    }
    return replace(best.design, extra={**best.design.extra, "tuning": tuning})
