"""The gantry MIMO law (thesis section 4.4.2) at its best under the limits: the CoM crossover, its phase margin
target and the active-damping increase whose edge wins under the objective (:class:`feedtune.tune.search.Objective`:
the highest actuator-level integral gain ``ki``, or the highest first CoM crossover) among the designs meeting the
limits policy.

Shapes: the phase-margin target ``pm_deg`` in :data:`PM_TARGETS_DEG` and the damping increase in
:data:`DAMPING_INCREASES` (thesis: 40 deg and +590 %), then at the best of them the integral gain through its phase lag
at the crossover in :data:`INTEGRAL_LAGS_DEG` (thesis rule: 10 deg); bandwidth parameter: the CoM crossover target
(eq. 4.26),
searched by :func:`feedtune.tune.search.highest_feasible` on the checked case (``discrete`` with an FRF, else
``ideal_discrete``) with the filter pack given (the thesis' h(s) in the demos); a scale whose ``sigma_max(S)`` on the
checked cases' grids (a lower bound of the checked ``Ms``) breaks the limit is skipped unchecked. A candidate passes
under the PID baseline's rule (:func:`feedtune.tune.gantry_cases.untrusted`: no unreliable Nyquist count, and on a
band-limited FRF a loop small enough at the last line). The winner is re-checked in every case, and the next best
shape is taken when it fails there.

With several FRFs (the gantry measured at several table positions, or loads) each is checked at its own position
with the law the target runs there (the schedule's ``alpha(x)``, :func:`feedtune.control.gantry.law_at`) and the
model at that position below the FRF's band: a candidate passes only when it meets the limits on every one, and its
objective is its lowest first CoM crossover over them.

With ``filter_choice="own"`` the notches and low-pass of ``h(s)`` are the tuner's
(:func:`feedtune.tune.filter_choice.tune_with_own_filters`: seeded at the resonances of every FRF and the sensitivity
peaks of the best design, kept when they raise the guaranteed crossover); the lead stages given are kept.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .. import progress
from ..analysis.gantry import analyze_gantry_case, gantry_plant_cases
from ..analysis.limits import DEFAULT_LIMITS, check_cases
from ..analysis.mimo import matmul, sensitivity_gain
from ..control.discretize import check_sampling
from ..control.filters import FilterPack
from ..control.gantry import law_at
from ..design.gantry_mimo import GantryMimoDesign, design_gantry_mimo
from ..errors import DesignError, FeedtuneError, UsageError
from ..frf import Frf
from ..models.gantry import GantryModel
from .filter_choice import merge_resonances, tune_with_own_filters
from .gantry_cases import (
    frf_positions,
    gantry_objective,
    gantry_resonances,
    gantry_sensitivity_peaks,
    schedule_grid,
    top_line_doubt,
)
from .search import (
    BOUND_SLACK,
    Candidate,
    CheckedCases,
    Objective,
    SearchRecord,
    highest_feasible,
    refine_shape,
    robust_frfs,
    shape_bound_warnings,
)

PM_TARGETS_DEG = (30.0, 40.0, 50.0)
"""CoM phase-margin targets searched [deg] (thesis: 40)."""
DAMPING_INCREASES = (2.0, 4.0, 5.9, 8.0)
"""Increases of the torsional damping by active damping searched [-] (thesis: 5.9 = +590 %)."""
INTEGRAL_LAGS_DEG = (5.0, 10.0, 20.0)
"""Phase lags of the actuator-level integral at the crossover searched at the best shape [deg] (thesis rule: 10;
``ki = K_D wc tan(lag)``)."""
QUICK_PM, QUICK_DAMPING = (40.0,), (5.9,)
"""The shape of the quick search that ranks filter candidates when nothing is feasible without filters."""
CROSSOVER_RANGE_HZ = (5.0, 250.0)
"""Search bounds of the CoM crossover target [Hz]."""


@progress.searching("tuning gantry MIMO")
def tune_gantry_mimo(model: GantryModel, *, limits=None, filters: FilterPack | None = None, fs: float = 15000.0,
                     delay_samples: int = 1, x: float = 0.0, frf: Frf | Sequence[Frf] | None = None,
                     positions: Sequence[float] | None = None, pm_targets=PM_TARGETS_DEG,
                     damping_increases=DAMPING_INCREASES, integral_lags=INTEGRAL_LAGS_DEG,
                     crossover_range_hz=CROSSOVER_RANGE_HZ, filter_choice: str = "identical",
                     objective: str | Objective | None = None, **design_options) -> GantryMimoDesign:
    """The MIMO design that wins under ``objective`` among those that meet ``limits`` (module docstring).

    Parameters
    ----------
    model : GantryModel
    limits : Limits, optional
        The policy (default: ``textbook``).
    filters : FilterPack, optional
        The filter pack h(s): as given (``identical``), or candidates and kept leads (``own``).
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
    integral_lags : sequence of float
        Integral lags searched at the best shape [deg] (not searched when ``ki`` or ``integral_lag_deg`` is given).
    crossover_range_hz : (float, float)
        Bounds of the CoM crossover target [Hz].
    filter_choice : {"identical", "own"}
        Whether the tuner places the notches and low-pass itself.
    objective : {"stiffness", "bandwidth", "pareto"} or Objective, optional
        Which edge wins (default :data:`feedtune.tune.search.DEFAULT_OBJECTIVE`; the integral gain is ``ki``
        [V/(m s)]).
    **design_options
        Passed to :func:`~feedtune.design.gantry_mimo.design_gantry_mimo` (schedule grid, pre-filters, ``ki``);
        the default schedule grid covers every FRF's position.

    Raises
    ------
    DesignError
        No candidate meets the limits.
    """
    policy = limits or DEFAULT_LIMITS
    obj = gantry_objective(objective)
    progress.figure(*(("ki", f"{model.input_unit}/(m s)") if obj.by_gain else ("first crossover", "Hz")))
    check_sampling(fs, delay_samples)
    filters = filters or FilterPack()
    filters.check_nyquist(fs)  # bad input is refused before the search, not turned into "no design"
    frfs = robust_frfs(frf)
    xs = frf_positions(frfs, positions, x) if frfs else [float(x)]
    design_options["x_grid"] = schedule_grid(model, xs, design_options.get("x_grid"))
    case = "discrete" if frfs else "ideal_discrete"
    all_cases = [gantry_plant_cases(model, xi, fs, delay_samples, fi) for xi, fi in zip(xs, frfs or [None],
                                                                                        strict=True)]
    pcs = [cases[case] for cases in all_cases]
    if filter_choice == "own":
        def tune(filters: FilterPack, **shapes) -> GantryMimoDesign:
            return tune_gantry_mimo(model, limits=policy, filters=filters, fs=fs, delay_samples=delay_samples, x=x,
                                    frf=frfs or None, positions=xs if frfs else None,
                                    crossover_range_hz=crossover_range_hz, objective=obj,
                                    **({"pm_targets": pm_targets, "damping_increases": damping_increases,
                                        "integral_lags": integral_lags} | shapes), **design_options)

        def peaks(d: GantryMimoDesign) -> list[float]:
            return gantry_sensitivity_peaks([(law_at(d.law, d.schedule, xi), pc) for xi, pc in zip(xs, pcs,
                                                                                                 strict=True)],
                                            d.tuning["first_crossover_hz"])

        design, record = tune_with_own_filters(
            tune, lambda d: {"pm_targets": (d.pm_deg,), "damping_increases": (d.damping_increase,),
                             "integral_lags": (d.tuning["integral_lag_deg"],)},
            filters, merge_resonances([gantry_resonances(pc, fs) for pc in pcs]), peaks, fs,
            {"pm_targets": QUICK_PM, "damping_increases": QUICK_DAMPING, "integral_lags": (10.0,)}, objective=obj)
        if design is None:
            raise DesignError(f"no gantry MIMO design meets the limits ({policy.describe()}) in the {case} case with "
                              "or without the filters tried")
        tuning = {**design.tuning, "filters": record, "rule": design.tuning["rule"] + " (own filters)"}
        return replace(design, extra={**design.extra, "tuning": tuning})
    if filter_choice != "identical":
        raise UsageError(f"filter_choice must be 'identical' or 'own', got {filter_choice!r}")
    checked = CheckedCases((pc, model.alpha(xi), xi) for xi, pc in zip(xs, pcs, strict=True))

    designs: dict = {}

    def design_of(shape: dict, crossover_hz: float):
        """``(design, {position: law there})`` of a candidate, made once (the cheap condition and the check share
        it), or None when it cannot be made."""
        key = (*sorted(shape.items()), crossover_hz)
        if key not in designs:
            lag = {} if "integral_lag_deg" not in shape else {"integral_lag_deg": shape["integral_lag_deg"]}
            try:
                d = design_gantry_mimo(model, crossover_hz=crossover_hz, pm_deg=shape["pm_deg"],
                                       damping_increase=shape["damping_increase"], filters=filters, fs=fs,
                                       delay_samples=delay_samples, x=x, **(design_options | lag))
                designs[key] = (d, {xi: law_at(d.law, d.schedule, xi) for xi in xs})
                laws_of[id(d)] = designs[key][1]
            except FeedtuneError:
                designs[key] = None
        return designs[key]

    laws_of: dict = {}  # id(design) -> {position: the law there} (the designs are kept: an id names one)
    analysed: dict = {}  # (id(law), id(plant case)) -> figures of the checked case (the laws and cases are kept)

    def limits_figures(law, pc, weights):
        key = (id(law), id(pc))
        if key not in analysed:
            analysed[key] = analyze_gantry_case(law, pc, weights, figures="limits",
                                                disk_margin=policy.disk_margin_min is not None).metrics
        return analysed[key]

    def check(shape: dict, crossover_hz: float) -> Candidate | None:
        made = design_of(shape, crossover_hz)
        if made is None:
            return None
        design, laws = made

        def metrics_of(c):
            pc, weights, xi = c
            return limits_figures(laws[xi], pc, weights)

        def refuse(c, m) -> bool:
            pc, _, xi = c
            return top_line_doubt(laws[xi], pc, m, policy, fs) is not None

        m, xo = checked.judge(metrics_of, policy, case, refuse)
        return Candidate(shape, crossover_hz, design, m, xo, passed=m is not None)

    plants = [pc.plant(pc.freq_hz) * pc.hold(pc.freq_hz) for pc in pcs]

    def admissible(shape: dict, crossovers_hz) -> list[bool]:
        """``max sigma_max(S)`` on the checked cases' grids within the limit: a necessary condition (the analysis'
        Ms is the peak over a contour holding every point of the grid), with the relative slack
        :data:`~feedtune.tune.search.BOUND_SLACK` for the rounding of the two computations."""
        out = []
        for xc in crossovers_hz:
            made = design_of(shape, float(xc))
            ok = made is not None
            for xi, pc, ge in zip(xs, pcs, plants, strict=True):
                if not ok:
                    break
                law = made[1][xi]
                K = law.response_discrete(pc.freq_hz) if pc.discrete else law.response(pc.freq_hz)
                ok = float(np.max(sensitivity_gain(matmul(ge, K)))) <= policy.ms_max * (1 + BOUND_SLACK)
            out.append(ok)
        return out

    def full_check(c: Candidate) -> list:
        """The limits in the checked case and stability in every case, per FRF (the cases of
        :func:`feedtune.analysis.gantry.analyze_gantry`: the figures the limits read in the checked case, the
        Nyquist count in the others)."""
        d = c.design
        out = []
        for xi, cases in zip(xs, all_cases, strict=True):
            law = laws_of[id(d)][xi]  # the search's law there: its checked case is analysed already
            w = model.alpha(xi)
            out.append(check_cases(policy, {name: None if pc is None else limits_figures(law, pc, w) if name == case
                                            else analyze_gantry_case(law, pc, w, figures="stability").metrics
                                            for name, pc in cases.items()}, [case]))
        return out

    verdicts: dict = {}

    def accept(c: Candidate) -> bool:
        if id(c) not in verdicts:
            verdicts[id(c)] = full_check(c)
        return all(f.ok for f in verdicts[id(c)])

    record = SearchRecord()
    fixed_ki = "ki" in design_options or "integral_lag_deg" in design_options
    lag0 = {} if fixed_ki else {"integral_lag_deg": 10.0 if 10.0 in integral_lags else float(integral_lags[0])}
    shapes = [{"pm_deg": float(p), "damping_increase": float(d), **lag0} for p in pm_targets
              for d in damping_increases]
    cheap = admissible if policy.ms_max is not None else None
    best = highest_feasible(check, shapes, *crossover_range_hz, record, bound_name="crossover_hz",
                            gain=_ki, objective=obj, accept=accept, admissible=cheap)
    searched = list(shapes)
    if best is not None and not fixed_ki and len(integral_lags) > 1:  # the integral gain at the best shape
        # ... at every shape that ties with it (equal figures: the same limit binds, e.g. a gain margin no damping
        # increase moves; the lag may set them apart: 40e6 at three damping increases, 42e6 to 73e6 at another lag)
        tied = [c.shape for c in record.found
                if c.design is not None and _ki(c) == _ki(best) and c.objective == best.objective]
        lags = [{**shape, "integral_lag_deg": float(v)} for shape in tied or [best.shape] for v in integral_lags
                if float(v) != shape["integral_lag_deg"]]
        searched += lags
        other = highest_feasible(check, lags, *crossover_range_hz, record, bound_name="crossover_hz",
                                 gain=_ki, objective=obj, accept=accept, admissible=cheap)
        if other is not None:
            best = obj.order([best, other], lambda c: c.objective, _ki)[0]
    refined = None
    names = ("pm_deg", "damping_increase") + (() if fixed_ki else ("integral_lag_deg",))
    box = tuple((float(min(v)), float(max(v))) for v in (pm_targets, damping_increases, integral_lags)[:len(names)])
    if best is not None and obj.by_gain and any(b[1] > b[0] for b in box):

        def gain_at(shape: dict, crossover_hz: float) -> float:
            made = design_of(shape, crossover_hz)
            return float("nan") if made is None else float(made[0].law.ki)

        best, refined = refine_shape(check, best, names, box, *crossover_range_hz, gain=_ki, objective=obj,
                                     gain_at=gain_at, admissible=cheap, accept=accept, min_step=1 / 8,
                                     diagonal=False)
        record.evaluations += 0 if refined is None else refined.checks
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
    front = None
    if obj.name == "pareto":
        edges = [best, *record.found, *([] if refined is None else [p.result for _, p in refined.edges()])]
        front = [{"shape": dict(c.shape), "crossover_target_hz": c.bandwidth, "first_crossover_hz": c.objective,
                  "integral_gain": _ki(c)} for c in obj.front(edges, lambda c: c.objective, _ki)]
    tuning = {
        "method": "the edge of every shape (PM target, damping increase) in the CoM crossover target (bisected to "
                  "the largest meeting the limits in the checked case of every FRF), ranked by the objective, then "
                  "the same over the integral lag at the best shape (and every shape tied with it); under stiffness "
                  "and pareto the winner's shape refined by a local search over continuous PM target, damping "
                  "increase and integral lag within the values listed; the winner stable in every case",
        **obj.record("ki", f"{model.input_unit}/(m s)", _ki(best), front),
        "rule": f"gantry MIMO tuned by feedtune.tune.gantry for {obj.name} under {policy.describe()}",
        "limits": policy.to_dict(),
        "checked_case": case,
        "frfs": len(frfs),
        "positions_m": xs,
        "first_crossover_hz": best.objective,
        "pm_target_deg": best.shape["pm_deg"],
        "damping_increase": best.shape["damping_increase"],
        "integral_lag_deg": best.shape.get("integral_lag_deg"),
        "active_limit": None if active is None else active.to_dict(),
        "evaluations": record.evaluations,
        "per_shape": record.per_shape,
        "filters": {"choice": "identical", "why": "the filters given are used as they are"},
        "warnings": shape_bound_warnings(best.shape, searched) + record.warnings,
    }
    return replace(best.design, extra={**best.design.extra, "tuning": tuning})


def _ki(c: Candidate) -> float:
    """The actuator-level integral gain ``ki`` [V/(m s)] of a candidate (the stiffness objective's figure)."""
    return float(c.design.law.ki)

