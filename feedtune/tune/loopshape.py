"""Tuner of the x axis' double-lead loop shaping (thesis §4.4.1, eq. 4.17-4.18): the best design under the limits.

Which edge wins is the objective (:class:`feedtune.tune.search.Objective`): the highest integral gain ``K`` of
``C = K (Ti s + 1)/s ...`` (``C ~ K/s`` at low frequency: the stiffness against a force; ``K/Ti`` in the textbook
form ``K' (1 + 1/(Ti s))``), or the highest first crossover.

:func:`feedtune.design.loopshape.design_loopshape` places the crossover ``wc`` and its phase margin exactly on the
discrete loop; its other parameters are the integral's phase lag at ``wc`` and the number of lead stages. The
tuner searches them as the PID tuner does (:mod:`feedtune.tune.pid`):

* the scale is the crossover ``wc``: for a shape, the largest ``wc`` whose design passes the check
  (:func:`feedtune.tune.search.feasibility_edge`, bracket ``RTOL`` = 0.2 %; a design that cannot be made, e.g. more
  lead than the stages give, fails);
* the shape is the phase-margin target and the integral lag, continuous over ``PM_BOUNDS`` (from just above the
  policy's phase-margin limit: a smaller target cannot pass) x ``PI_LAG_BOUNDS``
  (:func:`feedtune.tune.search.pattern_search`, log coordinates), for each number of lead stages in ``STAGES``.

**The check** is the analysis the design is judged by: the plant cases of
:func:`feedtune.analysis.gantry.axis_plant_cases` (the double integrator of the axis' mass, and the measured FRF
when the plant is one or one is given: then the ``discrete`` case, interpolated between the lines and continued by
the mass below them, else ``ideal_discrete``), :func:`analyze_axis_case` and the limits policy. On a band-limited
FRF the tuner also refuses a loop with ``|L| > 1 - 1/ms_max`` at the last line
(:func:`feedtune.tune.search.band_top_doubt`), or one whose Nyquist count the analysis calls unreliable
(:func:`feedtune.tune.search.unreliable`). The objective is the true first crossover (``metrics.crossovers_hz[0]``),
which equals the target ``wc`` unless the loop crosses 0 dB earlier. The winner is verified stable in every case.

The gain margin binds on ``1/(m s^2)`` with the thesis' axis filters and the textbook limits, and the crossover at
the edge falls as the PM target and the integral lag grow (241 Hz at PM 30 deg and 5 deg of lag, 191 Hz at 70 and
20 deg): the winner sits on the lower bounds, reported in ``tuning["warnings"]``. ``PI_LAG_BOUNDS`` starts at 5 deg,
an integral corner about a decade below the crossover.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from .. import progress
from ..analysis.gantry import analyze_axis_case, axis_plant_cases
from ..analysis.limits import DEFAULT_LIMITS, Limits, check_cases
from ..control.discretize import check_sampling
from ..control.filters import FilterPack
from ..control.prefilter import PrefilterGains
from ..design.loopshape import LoopShapeDesign, axis_plant, design_loopshape
from ..errors import DesignError, UsageError
from ..frf import Frf
from .filter_choice import choose_filters, merge_resonances, resonance_peaks, sensitivity_peaks
from .gantry_cases import gantry_objective
from .search import (
    GAIN_EXPONENT,
    EdgeResult,
    Objective,
    Probe,
    SearchResult,
    band_top_doubt,
    feasibility_edge,
    pattern_search,
    robust_frfs,
    unreliable,
)

PM_BOUNDS = (30.0, 75.0)
"""Phase-margin targets searched [deg]; the low bound is raised to just above the policy's ``pm_min_deg``."""
PI_LAG_BOUNDS = (5.0, 20.0)
"""Phase lag of the integral action at the crossover searched [deg]."""
STAGES = (1, 2, 3)
"""Numbers of equal lead stages searched."""
SCAN_HZ = (1.0, None)
"""Scan of the crossover [Hz]: from 1 Hz to ``fs / 8`` (None), inside the design FRF's lines (1.25 x the first to the
last / 1.25) when the design is made on an FRF."""
SCAN_POINTS = 24
RTOL = 2e-3
"""Relative width of the final bracket on the crossover [-]."""
PM_ABOVE_LIMIT = 0.01
"""The lowest PM target is this much [deg] above the policy's limit (the designed PM holds to 1e-6 deg)."""


