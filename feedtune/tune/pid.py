"""Tuner of the gantry's independent-PID baseline (thesis §4.4.2; issue 10: tuned as well as the proposal).

The PIDs (:mod:`feedtune.design.gantry_pid`) are placed from a bandwidth ``w`` and a shape ``(zeta, rho)``, gains
proportional to the side masses: the rigid body's closed loop has the poles of
``(s^2 + 2 zeta w s + w^2)(s + w/rho)``. Every positive ``(kp, kd, ki)`` per unit mass with a stable rigid-body loop
is one such triple, so the search covers the mass-scaled PIDs; it is continuous in all three:

* for a shape, the largest ``w`` that passes the check (:func:`feedtune.tune.search.feasibility_edge`; bracket
  ``RTOL`` = 0.2 %), from a scan of ``w`` over ``SCAN_HZ`` (log-spaced) or from a neighbouring shape's edge;
* over the shapes, the highest first CoM crossover at the edge (:func:`feedtune.tune.search.pattern_search`,
  log coordinates, a 3 x 3 lattice of starts, local searches from the best two with diagonal moves, steps down
  to ``SHAPE_STEP`` = 1/32 of the box).

**The check** is the analysis the design is judged by: the plant case of the checked case
(:func:`feedtune.analysis.gantry.gantry_plant_cases`: the measured FRF interpolated between its lines and the model
below them, ``discrete``; without an FRF the ZOH model, ``ideal_discrete``), :func:`analyze_gantry_case` and the
limits policy (:class:`feedtune.analysis.limits.Limits`: MIMO Nyquist stability, ``max sigma_max(S)``, and the
CoM loop's phase and gain margins at every crossover; the figures the limits read, ``figures="limits"``).
Candidates whose ``Ms`` on the case's base grid already exceeds the limit (a lower bound of the checked ``Ms``), or
whose loop at a band-limited FRF's last line is too large (the rule below), are skipped unchecked. The objective is
the true first crossover of the CoM loop (``metrics.crossovers_hz[0]``, including crossovers below the FRF's band).
The winner is verified in every case (stable in all, the limits in the checked case).

**The shape box** is ``ZETA_BOUNDS`` x ``RHO_BOUNDS``. On the thesis gantry with the MIMO design's notches and
low-pass at Ms 2.5 the crossover at the edge rises towards ``zeta = 1`` and large ``rho`` (12.1 Hz at (0.3, 0.5),
13.5 Hz at (1, 10); it falls to 3.7 Hz at (0.3, 10), where the phase margin binds) and goes on rising beyond the
box (14.4 Hz at ``zeta = 3``, ``rho = 32``): the ``Ms`` peak near the yaw mode caps the derivative gain, which sets
the crossover, and the crossover alone prefers a PD. The box keeps the PID a PID: ``zeta <= 1`` keeps the rigid-body
pair complex (above 1 its slow pole ``w (zeta - sqrt(zeta^2 - 1))`` creeps towards 0) and ``rho <= 10`` keeps the
integral pole within a decade of the bandwidth. A winner on a bound is reported in ``tuning["warnings"]``. Where
two limits meet (the phase margin and ``Ms``, or the band's last line) the best shapes lie on a diagonal ridge
(on the twin's FRF without filters: 202 Hz at (0.30, 2.2), 241 Hz at (0.36, 10)), hence the diagonal moves.

**Filters** (``filter_choice``; default ``"identical"`` when ``filters`` are given, else ``"own"``):
``"identical"`` uses the filters given (the thesis: the MIMO design's notches and low-pass); ``"own"`` lets the
tuner choose (:func:`choose_filters`): it seeds notches at the plant's resonances (the FRF's, or the model's lightly
damped poles) and at the sensitivity peaks of the best design without filters, tries low-pass filters of order 1 and
2, and keeps a filter only when it raises the first crossover under the limits.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import progress
from ..analysis.cases import CHECKED_WITH_FRF, CHECKED_WITHOUT_FRF
from ..analysis.gantry import analyze_gantry_case, default_grid, gantry_plant_cases
from ..analysis.limits import DEFAULT_LIMITS, Limits, check_cases
from ..analysis.margins import crossings
from ..analysis.mimo import com_loop, sensitivity_gain, singular_values
from ..control.discretize import backward_difference, backward_euler_integrator, check_sampling
from ..control.filters import TWO_PI, FilterPack
from ..control.gantry import PidLaw
from ..control.prefilter import PrefilterGains
from ..design.gantry_pid import GantryPidDesign, design_gantry_pid, pid_gains
from ..design.loopshape import matched_pack
from ..errors import DesignError, UsageError
from ..frf import Frf
from ..models.gantry import GantryModel
from .filter_choice import KEEP_GAIN, merge_resonances
from .filter_choice import choose_filters as own_filters
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
    EdgeResult,
    Objective,
    Probe,
    SearchResult,
    feasibility_edge,
    pattern_search,
    robust_frfs,
)

ZETA_BOUNDS = (0.3, 1.0)
"""Damping of the rigid-body closed-loop pair searched [-]."""
RHO_BOUNDS = (0.5, 10.0)
"""Ratio ``w / p`` of the bandwidth to the real closed-loop pole searched [-]."""
SCAN_HZ = (0.2, None)
"""Scan of the bandwidth ``w`` [Hz]: from 0.2 Hz to ``fs / 40`` (None)."""
SCAN_POINTS = 24
"""Points of that scan (ratio 1.38)."""
RTOL = 2e-3
"""Relative width of the final bracket on ``w`` [-]."""
SHAPE_STEP = 1 / 32
"""Smallest step of the shape search, a fraction of each parameter's log range [-]."""
FILTER_CHOICES = ("own", "identical")
"""Values of ``filter_choice``."""


