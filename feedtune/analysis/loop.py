"""Vectorised SISO loop analysis on a frequency grid: crossovers, margins, sensitivity, Nyquist stability.

All functions take the loop transfer ``L(j w)`` sampled on a strictly increasing grid ``freq_hz`` [Hz]
(positive frequencies). No per-frequency Python loop.

Nyquist criterion with open-loop poles at the origin
----------------------------------------------------
The Nyquist contour runs up the imaginary axis and is indented into the right half plane around ``s = 0``
with radius ``w_min = 2 pi f_min``, the lowest frequency of the contour. Along the positive axis the winding
of ``1 + L`` is taken from the unwrapped phase; the mirrored negative axis contributes the same by conjugate
symmetry; the indentation arc, where ``L(s) ~ L(j w_min) (j w_min / s)^n`` with ``n`` the low-frequency slope
of ``|L|`` (integer number of integrators, read from the data), turns ``L`` clockwise by about ``n pi`` from
``conj(L(j w_min))`` to ``L(j w_min)`` (the exact turn that closes the curve is used); the arc at infinity
contributes nothing when ``|L(j w_max)| < 1``. Closed-loop right-half-plane poles ``Z = N_cw + P`` where
``P`` is the number of open-loop right-half-plane poles.

The arc is only right where ``L`` already follows its low-frequency asymptote ``c / s^n``. A measured FRF
starts at a few Hz, where the slope of a loop with integrators is still in transition (1.2-2.9 for
``det(I + L) - 1`` of gantry PIDs of 2-8 Hz bandwidth at lowest lines of 2-20 Hz), and the count then
depends on the lowest line. Below
the measured band the plant is rigid-body dominated and the model holds, so the analysis cases pass a
:class:`LoopExtension` (:func:`model_extension`): the model's plant from ``EXTENSION_LOW_HZ`` up to the
first grid line, scaled by one complex factor so that it meets the measured plant at the junction (least
squares over the first octave of the grid, :func:`junction_scale`), in the loop with the same controller.
The contour then starts at ``EXTENSION_LOW_HZ`` (1e-5 Hz), where the slope is the structural one (the
integrators of plant and controller), and the arc is exact. The extension only serves the Nyquist count
(and warnings); crossovers, margins and ``Ms`` are the grid's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

EXTENSION_LOW_HZ = 1e-5
"""Lowest frequency of a model extension [Hz]: below the integral corners of practical designs (a gantry PID of
0.5 Hz bandwidth has its ``det L ~ 1/s^4`` asymptote from about 5e-5 Hz), above where the 2x2 algebra of a
rigid body loses precision (``det G`` of a rank-one stiffness cancels ``k / (m w^2) ~ 1e13`` at 1e-5 Hz)."""
EXTENSION_POINTS_PER_DECADE = 100
"""Density of the extension grid: a lightly damped mode below the first line is still resolved (3 points over
its half-power band at 3.5 % damping) so the unwrapped phase is continuous."""
JUNCTION_WARN_GAIN = 2.0
"""Model and FRF differing by more than this factor [-] at the junction give a warning."""
JUNCTION_WARN_DEG = 30.0
"""... or by more than this phase [deg]."""


def crossings(freq_hz: np.ndarray, y: np.ndarray, level: float = 0.0) -> np.ndarray:
    """Frequencies [Hz] where ``y`` crosses ``level``, linearly interpolated in ``log f``."""
    f = np.asarray(freq_hz, float)
    d = np.asarray(y, float) - level
    idx = np.flatnonzero(np.signbit(d[:-1]) != np.signbit(d[1:]))
    if idx.size == 0:
        return np.empty(0)
    lf = np.log(np.maximum(f, 1e-300))
    frac = d[idx] / (d[idx] - d[idx + 1])
    return np.exp(lf[idx] + frac * (lf[idx + 1] - lf[idx]))


def _interp_complex_at(freq_hz: np.ndarray, h: np.ndarray, f0: np.ndarray) -> np.ndarray:
    lf = np.log(freq_hz)
    mag = np.interp(np.log(f0), lf, np.log(np.abs(h)))
    ph = np.interp(np.log(f0), lf, np.unwrap(np.angle(h)))
    return np.exp(mag + 1j * ph)


@dataclass(frozen=True)
class LoopMetrics:
    """Frequency-domain figures of one loop.

    Attributes
    ----------
    crossovers_hz : list of float
        Every frequency [Hz] where ``|L| = 1``.
    phase_margins_deg : list of float
        Phase margin [deg] at each crossover (``180 + angle L`` wrapped to (-180, 180]).
    phase_margin_deg : float or None
        The one closest to 0 (the crossing nearest to -1 in angle; a crossing with ``L`` near +1 has a
        margin near +-180 deg and is harmless).
    gain_margin_db : float or None
        ``-20 log10 |L|`` [dB] at the phase crossover (``angle L = -180 deg``) closest to 0 dB; negative
        when the gain may only be reduced (conditionally stable loops).
    gain_margins_db, phase_crossovers_hz : list of float
        All gain margins [dB] and the phase-crossover frequencies [Hz].
    ms, ms_freq_hz : float
        Peak sensitivity ``max |S|`` [-] and its frequency [Hz].
    rejection_band_hz : [float, float] or None
        ``[f_low, f_high]`` [Hz]: the band from the grid's first frequency where ``|S| < 1``.
    stable : bool
        Closed-loop stability by the Nyquist criterion.
    nyquist_encirclements : int
        Clockwise encirclements of -1 by ``L`` over the whole contour.
    open_loop_rhp_poles : int
        ``P`` used in the criterion.
    integrators : int
        Open-loop poles at the origin found from the low-frequency slope.
    warnings : list of str
    contour_low_hz : float or None
        Lowest frequency of the Nyquist contour [Hz] (the indentation radius): the grid's first frequency, or
        the extension's (``EXTENSION_LOW_HZ``) when a model extension was used.
    model_extension : dict or None
        :meth:`LoopExtension.to_dict` of the extension used for the Nyquist count, None without one.
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
    stable: bool
    nyquist_encirclements: int
    open_loop_rhp_poles: int
    integrators: int
    warnings: list = field(default_factory=list)
    contour_low_hz: float | None = None
    model_extension: dict | None = None

    def to_dict(self) -> dict:
        """JSON-ready dict (keys carry units)."""
        return {
            "crossovers_hz": [float(x) for x in self.crossovers_hz],
            "phase_margins_deg": [float(x) for x in self.phase_margins_deg],
            "phase_margin_deg": _f(self.phase_margin_deg),
            "gain_margin_db": _f(self.gain_margin_db),
            "gain_margins_db": [float(x) for x in self.gain_margins_db],
            "phase_crossovers_hz": [float(x) for x in self.phase_crossovers_hz],
            "ms": float(self.ms),
            "ms_freq_hz": float(self.ms_freq_hz),
            "rejection_band_hz": None if self.rejection_band_hz is None else [float(x) for x in self.rejection_band_hz],
            "stable": bool(self.stable),
            "nyquist_encirclements": int(self.nyquist_encirclements),
            "open_loop_rhp_poles": int(self.open_loop_rhp_poles),
            "integrators": int(self.integrators),
            "nyquist_low_frequency_hz": _f(self.contour_low_hz),
            "model_extension": self.model_extension,
            "warnings": list(self.warnings),
        }


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)


