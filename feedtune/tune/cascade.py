"""Tuner of the drive cascade (:mod:`feedtune.control.cascade`): the speed loop first (PI and its own current-setpoint
filters under the limits, on every FRF), then the position gain with the closed speed loop as its plant.

**Speed loop.** The scale is the crossover ``fc`` the PI's gain is set for: ``Kp = 1 / |2 pi fc G_v(fc)|`` with
``G_v`` the model's speed response (the true first crossover is the check's, which the objective ranks by); the shape
is the integral time relative to it, ``Tn wc`` with ``wc = 2 pi fc`` (log coordinates over :data:`TN_WC_BOUNDS`; the
PI's phase lag at ``fc`` is ``atan(1 / (Tn wc))``): at a fixed shape a lower scale keeps the PI's lag where the
crossover goes, so the passing scales of a shape form one range from below, as the edge search assumes (an integral
time fixed in seconds would lag more as the gain falls). For each shape the largest ``fc`` whose law passes the check
is found (:func:`feedtune.tune.search.feasibility_edge`, bracket :data:`RTOL`), and the shapes are searched by
:func:`feedtune.tune.search.pattern_search`. The objective (:class:`feedtune.tune.search.Objective`) is ``bandwidth``
unless told otherwise -- a drive's speed loop is judged by its bandwidth at its margins (the vendors' automatic tuners
compare so); the ``bandwidth`` rule's tie is honoured within the continuous shapes: once the highest first crossover
is found, the highest integral gain ``Kp / Tn`` among the shapes within :data:`~feedtune.tune.search. CROSSOVER_TIE`
of it wins. ``stiffness`` ranks by ``Kp / Tn`` (the speed loop's stiffness against a load).

**The check** is the analysis the design is judged by (:mod:`feedtune.analysis.cascade`): the speed loop's ``discrete``
case on each FRF (``ideal_discrete`` on the model alone), the limits policy there (its ``band_top`` item included),
an unreliable Nyquist count refused; the winner is then verified stable in every case.

**Filters** (``filter_choice = "own"``): the current-setpoint filters are chosen as every tuner chooses its filter pack
(:func:`feedtune.tune.filter_choice.choose_filters`: notches at the plant's resonances and the sensitivity peaks, a
first- or second-order low-pass, each kept when it raises the objective), each notch a drive's general second-order
filter with equal frequencies, the low-pass a PT1 or PT2 (:func:`feedtune.control.cascade.pack_filters`). Then the
kept filters' parameters are searched with ``Tn`` (:data:`FILTER_BOUNDS`, one parameter at a time:
``pattern_search(diagonal=False)``): a notch's centre, zero and pole damping, a low-pass's frequency and damping -- the
candidates' values are a start, not the answer.

**Position loop.** ``Kv`` is the largest gain whose position loop (``position_discrete`` on each FRF,
``position_ideal_discrete`` on the model) meets the same limits, by :func:`feasibility_edge` over
:data:`KV_SCAN_HZ` (``Kv / (2 pi)`` in Hz); the speed loop stays as tuned. ``position_encoder="load"`` closes it on
the load encoder of a two-encoder FRF or a two-mass model.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..analysis.cascade import POSITION, analyze_loop_case, cascade_plant_cases
from ..analysis.limits import DEFAULT_LIMITS, Limits, check_cases
from ..control.cascade import describe_filter, filters_pack, pack_filters
from ..control.filters import FilterPack, Notch
from ..design.cascade import CascadeDesign, design_cascade
from ..errors import DesignError, UsageError
from .filter_choice import choose_filters, merge_resonances, resonance_peaks, sensitivity_peaks
from .search import EdgeResult, Objective, Probe, feasibility_edge, pattern_search, robust_frfs, unreliable

DEFAULT_OBJECTIVE = "bandwidth"
"""The cascade's objective unless told otherwise (module docstring)."""
TN_WC_BOUNDS = (0.7, 40.0)
"""``Tn wc`` searched [-]: the PI's lag at the crossover from 55 deg down to 1.4 deg."""
SCAN_HZ = (1.0, None)
"""The speed loop's crossover scale [Hz]: from 1 Hz to ``fs / 6`` (None); inside a design FRF's lines (1.25 x the
first to the last / 1.25 -- with the continuation, the last line may be passed by the check's own ruling)."""
SCAN_POINTS = 24
RTOL = 2e-3
"""Relative width of the final bracket on the crossover scale and on ``Kv`` [-]."""
KV_SCAN_HZ = (0.05, None)
"""``Kv / (2 pi)`` searched [Hz]: from 0.05 Hz to the position loop's ``fp / 4`` (None)."""
FILTER_BOUNDS = {"notch_hz": (0.8, 1.25), "zeta_z": (0.005, 0.5), "zeta_p": (0.03, 1.0), "lpf_hz": (0.5, 2.0),
                 "lpf_zeta": (0.3, 1.0)}