@dataclass
class _AxisCase:
    """The checked plant case of the axis and its plant on the base grid (``|L|`` at the last line)."""

    name: str
    pc: object
    cases: dict
    Ge: np.ndarray
    policy: Limits
    fs: float
    checks: int = 0


class _AxisSearch:
    """Designs for a number of lead stages: the real check, the edge and the shape search."""

    def __init__(self, cases: list[_AxisCase], make, stages: int, bounds, scan: np.ndarray, objective: Objective):
        self.cases = list(cases)
        self.objective = objective
        self.make = make  # make(crossover_hz, pm_deg, pi_lag_deg, stages) -> LoopShapeDesign (or DesignError)
        self.stages = stages
        self.bounds = bounds
        self.scan = scan
        self._designs: dict = {}
        self._verdicts: dict = {}  # (case, design) -> the analysis' verdict on the checked case (analysed once)
        self._elsewhere: dict = {}  # (case, design) -> why it is unstable in another case, or None
        self._relaxed: dict = {}  # shape -> its edge under the limits alone (not pruned)
        self._whole: dict = {}  # shape -> its edge under the whole check
        self._unstable: set = set()  # shapes whose edge under the limits alone is unstable in another case

    def merit(self, p: Probe) -> float:
        """What the objective maximises at an edge: the first crossover [Hz] or the integral gain ``K``."""
        return self.objective.merit(p.crossover_hz, p.result[0].gain if p.result is not None else math.nan)

    def design(self, xo: float, pm: float, lag: float) -> LoopShapeDesign | None:
        key = (xo, pm, lag)
        if key not in self._designs:
            try:
                self._designs[key] = self.make(xo, pm, lag, self.stages)
            except (DesignError, UsageError):
                self._designs[key] = None
        return self._designs[key]

    def check(self, xo: float, pm: float, lag: float, others: bool = True) -> Probe:
        """The analysis' own check of the design for ``(xo, pm, lag)`` in the checked case of every FRF: passes when
        it passes on each; the figures are those of the case with the lowest first crossover, the slack the
        smallest (the case that failed is checked first next time). Without ``others`` the stability in the other
        cases is not asked (:meth:`edge` asks it of the edge it finds)."""
        d = self.design(xo, pm, lag)
        if d is None:
            return Probe(float(xo), False, math.nan, None, None)
        probes = []
        for k, c in enumerate(self.cases):
            p = self._check_case(c, d, xo, others)
            probes.append(p)
            if not p.ok:
                if k:
                    self.cases.insert(0, self.cases.pop(k))
                return p
        best = min(probes, key=lambda p: p.crossover_hz)
        slacks = [p.slack for p in probes if p.slack is not None]
        return Probe(best.scale, True, best.crossover_hz, min(slacks) if slacks else None, best.result)

    def _check_case(self, c: _AxisCase, d: LoopShapeDesign, xo: float, others: bool = True) -> Probe:
        """The check on one FRF's checked case (limits, the band's top, and with ``others`` stability in its other
        cases). A design is analysed once per case: the search with ``others`` re-checks the scales the search
        without them has checked."""
        key = (id(c), id(d))  # the designs are kept (self._designs): an id names one design
        if key not in self._verdicts:
            c.checks += 1
            m = analyze_axis_case(d, c.pc, responses=False).metrics
            items = c.policy.check(m, c.name)
            top = c.pc.freq_hz[-1:]
            l_top = float(np.abs(c.Ge[-1:] * d.controller_discrete().freqresp(top))[0])
            self._verdicts[key] = (m, items, unreliable(m.warnings)
                                   or band_top_doubt(l_top, float(top[0]), c.fs, c.policy.ms_max))
        m, items, doubt = self._verdicts[key]
        ok = all(i.ok for i in items) and doubt is None
        if ok and others:  # stable in every other case too (the check a design is judged by)
            doubt = self._unstable_elsewhere(c, d)
            ok = doubt is None
        slacks = [i.slack for i in items if i.slack is not None]
        slack = None if not m.stable or doubt is not None else (min(slacks) if slacks else 1.0)
        xc = float(m.crossovers_hz[0]) if m.crossovers_hz else math.nan
        return Probe(float(xo), ok, xc, slack, (d, m, items))

    def _unstable_elsewhere(self, c: _AxisCase, d: LoopShapeDesign) -> str | None:
        """Why the design is not stable in one of the FRF's other cases, or None (the discrete model first: the
        case that fails most often); asked once per design."""
        key = (id(c), id(d))
        if key not in self._elsewhere:
            self._elsewhere[key] = None
            for k, p in sorted(c.cases.items(), key=lambda kv: kv[0] != "ideal_discrete"):
                if p is None or k == c.name:
                    continue
                other = analyze_axis_case(d, p, responses=False).metrics
                if not (other.stable and other.nyquist_reliable):
                    self._elsewhere[key] = f"unstable in the {k} case"
                    break
        return self._elsewhere[key]

    def edge(self, shape: tuple, ref: tuple | None = None, beat: float | None = None):
        """The largest crossover of one shape whose design passes the check (:func:`feasibility_edge`); with
        ``beat`` [Hz] the first check is at that crossover.

        The search checks the limits in the checked case and asks the stability in the other cases of the edge it
        finds alone: that edge passing them, its bracket holds for the whole check (a scale failing the limits fails
        the whole check). Should the edge fail there, the edge of the whole check lies below it: it is sought from
        there down with every check asking them. An edge that does not beat ``beat`` is not asked at all: the edge of
        the whole check, no higher, cannot beat it either (the shape is returned as pruned, its crossover the bound).
        """
        pm, lag = shape
        key = (float(pm), float(lag))
        e = self._relaxed.get(key)
        if e is None:  # the edge of a shape is sought once (a later request, with another beat, reuses it)
            start = None if ref is None else ref[1].scale
            if beat is not None and not self.objective.by_gain:
                start = beat  # the scale is the crossover target
            elif beat is not None and start is not None and self.merit(ref[1]) > 0:
                start *= (beat / self.merit(ref[1])) ** (1 / GAIN_EXPONENT)  # K = m wc^3 tan(lag) on a mass
            e = feasibility_edge(lambda xo: self.check(xo, pm, lag, others=False), self.scan, rtol=RTOL, start=start,
                                 beat=beat if start is not None else None, merit=self.merit)
            if e.best is None:
                return e
            self._relaxed[key] = e
        if beat is not None and self.merit(e.best) <= beat:
            return EdgeResult(None, e.fail_scale, e.checks, pruned=True, bound_hz=self.merit(e.best))
        if key in self._whole:
            return self._whole[key]
        if key not in self._unstable and all(self._unstable_elsewhere(c, e.best.result[0]) is None
                                             for c in self.cases):
            self._whole[key] = e
            return e
        self._unstable.add(key)
        full = feasibility_edge(lambda xo: self.check(xo, pm, lag), self.scan, rtol=RTOL, start=e.best.scale,
                                beat=beat, merit=self.merit)
        if not full.pruned:  # a pruned one may be asked again with a lower beat
            self._whole[key] = full
        return replace(full, checks=full.checks + e.checks)

    def run(self, ref: tuple | None) -> SearchResult | None:
        """The shape search over the box (the first edge from ``ref``, a passing probe of another stage count)."""
        return pattern_search(self.edge, ("pm_deg", "pi_lag_deg"), self.bounds, ref=ref, merit=self.merit)

    def run_from(self, shape: tuple, probe: Probe) -> SearchResult | None:
        """A local shape search from ``shape``, whose edge is expected near that of ``probe``."""
        return pattern_search(self.edge, ("pm_deg", "pi_lag_deg"), self.bounds, initial=shape,
                              ref=(tuple(shape), probe), merit=self.merit)