@dataclass
class _Case:
    """One checked plant case (an FRF at its table position, or the model) and its base-grid arrays of the cheap
    ``Ms`` bound."""

    x: float
    name: str
    pc: object
    cases: dict
    weights: tuple
    Ge: np.ndarray
    D: np.ndarray
    Iz: np.ndarray


@dataclass
class _Problem:
    """What every candidate is checked against: the design (model, position whose side masses scale the gains,
    sampling), the limits and one :class:`_Case` per FRF, checked in turn with the last to fail first."""

    model: GantryModel
    x: float
    fs: float
    delay_samples: int
    masses: np.ndarray
    policy: Limits
    cases: list
    checks: int = 0
    analysed: dict = field(default_factory=dict)  # (id(law), case index) -> (law, figures of its checked case)

    @property
    def name(self) -> str:
        """The checked case (``discrete`` with FRFs, else ``ideal_discrete``)."""
        return self.cases[0].name


def _case(model, x, fs, delay_samples, frf, grid) -> _Case:
    name = CHECKED_WITH_FRF if frf is not None else CHECKED_WITHOUT_FRF
    cases = gantry_plant_cases(model, x, fs, delay_samples, frf, grid)
    pc = cases[name]
    f = pc.freq_hz
    with np.errstate(divide="ignore", invalid="ignore"):
        Iz = backward_euler_integrator(fs).freqresp(f)
    return _Case(float(x), name, pc, cases, model.alpha(x), pc.plant(f) * pc.hold(f),
                 backward_difference(fs).freqresp(f), Iz)


def _problem(model, x, fs, delay_samples, frfs, positions, grid, policy) -> _Problem:
    xs = frf_positions(frfs, positions, x) if frfs else [float(x)]
    cases = [_case(model, xi, fs, delay_samples, fi, grid) for xi, fi in zip(xs, frfs or [None], strict=True)]
    return _Problem(model, float(x), float(fs), int(delay_samples), np.array(model.side_masses(x)), policy, cases)


