"""The P-PI cascade at its best under the limits policy (thesis Figure 3.9, eq. 3.25; issues 10, 23).

Objective
---------
Which design wins is the objective (:class:`feedtune.tune.search.Objective`): under ``stiffness`` (and ``pareto``) the
highest low-frequency gain ``Ki2 = Kiv Kpx`` [V/(rad s)], the same physical quantity as the MC-PPC's ``Ki2`` (the
law's table-error integral gain, docs/gains.md), among the designs meeting the limits (and the compliance cap, when
given); under ``bandwidth`` the rule below. Stage 2 of the search then climbs ``Ki2`` over every feasible shape
(the tie threshold is 0).

The first crossover ``f_c1`` [Hz] of the loop broken at the plant input, ``L = G_fp (Kpv + Kiv / s)(s G11 + Kpx G21)``
(eq. 3.25, discrete controller, hold and delay in the checked case): ``crossovers_hz[0]`` of
:func:`~feedtune.analysis.ballscrew.analyze_case`, the lowest frequency where ``|L| = 1`` over the whole Nyquist
contour, below the FRF's band too (model extension). It must meet every limit of the
:class:`~feedtune.analysis.limits.Limits` in the checked case (``discrete`` with an FRF, else ``ideal_discrete``) and
the winner must be stable in every analysis case (:func:`~feedtune.analysis.check.check_design`).

The first crossover is nearly flat over the P-PI's shape: on the example FRF (``Ms <= 3.25``, ``PM >= 30 deg``,
``GM >= 6 dB``) most shapes with ``Kiv / Kpv`` and ``Kpx`` below about 10 Hz reach 107-110 Hz; the highest, 110.6 Hz,
has ``Kpx`` on the lower bound of the box (0.1 Hz) and a low-frequency gain ``Ki2 = Kiv Kpx`` [V/(rad s)]
(``L ~ Ki2 / (M s^3)`` below the corners, ``M = m1 + m2``) 29 times smaller than a design at 108.6 Hz. So designs whose
first crossover is within :data:`CROSSOVER_TIE` of the highest one found count as equal and the one with the highest
``Ki2`` (the stiffness against slow disturbances) wins, as :data:`~feedtune.design.gantry_pid.SHAPE_TIE` does for the
gantry PID. The first crossover can jump with the gain: on the Table 3.1 model the loop crosses above the mode
(444 Hz) only while ``|L| > 1`` at the anti-resonance (118 Hz), and just below that gain at 118 Hz. Pushing ``Ki2`` up
inside the tie would put the design on that jump (``|L| = 1.0004`` at 118 Hz), so a design is tied only when its first
crossover stays within the tie with :data:`TIE_GAIN_MARGIN` less ``Kpv``. ``crossover_tie=0`` gives the highest first
crossover alone.

Parametrisation
---------------
With ``wi = Kiv / Kpv`` [rad/s] (the PI corner) the loop is ``L = Kpv l(f)``, ``l = (wi + D) A + Kpx (1 + wi I) B``,
where ``A``, ``B`` are the plant channels ``x1/u``, ``x2/u`` times hold, delay and filter pack, ``D`` the velocity
estimator and ``I`` the integrator (``(1 - z^-1)/T``, ``T/(1 - z^-1)``; ``s``, ``1/s`` in the continuous cases). The
shape ``(wi, Kpx)`` fixes ``l``; ``Kpv`` scales it. The first crossover of an integrating loop grows monotonically with
``Kpv`` (the set where ``|l| <= 1/Kpv`` shrinks from below), so the best ``Kpv`` of a shape is the top of the shape's
feasible set, and the search is a 2-D search over shapes with the edge in ``Kpv`` found per shape.

Search (the surrogate proposes, the analysis decides)
-----------------------------------------------------
1. Surrogate: ``l`` of a shape on one fixed contour (the checked case's lines, 40 points around every lightly damped
   root of plant and filter pack, at least :data:`CONTOUR_POINTS_PER_DECADE`, and the model extension below the lines
   from the analysis' own :func:`~feedtune.analysis.loop.model_extension`), built from the checked
   :class:`~feedtune.analysis.cases.PlantCase`. On it every limit is a set of forbidden gains, exactly per point:
   ``|1 + Kpv l| < 1/ms_max`` is an interval of ``Kpv`` per frequency (a quadratic), so is the disk margin; a
   crossover with ``|PM| < pm_min`` happens at ``Kpv = 1/|l|`` for the frequencies where ``|angle(-l)| < pm_min``;
   ``|GM| < gm_min`` around ``Kpv = 1/|l|`` at each phase crossover (which do not move with ``Kpv``), where the
   Nyquist count also changes. The top of the highest gap between them whose Nyquist count (on the contour) is stable
   is the shape's edge, and ``f_c1`` there its value.
2. Shapes: a :data:`GRID_POINTS` x :data:`GRID_POINTS` log grid over the box, then Nelder-Mead in log coordinates from
   the :data:`STARTS` best separated cells (the feasible set is disconnected): first for the highest ``f_c1``
   (``f*``), then for the highest ``Ki2`` with ``f_c1 >= (1 - CROSSOVER_TIE) f*``, also with less gain (above).
3. Check: for the best shape of each start, the analysis itself (:func:`~feedtune.analysis.ballscrew.analyze_case` on
   the same plant case, :meth:`~feedtune.analysis.limits.Limits.check`) at the surrogate's edge, stepping and bisecting
   ``Kpv`` until the edge is known to :data:`EDGE_TOL` (relative). The rule above picks among the checked candidates
   with the analysis' own figures (``f_c1`` at the edge and with less gain); the winner must pass
   :func:`~feedtune.analysis.check.check_design`, else the next.

Search box (``2 pi`` times these [rad/s]): ``Kiv / Kpv`` and ``Kpx`` from :data:`SHAPE_LOW_HZ` to half the top of the
checked grid, ``Kpv / M`` from :data:`SHAPE_LOW_HZ` to ``fs / 2``. A winner within :data:`BOUND_TOL` of a bound is
reported in ``tuning["warnings"]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from .. import progress
from ..analysis.ballscrew import analyze_case
from ..analysis.cases import CHECKED_WITH_FRF, CHECKED_WITHOUT_FRF, PlantCase
from ..analysis.check import check_design, resolve_limits
from ..analysis.limits import Limits
from ..analysis.loop import band_top_index, count_integrators, model_extension, nyquist_winding
from ..analysis.margins import PROOF_SIGMAS, line_scatter_at
from ..analysis.resolution import ResolutionError, feature_points, lightly_damped
from ..control.discretize import check_sampling, matched
from ..control.filters import FilterPack
from ..design.ppi import PpiDesign, design_ppi
from ..errors import DesignError, UsageError
from ..frf import Frf
from ..models.ballscrew import BallScrewModel
from .ballscrew_filters import ballscrew_resonances, ballscrew_sensitivity_peaks, search_cases
from .compliance import AxialCompliance
from .filter_choice import tune_with_own_filters
from .search import CheckedCases, Objective, robust_frfs

CROSSOVER_TIE = 0.02
"""Designs whose first crossover is within this fraction of the highest found count as equal [-]."""
TIE_GAIN_MARGIN = 0.02
"""A design counts as tied only if its first crossover stays within the tie with this fraction less ``Kpv`` [-]."""
SHAPE_LOW_HZ = 0.1
"""Lower bound of the PI corner ``Kiv / Kpv / (2 pi)``, of ``Kpx / (2 pi)`` and of ``Kpv / M / (2 pi)`` [Hz]."""
SHAPE_HIGH_FRACTION = 0.5
"""Upper bound of the PI corner and of ``Kpx / (2 pi)`` as a fraction of the checked grid's top [-]."""
GRID_POINTS = 16
"""Shapes per axis of the first, coarse pass."""
STARTS = 3
"""Nelder-Mead starts per stage (the best separated grid cells)."""
SCREEN_GRID_POINTS = 6
"""Shapes per axis of the grid a filter candidate's screen falls back to when the candidate makes the current
winner's shape infeasible (the screen otherwise climbs from that shape alone)."""
NM_EVALUATIONS = 60
"""Surrogate evaluations per Nelder-Mead run."""
EDGE_TOL = 1e-3
"""Relative width [-] to which the analysis' feasibility edge in ``Kpv`` is bisected."""
EDGE_STEP = 4e-3
"""First relative step [-] from the surrogate's edge when the analysis disagrees (doubled per step)."""
CONTOUR_POINTS_PER_DECADE = 400
"""Smallest density of the surrogate's contour [points/decade]."""
BOUND_TOL = 0.02
"""A winner within this relative distance of a bound of the search box is reported [-]."""
TWO_PI = 2 * np.pi