def margins(freq_hz: np.ndarray, L: np.ndarray) -> tuple[list, list, list, list]:
    """Crossovers [Hz], phase margins [deg], phase crossovers [Hz] and gain margins [dB] of ``L``."""
    f = np.asarray(freq_hz, float)
    mag_db = 20 * np.log10(np.abs(L))
    wc = merge_noisy_crossings(crossings(f, mag_db, 0.0))
    pm = []
    if wc.size:
        Lc = _interp_complex_at(f, L, wc)
        pm = list(np.rad2deg(np.angle(-Lc)))  # 180 + angle(L) wrapped to (-180, 180]
    # phase crossovers: Im(L) changes sign while Re(L) < 0
    im = L.imag
    idx = np.flatnonzero((np.signbit(im[:-1]) != np.signbit(im[1:])) & (L.real[:-1] + L.real[1:] < 0))
    w180, gm = [], []
    for i in idx:  # loop over sign changes (a handful), not over frequencies
        frac = im[i] / (im[i] - im[i + 1])
        fi = np.exp(np.log(f[i]) + frac * (np.log(f[i + 1]) - np.log(f[i])))
        mag = np.exp(np.log(abs(L[i])) + frac * (np.log(abs(L[i + 1])) - np.log(abs(L[i]))))
        w180.append(float(fi))
        gm.append(float(-20 * np.log10(mag)))
    return list(map(float, wc)), [float(x) for x in pm], w180, gm