class _Search:
    """The search for one filter pack: the cheap bound, the real check, the edge and the shape search."""

    def __init__(self, problem: _Problem, pack: FilterPack, zeta_bounds, rho_bounds, scan: np.ndarray,
                 objective: Objective):
        self.problem = problem
        self.objective = objective
        self.pack = pack
        self.h = [matched_pack(pack, problem.fs).freqresp(c.pc.freq_hz) for c in problem.cases]
        self.gm = [c.Ge * problem.masses[None, :, None] for c in problem.cases]  # column j: G_j h m_j
        self.order = list(range(len(problem.cases)))  # the case that failed last is checked first
        self.bounds = (tuple(zeta_bounds), tuple(rho_bounds))
        self.scan = scan

    def grid_loops(self, i: int, bw_hz: np.ndarray, zeta: float, rho: float) -> np.ndarray:
        """``L`` on case ``i``'s base grid for each bandwidth [Hz] of ``bw_hz``, shape ``(2, 2, n_bw, n_f)``."""
        c = self.problem.cases[i]
        w = TWO_PI * np.asarray(bw_hz, float)[:, None]
        pid = w * w * (1 + 2 * zeta / rho) + w * (2 * zeta + 1 / rho) * c.D + w**3 / rho * c.Iz  # per unit mass
        k = self.h[i] * pid  # (n_bw, n_f)
        return self.gm[i][:, :, None, :] * k[None, None, :, :]  # column j: m_j k

    def grid_ms(self, bw_hz: np.ndarray, zeta: float, rho: float, *, band_top: bool = False) -> np.ndarray:
        """``max sigma_max(S)`` over every case's base grid for each bandwidth [Hz] of ``bw_hz``; with ``band_top``,
        a bandwidth whose loop on a band-limited FRF is too large at the last line
        (:func:`feedtune.tune.search.band_top_doubt`, which the check applies there) gets ``inf``."""
        out = None
        p = self.problem
        for i, c in enumerate(p.cases):
            L = self.grid_loops(i, bw_hz, zeta, rho)
            n_bw, n_f = L.shape[2:]
            ms = np.max(sensitivity_gain(L.reshape(2, 2, n_bw * n_f)).reshape(n_bw, n_f), axis=1)
            if band_top and c.pc.freq_hz[-1] < 0.999 * p.fs / 2 and p.policy.ms_max is not None:
                top = singular_values(np.ascontiguousarray(L[:, :, :, -1]))[0]
                ms = np.where(top > (1.0 - 1.0 / p.policy.ms_max) * (1 + BOUND_SLACK), np.inf, ms)
            out = ms if out is None else np.maximum(out, ms)
        return out

    def grid_crossover(self, bw_hz: float, zeta: float, rho: float) -> float:
        """Lowest first crossover [Hz] of the CoM loop over the cases' base grids (nan when a loop starts below 1
        on its grid)."""
        found = []
        for i, c in enumerate(self.problem.cases):
            lc = com_loop(self.grid_loops(i, [bw_hz], zeta, rho)[:, :, 0, :], c.weights)
            x = crossings(c.pc.freq_hz, np.log(np.abs(lc)), 0.0)
            found.append(float(x[0]) if x.size and abs(lc[0]) > 1 else math.nan)
        return min(found)

    def admissible(self, zeta: float, rho: float):
        """The cheap necessary condition of a shape (None without an ``Ms`` limit): ``Ms`` on the base grids (a lower
        bound of the checked ``Ms``) and the loop at a band-limited FRF's last line (as the check judges it), each
        with a relative slack of :data:`BOUND_SLACK` for the rounding of the two computations."""
        ms_max = self.problem.policy.ms_max
        if ms_max is None:
            return None
        return lambda bw: self.grid_ms(np.atleast_1d(bw), zeta, rho, band_top=True) <= ms_max * (1 + BOUND_SLACK)

    def merit(self, p: Probe) -> float:
        """What the objective maximises at an edge: the first crossover [Hz] or the integral gain (:func:`ki_sum`)."""
        return self.objective.merit(p.crossover_hz, ki_sum(p.result[0]) if p.result is not None else math.nan)

    def law(self, bw_hz: float, zeta: float, rho: float) -> PidLaw:
        p = self.problem
        return PidLaw(**pid_gains(p.model, p.x, bw_hz, zeta, rho), filters=self.pack, fs=p.fs,
                      delay_samples=p.delay_samples)

    def check(self, bw_hz: float, zeta: float, rho: float) -> Probe:
        """The analysis' own check of one candidate on every case in turn (the last to fail first).

        A pass carries the figures of the case with the lowest first crossover (the crossover guaranteed on all);
        a failure the failing case's figures, whose crossover bounds the guaranteed one from above.
        """
        p = self.problem
        p.checks += 1
        law = self.law(bw_hz, zeta, rho)
        found = []
        for k, i in enumerate(self.order):
            c = p.cases[i]
            m = analyze_gantry_case(law, c.pc, c.weights, figures="limits",
                                    disk_margin=p.policy.disk_margin_min is not None).metrics
            p.analysed[(id(law), i)] = (law, m)  # the law is kept with it: its id names it
            items = p.policy.check(m, c.name)
            doubt = top_line_doubt(law, c.pc, m, p.policy, p.fs)
            ok = all(i.ok for i in items) and doubt is None and bool(m.crossovers_hz)
            xo = float(m.crossovers_hz[0]) if m.crossovers_hz else math.nan
            if not ok:
                if k:
                    self.order.insert(0, self.order.pop(k))
                slacks = [i.slack for i in items if i.slack is not None]
                slack = None if not m.stable or doubt is not None else (min(slacks) if slacks else 1.0)
                bound = min([xo] + [f[0] for f in found])
                return Probe(float(bw_hz), False, bound, slack, (law, m, items))
            slacks = [i.slack for i in items if i.slack is not None]
            found.append((xo, min(slacks) if slacks else 1.0, m, items))
        xo, _, m, items = min(found, key=lambda f: f[0])
        return Probe(float(bw_hz), True, xo, min(f[1] for f in found), (law, m, items))

    def edge(self, shape: tuple, ref: tuple | None = None, beat: float | None = None, rtol: float = RTOL) -> EdgeResult:
        """The largest bandwidth of one shape passing the check (:func:`feasibility_edge`).

        ``ref`` is ``(shape, Probe)`` of a neighbouring edge; with ``beat`` [Hz] the first check is at the bandwidth
        expected to give that crossover: the reference's crossover per bandwidth, scaled by the ratio of the
        rigid-body crossovers of the two shapes (:func:`rigid_crossover`).
        """
        zeta, rho = shape
        start = None
        by_gain = self.objective.by_gain
        if ref is not None:
            (z0, r0), p0 = ref
            start = p0.scale
            v0 = self.merit(p0)
            if beat is not None and math.isfinite(v0) and v0 > 0:
                # the scale expected to reach ``beat``: the crossover scales with w (times the rigid-body crossover
                # of the shape), the integral gain with w^3 / rho
                start = (p0.scale * (beat / v0 * rho / r0) ** (1 / 3) if by_gain else
                         beat * p0.scale / v0 * rigid_crossover(z0, r0) / rigid_crossover(zeta, rho))
        cheap = ((lambda bw: ki_sum(self.law(bw, zeta, rho))) if by_gain else
                 (lambda bw: self.grid_crossover(bw, zeta, rho)))
        return feasibility_edge(lambda bw: self.check(bw, zeta, rho), self.scan,
                                admissible=self.admissible(zeta, rho), rtol=rtol, start=start,
                                beat=beat if start is not None else None, cheap_crossover=cheap, merit=self.merit)

    def run(self) -> SearchResult | None:
        """The shape search over the whole box."""
        return pattern_search(self.edge, ("zeta", "rho"), self.bounds, min_step=SHAPE_STEP, merit=self.merit)

    def run_from(self, shape: tuple, probe: Probe) -> SearchResult | None:
        """A local shape search from ``shape``, whose edge is expected near that of ``probe``."""
        return pattern_search(self.edge, ("zeta", "rho"), self.bounds, min_step=SHAPE_STEP, initial=shape,
                              ref=(tuple(shape), probe), merit=self.merit)