"""The box of the filter refinement: a notch's centre and a low-pass's frequency relative to the chosen one [-], the
dampings absolute [-]."""
FILTER_MIN_STEP = 1 / 16
"""The refinement's smallest step, a fraction of each parameter's log range."""
SCREEN_STEP = 1 / 8
"""The filter screen's local search over ``Tn wc``: its first step, a fraction of the log range of
:data:`TN_WC_BOUNDS`
(halved once)."""


# ------------------------------------------------------------------------------------------ the speed loop
@dataclass
class _Case:
    """One FRF (or the model): the checked case of a loop, its other cases, the limits."""

    checked: object
    others: dict
    policy: Limits
    checks: int = 0


def _speed_response(design: CascadeDesign) -> Callable[[float], float]:
    """``fc -> Kp`` with ``|2 pi fc Kp G_v(fc)| = 1`` on the plant model."""
    plant = design.plant

    def kp_of(fc: float) -> float:
        g = plant.response(np.array([fc]))[0, 0]
        return float(1.0 / abs(2j * np.pi * fc * g))

    return kp_of


class _SpeedSearch:
    """The speed loop for one way of making the filters from a shape: the check, the edge, the shape search.

    ``shape = (Tn wc, *filter parameters)``; ``pack_of(shape) -> FilterPack`` makes the filters.
    """

    def __init__(self, cases: list[_Case], law0, kp_of, pack_of, names, bounds, scan: np.ndarray,
                 objective: Objective, others: bool = False):
        self.cases, self.law0, self.kp_of, self.pack_of = cases, law0, kp_of, pack_of
        self.names, self.bounds, self.scan, self.objective = tuple(names), list(bounds), scan, objective
        self.others = others
        self._probes: dict = {}
        self.tie_from: float | None = None  # under bandwidth: the first crossover the tie counts from

    def law(self, fc: float, shape: tuple):
        try:
            filters = pack_filters(self.pack_of(shape))
            return self.law0.with_gains(kp=self.kp_of(fc), tn_s=float(shape[0]) / (2 * np.pi * fc),
                                        filters=filters)
        except UsageError:
            return None

    def merit(self, p: Probe) -> float:
        """The objective's figure at an edge: the first crossover [Hz], or ``Kp / Tn``; with a tie set (the
        bandwidth rule's second phase) ``Kp / Tn`` where the crossover is within the tie, else nothing."""
        if p is None or p.result is None:
            return math.nan
        law = p.result[0]
        if self.tie_from is not None:
            return law.integral_gain if p.crossover_hz >= self.tie_from else -math.inf
        return self.objective.merit(p.crossover_hz, law.integral_gain)

    def check(self, fc: float, shape: tuple) -> Probe:
        key = (float(fc), tuple(float(v) for v in shape))
        if key in self._probes:
            return self._probes[key]
        law = self.law(fc, shape)
        if law is None:
            p = Probe(float(fc), False, math.nan, None, None)
        else:
            probes = []
            for k, c in enumerate(self.cases):
                p = _check_case(law, c, float(fc), "", self.others)
                probes.append(p)
                if not p.ok:
                    if k:
                        self.cases.insert(0, self.cases.pop(k))
                    break
            else:
                best = min(probes, key=lambda q: q.crossover_hz)
                slacks = [q.slack for q in probes if q.slack is not None]
                p = Probe(float(fc), True, best.crossover_hz, min(slacks) if slacks else None, best.result)
        self._probes[key] = p
        return p

    def edge(self, shape: tuple, ref: tuple | None = None, beat: float | None = None) -> EdgeResult:
        start = None if ref is None else ref[1].scale
        return feasibility_edge(lambda fc: self.check(fc, shape), self.scan, rtol=RTOL, start=start,
                                beat=beat if start is not None else None, merit=self.merit)

    def run(self, initial: tuple | None = None, ref: tuple | None = None):
        """The shape search (from ``initial`` when given: a local search, one parameter at a time)."""
        if initial is None:
            return pattern_search(self.edge, self.names, self.bounds, ref=ref, merit=self.merit)
        return pattern_search(self.edge, self.names, self.bounds, initial=initial, ref=ref, merit=self.merit,
                              diagonal=len(self.names) <= 2, min_step=FILTER_MIN_STEP)