# ----------------------------------------------------------------------------------------- surrogate
def _densify(f: np.ndarray, points_per_decade: float) -> np.ndarray:
    """``f`` [Hz] (> 0) with log-spaced points inserted where neighbours are further apart than the density."""
    lf = np.log10(np.unique(f))
    step = np.diff(lf)
    n = np.maximum(np.ceil(step * points_per_decade).astype(int), 1)
    t = np.arange(int(n.max()))[None, :] / n[:, None]
    pts = lf[:-1, None] + step[:, None] * t
    return 10 ** np.r_[pts[t < 1], lf[-1]]


@dataclass(frozen=True)
class Edge:
    """The surrogate's answer for one shape: the highest admissible ``Kpv`` [V/(rad/s)], and the first crossover there
    and with :data:`TIE_GAIN_MARGIN` less gain [Hz] (0 without one)."""

    kpv: float
    fc1_hz: float
    fc1_low_gain_hz: float


class Surrogate:
    """The loop of any P-PI shape on one fixed contour of a plant case (module docstring, step 1).

    Parameters
    ----------
    plant_case : PlantCase
        The checked case (its plant, hold, grid, features and model extension).
    filters : FilterPack
    fs : float
        Sample rate [Hz].
    limits : Limits
    kpv_box : (float, float)
        Range of ``Kpv`` [V/(rad/s)].
    """

    def __init__(self, plant_case: PlantCase, filters: FilterPack, fs: float, limits: Limits,
                 kpv_box: tuple[float, float]):
        pc = plant_case
        Fs = filters.zpk()
        F = matched(Fs, fs).tf if pc.discrete else Fs
        f0 = np.asarray(pc.freq_hz, float)
        feats = np.vstack([pc.features, lightly_damped(F.poles, F.dt), lightly_damped(F.zeros, F.dt)])
        fb = _densify(np.union1d(f0, feature_points(feats, f0[0], f0[-1])), CONTOUR_POINTS_PER_DECADE)
        g = pc.plant(fb)
        ext = model_extension(f0, pc.plant(f0), pc.model_plant)  # the analysis' extension (scale fitted the same way)
        if ext is not None:
            fe = _densify(np.r_[ext.freq_hz, f0[0]], CONTOUR_POINTS_PER_DECADE)[:-1]
            f, g = np.r_[fe, fb], np.concatenate([ext.evaluate(fe), g], axis=-1)
        else:
            f = fb
        H = pc.hold(f) * F.freqresp(f)
        if pc.discrete:
            z1 = np.exp(-2j * np.pi * f / fs)
            D, I = (1 - z1) * fs, 1.0 / ((1 - z1) * fs)
        else:
            D = 2j * np.pi * f
            I = 1.0 / D
        self.freq_hz = f
        self._A, self._B, self._D, self._I = H * g[0], H * g[1], D, I
        self._gm_guard_db = np.zeros(f.size)  # what a gain margin must exceed its limit by (the analysis' rule)
        if pc.noise_db is not None:
            lines = getattr(pc.noise_db, "lines", None) or np.asarray(pc.noise_db, float).__getitem__
            top = float(f0[band_top_index(f0, pc.band_edge)])
            self._gm_guard_db = PROOF_SIGMAS * np.asarray(line_scatter_at(f0, lines, f, top))
        self.limits = limits
        self.kpv_box = (float(kpv_box[0]), float(kpv_box[1]))
        self.evaluations = 0

    def loops(self, wi, kpx) -> np.ndarray:
        """``l`` [V^-1 (rad/s)] of shapes ``wi = Kiv / Kpv`` [rad/s] and ``Kpx`` [1/s] (arrays), shape ``(n, freq)``."""
        wi = np.atleast_1d(np.asarray(wi, float))[:, None]
        kpx = np.atleast_1d(np.asarray(kpx, float))[:, None]
        return (wi + self._D) * self._A + kpx * (1 + wi * self._I) * self._B

    def forbidden(self, l: np.ndarray) -> np.ndarray:
        """Intervals of ``Kpv`` (rows ``[lo, hi]``) that break a limit somewhere on the contour, and the gains where
        the Nyquist count changes (rows ``[k, k]``)."""
        lim = self.limits
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a2 = np.abs(l) ** 2
            re = l.real
            li = -0.5 * np.log(a2)  # log(1 / |l|)
            out = []
            if lim.ms_max is not None:  # |1 + k l|^2 < r^2
                out.append(_quadratic_band(a2, 2 * re, 1 - lim.ms_max**-2))
            if lim.disk_margin_min is not None:  # |1 - k l| > q |1 + k l|, q = 2 / alpha
                q2 = (2.0 / lim.disk_margin_min) ** 2
                out.append(_quadratic_band((q2 - 1) * a2, 2 * re * (1 + q2), q2 - 1))
            if lim.pm_min_deg is not None:
                out.append(_pm_band(li, np.abs(np.angle(-l, deg=True)) - lim.pm_min_deg))
            im = l.imag / np.sqrt(a2)
            j = np.flatnonzero((np.signbit(im[:-1]) != np.signbit(im[1:])) & (re[:-1] + re[1:] < 0))
            t = im[j] / (im[j] - im[j + 1])
            k180 = np.exp(li[j] + t * (li[j + 1] - li[j]))
            out.append(np.c_[k180, k180])
            if lim.gm_min_db is not None or lim.gm_low_min_db is not None:  # gain-increase | gain-reduction margin
                g0 = self._gm_guard_db[j]
                guard = g0 + t * (self._gm_guard_db[j + 1] - g0)
                up = 10 ** (((lim.gm_min_db or 0.0) + guard) / 20)
                down = 10 ** (((lim.gm_low_min_db or 0.0) + guard) / 20)
                out.append(np.c_[k180 / up, k180 * down])
        iv = np.vstack(out)
        return iv[np.all(np.isfinite(iv), axis=1)]

    def gaps(self, l: np.ndarray) -> np.ndarray:
        """Admissible ``Kpv`` intervals (rows ``[lo, hi]``, increasing) inside the box, ignoring stability."""
        return _gaps(self.forbidden(l), self.kpv_box)

    def stable(self, kl: np.ndarray) -> bool:
        """Nyquist stability of the loop ``kl`` on the contour (no open-loop right-half-plane poles)."""
        n = count_integrators(self.freq_hz, kl)
        return int(np.round(nyquist_winding(self.freq_hz, kl, n))) == 0

    def first_crossover(self, kl: np.ndarray) -> float | None:
        """Lowest frequency [Hz] where ``|kl| = 1`` (log-interpolated), None without one."""
        with np.errstate(divide="ignore"):
            d = np.log(np.abs(kl))
        j = np.flatnonzero(np.signbit(d[:-1]) != np.signbit(d[1:]))
        if j.size == 0:
            return None
        j = j[0]
        lf = np.log(self.freq_hz)
        return float(np.exp(lf[j] + d[j] / (d[j] - d[j + 1]) * (lf[j + 1] - lf[j])))

    def edge(self, wi: float, kpx: float) -> Edge | None:
        """The top of the highest stable admissible ``Kpv`` interval of a shape and its first crossover (or None)."""
        self.evaluations += 1
        return _common_edge([self], wi, kpx)