def low_frequency_slope(freq_hz: np.ndarray, y: np.ndarray, octaves: float = 1.0) -> float:
    """``-d log|y| / d log f`` fitted over the first ``octaves`` of the grid (at least 3 points) [-]."""
    f = np.asarray(freq_hz, float)
    sel = f <= f[0] * 2.0**octaves
    if sel.sum() < 3:
        sel = np.arange(f.size) < min(3, f.size)
    if sel.sum() < 2:
        return 0.0
    return float(-np.polyfit(np.log(f[sel]), np.log(np.maximum(np.abs(y[sel]), 1e-300)), 1)[0])


def count_integrators(freq_hz: np.ndarray, L: np.ndarray, octaves: float = 1.0) -> int:
    """Number of open-loop poles at the origin from the low-frequency slope of ``|L|`` [-].

    The slope is fitted over the first ``octaves`` of the grid (at least 3 points), so measurement noise on
    single points does not change the count.
    """
    return max(0, int(np.round(low_frequency_slope(freq_hz, L, octaves))))


def merge_noisy_crossings(freqs: np.ndarray, rel: float = 0.03) -> np.ndarray:
    """Merge crossings closer than ``rel`` (relative frequency): noise makes one crossing look like several.

    A cluster with an odd number of crossings is one crossing (its first member); an even cluster is a
    touch of the level without a net crossing and is dropped.
    """
    if freqs.size < 2:
        return freqs
    out, cluster = [], [freqs[0]]
    for f in freqs[1:]:  # a handful of crossings
        if f <= cluster[-1] * (1 + rel):
            cluster.append(f)
        else:
            if len(cluster) % 2:
                out.append(cluster[0])
            cluster = [f]
    if len(cluster) % 2:
        out.append(cluster[0])
    return np.array(out)


def nyquist_winding(freq_hz: np.ndarray, L: np.ndarray, integrators: float) -> float:
    """Counter-clockwise winding number of ``1 + L`` around 0 on the indented Nyquist contour [-].

    ``L`` is any response that behaves like ``c / s^integrators`` on the indentation arc of radius
    ``2 pi freq_hz[0]`` (``integrators`` may be a fitted, non-integer slope: the turn that closes the curve
    nearest to it is used). The MIMO criterion counts ``det(I + L) = 1 + (det(I + L) - 1)`` with it.
    """
    one_plus = 1.0 + L
    ph = np.unwrap(np.angle(one_plus))
    along = ph[-1] - ph[0]  # 0+ -> +inf
    # indentation arc around s = 0 (z = 1) through the unstable region: L turns clockwise by about n*pi from
    # L(-j w0) = conj(L0) to L(+j w0) = L0; the exact turn is the one of that size closing the curve
    L0 = L[0]
    phi0 = float(np.angle(L0))
    k = np.round((-integrators * np.pi - 2 * phi0) / (2 * np.pi))
    turn = 2 * phi0 + 2 * np.pi * k
    arc = 1.0 + np.abs(L0) * np.exp(1j * (-phi0 + turn * np.linspace(0.0, 1.0, 721)))
    arc_ph = np.unwrap(np.angle(arc))
    arc_change = arc_ph[-1] - arc_ph[0]
    # negative frequencies: conjugate branch from -inf to -0 has the same phase change as 0 -> +inf
    total = 2 * along + arc_change
    return total / (2 * np.pi)


