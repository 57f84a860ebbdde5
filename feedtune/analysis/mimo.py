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

from dataclasses import dataclass, field

import numpy as np

from .loop import LoopExtension, contour_warnings, crossings, low_frequency_slope, margins, nyquist_winding


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
                 extension: LoopExtension | None = None) -> MimoNyquist:
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
    """
    f = np.asarray(freq_hz, float)
    fc, Lc = (f, L) if extension is None else extension.prepend(f, L)
    D = return_difference_det(Lc)
    slope = low_frequency_slope(fc, D - 1.0)
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


# ---------------------------------------------------------------------------------------- bands
def level_bands(freq_hz, y, level: float = 1.0) -> list[list[float]]:
    """Intervals [Hz] where ``y > level``, with the edges interpolated in log frequency and log ``y``."""
    f = np.asarray(freq_hz, float)
    d = np.log(np.maximum(np.asarray(y, float), 1e-300)) - np.log(level)
    m = d > 0
    if not m.any():
        return []
    lf = np.log(f)

    def edge(i: int) -> float:  # crossing between grid points i and i + 1
        frac = d[i] / (d[i] - d[i + 1])
        return float(np.exp(lf[i] + frac * (lf[i + 1] - lf[i])))

    edges = np.diff(m.astype(np.int8))
    starts = [edge(int(i)) for i in np.flatnonzero(edges == 1)]
    ends = [edge(int(i)) for i in np.flatnonzero(edges == -1)]
    if m[0]:
        starts.insert(0, float(f[0]))
    if m[-1]:
        ends.append(float(f[-1]))
    return [[a, b] for a, b in zip(starts, ends, strict=True)]


# ---------------------------------------------------------------------------------------- metrics
@dataclass(frozen=True)
class MimoMetrics:
    """Frequency-domain figures of a 2x2 loop (thesis §4.4.2).

    The SISO-style keys (``crossovers_hz``, phase and gain margins) are those of the centre-of-mass loop
    ``l_com = w^T L 1`` (common error in, mass-weighted output; ``h (D + ki/s) / (m s^2)`` for the MIMO
    law); ``ms`` is the MIMO ``max sigma_max(S)``; stability is the MIMO Nyquist criterion.

    Attributes
    ----------
    crossovers_hz, phase_margins_deg, phase_margin_deg, gain_margin_db, gain_margins_db, phase_crossovers_hz
        Of the CoM loop [Hz, deg, dB].
    ms, ms_freq_hz : float
        ``max sigma_max(S)`` [-] and its frequency [Hz].
    rejection_band_hz : [float, float] or None
        From the first grid frequency to where ``sigma_max(S)`` first reaches 1 [Hz].
    sigma_max_l_crossovers_hz : list of float
        Where ``sigma_max(L)`` crosses 1 [Hz].
    active_bands_hz : list of [float, float]
        Where ``sigma_max(L) > 1`` (feedback active) [Hz].
    damping_band_hz : [float, float] or None
        The first active band above the CoM crossover: the band of active damping [Hz].
    nyquist : MimoNyquist
    """

    crossovers_hz: list
    phase_margins_deg: list
    phase_margin_deg: float | None
    gain_margin_db: float | None
    gain_margins_db: list
    phase_crossovers_hz: list
    ms: float
    ms_freq_hz: float
    rejection_band_hz: list | None
    sigma_max_l_crossovers_hz: list
    active_bands_hz: list
    damping_band_hz: list | None
    nyquist: MimoNyquist

    @property
    def stable(self) -> bool:
        """MIMO Nyquist stability."""
        return self.nyquist.stable

    def to_dict(self) -> dict:
        """JSON-ready figures (keys carry units; ``ms`` and ``sigma_max_s`` are the same number)."""
        ny = self.nyquist
        return {
            "crossovers_hz": [float(x) for x in self.crossovers_hz],
            "phase_margins_deg": [float(x) for x in self.phase_margins_deg],
            "phase_margin_deg": _f(self.phase_margin_deg),
            "gain_margin_db": _f(self.gain_margin_db),
            "gain_margins_db": [float(x) for x in self.gain_margins_db],
            "phase_crossovers_hz": [float(x) for x in self.phase_crossovers_hz],
            "ms": float(self.ms),
            "ms_freq_hz": float(self.ms_freq_hz),
            "sigma_max_s": float(self.ms),
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
            "warnings": list(ny.warnings),
        }


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)


def com_loop(L: np.ndarray, weights) -> np.ndarray:
    """Centre-of-mass loop ``w^T L [1, 1]^T`` (common error in, weighted output ``w1 y1 + w2 y2``)."""
    w1, w2 = weights
    return w1 * (L[0, 0] + L[0, 1]) + w2 * (L[1, 0] + L[1, 1])


def analyze_mimo(freq_hz, L: np.ndarray, *, weights=(0.5, 0.5), integrators: int | None = None,
                 open_loop_rhp_poles: int = 0, S: np.ndarray | None = None,
                 extension: LoopExtension | None = None) -> MimoMetrics:
    """All figures of :class:`MimoMetrics` for a 2x2 loop on a grid [Hz].

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
    L : ndarray, shape (2, 2, n)
        Loop ``G K``.
    weights : (float, float)
        Mass distribution ``(alpha1, alpha2)`` of the CoM output.
    integrators, open_loop_rhp_poles : int
        See :func:`mimo_nyquist`.
    S : ndarray, shape (2, 2, n), optional
        ``(I + L)^-1`` when already computed.
    extension : LoopExtension, optional
        The loop below the grid from the model, for the Nyquist count (see :func:`mimo_nyquist`); the other
        figures are the grid's.
    """
    f = np.asarray(freq_hz, float)
    S = sensitivity(L) if S is None else S
    smax_s, _ = singular_values(S)
    smax_l, _ = singular_values(L)
    i_ms = int(np.argmax(smax_s))
    lc = com_loop(L, weights)
    wc, pm, w180, gm = margins(f, lc)
    sl_x = list(map(float, crossings(f, np.log(smax_l), 0.0)))
    active = level_bands(f, smax_l, 1.0)
    first = wc[0] if wc else (sl_x[0] if sl_x else None)
    damping = next((b for b in active if first is not None and b[0] > first * 1.02), None)
    if smax_s[0] < 1:
        up = crossings(f, np.log(smax_s), 0.0)
        rej = [float(f[0]), float(up[0]) if up.size else float(f[-1])]
    else:
        rej = None
    ny = mimo_nyquist(f, L, integrators=integrators, open_loop_rhp_poles=open_loop_rhp_poles, extension=extension)
    if extension is not None:
        ms_below = float(np.max(singular_values(sensitivity(extension.L))[0]))
        ny.warnings.extend(extension.warnings(float(smax_s[i_ms]), ms_below))
    return MimoMetrics(wc, pm, min(pm, key=abs) if pm else None, min(gm, key=abs) if gm else None, gm, w180,
                       float(smax_s[i_ms]), float(f[i_ms]), rej, sl_x, active, damping, ny)