class SurrogateSet:
    """The surrogates of several plant cases (one per measured FRF): a ``Kpv`` is admissible when it is on every
    one (the union of their forbidden intervals), stable when the loop is stable on every one, and the first
    crossover of a shape is the lowest over them (the bandwidth guaranteed on all).

    Parameters
    ----------
    surrogates : sequence of Surrogate
        With the same limits and ``Kpv`` box.
    """

    def __init__(self, surrogates):
        self.members = list(surrogates)
        self.evaluations = 0

    def edge(self, wi: float, kpx: float) -> Edge | None:
        """:meth:`Surrogate.edge` over every member (one candidate judged, :func:`feedtune.progress.judged`)."""
        self.evaluations += 1
        progress.judged()
        return _common_edge(self.members, wi, kpx)


def _gaps(forbidden: np.ndarray, box: tuple[float, float]) -> np.ndarray:
    """Admissible ``Kpv`` intervals (rows ``[lo, hi]``, increasing) inside ``box`` outside the ``forbidden`` rows."""
    klo, khi = box
    iv = forbidden[(forbidden[:, 1] >= klo) & (forbidden[:, 0] <= khi)]
    iv = iv[np.argsort(iv[:, 0], kind="stable")]
    starts = np.r_[klo, np.maximum(np.maximum.accumulate(iv[:, 1]), klo)] if iv.size else np.array([klo])
    ends = np.r_[iv[:, 0], khi]
    keep = ends > starts
    return np.c_[starts[keep], np.minimum(ends[keep], khi)]