def ki_sum(law: PidLaw) -> float:
    """The integral gains of both sides added [V/(m s)]: the PID pair's low-frequency stiffness against a force at the
    CoM (what the stiffness objective maximises)."""
    return float(sum(law.ki))


def rigid_crossover(zeta: float, rho: float) -> float:
    """Crossover [rad/s] of the PID loop on the rigid body at unit bandwidth ``w = 1 rad/s`` (scales with ``w``).

    ``|kp + j (w kd - ki / w)| = w^2`` with the gains per unit mass of :func:`~feedtune.design.gantry_pid.pid_gains`;
    in ``u = w^2``: ``u^3 - kd^2 u^2 - (kp^2 - 2 kd ki) u - ki^2 = 0``, whose largest real root is taken.
    """
    kp, kd, ki = 1 + 2 * zeta / rho, 2 * zeta + 1 / rho, 1 / rho
    roots = np.roots([1.0, -kd * kd, -(kp * kp - 2 * kd * ki), -ki * ki])
    return float(math.sqrt(max(r.real for r in roots if abs(r.imag) < 1e-9 * max(1.0, abs(r)))))


def _bounds(value, default, name: str) -> tuple[float, float]:
    b = default if value is None else tuple(float(v) for v in value)
    if len(b) != 2 or not (0 < b[0] <= b[1] and all(math.isfinite(v) for v in b)):
        raise UsageError(f"{name} must be two numbers 0 < low <= high, got {value!r}")
    return b