def _stable(metrics) -> bool:
    return bool(metrics.stable and metrics.nyquist_reliable)


def _bounds(value, default, name: str, lo_limit: float, hi_limit: float) -> tuple[float, float]:
    b = default if value is None else tuple(float(v) for v in value)
    if len(b) != 2 or not (lo_limit < b[0] <= b[1] < hi_limit and all(math.isfinite(v) for v in b)):
        raise UsageError(f"{name} must be two numbers {lo_limit:g} < low <= high < {hi_limit:g}, got {value!r}")
    return b


@progress.searching("tuning x-axis loop shaping")
def tune_loopshape(
    plant,
    *,
    limits: Limits | None = None,
    ms_max: float | None = None,
    filters: FilterPack | None = None,
    fs: float = 15000.0,
    delay_samples: int = 1,
    frf: Frf | Sequence[Frf] | None = None,
    mass: float | None = None,
    channel: str | None = None,
    prefilter: PrefilterGains | None = None,
    prefilter_hz: float = 80.0,
    pm_bounds=None,
    pi_lag_bounds=None,
    stages=STAGES,
    filter_choice: str = "identical",
    objective: str | Objective | None = None,
) -> LoopShapeDesign:
    """The loop-shaping design of an axis that wins under ``objective`` among those that meet the limits.

    See the module docstring for the search and the check.

    Parameters
    ----------
    plant : float, GantryModel, rigid-body model, Frf or AxisPlant
        The axis, as for :func:`~feedtune.design.loopshape.design_loopshape` (an FRF's mass is estimated once, from
        its first decade, unless ``mass`` is given).
    limits : Limits, optional
        The limits policy (default :data:`feedtune.analysis.limits.DEFAULT_LIMITS`).
    ms_max : float, optional
        Overrides the policy's peak sensitivity limit [-].
    filters : FilterPack, optional
        Filter pack of the controller (as given).
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    frf : Frf or sequence of Frf, optional
        Measured SISO position FRF [m/V] of the ``measured``/``discrete`` cases when the plant is not one; with
        several (loads, positions) the limits must hold on every one and the objective is the lowest first
        crossover over them.
    mass : float, optional
        Axis mass [V/(m/s^2)] overriding the model's or the FRF estimate.
    channel : str, optional
        FRF channel when the FRF has several.
    prefilter, prefilter_hz
        Pre-filter gains and low-pass [Hz] of the design (not part of the loop).
    pm_bounds, pi_lag_bounds : (float, float), optional
        The shape box [deg] (default ``PM_BOUNDS``, ``PI_LAG_BOUNDS``).
    stages : sequence of int
        Numbers of lead stages searched.
    filter_choice : {"identical", "own"}
        ``identical``: the filter pack as given; ``own``: the tuner places notches and a low-pass
        (:func:`feedtune.tune.filter_choice.choose_filters`; the given filters are candidates, its leads are kept),
        recorded in ``tuning["filters"]``.
    objective : {"stiffness", "bandwidth", "pareto"} or Objective, optional
        Which edge wins (default :data:`feedtune.tune.search.DEFAULT_OBJECTIVE`; the integral gain is ``K``
        [U/(m s)]).

    Returns
    -------
    LoopShapeDesign
        ``tuning`` records the rule, the limits, the active limit, the checked case and the warnings.

    Raises
    ------
    DesignError
        No design meets the limits.
    """
    t0 = time.perf_counter()
    policy = (limits or DEFAULT_LIMITS).override(ms_max=ms_max)
    obj = gantry_objective(objective)
    progress.figure(*(("K", "") if obj.by_gain else ("first crossover", "Hz")))
    check_sampling(fs, delay_samples)
    pack = filters if filters is not None else FilterPack()
    pack.check_nyquist(fs)
    ap = axis_plant(plant, mass=mass, channel=channel)
    pmb = _bounds(pm_bounds, PM_BOUNDS, "pm_bounds", 0.0, 90.0)
    floor = (policy.pm_min_deg or 0.0) + PM_ABOVE_LIMIT
    if pmb[1] < floor:
        raise UsageError(f"a phase-margin target of at most {pmb[1]:g} deg cannot meet the phase-margin limit "
                         f"{policy.pm_min_deg:g} deg")
    pmb = (max(pmb[0], floor), pmb[1])
    lagb = _bounds(pi_lag_bounds, PI_LAG_BOUNDS, "pi_lag_bounds", 0.0, 45.0)
    counts = tuple(int(n) for n in stages)
    if not counts or any(n < 1 for n in counts):
        raise UsageError(f"stages must be integers >= 1, got {stages!r}")

    if filter_choice not in ("identical", "own"):
        raise UsageError(f"filter_choice must be 'identical' or 'own', got {filter_choice!r}")

    def maker(filters: FilterPack):
        def make(xo, pm, lag, n):
            return design_loopshape(ap, crossover_hz=xo, pm_deg=pm, pi_lag_deg=lag, filters=filters, fs=fs,
                                    delay_samples=delay_samples, prefilter=prefilter, prefilter_hz=prefilter_hz,
                                    stages=n)
        return make

    trial = design_loopshape(ap, crossover_hz=min(10.0, fs / 20), pm_deg=45.0, filters=pack, fs=fs,
                             delay_samples=delay_samples)
    frfs = robust_frfs(frf)
    all_cases = [axis_plant_cases(trial, fr, channel=channel if fr is not None else None) for fr in (frfs or [None])]
    name = "discrete" if all_cases[0].get("discrete") is not None else "ideal_discrete"
    axis_cases = []
    for cases in all_cases:
        pc = cases[name]
        f = pc.freq_hz
        axis_cases.append(_AxisCase(name, pc, cases, pc.plant(f) * pc.hold(f), policy, float(fs)))
    case = axis_cases[0]
    pc, f = case.pc, case.pc.freq_hz
    bottom, top = SCAN_HZ[0], fs / 8 if SCAN_HZ[1] is None else SCAN_HZ[1]
    if ap.frf is not None:  # a design on an FRF places its crossover inside the measured band
        lines = ap.frf.freq_hz[ap.frf.freq_hz > 0]
        bottom, top = max(bottom, float(lines[0]) * 1.25), min(top, float(lines[-1]) / 1.25)
    scan = np.geomspace(bottom, top, SCAN_POINTS)

    def search(filters: FilterPack):
        """``(best stage count, its SearchResult, every count's result)`` with a filter pack, or None."""
        results = {}
        ref = None
        for n in counts:
            r = _AxisSearch(axis_cases, maker(filters), n, (pmb, lagb), scan, obj).run(ref)
            results[n] = r
            if r is not None:
                ref = (r.point, r.edge.best)
        found = {n: r for n, r in results.items() if r is not None}
        if not found:
            return None
        n_best = obj.order(sorted(found), lambda n: found[n].edge.best.crossover_hz,
                           lambda n: found[n].edge.best.result[0].gain)[0]
        return n_best, found[n_best], results

    filter_record = {"choice": "identical", "why": "the filters given are used as they are"}
    if filter_choice == "own":
        pack, outcome, filter_record = _own_filters(pack, search, axis_cases, maker, (pmb, lagb), scan, fs, obj)
    else:
        outcome = search(pack)
    if outcome is None:
        raise DesignError(f"no loop-shaping design meets the limits ({policy.describe()}) in the {name} case; "
                          "relax the limits or change the filters")
    n_best, best, results = outcome
    design, metrics, _ = best.edge.best.result
    stable = {}
    for i, cases in enumerate(all_cases):
        on = f" (FRF {i + 1})" if len(all_cases) > 1 else ""
        stable.update({k + on: True if k == name else _stable(analyze_axis_case(design, p, responses=False).metrics)
                       for k, p in cases.items() if p is not None})
    if not all(stable.values()):
        raise DesignError(f"the best loop-shaping design meets the limits in the {name} case but is unstable in "
                          f"the {', '.join(k for k, v in stable.items() if not v)} case")
    warnings = [f"the winner sits on a search bound: {b}" for b in best.on_bound]
    if best.edge.at_top:
        warnings.append(f"the winner's crossover is the top of the scan ({best.edge.best.scale:g} Hz: fs/8, or the "
                        "top of the design FRF / 1.25)")
    act = check_cases(policy, {name: metrics}, [name]).active()
    pm, lag = best.point
    front = None
    if obj.name == "pareto":
        edges = [(n, sh, p) for n, r in results.items() if r is not None for sh, p in r.edges()]
        front = [{"shape": {"pm_deg": float(sh[0]), "pi_lag_deg": float(sh[1]), "lead_stages": int(n)},
                  "first_crossover_hz": float(p.crossover_hz), "integral_gain": float(p.result[0].gain)}
                 for n, sh, p in obj.front(edges, lambda e: e[2].crossover_hz, lambda e: e[2].result[0].gain)]
    tuning = {
        "method": "the edge of every shape under the limits, ranked by the objective; loop shaping (eq. 4.17-4.18) "
                  "with the crossover by bisection to the feasibility edge and (PM target, integral lag) by a pattern "
                  "search, for each number of lead stages",
        **obj.record("K", f"{design.plant.command_unit}/(m s)", design.gain, front),
        "rule": f"x-axis loop shaping tuned by feedtune.tune.loopshape for {obj.name} under {policy.describe()}",
        "crossover_measure": "first crossover of the loop over the whole contour",
        "limits": policy.to_dict(),
        "active_limit": None if act is None else act.to_dict(),
        "checked_case": name,
        "frfs": len(frfs),
        "checked_from_hz": float(f[0]),
        "checked_to_hz": float(f[-1]),
        "stable_in_cases": stable,
        "crossover_hz": float(metrics.crossovers_hz[0]),
        "first_crossover_hz": float(metrics.crossovers_hz[0]),
        "pm_target_deg": float(pm),
        "pi_lag_deg": float(lag),
        "lead_stages": int(n_best),
        "ms_found": float(metrics.ms),
        "search": {"pm_bounds_deg": list(pmb), "pi_lag_bounds_deg": list(lagb), "stages": list(counts),
                   "crossover_scan_hz": [float(scan[0]), float(scan[-1])], "crossover_rtol": RTOL,
                   "best_per_stages_hz": {str(n): (None if r is None else float(r.edge.best.crossover_hz))
                                          for n, r in results.items()},
                   "checks": sum(c.checks for c in axis_cases), "seconds": round(time.perf_counter() - t0, 3)},
        "filters": filter_record,
        "warnings": warnings,
    }
    return replace(design, tuning=tuning)