def _check_case(law, c: _Case, scale: float, prefix: str, others: bool) -> Probe:
    """The check of a law on one FRF's checked case (limits, an unreliable count refused, with ``others``
    stability in the loop's other cases)."""
    c.checks += 1
    m = analyze_loop_case(law, c.checked).metrics
    items = c.policy.check(m, c.checked.name)
    doubt = unreliable(m.warnings)
    ok = all(i.ok for i in items) and doubt is None and bool(m.crossovers_hz)
    if ok and others:
        for lp in c.others.values():
            o = analyze_loop_case(law, lp).metrics
            if not (o.stable and o.nyquist_reliable):
                ok = False
                break
    slacks = [i.slack for i in items if i.slack is not None]
    slack = None if not m.stable or doubt is not None else (min(slacks) if slacks else 1.0)
    xc = float(m.crossovers_hz[0]) if m.crossovers_hz else math.nan
    return Probe(scale, ok, xc, slack, (law, m, items))


def _best(search: _SpeedSearch, initial: tuple | None, ref: tuple | None, objective: Objective):
    """The winner of a search: under ``bandwidth``, the highest integral gain within the tie of the highest first
    crossover (a second, local search from the crossover's winner)."""
    r = search.run(initial, ref)
    if r is None or r.edge.best is None or objective.by_gain:
        return r
    search.tie_from = (1 - objective.tie) * r.edge.best.crossover_hz
    search._probes.clear()  # the merit changed; the probes' figures did not, but keep the search's bookkeeping clean
    tied = pattern_search(search.edge, search.names, search.bounds, initial=r.point, ref=(r.point, r.edge.best),
                          merit=search.merit, diagonal=len(search.names) <= 2, min_step=FILTER_MIN_STEP)
    search.tie_from = None
    if tied is None or tied.edge.best is None or not math.isfinite(search.merit(tied.edge.best)):
        return r
    return tied


# ------------------------------------------------------------------------------------------ shapes with filters
def _filter_shape(pack: FilterPack) -> tuple[list[str], list[tuple[float, float]], tuple, Callable]:
    """The names, bounds and values of a pack's parameters, and ``make(values) -> FilterPack``."""
    names, bounds, values = [], [], []
    for i, n in enumerate(pack.notches):
        lo, hi = FILTER_BOUNDS["notch_hz"]
        names += [f"notch{i + 1}_hz", f"notch{i + 1}_zeta_z", f"notch{i + 1}_zeta_p"]
        bounds += [(n.freq_hz * lo, n.freq_hz * hi), FILTER_BOUNDS["zeta_z"], FILTER_BOUNDS["zeta_p"]]
        values += [n.freq_hz, min(max(n.zeta_z, FILTER_BOUNDS["zeta_z"][0]), FILTER_BOUNDS["zeta_z"][1]),
                   min(max(n.zeta_p, FILTER_BOUNDS["zeta_p"][0]), FILTER_BOUNDS["zeta_p"][1])]
    if pack.lpf_hz is not None:
        lo, hi = FILTER_BOUNDS["lpf_hz"]
        names.append("lpf_hz")
        bounds.append((pack.lpf_hz * lo, pack.lpf_hz * hi))
        values.append(pack.lpf_hz)
        if pack.lpf_order == 2:
            names.append("lpf_zeta")
            bounds.append(FILTER_BOUNDS["lpf_zeta"])
            values.append(min(max(pack.lpf_zeta, FILTER_BOUNDS["lpf_zeta"][0]), FILTER_BOUNDS["lpf_zeta"][1]))

    def make(v: Sequence[float]) -> FilterPack:
        notches, k = [], 0
        for _ in pack.notches:
            f, zz, zp = v[k:k + 3]
            if zz >= zp:
                raise UsageError("a notch's zero damping must stay below its pole damping", parameter="filters")
            notches.append(Notch(f, zz, zp))
            k += 3
        if pack.lpf_hz is None:
            return FilterPack(notches)
        zeta = v[k + 1] if pack.lpf_order == 2 else pack.lpf_zeta
        return FilterPack(notches, v[k], pack.lpf_order, zeta)

    return names, bounds, tuple(values), make


