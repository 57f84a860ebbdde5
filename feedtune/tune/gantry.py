"""The gantry MIMO law (thesis section 4.4.2) at its best under the limits: the CoM crossover, its phase margin
target and the active-damping increase that give the highest first CoM crossover meeting the limits policy.

Shapes: the phase-margin target ``pm_deg`` in :data:`PM_TARGETS_DEG` and the damping increase in
:data:`DAMPING_INCREASES` (thesis: 40 deg and +590 %); bandwidth parameter: the CoM crossover target (eq. 4.26),
searched by :func:`feedtune.tune.search.highest_feasible` on the checked case (``discrete`` with an FRF, else
``ideal_discrete``) with the filter pack given (the thesis' h(s) in the demos). A candidate passes under the PID
baseline's rule (:func:`feedtune.tune.gantry_cases.untrusted`: no unreliable Nyquist count, and on a band-limited FRF
a loop small enough at the last line). The winner is re-checked in every case, and the next best shape is taken when
it fails there.

With several FRFs (the gantry measured at several table positions, or loads) each is checked at its own position
with the law the target runs there (the schedule's ``alpha(x)``, :func:`feedtune.control.gantry.law_at`) and the
model at that position below the FRF's band: a candidate passes only when it meets the limits on every one, and its
objective is its lowest first CoM crossover over them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from ..analysis.gantry import analyze_gantry, analyze_gantry_case, gantry_plant_cases
from ..analysis.limits import DEFAULT_LIMITS, check_analysis
from ..control.discretize import check_sampling
from ..control.filters import FilterPack
from ..control.gantry import law_at
from ..design.gantry_mimo import GantryMimoDesign, design_gantry_mimo
from ..errors import DesignError, FeedtuneError
from ..frf import Frf
from ..models.gantry import GantryModel
from .gantry_cases import frf_positions, schedule_grid, top_line_doubt
from .search import CROSSOVER_TIE, Candidate, CheckedCases, SearchRecord, highest_feasible, robust_frfs

PM_TARGETS_DEG = (30.0, 40.0, 50.0)
"""CoM phase-margin targets searched [deg] (thesis: 40)."""
DAMPING_INCREASES = (2.0, 4.0, 5.9, 8.0)
"""Increases of the torsional damping by active damping searched [-] (thesis: 5.9 = +590 %)."""
CROSSOVER_RANGE_HZ = (5.0, 250.0)
"""Search bounds of the CoM crossover target [Hz]."""


def tune_gantry_mimo(model: GantryModel, *, limits=None, filters: FilterPack | None = None, fs: float = 15000.0,
                     delay_samples: int = 1, x: float = 0.0, frf: Frf | Sequence[Frf] | None = None,
                     positions: Sequence[float] | None = None, pm_targets=PM_TARGETS_DEG,
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
    frf : Frf or sequence of Frf, optional
        Measured 2x2 position FRF(s): the ``discrete`` case on each, at its position, is checked (all must pass).
    positions : sequence of float, optional
        Table position [m] of each FRF (default: :func:`frf_positions`).
    pm_targets, damping_increases : sequence of float
        Shapes searched [deg, -].
    crossover_range_hz : (float, float)
        Bounds of the CoM crossover target [Hz].
    **design_options
        Passed to :func:`~feedtune.design.gantry_mimo.design_gantry_mimo` (schedule grid, pre-filters); the
        default schedule grid covers every FRF's position.

    Raises
    ------
    DesignError
        No candidate meets the limits.
    """
    policy = limits or DEFAULT_LIMITS
    check_sampling(fs, delay_samples)
    (filters or FilterPack()).check_nyquist(fs)  # bad input is refused before the search, not turned into "no design"
    frfs = robust_frfs(frf)
    xs = frf_positions(frfs, positions, x) if frfs else [float(x)]
    design_options["x_grid"] = schedule_grid(model, xs, design_options.get("x_grid"))
    case = "discrete" if frfs else "ideal_discrete"
    checked = CheckedCases((gantry_plant_cases(model, xi, fs, delay_samples, fi)[case], model.alpha(xi), xi)
                           for xi, fi in zip(xs, frfs or [None], strict=True))

    def check(shape: dict, crossover_hz: float) -> Candidate | None:
        try:
            design = design_gantry_mimo(model, crossover_hz=crossover_hz, pm_deg=shape["pm_deg"],
                                        damping_increase=shape["damping_increase"], filters=filters, fs=fs,
                                        delay_samples=delay_samples, x=x, **design_options)
        except FeedtuneError:
            return None

        def metrics_of(c):
            pc, weights, xi = c
            law = law_at(design.law, design.schedule, xi)
            m = analyze_gantry_case(law, pc, weights).metrics
            return None if top_line_doubt(law, pc, m, policy, fs) is not None else m

        m = checked.guaranteed(metrics_of, policy, case)
        return None if m is None else Candidate(shape, crossover_hz, design, m, m.crossovers_hz[0])

    def full_check(c: Candidate) -> list:
        d = c.design
        return [check_analysis(analyze_gantry(law_at(d.law, d.schedule, xi), model, x=xi, frf=fi), policy)[0]
                for xi, fi in zip(xs, frfs or [None], strict=True)]

    verdicts: dict = {}

    def accept(c: Candidate) -> bool:
        verdicts[id(c)] = full_check(c)
        return all(f.ok for f in verdicts[id(c)])

    record = SearchRecord()
    shapes = [{"pm_deg": float(p), "damping_increase": float(d)} for p in pm_targets for d in damping_increases]
    best = highest_feasible(check, shapes, *crossover_range_hz, record, bound_name="crossover_hz",
                            secondary=lambda c: c.design.law.ki, accept=accept)
    if best is None:
        if not verdicts:
            raise DesignError(f"no gantry MIMO design meets the limits ({policy.describe()}) in the {case} case")
        first = next(iter(verdicts.values()))
        bad = next(i for i, f in enumerate(first) if not f.ok)
        on = f" on FRF {bad + 1} of {len(frfs)} (x = {xs[bad]:g} m)" if len(frfs) > 1 else ""
        raise DesignError(f"the best MIMO designs in the {case} case fail the full check{on}: "
                          f"{'; '.join(first[bad].violations)}")
    finals = verdicts[id(best)]
    actives = [a for a in (f.active() for f in finals) if a is not None]
    active = min(actives, key=lambda a: a.slack) if actives else None
    tuning = {
        "method": "highest first CoM crossover over the PM target, the damping increase and the crossover target "
                  "(bisected to the edge) with the limits in the checked case and stability in every case; shapes "
                  f"within {100 * CROSSOVER_TIE:g} % of the highest first crossover count as equal and the highest "
                  "actuator-level integral gain ki wins",
        "rule": f"gantry MIMO tuned by feedtune.tune.gantry under {policy.describe()}",
        "limits": policy.to_dict(),
        "checked_case": case,
        "frfs": len(frfs),
        "positions_m": xs,
        "first_crossover_hz": best.objective,
        "active_limit": None if active is None else active.to_dict(),
        "evaluations": record.evaluations,
        "per_shape": record.per_shape,
        "warnings": record.warnings,
    }
    return replace(best.design, extra={**best.design.extra, "tuning": tuning})