def _own_filters(given: FilterPack, search, axis_cases: list, maker, bounds, scan: np.ndarray, fs: float,
                 obj: Objective):
    """The tuner's own filter pack (:func:`feedtune.tune.filter_choice.choose_filters`): ``(pack, outcome of
    search or None, record)``. Resonances: the peaks of the accelerance ``|G| (2 pi f)^2`` of every FRF (the model's
    lightly damped poles without one); sensitivity peaks: of ``|S|`` of the current design on every FRF."""

    def axis_search(pack: FilterPack, n: int) -> _AxisSearch:
        return _AxisSearch(axis_cases, maker(pack), n, bounds, scan, obj)

    what, unit = ("integral gain", "") if obj.by_gain else ("first crossover", "Hz")

    def objective(outcome) -> float:
        return float(axis_search(given, outcome[0]).merit(outcome[1].edge.best))

    def screen(pack: FilterPack, outcome, beat: float):
        n, r, _ = outcome
        s = axis_search(pack, n)
        e = s.edge(tuple(r.point), (r.point, r.edge.best), beat)
        note = None if not e.pruned else (f"fails at {e.fail_scale:.4g} Hz, where the {what} is still below "
                                          f"{beat:.4g}{' ' + unit if unit else ''}: it cannot raise it")
        return (None if e.best is None else s.merit(e.best)), e.best, note

    def refine(pack: FilterPack, outcome, probe):
        n, r, results = outcome
        local = axis_search(pack, n).run_from(tuple(r.point), probe)
        return None if local is None else (n, local, {**results, n: local})

    def resonances_of(c: _AxisCase) -> list:
        pc = c.pc
        if not pc.measured:
            feats = [(float(f), float(z)) for f, z in np.asarray(pc.features).reshape(-1, 2) if 0 < f < 0.45 * fs]
            return sorted(feats, key=lambda fz: fz[1])[:3]
        f = pc.freq_hz
        return resonance_peaks(f, np.abs(pc.plant(f)).reshape(-1) * (2 * np.pi * f) ** 2)

    def peaks(outcome) -> list[float]:
        design = outcome[1].edge.best.result[0]
        found = []
        for c in axis_cases:
            f = c.pc.freq_hz
            s = np.abs(1.0 / (1.0 + c.Ge * design.controller_discrete().freqresp(f)))
            found.extend((float(np.interp(p, f, s)), p) for p in sensitivity_peaks(f, s, objective(outcome)))
        return [p for _, p in sorted(found, reverse=True)[:2]]

    return choose_filters(given, run=search, objective=objective, screen=screen, refine=refine, what=what, unit=unit,
                          resonances=merge_resonances([resonances_of(c) for c in axis_cases]), peaks=peaks, fs=fs)