# ------------------------------------------------------------------------------------------ the tuner
def tune_cascade(plant, *, frf=None, limits: Limits | None = None, ms_max: float | None = None, filters=None,
                 filter_choice: str = "own", fs: float = 8000.0, position_ratio: int = 8, delay_samples: int = 1,
                 kv_ff: float = 1.0, inertia_ff: float | None = None, position_encoder: str = "motor",
                 current_loop_hz: float | None = None, motor_channel: str | None = None,
                 load_channel: str | None = None, objective: str | Objective | None = None, tn_bounds=None,
                 position: bool = True, refine_filters: bool = True) -> CascadeDesign:
    """The cascade that wins under ``objective`` among those that meet the limits (module docstring).

    Parameters
    ----------
    plant : RigidBodyModel, BallScrewModel, CascadePlant or Frf
        The axis (:func:`feedtune.design.cascade.cascade_plant`): a model, or a measured FRF (then also the first of
        the FRFs the limits hold on).
    frf : Frf or sequence of Frf, optional
        Measured FRFs the limits must hold on (positions, loads of one axis); the objective is the lowest first
        crossover over them.
    limits : Limits, optional
        The policy (default ``textbook``); ``ms_max`` overrides its peak sensitivity.
    filters : sequence of DriveFilter, optional
        Current-setpoint filters given (with ``filter_choice="own"``: candidates, and the pack they form as a
        whole; with ``"identical"``: used as they are).
    filter_choice : {"own", "identical"}
    fs : float
        Speed-loop rate [Hz].
    position_ratio : int
        Speed samples per position-loop sample.
    delay_samples : int
        Computational delay [speed samples].
    kv_ff, inertia_ff : float, optional
        The feedforward (:func:`~feedtune.design.cascade.design_cascade`).
    position_encoder : {"motor", "load"}
    current_loop_hz, motor_channel, load_channel
        See :func:`~feedtune.design.cascade.cascade_plant`.
    objective : {"bandwidth", "stiffness", "pareto"} or Objective, optional
        Default :data:`DEFAULT_OBJECTIVE` (``pareto`` ranks as ``stiffness`` here).
    tn_bounds : (float, float), optional
        ``Tn wc`` searched [-] (default :data:`TN_WC_BOUNDS`).
    position : bool
        Tune ``Kv`` after the speed loop (else the position loop stays open, ``Kv = 0``).
    refine_filters : bool
        Search the kept filters' parameters with ``Tn`` (module docstring).

    Returns
    -------
    CascadeDesign
        ``tuning`` records the rule, the limits, the checked cases, the filter choice and the figures.

    Raises
    ------
    DesignError
        No speed loop (or no position loop) meets the limits.
    """
    t0 = time.perf_counter()
    policy = (limits or DEFAULT_LIMITS).override(ms_max=ms_max)
    obj = Objective.of(DEFAULT_OBJECTIVE if objective is None else objective)
    if obj.compliance_max is not None:
        raise UsageError("compliance_max caps a ball screw's axial-mode compliance; the cascade has none",
                         parameter="compliance_max")
    if filter_choice not in ("own", "identical"):
        raise UsageError(f"filter_choice must be 'own' or 'identical', got {filter_choice!r}",
                         parameter="filter_choice")
    given = tuple(filters or ())
    given_pack = filters_pack(given) if given else FilterPack()
    if filter_choice == "own" and given and given_pack is None:
        raise UsageError("with filter_choice='own' the given filters must be notches and one low-pass after them "
                         "(candidates of the choice); pass filter_choice='identical' to use others as they are",
                         parameter="filters")
    frfs = robust_frfs(frf)
    if not isinstance(plant, (list, tuple)) and hasattr(plant, "freq_hz") and hasattr(plant, "channels"):
        frfs = [plant, *[f for f in frfs if f is not plant]]
    trial = design_cascade(plant, kp=1.0, tn_s=math.inf, fs=fs, position_ratio=position_ratio,
                           delay_samples=delay_samples, kv_ff=kv_ff, inertia_ff=inertia_ff,
                           position_encoder=position_encoder, frf=frfs[0] if frfs else None,
                           current_loop_hz=current_loop_hz, motor_channel=motor_channel, load_channel=load_channel)
    src = trial.source
    lo_tn, hi_tn = (float(v) for v in (tn_bounds or TN_WC_BOUNDS))
    if not (0 < lo_tn < hi_tn):
        raise UsageError(f"tn_bounds must be two values 0 < low < high of Tn wc [-], got {tn_bounds!r}",
                         parameter="tn_bounds")
    law0 = replace(trial.law, kv=0.0)
    name = "discrete" if frfs else "ideal_discrete"
    prepared = [cascade_plant_cases(law0, src.plant, f, **src.channels()) for f in (frfs or [None])]
    cases = [_Case(p[name], {k: v for k, v in p.items() if v is not None and k != name and not k.startswith(POSITION)},
                   policy) for p in prepared]
    bottom, top = SCAN_HZ[0], fs / 6 if SCAN_HZ[1] is None else SCAN_HZ[1]
    if src.frf is not None:
        lines = src.frf.freq_hz[src.frf.freq_hz > 0]
        bottom = max(bottom, float(lines[0]) * 1.25)
    scan = np.geomspace(bottom, top, SCAN_POINTS)
    kp_of = _speed_response(trial)

    def search(pack: FilterPack, others: bool = False) -> _SpeedSearch:
        return _SpeedSearch(cases, law0, kp_of, lambda shape: pack, ("tn_wc",), [(lo_tn, hi_tn)], scan, obj, others)

    def run(pack: FilterPack):
        r = search(pack).run()
        return None if r is None or r.edge.best is None else (pack, r)

    def merit(outcome) -> float:
        return float(search(outcome[0]).merit(outcome[1].edge.best))

    record = {"choice": "identical", "why": "the filters given are used as they are"}
    if filter_choice == "own":
        pack, outcome, record = _own_filters(given_pack, run, merit, search, cases, fs, obj)
        if outcome is None:
            raise DesignError(f"no speed loop meets the limits ({policy.describe()}) in the {name} case, with or "
                              "without current-setpoint filters; relax the limits")
        filters_now = pack_filters(pack)
        names, bounds, values, make = _filter_shape(pack)
    else:
        filters_now = given
        names, bounds, values, make = [], [], (), None
    # the final search: Tn with the kept filters' parameters (or Tn alone), under the objective's rule
    if make is not None and refine_filters and names:
        def pack_of(shape):
            return make(shape[1:])
        s = _SpeedSearch(cases, law0, kp_of, pack_of, ("tn_wc", *names), [(lo_tn, hi_tn), *bounds], scan, obj)
        start = (outcome[1].point[0], *values)
        first = s.edge(start)
        best = _best(s, start, (start, first.best), obj) if first.best is not None else None
    else:
        fixed = given if make is None else filters_now
        s = _SpeedSearch(cases, law0, kp_of, lambda shape: filters_pack(fixed) or FilterPack(), ("tn_wc",),
                         [(lo_tn, hi_tn)], scan, obj)
        if make is None:
            s.law = lambda fc, shape: law0.with_gains(kp=kp_of(fc), tn_s=float(shape[0]) / (2 * np.pi * fc),
                                                      filters=fixed)
        best = _best(s, None, None, obj)
    if best is None or best.edge.best is None:
        raise DesignError(f"no speed loop meets the limits ({policy.describe()}) in the {name} case; relax the "
                          "limits or change the filters")
    law, metrics, _ = best.edge.best.result
    unstable = _unstable_cases(law, cases)
    if unstable:
        s.others = True
        s._probes.clear()
        best = _best(s, best.point, None, obj)
        if best is None or best.edge.best is None:
            raise DesignError(f"the best speed loop meets the limits in the {name} case but is unstable in the "
                              f"{', '.join(unstable)} case")
        law, metrics, _ = best.edge.best.result
    speed = {"crossover_scale_hz": float(best.edge.best.scale), "first_crossover_hz": float(metrics.crossovers_hz[0]),
             "ms": float(metrics.ms), "pm_deg": metrics.phase_margin_deg, "gm_db": metrics.gain_margin_db,
             "Kp": law.kp, "Tn_s": law.tn_s, "tn_wc": float(best.point[0]), "integral_gain": law.integral_gain,
             "filters": [describe_filter(f) for f in law.enabled_filters],
             "on_bound": list(best.on_bound), "checks": int(sum(c.checks for c in cases))}
    pos_record = None
    if position:
        law, pos_record = _tune_position(law, src, frfs, policy, name, position_ratio)
    warnings = [f"the speed loop's winner sits on a search bound: {b}" for b in best.on_bound]
    if best.edge.at_top:
        warnings.append(f"the speed loop's crossover scale is the top of the scan ({best.edge.best.scale:g} Hz: "
                        "fs/6)")
    act = check_cases(policy, {name: metrics}, [name]).active()
    tuning = {
        "method": "the speed loop first: the crossover scale to the edge of the limits by bisection, the integral "
                  "time (and the kept filters' parameters) by a pattern search; then Kv to the edge of the limits "
                  "of the position loop on the closed speed loop",
        **obj.record("Kp/Tn", f"{law.command_unit}/{law.position_unit}", law.integral_gain),
        "rule": f"drive cascade tuned by feedtune.tune.cascade for {obj.name} under {policy.describe()}",
        "limits": policy.to_dict(), "active_limit": None if act is None else act.to_dict(),
        "checked_case": name, "frfs": len(frfs), "rests_on": src.rests_on,
        "first_crossover_hz": speed["first_crossover_hz"], "crossover_hz": speed["first_crossover_hz"],
        "speed_loop": speed, "position_loop": pos_record, "filters": record,
        "search": {"tn_wc_bounds": [lo_tn, hi_tn], "crossover_scan_hz": [float(scan[0]), float(scan[-1])],
                   "rtol": RTOL, "seconds": round(time.perf_counter() - t0, 3)},
        "warnings": warnings + ([] if pos_record is None else pos_record.get("warnings", [])),
    }
    return CascadeDesign(law, src, tuning)