def analyze_loop(freq_hz, L, *, open_loop_rhp_poles: int = 0, integrators: int | None = None,
                 extension: LoopExtension | None = None) -> LoopMetrics:
    """All loop figures of :class:`LoopMetrics` from ``L(j w)`` on a grid [Hz].

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Strictly increasing grid [Hz].
    L : array_like, shape (n,)
        Loop transfer [-].
    open_loop_rhp_poles : int
        Open-loop right-half-plane poles [-].
    integrators : int, optional
        Open-loop poles at the origin; default: the rounded low-frequency slope of the contour.
    extension : LoopExtension, optional
        The loop below ``freq_hz[0]`` from a model (:func:`model_extension`); used for the Nyquist count only.
    """
    f = np.asarray(freq_hz, float)
    L = np.asarray(L, complex)
    wc, pm, w180, gm = margins(f, L)
    S = 1.0 / (1.0 + L)
    aS = np.abs(S)
    i_ms = int(np.argmax(aS))
    fc, Lc = (f, L) if extension is None else extension.prepend(f, L)
    n_int = count_integrators(fc, Lc) if integrators is None else int(integrators)
    warnings = contour_warnings(fc, low_frequency_slope(fc, Lc), abs(Lc[0]), n_int, extension is not None)
    if abs(L[-1]) >= 1:
        warnings.append(
            f"|L| = {abs(L[-1]):.3g} >= 1 at the highest frequency {f[-1]:g} Hz; "
            "extend the frequency grid for a valid Nyquist count"
        )
    if extension is not None:
        ms_below = float(np.max(np.abs(1.0 / (1.0 + extension.L))))
        warnings += extension.warnings(float(aS[i_ms]), ms_below)
    winding = nyquist_winding(fc, Lc, n_int)
    n_ccw = int(np.round(winding))
    if abs(winding - n_ccw) > 0.2:
        warnings.append(f"Nyquist winding number {winding:.2f} is not close to an integer; grid too coarse")
    n_cw = -n_ccw
    z = n_cw + int(open_loop_rhp_poles)
    stable = z == 0
    return LoopMetrics(
        wc,
        pm,
        min(pm, key=abs) if pm else None,
        min(gm, key=abs) if gm else None,
        gm,
        w180,
        float(aS[i_ms]),
        float(f[i_ms]),
        rejection_band(f, aS),
        bool(stable),
        n_cw,
        int(open_loop_rhp_poles),
        n_int,
        warnings,
        float(fc[0]),
        None if extension is None else extension.to_dict(),
    )


def contour_warnings(freq_hz: np.ndarray, slope: float, magnitude_low: float, integrators: int | None,
                     extended: bool) -> list[str]:
    """Warnings on the indentation at the contour's lowest frequency ``freq_hz[0]`` [Hz] (SISO and MIMO).

    ``slope`` is the fitted low-frequency slope of the counted response [-], ``magnitude_low`` its magnitude
    there [-], ``integrators`` the open-loop poles at the origin (None: unknown).
    """
    out = []
    f0 = float(freq_hz[0])
    if abs(slope - round(slope)) > 0.25:
        fix = "" if extended else "; give a model to extend the loop below the grid"
        out.append(f"the loop's low-frequency slope at {f0:.3g} Hz is {slope:.2f}, between two integer "
                   f"asymptotes: the Nyquist count near 0 Hz is uncertain{fix}")
    elif extended and integrators is not None and round(slope) != integrators:
        out.append(f"the loop falls as 1/s^{round(slope)} at {f0:.3g} Hz although it has {integrators} open-loop "
                   f"poles at the origin: closed-loop poles slower than about {f0:.3g} Hz are not counted")
    if magnitude_low < 10 and (integrators or 0) > 0:
        out.append(f"|L| is only {magnitude_low:.3g} at the lowest frequency {f0:g} Hz; "
                   "the Nyquist count near 0 Hz is less reliable")
    return out


