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
    check_low_end,
    contour_warnings,
    line_resolution_warnings,
    loop_margins,
    low_frequency_slope,
    nyquist_winding,
    piecewise,
    scalar_loops,
    scatter_of,
    worst,
)
from .margins import crossings, disk_margins, level_bands, peak, prune_bands
from .resolution import INTERPOLATION, check_samples, resolve


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
        """``[{"freq_hz", "gm_db"}]`` of the CoM loop."""
        return [{"freq_hz": float(f), "gm_db": float(g)}
                for f, g in zip(self.phase_crossovers_hz, self.gain_margins_db, strict=True)]

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


def analyze_mimo(freq_hz, L: np.ndarray | None = None, *, evaluate=None, features=None, weights=(0.5, 0.5),
                 integrators: int | None = None, open_loop_rhp_poles: int = 0, S: np.ndarray | None = None,
                 extension: LoopExtension | None = None, noise_db: np.ndarray | None = None, measured: bool = False,
                 below_grid: str = "refuse", figures: str = "all", disk_margin: bool = True) -> MimoMetrics:
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
    figures : {"all", "limits"}
        ``"limits"``: only what :meth:`~feedtune.analysis.limits.Limits.check` and the tuners' acceptance read
        (crossovers, phase and gain margins, ``Ms``, the disk margin, Nyquist stability and its warnings, the band
        top), each exactly as with ``"all"``; the bands (rejection, active, damping) and the ``sigma_max(L)``
        crossovers are left empty. For the many candidates of a search (the winner is analysed in full).
    disk_margin : bool
        With ``figures="limits"``: compute the disk margin (False: ``inf``, for a policy without a disk-margin
        limit).
    """
    if figures not in ("all", "limits"):
        raise ValueError(f"figures must be 'all' or 'limits', got {figures!r}")
    full = figures == "all"
    f0 = np.asarray(freq_hz, float)
    extra_warnings: list[str] = []

    def probe(R):
        return [com_loop(R, weights), *scalar_loops(R)]

    if evaluate is not None:
        L0 = evaluate(f0) if L is None else np.asarray(L, complex)
        f, Lg = resolve(f0, evaluate, probe, features, known=L0)
        S = None
        if measured:
            extra_warnings += line_resolution_warnings(f0, com_loop(L0, weights))
    else:
        f, Lg = f0, np.asarray(L, complex)
        check_samples(f, probe(Lg))
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
    if fn is None:
        fns = {"com": None, "s": None, "half": None, "l": None}
    else:
        fns = {"com": lambda fq: com_loop(fn(fq), weights),
               "s": lambda fq: _sigma_max(sensitivity(fn(fq))),
               "inv_s": lambda fq: 1.0 / _sigma_max(sensitivity(fn(fq))),
               "half": lambda fq: _sigma_max(sensitivity(fn(fq)) - 0.5 * identity2(np.size(fq))),
               "l": lambda fq: _sigma_max(fn(fq))}
    noise = None
    if noise_db is not None:
        lines = np.interp(np.log(f), np.log(f0), np.asarray(noise_db, float))
        noise = np.r_[np.zeros(fc.size - f.size), lines]
    mg = loop_margins(fc, lc, fns["com"], noise)
    ms_f, ms = peak(fc, smax_s, fns["s"])
    if full or disk_margin:
        dm_f, dm_peak = peak(fc, _sigma_max(Sc - 0.5 * identity2(fc.size)), fns["half"])
    else:
        dm_f, dm_peak = math.nan, 0.0
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
    wc = mg.crossovers_hz
    first = wc[0] if wc else (sl_x[0] if sl_x else None)
    damping = next((b for b in active if first is not None and b[0] > first * 1.02), None)
    ny.warnings.extend(extra_warnings)
    if mg.merged:
        ny.warnings.append(f"{len(mg.merged)} cluster(s) of CoM crossings within the FRF's scatter were merged "
                           "(merged_crossovers)")
    if extension is not None:
        ms_grid = float(np.max(_sigma_max(sensitivity(Lg))))
        ms_below = float(np.max(_sigma_max(sensitivity(extension.L))))
        ny.warnings.extend(extension.warnings(ms_grid, ms_below))
    return MimoMetrics(wc, mg.phase_margins_deg, worst(mg.phase_margins_deg), worst(mg.gain_margins_db),
                       mg.gain_margins_db, mg.phase_crossovers_hz, float(ms), float(ms_f), bands, sl_x, active,
                       damping, ny, [x for x in wc if x < f[0]], float(1.0 / dm_peak) if dm_peak > 0 else float("inf"),
                       float(dm_f), mg.merged, int(fc.size), INTERPOLATION if measured else None,
                       float(f0[-1]) if measured else None,
                       float(_sigma_max(Lg[:, :, -1:])[0]) if measured else None)
