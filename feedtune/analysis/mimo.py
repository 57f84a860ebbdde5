"""Vectorised 2x2 MIMO frequency-domain analysis: singular values, sensitivity, MIMO Nyquist (thesis §4.4.2).

Responses are arrays of shape ``(2, 2, n_freq)`` (output, input, frequency), the layout of
:class:`~feedtune.frf.Frf`. Every operation is batched over the frequency axis with closed-form 2x2
algebra (products, adjugate inverses, determinants, singular values); there is no per-frequency loop.

* Singular values of a 2x2 matrix ``A``: ``sigma^2 = (|A|_F^2 +- sqrt(|A|_F^4 - 4 |det A|^2)) / 2``.
* ``S = (I + L)^-1``, ``Ms = max_w sigma_max(S)``; ``sigma_max(S) < 1`` means disturbances are rejected in
  every input direction.
* MIMO Nyquist criterion: the closed loop is stable when ``det(I + L)`` makes ``P`` counter-clockwise
  encirclements of the origin (``P`` = open-loop right-half-plane poles) and does not pass through it. The
  winding is counted by :func:`feedtune.analysis.loop.nyquist_winding` on ``1 + (det(I + L) - 1)``: along
  the positive frequencies from the unwrapped phase, twice by conjugate symmetry, plus the indentation of
  radius ``2 pi f_0`` (the contour's lowest frequency) around the open-loop poles at ``s = 0`` (``z = 1``),
  on which ``det(I + L) ~ c / s^n`` turns clockwise by about ``n pi``. ``n`` is the *local* slope of
  ``|det(I + L) - 1|`` at ``f_0``: with integrating controllers ``tr L ~ 1/s^3`` dominates
  ``det L ~ 1/s^4`` down to ``L^2 ki / (2 k)`` rad/s, and between the two asymptotes the slope (1.2-2.9 for
  gantry PIDs of 2-8 Hz bandwidth at lowest lines of 2-20 Hz) does not say how far the arc turns. The
  analysis cases therefore extend the loop below the grid with the model
  (:func:`feedtune.analysis.loop.model_extension`, down to 1e-5 Hz, where the slope is the structural 4 for
  practical designs). The arc is that of ``det(I + L) - 1`` drawn about 1, so where
  ``|det(I + L) - 1| < 1`` at the first line it adds no turn about the origin (counting a full turn of
  ``det(I + L)`` there, as this module did before, miscounted by one). A discrete loop is analysed on the
  unit circle: the grid must end at ``fs / 2``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .loop import (
    LoopExtension,
    Margins,
    assumptions,
    band_top_index,
    check_low_end,
    contour_warnings,
    gain_margin_entries,
    line_resolution_warnings,
    loop_margins,
    low_frequency_slope,
    nyquist_winding,
    piecewise,
    possible_crossings,
    possible_warning,
    scalar_loops,
    scatter_of,
    with_possible,
    worst,
)
from .margins import (
    NEGLIGIBLE_LOOP,
    crossings,
    disk_margins,
    level_bands,
    line_scatter_at,
    merge_chatter,
    peak,
    prune_bands,
)
from .resolution import (
    INTERPOLATION,
    MAX_ROUNDS,
    SPLIT,
    check_samples,
    feature_points,
    pair_unresolved,
    peak_rounds,
    resolve,
    root_rounds,
)


# ---------------------------------------------------------------------------------------- 2x2 algebra
def matmul(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Batched product of ``(2, 2, n)`` arrays (a ``(2, 2)`` constant broadcasts over the batch)."""
    A = A if A.ndim == 3 else A[:, :, None]
    B = B if B.ndim == 3 else B[:, :, None]
    return np.array([[A[0, 0] * B[0, 0] + A[0, 1] * B[1, 0], A[0, 0] * B[0, 1] + A[0, 1] * B[1, 1]],
                     [A[1, 0] * B[0, 0] + A[1, 1] * B[1, 0], A[1, 0] * B[0, 1] + A[1, 1] * B[1, 1]]])