def _unstable_cases(law, cases: list[_Case]) -> list[str]:
    out = []
    for i, c in enumerate(cases):
        for k, lp in c.others.items():
            m = analyze_loop_case(law, lp).metrics
            if not (m.stable and m.nyquist_reliable):
                out.append(k + (f" (FRF {i + 1})" if len(cases) > 1 else ""))
    return out


def _tune_position(law, src, frfs: list, policy: Limits, name: str, ratio: int):
    """``(law with Kv, record)``: the largest ``Kv`` meeting the limits in the position loop's checked case on every
    FRF (module docstring)."""
    fp = law.fs / ratio
    top = fp / 4 if KV_SCAN_HZ[1] is None else KV_SCAN_HZ[1]
    scan = np.geomspace(KV_SCAN_HZ[0], top, SCAN_POINTS) * 2 * np.pi
    probe_law = law.with_gains(kv=1.0)
    prepared = [cascade_plant_cases(probe_law, src.plant, f, **src.channels()) for f in (frfs or [None])]
    pname = POSITION + name
    cases = [_Case(p[pname], {k: v for k, v in p.items() if v is not None and k.startswith(POSITION) and k != pname},
                   policy) for p in prepared]

    def check(kv: float) -> Probe:
        trial = law.with_gains(kv=float(kv))
        probes = [_check_case(trial, c, float(kv), POSITION, False) for c in cases]
        bad = next((p for p in probes if not p.ok), None)
        if bad is not None:
            return bad
        best = min(probes, key=lambda q: q.crossover_hz)
        slacks = [q.slack for q in probes if q.slack is not None]
        return Probe(float(kv), True, best.crossover_hz, min(slacks) if slacks else None, best.result)

    edge = feasibility_edge(check, scan, rtol=RTOL, merit=lambda p: p.scale)
    if edge.best is None:
        raise DesignError(f"no position gain Kv meets the limits ({policy.describe()}) in the {pname} case on the "
                          "tuned speed loop")
    tuned, m, _ = edge.best.result
    unstable = _unstable_cases(tuned, cases)
    if unstable:
        raise DesignError(f"the highest Kv meets the limits in the {pname} case but is unstable in the "
                          f"{', '.join(unstable)} case")
    warnings = [f"Kv sits on the top of its scan ({edge.best.scale:.4g} 1/s: fp/4)"] if edge.at_top else []
    return tuned, {"Kv": tuned.kv, "first_crossover_hz": float(m.crossovers_hz[0]), "ms": float(m.ms),
                   "pm_deg": m.phase_margin_deg, "gm_db": m.gain_margin_db, "position_fs_hz": fp,
                   "checked_case": pname, "warnings": warnings}