def _common_edge(members: list[Surrogate], wi: float, kpx: float) -> Edge | None:
    """The top of the highest ``Kpv`` interval admissible and stable on every member, with the lowest first
    crossover over them there and with :data:`TIE_GAIN_MARGIN` less gain (or None)."""
    loops = [s.loops(wi, kpx)[0] for s in members]
    box = members[0].kpv_box
    khi = box[1]
    for lo, hi in _gaps(np.vstack([s.forbidden(l) for s, l in zip(members, loops, strict=True)]), box)[::-1]:
        k = hi if hi >= khi else hi * (1 - 1e-9)
        if k <= lo:
            continue
        if all(s.stable(k * l) for s, l in zip(members, loops, strict=True)):
            fcs = [s.first_crossover(k * l) for s, l in zip(members, loops, strict=True)]
            if any(fc is None for fc in fcs):
                return None
            lows = [s.first_crossover((1 - TIE_GAIN_MARGIN) * k * l) for s, l in zip(members, loops, strict=True)]
            low = 0.0 if any(x is None for x in lows) else min(lows)
            return Edge(float(k), min(fcs), low)
    return None


def _quadratic_band(a: np.ndarray, b: np.ndarray, c: float) -> np.ndarray:
    """Rows ``[lo, hi]`` of positive ``k`` with ``a k^2 + b k + c < 0`` (``a > 0``, ``c > 0``), one per frequency
    where the roots are real and positive."""
    disc = b * b - 4 * a * c
    m = (disc > 0) & (b < 0) & (a > 0)
    sq = np.sqrt(disc[m])
    return np.c_[(-b[m] - sq) / (2 * a[m]), (-b[m] + sq) / (2 * a[m])]