# ------------------------------------------------------------------------------------- model extension
@dataclass(frozen=True)
class LoopExtension:
    """The loop below an FRF's band, from the model, for the Nyquist count (module docstring).

    Attributes
    ----------
    freq_hz : ndarray, shape (m,)
        Strictly increasing frequencies [Hz], all below the grid it extends.
    L : ndarray, shape (..., m)
        Loop on ``freq_hz`` (scalar loop, or ``(2, 2, m)`` for a 2x2 loop) [-].
    scale : complex
        Factor applied to the model's plant so that it meets the grid's plant at the junction [-].
    junction_hz : (float, float)
        Band of the grid over which ``scale`` was fitted [Hz].
    """

    freq_hz: np.ndarray
    L: np.ndarray
    scale: complex
    junction_hz: tuple

    def prepend(self, freq_hz: np.ndarray, L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(freq_hz, L)`` of the whole contour: this extension followed by the grid."""
        return np.r_[self.freq_hz, freq_hz], np.concatenate([self.L, L], axis=-1)

    def warnings(self, ms_grid: float, ms_below: float) -> list[str]:
        """Model-FRF mismatch at the junction, and a peak sensitivity [-] below the grid above the grid's."""
        out = []
        gain, phase = abs(self.scale), float(np.degrees(np.angle(self.scale)))
        lo, hi = self.junction_hz
        if not (1 / JUNCTION_WARN_GAIN <= gain <= JUNCTION_WARN_GAIN) or abs(phase) > JUNCTION_WARN_DEG:
            out.append(f"the model differs from the FRF at its lowest lines ({lo:.4g}-{hi:.4g} Hz) by a gain of "
                       f"{gain:.3g} and {phase:+.0f} deg; the Nyquist count below {lo:.4g} Hz uses the model scaled "
                       "by that factor: check the FRF's low end or the model")
        if ms_below > ms_grid:
            out.append(f"the model puts a peak sensitivity of {ms_below:.3g} below the lowest line {lo:.4g} Hz "
                       f"(above the {ms_grid:.3g} on the grid)")
        return out

    def to_dict(self) -> dict:
        """Summary: range [Hz], scale (gain [-], phase [deg]) and junction band [Hz]."""
        return {"from_hz": float(self.freq_hz[0]), "to_hz": float(self.freq_hz[-1]),
                "junction_hz": [float(x) for x in self.junction_hz], "scale_gain": float(abs(self.scale)),
                "scale_phase_deg": float(np.degrees(np.angle(self.scale)))}


def extension_grid(first_hz: float, low_hz: float = EXTENSION_LOW_HZ,
                   points_per_decade: int = EXTENSION_POINTS_PER_DECADE) -> np.ndarray:
    """Log grid [Hz] from ``low_hz`` up to, not including, ``first_hz`` (empty when ``first_hz <= low_hz``)."""
    if not first_hz > low_hz:
        return np.empty(0)
    n = max(2, int(np.ceil(np.log10(first_hz / low_hz) * points_per_decade)))
    return np.logspace(np.log10(low_hz), np.log10(first_hz), n + 1)[:-1]


def junction_scale(freq_hz: np.ndarray, plant: np.ndarray, model_plant: np.ndarray,
                   octaves: float = 1.0) -> tuple[complex, tuple[float, float]]:
    """Complex factor ``c`` [-] with ``c * model_plant ~ plant`` over the first ``octaves`` of the grid.

    Per frequency the least-squares ratio over all channels ``sum conj(M) P / sum |M|^2`` (leading axes are
    channels, the last one frequency), averaged over the band; returns ``(c, (f_low, f_high))`` [-, Hz].
    """
    f = np.asarray(freq_hz, float)
    sel = f <= f[0] * 2.0**octaves
    P = np.asarray(plant)[..., sel].reshape(-1, int(sel.sum()))
    M = np.asarray(model_plant)[..., sel].reshape(-1, int(sel.sum()))
    den = np.sum(np.abs(M) ** 2, axis=0)
    num = np.sum(np.conj(M) * P, axis=0)
    ok = (den > 0) & np.isfinite(num) & np.isfinite(den)
    c = complex(np.mean(num[ok] / den[ok])) if ok.any() else 1.0 + 0j
    return c, (float(f[sel][0]), float(f[sel][-1]))


def model_extension(freq_hz, plant: np.ndarray, model_plant: Callable[[np.ndarray], np.ndarray],
                    loop: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None, *,
                    low_hz: float = EXTENSION_LOW_HZ) -> LoopExtension | None:
    """The loop below ``freq_hz[0]`` from the model, scaled to meet ``plant`` at the junction.

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Grid of the case [Hz].
    plant : ndarray, shape (..., n)
        The plant on the grid (measured FRF, or the model itself) in the same units as ``model_plant``.
    model_plant : callable
        ``model_plant(f)`` -> the model's plant on ``f`` [Hz], shape ``(..., len(f))``.
    loop : callable, optional
        ``loop(f, G)`` -> the loop on ``f`` for the plant ``G`` (controller, hold and delay applied); default:
        the scaled plant itself (to form many loops from one extension).
    low_hz : float
        Lowest frequency of the extension [Hz].

    Returns
    -------
    LoopExtension or None
        None when the grid already starts at or below ``low_hz``.
    """
    f = np.asarray(freq_hz, float)
    f_ext = extension_grid(float(f[0]), low_hz)
    if f_ext.size == 0:
        return None
    sel = f <= f[0] * 2.0
    scale, band = junction_scale(f[sel], np.asarray(plant)[..., sel], model_plant(f[sel]))
    G_ext = scale * model_plant(f_ext)
    return LoopExtension(f_ext, G_ext if loop is None else loop(f_ext, G_ext), scale, band)


def rejection_band(freq_hz: np.ndarray, abs_s: np.ndarray) -> list | None:
    """``[f_low, f_high]`` [Hz] where ``|S| < 1`` starting at the first grid frequency, or None."""
    if abs_s[0] >= 1:
        return None
    up = crossings(freq_hz, 20 * np.log10(abs_s), 0.0)
    return [float(freq_hz[0]), float(up[0]) if up.size else float(freq_hz[-1])]