def _own_filters(given: FilterPack, run, merit, search, cases: list[_Case], fs: float, obj: Objective):
    """The speed loop's own current-setpoint filters (:func:`feedtune.tune.filter_choice.choose_filters`):
    ``(pack, outcome or None, record)``. Resonances: the peaks of the accelerance ``|G_1| (2 pi f)^2`` of every FRF
    (the model's lightly damped poles without one); sensitivity peaks: of ``|S|`` of the current winner."""
    what, unit = ("integral gain Kp/Tn", "") if obj.by_gain else ("first crossover", "Hz")

    def screen(pack: FilterPack, outcome, beat: float):
        """A coarse local search over ``Tn`` from the winner's (a filter's phase may need another integral time
        than the winner's: screened at that shape alone, a notch below a crossover limited by the phase margin
        would never pass)."""
        s = search(pack)
        r = outcome[1]
        e = s.edge(tuple(r.point), (r.point, r.edge.best), None)
        if e.best is None:
            return None, None, f"no speed loop meets the limits with it at Tn = {r.point[0] * 1e3:.4g} ms"
        local = pattern_search(s.edge, s.names, s.bounds, initial=tuple(r.point), ref=(tuple(r.point), e.best),
                               merit=s.merit, initial_step=SCREEN_STEP, min_step=SCREEN_STEP / 2)
        found = e.best if local is None or local.edge.best is None else local.edge.best
        value = s.merit(found)
        note = None if value > beat else f"its {what} reaches {value:.4g}{' ' + unit if unit else ''} at best"
        return value, found, note

    def refine(pack: FilterPack, outcome, probe):
        s = search(pack)
        point = (float(probe.result[0].tn_s * 2 * np.pi * probe.scale),) if probe is not None else None
        local = s.run(point, (point, probe)) if point is not None else s.run()
        return None if local is None or local.edge.best is None else (pack, local)

    def resonances_of(c: _Case) -> list:
        pc = c.checked.pc
        if not pc.measured:
            feats = [(float(f), float(z)) for f, z in np.asarray(pc.features).reshape(-1, 2) if 0 < f < 0.45 * fs]
            return sorted(feats, key=lambda fz: fz[1])[:3]
        f = pc.freq_hz[:pc.band_edge.lines] if pc.band_edge is not None else pc.freq_hz
        return resonance_peaks(f, np.abs(c.checked.plant[0, :f.size]) * (2 * np.pi * f) ** 2)

    def peaks(outcome) -> list[float]:
        law = outcome[1].edge.best.result[0]
        found = []
        for c in cases:
            f = c.checked.pc.freq_hz
            s = np.abs(analyze_loop_case(law, c.checked).S)
            found.extend((float(np.interp(p, f, s)), p) for p in sensitivity_peaks(f, s, merit_xo(outcome)))
        return [p for _, p in sorted(found, reverse=True)[:2]]

    def merit_xo(outcome) -> float:
        return float(outcome[1].edge.best.crossover_hz)

    return choose_filters(given, run=run, objective=merit, screen=screen, refine=refine, what=what, unit=unit,
                          resonances=merge_resonances([resonances_of(c) for c in cases]), peaks=peaks, fs=fs)


__all__ = ["DEFAULT_OBJECTIVE", "FILTER_BOUNDS", "TN_WC_BOUNDS", "tune_cascade"]