def _resolve_choice(filter_choice: str | None, filters: FilterPack | None) -> str:
    choice = ("identical" if filters is not None else "own") if filter_choice is None else str(filter_choice)
    if choice not in FILTER_CHOICES:
        raise UsageError(f"filter_choice must be 'own' or 'identical', got {filter_choice!r}")
    return choice


@progress.searching("tuning gantry PIDs")
def tune_gantry_pid(
    model: GantryModel,
    *,
    limits: Limits | None = None,
    ms_max: float | None = None,
    filters: FilterPack | None = None,
    filter_choice: str | None = None,
    fs: float = 15000.0,
    delay_samples: int = 1,
    x: float = 0.0,
    frf: Frf | Sequence[Frf] | None = None,
    positions: Sequence[float] | None = None,
    x_grid=None,
    prefilter1: PrefilterGains | None = None,
    prefilter2: PrefilterGains | None = None,
    prefilter_hz: float = 80.0,
    grid_points: int | None = None,
    zeta_bounds=None,
    rho_bounds=None,
    objective: str | Objective | None = None,
) -> GantryPidDesign:
    """The PID pair that wins under ``objective`` among those that meet the limits in the checked case of every FRF.

    See the module docstring for the parametrisation, the search, the check and the filter choice.

    Parameters
    ----------
    model : GantryModel
        Design model (side masses, CoM weights; the plant below the FRF's band).
    limits : Limits, optional
        The limits policy (default :data:`feedtune.analysis.limits.DEFAULT_LIMITS`).
    ms_max : float, optional
        Overrides the policy's ``max sigma_max(S)`` [-] (e.g. the MIMO design's ``Ms``, ``design pid --match``).
    filters : FilterPack, optional
        Filter pack ``h(s)`` in front of both PIDs: used as given (``identical``), or as candidates the tuner
        may keep or drop (``own``; its leads are kept).
    filter_choice : {"identical", "own"}, optional
        Default ``identical`` when ``filters`` are given, else ``own``.
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    x : float
        Table position [m] of the design (its side masses scale the gains).
    frf : Frf or sequence of Frf, optional
        Measured 2x2 position FRF(s) [m/V] to check on (``discrete`` case, each at its table position: the limits
        must hold on every one and the objective is the lowest first crossover over them); default the model
        (``ideal_discrete``).
    positions : sequence of float, optional
        Table position [m] of each FRF (default :func:`feedtune.tune.gantry_cases.frf_positions`).
    x_grid, prefilter1, prefilter2, prefilter_hz
        Schedule grid [m], pre-filter gains and low-pass [Hz] of the design.
    grid_points : int, optional
        Points of the model's grid when no FRF is given (default that of
        :func:`feedtune.analysis.gantry.default_grid`, so the analysis' ``ideal_discrete`` case is the check).
    zeta_bounds, rho_bounds : (float, float), optional
        The shape box (default ``ZETA_BOUNDS``, ``RHO_BOUNDS``).
    objective : {"stiffness", "bandwidth", "pareto"} or Objective, optional
        Which edge wins (default :data:`feedtune.tune.search.DEFAULT_OBJECTIVE`; the integral gain is the sum of
        the sides' ``ki`` [V/(m s)], :func:`ki_sum`).

    Returns
    -------
    GantryPidDesign
        ``tuning`` records the rule, the limits, the active limit, the checked case, the filters chosen and why,
        and the warnings (winner on a search bound).

    Raises
    ------
    DesignError
        No candidate meets the limits.
    """
    t0 = time.perf_counter()
    policy = (limits or DEFAULT_LIMITS).override(ms_max=ms_max)
    obj = gantry_objective(objective)
    progress.figure(*(("ki (both sides)", f"{model.input_unit}/(m s)") if obj.by_gain else ("first crossover", "Hz")))
    check_sampling(fs, delay_samples)
    choice = _resolve_choice(filter_choice, filters)
    given = filters or FilterPack()
    given.check_nyquist(fs)
    zb = _bounds(zeta_bounds, ZETA_BOUNDS, "zeta_bounds")
    rb = _bounds(rho_bounds, RHO_BOUNDS, "rho_bounds")
    grid = default_grid(fs) if grid_points is None else default_grid(fs, grid_points)
    frfs = robust_frfs(frf)
    problem = _problem(model, x, fs, delay_samples, frfs, positions, grid, policy)
    x_grid = schedule_grid(model, [c.x for c in problem.cases], x_grid)
    top = fs / 40 if SCAN_HZ[1] is None else SCAN_HZ[1]
    scan = np.geomspace(SCAN_HZ[0], top, SCAN_POINTS)

    if choice == "identical":
        pack, result = given, _Search(problem, given, zb, rb, scan, obj).run()
        filter_record = {"choice": "identical", "why": "the filters given are used as they are"}
    else:
        pack, result, filter_record = choose_filters(problem, given, zb, rb, scan, obj)
    if result is None:
        raise DesignError(f"no PID pair meets the limits ({policy.describe()}) with a stable loop in the "
                          f"{problem.name} case; relax the limits or change the filter pack")
    winner, verify, act = _verified_winner(result, problem, obj)
    law, metrics, _ = winner.result
    zeta, rho = result.point if winner is result.edge.best else _shape_of(result, winner)
    bw = winner.scale
    warnings = [f"the winner sits on a search bound: {b}" for b in result.on_bound] if winner is result.edge.best else \
        ["the best candidate was unstable in another case; the next best stable in every case was taken"]
    if winner is result.edge.best and result.edge.at_top:
        warnings.append(f"the winner's bandwidth is the top of the scan ({bw:g} Hz = fs/40)")
    xo = float(metrics.crossovers_hz[0])
    case = problem.cases[0]
    front = None
    if obj.name == "pareto":
        front = [{"shape": {"zeta": float(sh[0]), "rho": float(sh[1])}, "bandwidth_hz": p.scale,
                  "first_crossover_hz": float(p.crossover_hz), "integral_gain": ki_sum(p.result[0])}
                 for sh, p in obj.front(result.edges(), lambda e: e[1].crossover_hz, lambda e: ki_sum(e[1].result[0]))]
    tuning = {
        "method": "the edge of every shape under the limits, ranked by the objective; PID gains from (bandwidth w, "
                  "shape zeta, rho) scaled by the side masses, searched continuously: w by bisection to the "
                  "feasibility edge, (zeta, rho) by a pattern search over the shape box",
        **obj.record("ki (both sides)", f"{model.input_unit}/(m s)", ki_sum(law), front),
        "rule": f"gantry PID tuned by feedtune.tune.pid ({choice} filters) for {obj.name} under {policy.describe()}",
        "crossover_measure": "first crossover of the CoM loop over the whole contour (incl. the model below the FRF)",
        "ms_measure": "max over frequency of the largest singular value of the 2x2 sensitivity",
        "limits": policy.to_dict(),
        "active_limit": None if act is None else act.to_dict(),
        "checked_case": case.name,
        "frfs": len(frfs),
        "positions_m": [c.x for c in problem.cases],
        "checked_from_hz": float(min(c.pc.freq_hz[0] for c in problem.cases)),
        "checked_to_hz": float(min(c.pc.freq_hz[-1] for c in problem.cases)),
        "stable_in_cases": verify,
        "ms_max": policy.ms_max,
        "ms_found": float(metrics.ms),
        "bandwidth_hz": float(bw),
        "zeta": float(zeta),
        "rho": float(rho),
        "com_crossover_hz": xo,
        "first_crossover_hz": xo,
        "com_phase_margin_deg": float(abs(metrics.phase_margins_deg[0])),
        "search": {"zeta_bounds": list(zb), "rho_bounds": list(rb), "bandwidth_scan_hz": [float(scan[0]),
                   float(scan[-1])], "bandwidth_rtol": RTOL, "shapes_evaluated": len(result.evaluated),
                   "checks": problem.checks, "seconds": round(time.perf_counter() - t0, 3)},
        "filters": filter_record,
        "warnings": warnings,
    }
    return design_gantry_pid(model, kp=law.kp, kd=law.kd, ki=law.ki, filters=pack, fs=fs,
                             delay_samples=delay_samples, x=x, x_grid=x_grid, prefilter1=prefilter1,
                             prefilter2=prefilter2, prefilter_hz=prefilter_hz, tuning=tuning)