def matvec(A: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batched ``A v`` for ``A`` of shape ``(2, 2, n)`` and ``v`` of shape ``(2, n)``."""
    return np.array([A[0, 0] * v[0] + A[0, 1] * v[1], A[1, 0] * v[0] + A[1, 1] * v[1]])


def det2(A: np.ndarray) -> np.ndarray:
    """Determinant of each 2x2 matrix, shape ``(n,)``."""
    return A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]


def inv2(A: np.ndarray) -> np.ndarray:
    """Inverse of each 2x2 matrix by the adjugate formula."""
    d = det2(A)
    return np.array([[A[1, 1], -A[0, 1]], [-A[1, 0], A[0, 0]]]) / d


def identity2(n: int) -> np.ndarray:
    """``I`` repeated ``n`` times, shape ``(2, 2, n)``."""
    out = np.zeros((2, 2, n), complex)
    out[0, 0] = out[1, 1] = 1.0
    return out


def singular_values(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Upper and lower singular values ``(sigma_max, sigma_min)`` of each 2x2 matrix [units of A].

    ``sigma_max^2`` is the larger eigenvalue of the Hermitian ``A^H A = [[p, b], [conj(b), g]]``,
    ``(p + g)/2 + sqrt(((p - g)/2)^2 + |b|^2)`` (a sum of squares under the root: accurate also when the two
    singular values are equal), and ``sigma_min = |det A| / sigma_max``.

    Examples
    --------
    >>> A = np.array([[3.0, 0.0], [0.0, 0.5]])[:, :, None]
    >>> [float(s[0]) for s in singular_values(A)]
    [3.0, 0.5]
    """
    a, b, c, d = A[0, 0], A[0, 1], A[1, 0], A[1, 1]
    p = np.abs(a) ** 2 + np.abs(c) ** 2
    g = np.abs(b) ** 2 + np.abs(d) ** 2
    off = np.conj(a) * b + np.conj(c) * d
    smax = np.sqrt(0.5 * (p + g) + np.hypot(0.5 * (p - g), np.abs(off)))
    with np.errstate(divide="ignore", invalid="ignore"):
        smin = np.where(smax > 0, np.abs(det2(A)) / smax, 0.0)
    return smax, smin


def sensitivity_gain(L: np.ndarray) -> np.ndarray:
    """``sigma_max((I + L)^-1)`` per frequency [-] without forming the inverse: ``sigma_max(A) / |det A|`` with
    ``A = I + L`` (``sigma_max(S) = 1 / sigma_min(A)`` and ``sigma_min sigma_max = |det|``); equal to
    ``singular_values(sensitivity(L))[0]`` to rounding, at a third of its cost (the tuners' cheap bounds)."""
    a, b, c, d = 1.0 + L[0, 0], L[0, 1], L[1, 0], 1.0 + L[1, 1]
    p = a.real ** 2 + a.imag ** 2 + c.real ** 2 + c.imag ** 2
    g = b.real ** 2 + b.imag ** 2 + d.real ** 2 + d.imag ** 2
    off = np.abs(np.conj(a) * b + np.conj(c) * d)
    smax = np.sqrt(0.5 * (p + g) + np.hypot(0.5 * (p - g), off))
    with np.errstate(divide="ignore", invalid="ignore"):
        return smax / np.abs(a * d - b * c)


def sensitivity(L: np.ndarray) -> np.ndarray:
    """``S = (I + L)^-1``, shape ``(2, 2, n)``."""
    return inv2(identity2(L.shape[2]) + L)


def return_difference_det(L: np.ndarray) -> np.ndarray:
    """``det(I + L)`` [-] per frequency."""
    return (1.0 + L[0, 0]) * (1.0 + L[1, 1]) - L[0, 1] * L[1, 0]


# ---------------------------------------------------------------------------------------- Nyquist
@dataclass(frozen=True)
class MimoNyquist:
    """MIMO Nyquist result.

    Attributes
    ----------
    encirclements : int
        Clockwise encirclements of the origin by ``det(I + L)`` over the whole contour.
    winding : float
        Counter-clockwise winding number before rounding [-].
    open_loop_rhp_poles : int
        ``P`` [-].
    integrators : int
        Open-loop poles at the origin (as given, else the local slope rounded) [-].
    low_frequency_slope : float
        ``-d log|det(I + L) - 1| / d log f`` over the first octave of the contour; the indentation arc turns
        ``det(I + L)`` by about this many half turns [-].
    stable : bool
        ``encirclements + P == 0`` and the locus does not pass through the origin.
    min_distance : float
        Smallest ``|det(I + L)|`` on the contour [-].
    warnings : list of str
    contour_low_hz : float or None
        Lowest frequency of the contour [Hz]: the grid's first, or the model extension's.
    model_extension : dict or None
        :meth:`~feedtune.analysis.loop.LoopExtension.to_dict` of the extension used, None without one.
    """

    encirclements: int
    winding: float
    open_loop_rhp_poles: int
    integrators: int
    low_frequency_slope: float
    stable: bool
    min_distance: float
    warnings: list = field(default_factory=list)
    contour_low_hz: float | None = None
    model_extension: dict | None = None


def det_winding(freq_hz, D: np.ndarray, slope: float) -> float:
    """Counter-clockwise winding of ``D = det(I + L)`` around 0 on the indented Nyquist contour [-].

    :func:`~feedtune.analysis.loop.nyquist_winding` of ``1 + (D - 1)``: ``D - 1 = tr L + det L ~ c / s^slope``
    on the indentation arc (the *local* slope at ``freq_hz[0]`` matters; the turn that closes the curve
    nearest to ``slope`` half turns is used).
    """
    return float(nyquist_winding(freq_hz, np.asarray(D) - 1.0, slope))


def mimo_nyquist(freq_hz, L: np.ndarray, *, integrators: int | None = None, open_loop_rhp_poles: int = 0,
                 extension: LoopExtension | None = None, below_grid: str = "refuse") -> MimoNyquist:
    """Closed-loop stability from the encirclements of the origin by ``det(I + L)``.

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Strictly increasing grid [Hz] from near 0 to where ``|L|`` has rolled off (or to ``fs/2`` for a
        discrete loop).
    L : ndarray, shape (2, 2, n)
        Loop transfer matrix ``G K``.
    integrators : int, optional
        Number of open-loop poles at ``s = 0`` (``z = 1``), e.g. 2 for the gantry's rigid body plus one per
        integrating controller channel. Reported and checked against the slope; the indentation itself
        uses the local slope of ``det(I + L) - 1`` at the contour's first frequency (see :func:`det_winding`).
    open_loop_rhp_poles : int
        Open-loop poles in the right half plane (outside the unit circle) [-].
    extension : LoopExtension, optional
        The loop ``(2, 2, m)`` below ``freq_hz[0]`` from the model
        (:func:`~feedtune.analysis.loop.model_extension`): the contour starts at its first frequency.
    below_grid : {"refuse", "assume"}
        Without an extension, refuse (default) or accept a grid that starts off the asymptote of
        ``det(I + L) - 1`` (:func:`~feedtune.analysis.loop.check_low_end`).
    """
    if below_grid not in ("refuse", "assume"):
        raise ValueError(f"below_grid must be 'refuse' or 'assume', got {below_grid!r}")
    f = np.asarray(freq_hz, float)
    fc, Lc = (f, L) if extension is None else extension.prepend(f, L)
    D = return_difference_det(Lc)
    slope = low_frequency_slope(fc, D - 1.0)
    if extension is None and below_grid == "refuse":
        check_low_end(fc, slope, float(abs(D[0] - 1.0)), integrators or 0)
    warnings = contour_warnings(fc, slope, float(abs(D[0] - 1.0)), integrators, extension is not None)
    winding = det_winding(fc, D, slope)
    n_ccw = int(np.round(winding))
    if abs(winding - n_ccw) > 0.2:
        warnings.append(f"MIMO Nyquist winding {winding:.2f} is not close to an integer; grid too coarse")
    smax_end = singular_values(L[:, :, -1:])[0][0]
    if smax_end >= 1:
        warnings.append(f"sigma_max(L) = {smax_end:.3g} >= 1 at the highest frequency {f[-1]:g} Hz; "
                        "extend the grid for a valid Nyquist count")
    min_dist = float(np.min(np.abs(D)))
    cw = -n_ccw
    stable = (cw + int(open_loop_rhp_poles) == 0) and min_dist > 1e-9
    n_int = round(slope) if integrators is None else int(integrators)
    return MimoNyquist(cw, float(winding), int(open_loop_rhp_poles), n_int, slope, bool(stable), min_dist,
                       warnings, float(fc[0]), None if extension is None else extension.to_dict())


# ---------------------------------------------------------------------------------------- metrics
@dataclass(frozen=True)
class MimoMetrics:
    """Frequency-domain figures of a 2x2 loop (thesis section 4.4.2), exact for the loop it was given.

    The SISO-style keys (``crossovers_hz``, phase and gain margins) are those of the centre-of-mass loop
    ``l_com = w^T L 1`` (common error in, mass-weighted output; ``h (D + ki/s) / (m s^2)`` for the MIMO
    law), over the whole contour; ``ms`` is the MIMO ``max sigma_max(S)``; stability is the MIMO Nyquist criterion.

    Attributes
    ----------
    crossovers_hz, phase_margins_deg, phase_margin_deg, gain_margin_db, gain_margins_db, phase_crossovers_hz
        Of the CoM loop [Hz, deg, dB]; the worst margins are those closest to 0.
    ms, ms_freq_hz : float
        ``max sigma_max(S)`` [-] and its frequency [Hz].
    rejection_bands_hz : list of [float, float]
        Every band [Hz] where ``sigma_max(S) < 1`` (a band from the contour's low end starts at 0 Hz).
    sigma_max_l_crossovers_hz : list of float
        Where ``sigma_max(L)`` crosses 1 [Hz].
    active_bands_hz : list of [float, float]
        Where ``sigma_max(L) > 1`` (feedback active) [Hz].
    damping_band_hz : [float, float] or None
        The first active band above the CoM crossover: the band of active damping [Hz].
    nyquist : MimoNyquist
    below_band_crossovers_hz : list of float
        CoM crossovers [Hz] on the model extension, below the grid.
    disk_margin : float
        ``1 / max sigma_max(S - I/2)`` [-]: the balanced disk margin for a full-block (unstructured) perturbation,
        a lower bound of the loop-at-a-time one (:mod:`feedtune.analysis.margins`).
    disk_margin_freq_hz : float or None
    merged_crossovers : list of dict
    points : int
    interpolation : str or None
    band_top_hz, band_top_loop_gain : float or None
        For a measured loop, the FRF's last line [Hz] and ``sigma_max(L)`` there [-] (see
        :class:`~feedtune.analysis.loop.LoopMetrics`).
    possible_crossovers, possible_phase_crossovers : list of dict
        Where the CoM loop comes within the FRF's scatter of a crossing the lines cannot rule out (see
        :class:`~feedtune.analysis.loop.LoopMetrics`); listed among the crossings too.
    gain_margin_sigmas_db : list of float
        For a measured loop, the 1-sigma line scatter [dB] of each gain margin (as
        :attr:`feedtune.analysis.loop.LoopMetrics.gain_margin_sigmas_db`).
    """

    crossovers_hz: list
    phase_margins_deg: list
    phase_margin_deg: float | None
    gain_margin_db: float | None
    gain_margins_db: list
    phase_crossovers_hz: list
    ms: float
    ms_freq_hz: float
    rejection_bands_hz: list
    sigma_max_l_crossovers_hz: list
    active_bands_hz: list
    damping_band_hz: list | None
    nyquist: MimoNyquist
    below_band_crossovers_hz: list = field(default_factory=list)
    disk_margin: float = float("inf")
    disk_margin_freq_hz: float | None = None
    merged_crossovers: list = field(default_factory=list)
    points: int = 0
    interpolation: str | None = None
    band_top_hz: float | None = None
    band_top_loop_gain: float | None = None
    possible_crossovers: list = field(default_factory=list)
    possible_phase_crossovers: list = field(default_factory=list)
    band_edge: dict | None = None
    gain_margin_sigmas_db: list = field(default_factory=list)

    @property
    def assumes(self) -> list[str]:
        """What the figures assume beyond the measured band (:func:`~feedtune.analysis.loop.assumptions`)."""
        return assumptions(self.band_edge, self.band_top_loop_gain)

    @property
    def first_crossover_hz(self) -> float | None:
        """The first CoM crossover the plant may have [Hz] (possible crossovers included), None without one."""
        return float(self.crossovers_hz[0]) if self.crossovers_hz else None

    @property
    def stable(self) -> bool:
        """MIMO Nyquist stability."""
        return self.nyquist.stable

    @property
    def nyquist_reliable(self) -> bool:
        """The winding number came out close to an integer."""
        return abs(self.nyquist.winding - round(self.nyquist.winding)) <= 0.2

    @property
    def warnings(self) -> list:
        """The analysis' warnings."""
        return self.nyquist.warnings

    @property
    def rejection_band_hz(self) -> list | None:
        """The first ``sigma_max(S) < 1`` band [Hz] (kept for scripts written before :attr:`rejection_bands_hz`)."""
        return self.rejection_bands_hz[0] if self.rejection_bands_hz else None

    @property
    def phase_margins(self) -> list[dict]:
        """``[{"freq_hz", "pm_deg"}]`` of the CoM loop."""
        return [{"freq_hz": float(f), "pm_deg": float(p)}
                for f, p in zip(self.crossovers_hz, self.phase_margins_deg, strict=True)]

    @property
    def gain_margins(self) -> list[dict]:
        """``[{"freq_hz", "gm_db"}]`` of the CoM loop, with ``sigma_db`` (1-sigma line scatter) when measured."""
        return gain_margin_entries(self.phase_crossovers_hz, self.gain_margins_db, self.gain_margin_sigmas_db)

    def to_dict(self) -> dict:
        """JSON-ready figures (keys carry units; ``ms`` and ``sigma_max_s`` are the same number)."""
        ny = self.nyquist
        dgm, dpm = disk_margins(self.disk_margin)
        return {
            "crossovers_hz": [float(x) for x in self.crossovers_hz],
            "below_band_crossovers_hz": [float(x) for x in self.below_band_crossovers_hz],
            "phase_margins": self.phase_margins,
            "phase_margins_deg": [float(x) for x in self.phase_margins_deg],
            "phase_margin_deg": _f(self.phase_margin_deg),
            "gain_margins": self.gain_margins,
            "gain_margin_db": _f(self.gain_margin_db),
            "gain_margins_db": [float(x) for x in self.gain_margins_db],
            "phase_crossovers_hz": [float(x) for x in self.phase_crossovers_hz],
            "ms": float(self.ms),
            "ms_freq_hz": float(self.ms_freq_hz),
            "sigma_max_s": float(self.ms),
            "disk_margin": _f(self.disk_margin),
            "disk_gain_margin_db": _f(dgm),
            "disk_phase_margin_deg": _f(dpm),
            "disk_margin_freq_hz": _f(self.disk_margin_freq_hz),
            "rejection_bands_hz": [[float(a), float(b)] for a, b in self.rejection_bands_hz],
            "rejection_band_hz": self.rejection_band_hz,
            "sigma_max_l_crossovers_hz": [float(x) for x in self.sigma_max_l_crossovers_hz],
            "active_bands_hz": self.active_bands_hz,
            "damping_band_hz": self.damping_band_hz,
            "stable": bool(ny.stable),
            "nyquist_encirclements": int(ny.encirclements),
            "open_loop_rhp_poles": int(ny.open_loop_rhp_poles),
            "integrators": int(ny.integrators),
            "nyquist_min_distance": float(ny.min_distance),
            "nyquist_low_frequency_slope": float(ny.low_frequency_slope),
            "nyquist_low_frequency_hz": _f(ny.contour_low_hz),
            "model_extension": ny.model_extension,
            "merged_crossovers": list(self.merged_crossovers),
            "points": int(self.points),
            "interpolation": self.interpolation,
            "nyquist_reliable": bool(self.nyquist_reliable),
            "band_top_hz": _f(self.band_top_hz),
            "band_top_loop_gain": _f(self.band_top_loop_gain),
            "first_crossover_hz": _f(self.first_crossover_hz),
            "possible_crossovers": list(self.possible_crossovers),
            "possible_phase_crossovers": list(self.possible_phase_crossovers),
            "band_edge": self.band_edge,
            "assumes": self.assumes,
            "warnings": list(ny.warnings),
        }


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)