def _pm_band(li: np.ndarray, excess: np.ndarray) -> np.ndarray:
    """Gains ``1/|l|`` (``li = log(1/|l|)``) of the contour points where a crossover would break the phase margin
    (``excess < 0``), as intervals per neighbouring pair, the boundary interpolated linearly."""
    a, b = excess[:-1] < 0, excess[1:] < 0
    j = np.flatnonzero(a | b)
    if j.size == 0:
        return np.empty((0, 2))
    e0, e1, l0, l1 = excess[j], excess[j + 1], li[j], li[j + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(np.nan_to_num(e0 / (e0 - e1), nan=0.5), 0.0, 1.0)
    mid = l0 + t * (l1 - l0)
    s0 = np.where(a[j], l0, mid)
    s1 = np.where(b[j], l1, mid)
    return np.exp(np.c_[np.minimum(s0, s1), np.maximum(s0, s1)])


# ----------------------------------------------------------------------------------------- shape search
@dataclass(frozen=True)
class _Shape:
    """A shape in log coordinates ``(log wi, log Kpx)`` [log rad/s, log 1/s] with its surrogate edge."""

    x: tuple
    edge: Edge | None

    @property
    def fc1(self) -> float:
        return 0.0 if self.edge is None else self.edge.fc1_hz

    @property
    def log_ki2(self) -> float:
        """``log(Kiv Kpx)`` at the edge [log V/(rad s)]."""
        return -np.inf if self.edge is None else float(np.log(self.edge.kpv) + self.x[0] + self.x[1])


class _ShapeSearch:
    """Grid and Nelder-Mead over shapes on the surrogate (module docstring, step 2)."""

    def __init__(self, surrogate: Surrogate, log_box: tuple[float, float]):
        self.s = surrogate
        self.lo, self.hi = log_box
        self._cache: dict = {}

    def shape(self, x) -> _Shape:
        x = tuple(float(np.clip(v, self.lo, self.hi)) for v in x)
        if x not in self._cache:
            self._cache[x] = _Shape(x, self.s.edge(np.exp(x[0]), np.exp(x[1])))
        return self._cache[x]

    def grid(self, points: int = GRID_POINTS) -> list[_Shape]:
        ax = np.linspace(self.lo, self.hi, points)
        return [self.shape((a, b)) for a in ax for b in ax]

    def starts(self, cells: list[_Shape], key, step: float) -> list[_Shape]:
        """Up to :data:`STARTS` best cells by ``key`` (descending), more than 1.5 grid steps apart from each other."""
        picked: list[_Shape] = []
        for c in sorted(cells, key=key, reverse=True):
            if all(max(abs(c.x[0] - p.x[0]), abs(c.x[1] - p.x[1])) > 1.5 * step for p in picked):
                picked.append(c)
            if len(picked) == STARTS:
                break
        return picked

    def climb(self, start: _Shape, cost, step: float) -> _Shape:
        """Nelder-Mead on ``cost(shape)`` from ``start`` in the box; the best shape seen."""
        from scipy.optimize import minimize

        x0 = np.array(start.x)
        h = 0.5 * step
        simplex = [x0]
        for i in range(2):
            e = np.zeros(2)
            e[i] = h if x0[i] + h <= self.hi else -h
            simplex.append(x0 + e)
        best = [start]

        def fun(x):
            sh = self.shape(x)
            if cost(sh) < cost(best[0]):
                best[0] = sh
            return cost(sh)

        minimize(fun, x0, method="Nelder-Mead", bounds=[(self.lo, self.hi)] * 2,
                 options={"initial_simplex": np.array(simplex), "maxfev": NM_EVALUATIONS, "xatol": 1e-3,
                          "fatol": 1e-9})
        return best[0]


# ----------------------------------------------------------------------------------------- the tuner
@dataclass(frozen=True)
class _Checked:
    """A candidate checked by the analysis: gains at its feasibility edge and its figures there."""

    wi: float
    kpx: float
    kpv: float
    metrics: object
    stage: str
    fc1_low_gain: float

    @property
    def fc1(self) -> float:
        return float(self.metrics.crossovers_hz[0])

    @property
    def ki2(self) -> float:
        return self.kpv * self.wi * self.kpx


def tune_ppi(
    model: BallScrewModel,
    *,
    limits: Limits | None = None,
    ms_max: float | None = None,
    pm_min_deg: float | None = None,
    filters: FilterPack | None = None,
    fs: float = 20000.0,
    delay_samples: int = 1,
    frf: Frf | Sequence[Frf] | None = None,
    crossover_tie: float = CROSSOVER_TIE,
    filter_choice: str = "identical",
    objective: str | Objective | None = None,
    compliance_max: float | None = None,
) -> PpiDesign:
    """The P-PI that wins under ``objective`` among those meeting the limits (module docstring).

    Parameters
    ----------
    model : BallScrewModel
        Design model (the loop below the FRF's band; the plant itself without an FRF).
    limits : Limits, optional
        The limits policy (default: the ``textbook`` profile).
    ms_max, pm_min_deg : float, optional
        Overrides of the policy's peak sensitivity [-] and phase margin [deg].
    filters : FilterPack, optional
        Filter pack in the feedback (default: none).
    fs : float
        Controller sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    frf : Frf or sequence of Frf, optional
        Measured ``x1/u``, ``x2/u``: the limits are checked in the ``discrete`` case on it (else ``ideal_discrete``).
        With several (table positions, loads), on every one, and the objective is the lowest first crossover over
        them.
    crossover_tie : float
        Designs whose first crossover is within this fraction of the highest count as equal; the highest
        low-frequency gain ``Kiv Kpx`` among them wins [-] (0: the highest first crossover alone).
    filter_choice : {"identical", "own"}
        ``identical``: the filter pack as given; ``own``: the tuner chooses notches and a low-pass
        (:mod:`feedtune.tune.filter_choice`; the given filters are candidates), recorded in ``tuning["filters"]``.
    objective : {"stiffness", "bandwidth", "pareto"} or Objective, optional
        Which design wins (default :data:`feedtune.tune.search.DEFAULT_OBJECTIVE`).
    compliance_max : float, optional
        Cap of the axial-mode compliance [rad/V] (:class:`feedtune.tune.compliance.AxialCompliance`).

    Returns
    -------
    PpiDesign
        With ``tuning``: the rule (``method``, ``objective``), the limits (``limits``, ``ms_max``, ``pm_min_deg``), the
        ``active_limit``, ``checked_case``, the figures of the winner, the search box, ``warnings`` (a bound of the box
        reached) and the evaluations made.

    Raises
    ------
    DesignError
        No P-PI in the box meets the limits and is stable in every case.
    """
    if not isinstance(model, BallScrewModel):
        raise UsageError(f"tune_ppi needs a ball-screw model (BallScrewModel), got {type(model).__name__}")
    policy = resolve_limits(limits, ms_max=ms_max, pm_min_deg=pm_min_deg)
    check_sampling(fs, delay_samples)
    if not (np.isfinite(crossover_tie) and 0 <= crossover_tie < 1):
        raise UsageError(f"crossover_tie must be in [0, 1), got {crossover_tie!r}")
    obj = Objective.of(objective, compliance_max)
    obj = Objective(obj.name, obj.compliance_max, crossover_tie)
    filters = filters or FilterPack()
    filters.check_nyquist(fs)
    frfs = robust_frfs(frf)
    case = CHECKED_WITH_FRF if frfs else CHECKED_WITHOUT_FRF
    if filter_choice not in ("identical", "own"):
        raise UsageError(f"filter_choice must be 'identical' or 'own', got {filter_choice!r}")
    with progress.search("tuning P-PI"):
        cases = search_cases(model, fs, delay_samples, frfs, obj.by_gain)  # once: every search shares them
        pcs = [c[case] for c in cases]
        if filter_choice == "identical":
            return _search(model, filters, cases, frfs, case, policy, obj, fs, delay_samples)

        def tune(filters: FilterPack, start: tuple[float, float] | None = None) -> PpiDesign:
            return _search(model, filters, cases, frfs, case, policy, obj, fs, delay_samples, start)

        def at_shape(d: PpiDesign) -> dict:
            """The screen of a filter candidate: the search from the current winner's shape (no grid)."""
            return {"start": (TWO_PI * d.tuning["pi_corner_hz"], TWO_PI * d.tuning["position_corner_hz"])}

        design, record = tune_with_own_filters(
            tune, at_shape, filters, ballscrew_resonances(pcs, fs),
            lambda d: ballscrew_sensitivity_peaks(d.law(), pcs, d.tuning["first_crossover_hz"]), fs, objective=obj)
    if design is None:
        raise DesignError(f"no P-PI meets the limits ({policy.describe()}) in the {case} case with or without "
                          "the filters tried")
    return replace(design, tuning={**design.tuning, "filters": record,
                                   "rule": design.tuning["rule"] + " (own filters)"})


def _search(model: BallScrewModel, filters: FilterPack, cases: list[dict], frfs: list, case: str, policy: Limits,
            obj: Objective, fs: float, delay_samples: int, start: tuple[float, float] | None = None) -> PpiDesign:
    """The search of the module docstring with one filter pack on the plant cases ``cases`` (one dict per FRF, of
    :func:`~feedtune.analysis.ballscrew.plant_cases`); from ``start`` (``(Kiv / Kpv, Kpx)`` [rad/s, 1/s]) the grid
    is skipped and the shapes climb from there (a filter candidate screened at the current winner's shape)."""
    crossover_tie = obj.tie
    pcs = [c[case] for c in cases]
    M = model.total_inertia
    z_box = (TWO_PI * SHAPE_LOW_HZ, TWO_PI * SHAPE_HIGH_FRACTION * min(float(pc.freq_hz[-1]) for pc in pcs))
    kpv_box = (M * TWO_PI * SHAPE_LOW_HZ, M * TWO_PI * fs / 2)
    sur = SurrogateSet([Surrogate(pc, filters, fs, policy, kpv_box) for pc in pcs])
    search = _ShapeSearch(sur, (float(np.log(z_box[0])), float(np.log(z_box[1]))))

    # step 2: shapes on the surrogate
    step = float(search.hi - search.lo) / (GRID_POINTS - 1)
    feasible = [] if start is None else [c for c in [search.shape(np.log(start))] if c.edge is not None]
    if not feasible:  # no start, or the filters make it infeasible: the grid (coarse for a screen)
        feasible = [c for c in search.grid(GRID_POINTS if start is None else SCREEN_GRID_POINTS) if c.edge is not None]
    if not feasible:
        raise DesignError(f"no P-PI gains in the search box meet the limits ({policy.describe()}) with a stable loop "
                          f"in the {case} case; relax the limits or adjust the filter pack")
    first = [search.climb(s, lambda sh: -sh.fc1, step) for s in search.starts(feasible, lambda c: c.fc1, step)]
    top = max(first, key=lambda sh: sh.fc1)
    threshold = 0.0 if obj.by_gain else (1 - crossover_tie) * top.fc1

    def tie_cost(sh: _Shape) -> float:
        if sh.edge is None:
            return 2e3
        short = threshold - min(sh.fc1, sh.edge.fc1_low_gain_hz)
        if short > 0:
            return 1e3 * (1 + short / threshold)
        return -sh.log_ki2

    near = [c for c in feasible if min(c.fc1, c.edge.fc1_low_gain_hz) >= threshold] or [top]
    second = [search.climb(s, tie_cost, step) for s in search.starts(near, lambda c: c.log_ki2, step)]

    # step 3: the analysis decides
    checks = {"n": 0}

    def law_of(wi: float, kpx: float, kpv: float):
        checks["n"] += 1
        return design_ppi(model, Kpx=kpx, Kpv=kpv, Kiv=kpv * wi, filters=filters, fs=fs,
                          delay_samples=delay_samples).law()

    def analyze(wi: float, kpx: float, kpv: float):
        law = law_of(wi, kpx, kpv)
        try:
            return [analyze_case(law, pc, responses=False).metrics for pc in pcs]
        except ResolutionError:  # the loop passes through -1
            return None

    def lowest(ms):
        """The metrics with the lowest first crossover (the guaranteed one); None when one has no crossover."""
        if ms is None or not all(m.crossovers_hz for m in ms):
            return None
        return min(ms, key=lambda m: m.crossovers_hz[0])

    in_turn = CheckedCases(pcs)
    compliance = None if obj.compliance_max is None else AxialCompliance(model, fs, delay_samples)

    def judge(wi: float, kpx: float, kpv: float):
        law = law_of(wi, kpx, kpv)

        def metrics_of(pc):
            try:
                return analyze_case(law, pc, responses=False).metrics
            except ResolutionError:  # the loop passes through -1
                return None

        m = in_turn.guaranteed(metrics_of, policy, case)
        if m is not None and compliance is not None and compliance(law) > obj.compliance_max:
            return None
        progress.judged(None if m is None else kpv * wi * kpx if obj.by_gain else float(m.crossovers_hz[0]))
        return m

    checked: list[_Checked] = []
    seen = set()
    for stage, sh in [("highest crossover", top)] + [("tie: highest Kiv Kpx", s) for s in second]:
        if sh.edge is None or sh.x in seen:
            continue
        seen.add(sh.x)
        wi, kpx = float(np.exp(sh.x[0])), float(np.exp(sh.x[1]))
        found = _edge(lambda k, wi=wi, kpx=kpx: judge(wi, kpx, k), sh.edge.kpv, kpv_box)
        if found is not None:
            low = lowest(analyze(wi, kpx, (1 - TIE_GAIN_MARGIN) * found[0]))
            low_fc1 = float(low.crossovers_hz[0]) if low is not None else 0.0
            checked.append(_Checked(wi, kpx, found[0], found[1], stage, low_fc1))
    if not checked:
        raise DesignError(f"no P-PI gains proposed by the search meet the limits ({policy.describe()}) in the "
                          f"{case} case; relax the limits or adjust the filter pack")
    best_fc1 = max(c.fc1 for c in checked)
    if obj.by_gain:
        order = obj.order(checked, lambda c: c.fc1, lambda c: c.ki2)
    else:  # tied only when the crossover stays within the tie with less gain (module docstring)
        tied = sorted([c for c in checked if min(c.fc1, c.fc1_low_gain) >= (1 - crossover_tie) * best_fc1],
                      key=lambda c: -c.ki2)
        order = tied + sorted([c for c in checked if c not in tied], key=lambda c: -c.fc1)
    refused = []
    for c in order:
        design = design_ppi(model, Kpx=c.kpx, Kpv=c.kpv, Kiv=c.kpv * c.wi, filters=filters, fs=fs,
                            delay_samples=delay_samples)
        verdicts = [check_design(design, frf=f, limits=policy, cases=cs) for f, cs in zip(frfs or [None], cases,
                                                                                         strict=True)]
        if all(v.ok for v in verdicts):
            break
        refused.append("; ".join(x for v in verdicts for x in v.violations))
    else:
        raise DesignError("the best P-PI candidates fail the design check: " + " | ".join(refused))
    tuning = _record(c, verdicts, policy, case, crossover_tie, best_fc1, z_box, kpv_box, M, sur.evaluations,
                     checks["n"], refused)
    front = None
    if obj.name == "pareto":
        front = [{"shape": {"pi_corner_hz": x.wi / TWO_PI, "position_corner_hz": x.kpx / TWO_PI},
                  "first_crossover_hz": x.fc1, "integral_gain": x.ki2}
                 for x in obj.front(checked, lambda x: x.fc1, lambda x: x.ki2)]
    tuning.update(obj.record("Ki2", f"{model.input_unit}/(rad s)", c.ki2, front))
    tuning["rule"] = f"P-PI tuned by feedtune.tune.ppi for {obj.name} under {policy.describe()}"
    if compliance is not None:
        tuning["axial_compliance_rad_per_V"] = compliance(design.law())
    return PpiDesign(model, dict(design.ppi_gains), filters, float(fs), int(delay_samples), tuning)


def _edge(judge, k0: float, box: tuple[float, float]):
    """The analysis' feasibility edge in ``Kpv`` near the surrogate's ``k0``: ``(kpv, metrics)`` or None.

    From ``k0``, steps of :data:`EDGE_STEP` (doubling) up while ``judge`` passes, or down until it passes; then
    bisection in log ``Kpv`` between the highest passing and the lowest failing gain above it to :data:`EDGE_TOL`.
    """
    m0 = judge(k0)
    up = m0 is not None
    ok, bad = ((k0, m0), None) if up else (None, k0)
    step, k_prev = EDGE_STEP, k0
    for _ in range(4 if up else 8):
        k = float(np.clip(k0 * (1 + step) if up else k0 * (1 - step), *box))
        if k == k_prev:  # on a bound of the box
            break
        m = judge(k)
        if m is not None:
            ok = (k, m)
        else:
            bad = k
        if (m is None) == up:  # crossed the edge
            break
        step, k_prev = 2 * step, k
    if ok is None:
        return None
    while bad is not None and bad / ok[0] - 1 > EDGE_TOL:
        k = float(np.sqrt(ok[0] * bad))
        m = judge(k)
        if m is not None:
            ok = (k, m)
        else:
            bad = k
    return ok


def _record(c: _Checked, verdicts: list, policy: Limits, case: str, tie: float, best_fc1: float, z_box, kpv_box,
            M: float, n_surrogate: int, n_checks: int, refused: list[str]) -> dict:
    """The ``tuning`` record of the winner (the rule, the limits, the figures, the box and its warnings); with
    several FRFs the figures are those of the FRF with the lowest first crossover, the active limit the one with
    the smallest slack over all."""
    m = min((v.analysis.cases[case].metrics for v in verdicts), key=lambda x: x.crossovers_hz[0])
    actives = [a for a in (v.limit_check.active() for v in verdicts) if a is not None]
    act = min(actives, key=lambda a: a.slack) if actives else None
    warnings = []
    for name, v, (lo, hi), unit, scale in (("Kiv/Kpv", c.wi, z_box, "Hz", TWO_PI), ("Kpx", c.kpx, z_box, "Hz", TWO_PI),
                                           ("Kpv/(m1+m2)", c.kpv / M, (kpv_box[0] / M, kpv_box[1] / M), "Hz",
                                            TWO_PI)):
        if v <= lo * (1 + BOUND_TOL):
            warnings.append(f"{name} = {v / scale:.4g} {unit} (x 2 pi) is at the lower bound {lo / scale:.4g} {unit} "
                            "of the search box: the best P-PI may lie beyond it")
        elif v >= hi / (1 + BOUND_TOL):
            warnings.append(f"{name} = {v / scale:.4g} {unit} (x 2 pi) is at the upper bound {hi / scale:.4g} {unit} "
                            "of the search box: the best P-PI may lie beyond it")
    if refused:
        warnings.append(f"{len(refused)} better candidate(s) refused by the design check: " + " | ".join(refused))
    return {
        "method": "the designs at the gain-feasibility edge (crossovers_hz[0] of the checked case, below-band "
                  "crossovers included, meeting the limits, stable in every case) ranked by the objective; under "
                  f"bandwidth crossovers within {100 * tie:g} % of the highest count as equal and the highest "
                  "low-frequency gain Kiv*Kpx wins; shapes (Kiv/Kpv, Kpx) by grid and Nelder-Mead on the loop's "
                  "gain-feasibility edge, Kpv bisected to the analysis' edge",
        "limits": policy.to_dict(),
        "ms_max": policy.ms_max,
        "pm_min_deg": policy.pm_min_deg,
        "checked_case": case,
        "frfs": len(verdicts) if verdicts[0].analysis.cases.get("discrete") is not None else 0,
        "active_limit": None if act is None else {"name": act.name, "value": act.value, "limit": act.limit,
                                                   "freq_hz": act.freq_hz},
        "first_crossover_hz": float(m.crossovers_hz[0]),
        "best_first_crossover_hz": float(best_fc1),
        "crossover_tie": float(tie),
        "chosen_by": c.stage,
        "ms_found": float(m.ms),
        "phase_margin_deg": m.phase_margin_deg,
        "gain_margin_db": m.gain_margin_db,
        "low_frequency_gain_Ki2": float(c.ki2),
        "low_frequency_gain_unit": "V/(rad s)",
        "pi_corner_hz": float(c.wi / TWO_PI),
        "position_corner_hz": float(c.kpx / TWO_PI),
        "velocity_crossover_hz": float(c.kpv / M / TWO_PI),
        "search_box_hz": {"pi_corner": [z / TWO_PI for z in z_box], "position_corner": [z / TWO_PI for z in z_box],
                          "velocity_crossover": [k / M / TWO_PI for k in kpv_box]},
        "evaluations": {"surrogate_shapes": int(n_surrogate), "analysis_checks": int(n_checks)},
        "warnings": warnings,
    }