# ------------------------------------------------------------------------------------------ own filters
SCREEN_RTOL = 1e-2
"""Bracket [-] of the bandwidth edge when screening a filter."""


def choose_filters(problem: _Problem, given: FilterPack, zeta_bounds, rho_bounds, scan: np.ndarray,
                   objective: Objective):
    """The tuner's own filter pack (:func:`feedtune.tune.filter_choice.choose_filters`): ``(pack, SearchResult or
    None, record)``. Candidates are screened at the winner's shape (the bandwidth edge to ``SCREEN_RTOL``, pruned
    when the first check cannot beat the crossover) and the kept one is refined by a local shape search."""

    def search(pack: FilterPack) -> _Search:
        return _Search(problem, pack, zeta_bounds, rho_bounds, scan, objective)

    what, unit = ("integral gain", "") if objective.by_gain else ("first crossover", "Hz")

    def screen(pack: FilterPack, result: SearchResult, beat: float):
        ref = (tuple(result.point), result.edge.best)
        s = search(pack)
        e = s.edge(tuple(result.point), ref, beat, SCREEN_RTOL)
        note = None
        if e.pruned:
            note = (f"fails at w = {e.fail_scale:.4g} Hz, where the {what} is still below {beat:.4g} {unit} "
                    f"(+{100 * KEEP_GAIN:g} %): it cannot raise it").replace("  (", " (")
        return (None if e.best is None else s.merit(e.best)), e.best, note

    def refine(pack: FilterPack, result: SearchResult, probe: Probe):
        return search(pack).run_from(tuple(result.point), probe)

    return own_filters(given, run=lambda pack: search(pack).run(),
                       objective=lambda r: search(given).merit(r.edge.best), screen=screen, refine=refine,
                       what=what, unit=unit,
                       resonances=merge_resonances([gantry_resonances(c.pc, problem.fs) for c in problem.cases]),
                       peaks=lambda r: gantry_sensitivity_peaks([(r.edge.best.result[0], c.pc) for c in problem.cases],
                                                                r.edge.best.crossover_hz),
                       fs=problem.fs)