def com_loop(L: np.ndarray, weights) -> np.ndarray:
    """Centre-of-mass loop ``w^T L [1, 1]^T`` (common error in, weighted output ``w1 y1 + w2 y2``)."""
    w1, w2 = weights
    return w1 * (L[0, 0] + L[0, 1]) + w2 * (L[1, 0] + L[1, 1])


def _sigma_max(A: np.ndarray) -> np.ndarray:
    return singular_values(A)[0]


# ---------------------------------------------------------------------------------------- resolution
def resolve_rounds(freq_hz, evaluate, loops, features=None, known: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~feedtune.analysis.resolution.resolve` (the same grid and response, point for point), with the rules
    checked on all scalar loops at once and in each round only on the intervals that round made: a rule reads the
    two ends of an interval alone, so an interval left as it was keeps its verdict. ``loops(R)`` must act point by
    point (the scalar loops of a response block). A loop that cannot be resolved is handed to
    :func:`~feedtune.analysis.resolution.resolve` for its error."""
    f = np.asarray(freq_hz, float)
    extra = feature_points(features if features is not None else np.empty((0, 2)), f[0], f[-1])
    R = evaluate(f) if known is None else np.asarray(known)
    ls = np.array(loops(R), complex).reshape(-1, f.size)  # every scalar loop, one row each
    if extra.size:
        f, R, ls = _merge_points(f, R, ls, extra, evaluate(extra), loops)
    bad = pair_unresolved(ls[:, :-1], ls[:, 1:]).any(axis=0)  # resolution.unresolved, all loops at once
    t = np.arange(1, SPLIT + 1) / (SPLIT + 1)
    for rnd in range(MAX_ROUNDS + 1):
        if not bad.any():
            return f, R
        split = bad & (f[1:] > f[:-1] * (1 + 1e-12))
        if not split.any() or rnd == MAX_ROUNDS:
            break
        i = np.flatnonzero(split)
        lo, hi = np.log(f[i]), np.log(f[i + 1])
        fn = np.exp(lo[:, None] + (hi - lo)[:, None] * t[None, :]).ravel()
        f, R, ls, bad, new = _merge_points(f, R, ls, fn, evaluate(fn), loops, bad)
        touched = np.flatnonzero(new[:-1] | new[1:])
        if touched.size:
            bad[touched] = pair_unresolved(ls[:, touched], ls[:, touched + 1]).any(axis=0)
    return resolve(freq_hz, evaluate, loops, features, known)  # unresolvable: resolve's own error


def _merge_points(f, R, ls, fn, Rn, loops, bad=None):
    """The grid with the points ``fn`` (response ``Rn``) merged in order as :func:`~feedtune.analysis.resolution.
    resolve` merges them (a point equal to one on the grid is not added), and the scalar loops ``ls`` (rows) with
    them; with ``bad`` also the verdicts of the intervals between two points that were neighbours before and a mask of
    the new points."""
    fa = np.r_[f, fn]
    order = np.argsort(fa, kind="stable")
    fa = fa[order]
    keep = np.r_[True, np.diff(fa) > 0]
    order, fa = order[keep], fa[keep]
    Ra = np.concatenate([R, Rn], axis=-1)[..., order]
    la = np.concatenate([ls, np.array(loops(Rn), complex).reshape(ls.shape[0], fn.size)], axis=1)[:, order]
    if bad is None:
        return fa, Ra, la
    new = order >= f.size
    kept = np.zeros(fa.size - 1, bool)  # intervals between two old points keep the verdict of the old interval
    both_old = ~(new[:-1] | new[1:])
    kept[both_old] = bad[order[:-1][both_old]]
    return fa, Ra, la, kept, new


# ---------------------------------------------------------------------------------------- joint refinement
# The limits' figures refine the CoM loop's crossovers and phase crossovers (margins.crossings and phase_crossovers by
# resolution.refine_roots), the loop at them (loop.loop_margins) and the peaks of sigma_max(S) and sigma_max(S - I/2)
# (margins.peak by resolution.refine_peaks). Called one after the other, each asks for the loop round by round: some
# twenty evaluations of a 2x2 loop per analysis. The same refinements as generators (resolution.root_rounds and
# peak_rounds, which refine_roots and refine_peaks run) ask for exactly the same frequencies with the same arithmetic,
# and :func:`_jointly` runs them side by side, so that each round is one evaluation for all of them (six in all): the
# figures are those of the functions named, value for value (the loop is evaluated point by point).
def _on_loop(rounds, values):
    """A :func:`~feedtune.analysis.resolution.root_rounds` / :func:`~feedtune.analysis.resolution.peak_rounds`
    generator driven by the loop: yields the frequencies [Hz] of each round, is sent the loop ``L`` there and sends
    ``values(L, rows)`` (the real function of the brackets ``rows``, one per point) on; returns its result."""
    try:
        f, rows = next(rounds)
        while True:
            L = yield f
            f, rows = rounds.send(values(L, rows))
    except StopIteration as stop:
        return stop.value


def _jointly(fn, tasks: list) -> list:
    """Run generators that yield frequencies [Hz] and are sent the loop ``fn(f)`` there, one evaluation of ``fn`` per
    round for all of them; their return values in order."""
    results: list = [None] * len(tasks)
    asked: dict = {}

    def advance(k, block=None, first=False):
        try:
            fq = next(tasks[k]) if first else tasks[k].send(block)
        except StopIteration as stop:
            results[k] = stop.value
            asked.pop(k, None)
        else:
            asked[k] = fq

    for k in range(len(tasks)):
        advance(k, first=True)
    while asked:
        keys = list(asked)
        parts = [asked[k] for k in keys]
        L = fn(np.concatenate(parts))
        start = 0
        for k, fq in zip(keys, parts, strict=True):
            advance(k, L[..., start:start + fq.size])
            start += fq.size
    return results


def _margin_rounds(f: np.ndarray, lc: np.ndarray, weights, noise, lines: np.ndarray | None = None):
    """:func:`~feedtune.analysis.loop.loop_margins` of the CoM loop ``lc`` on the contour ``f`` as a generator: the
    crossovers (:func:`~feedtune.analysis.margins.crossings` of ``20 log10 |l|``) and phase crossovers
    (:func:`~feedtune.analysis.margins.phase_crossovers`) refined in the same rounds, then the loop at them, then the
    clusters the scatter ``noise`` [dB] may have made settled (``lines``: the points of ``f`` that are FRF lines)."""
    with np.errstate(divide="ignore"):
        db = 20 * np.log10(np.abs(lc))
    ix = np.flatnonzero(np.signbit(db[:-1]) != np.signbit(db[1:]))
    a = np.abs(lc)
    im = lc.imag / np.maximum(a, 1e-300)
    big = a >= NEGLIGIBLE_LOOP
    ip = np.flatnonzero((np.signbit(im[:-1]) != np.signbit(im[1:])) & (lc.real[:-1] + lc.real[1:] < 0)
                        & (big[:-1] | big[1:]))
    n_x = ix.size

    def values(L, rows):  # 20 log10 |l| in the crossovers' brackets, Im l / |l| in the phase crossovers'
        v = com_loop(L, weights)
        a = np.abs(v)
        with np.errstate(divide="ignore"):
            return np.where(rows < n_x, 20 * np.log10(a) - 0.0, v.imag / np.maximum(a, 1e-300))

    idx = np.r_[ix, ip]
    roots = yield from _on_loop(root_rounds(f[idx], f[idx + 1]), values)
    wc, w180 = roots[:n_x], roots[n_x:]
    at = np.r_[wc, w180]
    v = com_loop((yield at), weights) if at.size else np.empty(0, complex)
    Lx, L180 = v[:wc.size], v[wc.size:]
    pm = [float(x) for x in np.rad2deg(np.angle(-Lx))] if wc.size else []
    gm = [float(-20 * np.log10(abs(x))) for x in L180]
    merged: list[dict] = []
    if noise is not None:
        wc, pm, merged = merge_chatter(wc, pm, f, db, noise, lines=lines)
        noise_deg = np.degrees(np.asarray(noise) * np.log(10) / 20)
        w180, gm, merged_180 = merge_chatter(w180, gm, f, np.degrees(np.angle(-lc)), noise_deg, "phase crossovers",
                                             "deg", lines=lines)
        merged += merged_180
    return Margins([float(x) for x in wc], list(pm), [float(x) for x in w180], list(gm), merged)


def _peaks_rounds(f: np.ndarray, curves: list[tuple[np.ndarray, object]], near: float = 0.9):
    """:func:`~feedtune.analysis.margins.peak` of each ``(y on f, quantity(L))`` of ``curves`` as a generator, all
    refined in the same rounds: a list of ``(f [Hz], value)``."""
    grid, lows, highs, owner = [], [], [], []
    for c, (y, _) in enumerate(curves):
        i = int(np.argmax(y))
        grid.append((float(f[i]), float(y[i])))
        if f.size < 3:
            continue
        inner = np.flatnonzero((y[1:-1] >= y[:-2]) & (y[1:-1] >= y[2:]) & (y[1:-1] >= near * y[i])) + 1
        lows.append(f[inner - 1])
        highs.append(f[inner + 1])
        owner.append(np.full(inner.size, c))
    if not owner:
        return grid
    owner_rows = np.concatenate(owner)

    def values(L, rows):
        if len(curves) == 1:
            return curves[0][1](L)
        which = owner_rows[rows]
        out = np.empty(rows.size)
        for c, (_, quantity) in enumerate(curves):
            sel = which == c
            if sel.any():
                out[sel] = quantity(L[..., sel])
        return out

    fp, yp = yield from _on_loop(peak_rounds(np.concatenate(lows), np.concatenate(highs)), values)
    out = []
    for c, at_grid in enumerate(grid):
        sel = owner_rows == c
        if not sel.any():
            out.append(at_grid)
            continue
        k = int(np.argmax(yp[sel]))
        out.append((float(fp[sel][k]), float(yp[sel][k])) if yp[sel][k] >= at_grid[1] else at_grid)
    return out


def _s_peak(L: np.ndarray) -> np.ndarray:
    return _sigma_max(sensitivity(L))


def _half_peak(L: np.ndarray) -> np.ndarray:
    return _sigma_max(sensitivity(L) - 0.5 * identity2(L.shape[2]))


def analyze_mimo(freq_hz, L: np.ndarray | None = None, *, evaluate=None, features=None, weights=(0.5, 0.5),
                 integrators: int | None = None, open_loop_rhp_poles: int = 0, S: np.ndarray | None = None,
                 extension: LoopExtension | None = None, noise_db: np.ndarray | None = None, measured: bool = False,
                 below_grid: str = "refuse", figures: str = "all", disk_margin: bool = True,
                 band_edge=None) -> MimoMetrics:
    """All figures of :class:`MimoMetrics` for a 2x2 loop.

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Samples' grid, or the base grid and band of ``evaluate`` [Hz].
    L : ndarray, shape (2, 2, n), optional
        Loop ``G K`` on ``freq_hz``: the samples without ``evaluate``; with it, ``evaluate(freq_hz)`` already
        computed by the caller (not evaluated again).
    evaluate : callable, optional
        ``evaluate(f)`` -> ``L`` at any ``f`` [Hz] of the band, shape ``(2, 2, len(f))``; the grid is refined with it
        (:func:`~feedtune.analysis.resolution.resolve` on the CoM loop, the diagonal and ``det(I + L) - 1``).
    features : array_like, shape (k, 2), optional
        Lightly damped poles and zeros (Hz, damping) of the exactly known parts.
    weights : (float, float)
        Mass distribution ``(alpha1, alpha2)`` of the CoM output.
    integrators, open_loop_rhp_poles : int
        See :func:`mimo_nyquist`.
    S : ndarray, shape (2, 2, n), optional
        ``(I + L)^-1`` on ``freq_hz`` when already computed (samples only).
    extension : LoopExtension, optional
        The loop below the grid from the model (see :func:`mimo_nyquist`); part of the contour.
    noise_db : ndarray, shape (n,), optional
        Measurement scatter [dB] on ``freq_hz`` of a measured loop (CoM crossover chatter within it is merged).
    measured : bool
        ``freq_hz`` are an FRF's lines interpolated by ``evaluate`` (a warning names unresolved intervals).
    below_grid : {"refuse", "assume"}
        See :func:`mimo_nyquist`.
    figures : {"all", "limits", "stability"}
        ``"limits"``: only what :meth:`~feedtune.analysis.limits.Limits.check` and the tuners' acceptance read
        (crossovers, phase and gain margins, ``Ms``, the disk margin, Nyquist stability and its warnings, the band
        top), each exactly as with ``"all"``; the bands (rejection, active, damping) and the ``sigma_max(L)``
        crossovers are left empty. For the many candidates of a search (the winner is analysed in full).
        ``"stability"``: only the Nyquist count on the resolved contour (``stable``, ``nyquist_reliable`` and the
        count's own warnings, exactly as with ``"all"``); every other figure is empty or nan. For the cases a
        candidate need only be stable in (:func:`~feedtune.analysis.limits.check_cases`).
    disk_margin : bool
        With ``figures="limits"``: compute the disk margin (False: ``inf``, for a policy without a disk-margin
        limit).
    band_edge : BandEdge, optional
        A measured case's record of where its plant is continued (see :func:`~feedtune.analysis.loop.analyze_loop`).
    """
    if figures not in ("all", "limits", "stability"):
        raise ValueError(f"figures must be 'all', 'limits' or 'stability', got {figures!r}")
    full = figures == "all"
    f0 = np.asarray(freq_hz, float)
    extra_warnings: list[str] = []

    def probe(R):
        return [com_loop(R, weights), *scalar_loops(R)]

    if evaluate is not None:
        L0 = evaluate(f0) if L is None else np.asarray(L, complex)
        f, Lg = resolve_rounds(f0, evaluate, probe, features, known=L0)
        S = None
        if measured and figures != "stability":
            extra_warnings += line_resolution_warnings(f0, com_loop(L0, weights))
    else:
        f, Lg = f0, np.asarray(L, complex)
        check_samples(f, probe(Lg))
    if figures == "stability":
        ny = mimo_nyquist(f, Lg, integrators=integrators, open_loop_rhp_poles=open_loop_rhp_poles,
                          extension=extension, below_grid=below_grid)
        fc = f if extension is None else extension.prepend(f, Lg)[0]
        return MimoMetrics([], [], None, None, [], [], math.nan, math.nan, [], [], [], None, ny, points=int(fc.size),
                           disk_margin=math.nan)
    if extension is not None:
        fc, Lc = extension.prepend(f, Lg)
        fn = piecewise(float(f[0]), extension.evaluate, evaluate)
        Sc = sensitivity(Lc)
    else:
        fc, Lc, fn = f, Lg, evaluate
        Sc = sensitivity(Lc) if S is None else S
    smax_s = _sigma_max(Sc)
    smax_l = _sigma_max(Lc) if full else None
    lc = com_loop(Lc, weights)
    fns = {"l": None, "inv_s": None} if fn is None else {"l": lambda fq: _sigma_max(fn(fq)),
                                                          "inv_s": lambda fq: 1.0 / _sigma_max(sensitivity(fn(fq)))}
    noise = lines = None
    if noise_db is not None:
        noise = np.r_[np.zeros(fc.size - f.size), np.interp(np.log(f), np.log(f0), np.asarray(noise_db, float))]
        lines = np.zeros(fc.size, bool)  # the contour's points that are the FRF's lines
        at = np.clip(np.searchsorted(fc, f0), 0, fc.size - 1)
        lines[at[fc[at] == f0]] = True
    half = _sigma_max(Sc - 0.5 * identity2(fc.size)) if full or disk_margin else None
    if fn is None:
        mg = loop_margins(fc, lc, None, noise, lines)
        (ms_f, ms), dm = peak(fc, smax_s), None if half is None else peak(fc, half)
    else:  # the crossings, the loop at them and the peaks in joint rounds (as the functions called above)
        curves = [(smax_s, _s_peak)] + ([] if half is None else [(half, _half_peak)])
        mg, peaks = _jointly(fn, [_margin_rounds(fc, lc, weights, noise, lines), _peaks_rounds(fc, curves)])
        (ms_f, ms), dm = peaks[0], (peaks[1] if half is not None else None)
    dm_f, dm_peak = (math.nan, 0.0) if dm is None else dm
    sl_x: list = []
    active: list = []
    bands: list = []
    if full:
        sl_x = [float(x) for x in crossings(fc, np.log(smax_l), 0.0,
                                            None if fns["l"] is None else (lambda fq: np.log(fns["l"](fq))))]
        active = level_bands(fc, smax_l, 1.0, fns["l"])
        bands = level_bands(fc, 1.0 / smax_s, 1.0, fns.get("inv_s"))
        bands = prune_bands(bands, fc, 1.0 / smax_s - 1.0, scatter_of(smax_l, noise))
    ny = mimo_nyquist(f, Lg, integrators=integrators, open_loop_rhp_poles=open_loop_rhp_poles, extension=extension,
                      below_grid=below_grid)
    if bands and bands[0][0] == fc[0] and ny.integrators > 0:
        bands[0][0] = 0.0
    possible_x: list = []
    possible_180: list = []
    if noise is not None:
        possible_x, possible_180 = possible_crossings(fc, lc, f0, np.asarray(noise_db, float).__getitem__,
                                                      mg.crossovers_hz, mg.phase_crossovers_hz, mg.merged)
    if possible_x or possible_180:
        wc_all, pm_all = with_possible(mg.crossovers_hz, mg.phase_margins_deg, possible_x, "pm_deg")
        w180_all, gm_all = with_possible(mg.phase_crossovers_hz, mg.gain_margins_db, possible_180, "gm_db")
        mg = Margins(wc_all, pm_all, w180_all, gm_all, mg.merged)
        ny.warnings.append(possible_warning(possible_x, possible_180).replace("the loop comes", "the CoM loop comes"))
    wc = mg.crossovers_hz
    first = wc[0] if wc else (sl_x[0] if sl_x else None)
    damping = next((b for b in active if first is not None and b[0] > first * 1.02), None)
    ny.warnings.extend(extra_warnings)
    if mg.merged:
        ny.warnings.append(f"{len(mg.merged)} cluster(s) of CoM crossings within the FRF's scatter were merged "
                           "(merged_crossovers)")
    if extension is not None:  # sigma_max(S) on the grid and below it (the contour's, point by point)
        nx = extension.freq_hz.size
        ny.warnings.extend(extension.warnings(float(np.max(smax_s[nx:])), float(np.max(smax_s[:nx]))))
    i_top = band_top_index(f0, band_edge)
    L_lines = L0 if evaluate is not None else Lg
    return MimoMetrics(wc, mg.phase_margins_deg, worst(mg.phase_margins_deg), worst(mg.gain_margins_db),
                       mg.gain_margins_db, mg.phase_crossovers_hz, float(ms), float(ms_f), bands, sl_x, active,
                       damping, ny, [x for x in wc if x < f[0]], float(1.0 / dm_peak) if dm_peak > 0 else float("inf"),
                       float(dm_f), mg.merged, int(fc.size), INTERPOLATION if measured else None,
                       float(f0[i_top]) if measured else None,
                       float(_sigma_max(L_lines[:, :, i_top:i_top + 1])[0]) if measured else None, possible_x,
                       possible_180, None if band_edge is None else band_edge.to_dict(),
                       [] if noise is None else line_scatter_at(f0, np.asarray(noise_db, float).__getitem__,
                                                                mg.phase_crossovers_hz, float(f0[i_top])))