def _full_check(law: PidLaw, problem: _Problem):
    """``({case (and FRF): stable}, LimitCheck per FRF)`` of a candidate: the limits in each FRF's checked case and
    stability in every case of every FRF."""
    stable, checks = {}, []
    disk = problem.policy.disk_margin_min is not None
    for i, c in enumerate(problem.cases):
        on = f" (FRF {i + 1})" if len(problem.cases) > 1 else ""
        # the limits in the checked case (as the search analysed it), the Nyquist count alone in the others (all
        # check_cases reads there)
        done = problem.analysed.get((id(law), i))
        metrics = {name: None if pc is None else done[1] if name == c.name and done and done[0] is law
                   else analyze_gantry_case(law, pc, c.weights, figures="limits" if name == c.name else "stability",
                                            disk_margin=disk).metrics
                   for name, pc in c.cases.items()}
        stable.update({name + on: bool(m.stable and m.nyquist_reliable) for name, m in metrics.items() if m})
        checks.append(check_cases(problem.policy, metrics, [c.name]))
    return stable, checks


def _verified_winner(result: SearchResult, problem: _Problem, objective: Objective, tries: int = 5):
    """``(probe, {case: stable}, active limit)`` of the best evaluated candidate that passes the full check (the
    search's winner unless it does not; then the next by the objective)."""
    edges = objective.order([p for _, p in result.edges()], lambda p: p.crossover_hz, lambda p: ki_sum(p.result[0]))
    order = [result.edge.best] + [p for p in edges if p is not result.edge.best]
    for probe in order[:tries]:
        stable, checks = _full_check(probe.result[0], problem)
        if all(stable.values()) and all(c.ok for c in checks):
            actives = [a for a in (c.active() for c in checks) if a is not None]
            return probe, stable, min(actives, key=lambda a: a.slack) if actives else None
    why = ", ".join(k for k, v in stable.items() if not v) or "; ".join(v for c in checks for v in c.violations)
    raise DesignError(f"the best PID candidates meet the limits in the {problem.name} case but fail the full check "
                      f"({why})")


def _shape_of(result: SearchResult, probe: Probe) -> tuple:
    return next(shape for shape, e in result.evaluated.items() if e is not None and e.best is probe)
