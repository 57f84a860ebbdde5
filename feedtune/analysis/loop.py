"""SISO loop analysis: every crossover and margin, peak and disk margins, rejection bands, Nyquist stability.

:func:`analyze_loop` takes the loop ``L(j w)`` either as a function that evaluates it at any frequency (the
analysis cases build one: models and controllers exactly, a measured FRF interpolated between its lines) or as
samples on a strictly increasing grid ``freq_hz`` [Hz]. With a function, the grid is refined until the loop is
resolved (:mod:`feedtune.analysis.resolution`: around crossovers, where the phase turns fast, around lightly damped
poles and zeros), crossings are bracketed and peaks zoomed, so that the figures do not depend on the grid. Samples
that do not resolve the loop are refused (:class:`~feedtune.analysis.resolution.ResolutionError`), never judged.

Every crossover is kept: crossings are merged only in a measured loop and only where the FRF's scatter explains them
(:func:`~feedtune.analysis.margins.merge_chatter`, listed in ``merged_crossovers``).

Nyquist criterion with open-loop poles at the origin
----------------------------------------------------
The Nyquist contour runs up the imaginary axis and is indented into the right half plane around ``s = 0``
with radius ``w_min = 2 pi f_min``, the lowest frequency of the contour. Along the positive axis the winding
of ``1 + L`` is taken from the unwrapped phase; the mirrored negative axis contributes the same by conjugate
symmetry; above the grid's top, where ``|L| < 1``, the loop is taken to roll off to 0 without reaching ``|L| = 1``
again (the ``band_top`` limit holds measured loops to it); the indentation arc, where
``L(s) ~ L(j w_min) (j w_min / s)^n`` with ``n`` the low-frequency slope
of ``|L|`` (integer number of integrators, read from the data), turns ``L`` clockwise by about ``n pi`` from
``conj(L(j w_min))`` to ``L(j w_min)`` (the exact turn that closes the curve is used); the arc at infinity
contributes nothing when ``|L(j w_max)| < 1``. Closed-loop right-half-plane poles ``Z = N_cw + P`` where
``P`` is the number of open-loop right-half-plane poles.

The arc is only right where ``L`` already follows its low-frequency asymptote ``c / s^n``. A measured FRF
starts at a few Hz, where the slope of a loop with integrators is still in transition, and the count then
depends on the lowest line. Below the measured band the plant is rigid-body dominated and the model holds, so
the analysis cases pass a :class:`LoopExtension` (:func:`model_extension`): the model's plant from
``EXTENSION_LOW_HZ`` up to the first grid line, scaled by one complex factor so that it meets the measured plant at
the junction (least squares over the first octave of the grid, :func:`junction_scale`), in the loop with the same
controller. The contour then starts at ``EXTENSION_LOW_HZ`` (1e-5 Hz), where the slope is the structural one, and
the arc is exact. The extension is part of the contour: crossovers, margins, ``Ms`` and bands below the grid come
from it (crossovers there are listed in ``below_band_crossovers_hz``).

Without an extension, a loop with integrators whose grid starts where ``|L| < 10`` (the loop below the grid may still
wind around -1 there, and the arc is not yet far from it) is refused
(:class:`BandLimitedError`) unless ``below_grid="assume"``: the count would depend on what the grid does not show.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import DataError
from .margins import (
    crossings,
    disk_margins,
    interp_complex,
    level_bands,
    merge_chatter,
    peak,
    phase_crossovers,
    prune_bands,
)
from .resolution import INTERPOLATION, SAMPLE_SLACK, check_samples, resolve, unresolved

EXTENSION_LOW_HZ = 1e-5
"""Lowest frequency of a model extension [Hz]: below the integral corners of practical designs (a gantry PID of
0.5 Hz bandwidth has its ``det L ~ 1/s^4`` asymptote from about 5e-5 Hz), above where the 2x2 algebra of a
rigid body loses precision (``det G`` of a rank-one stiffness cancels ``k / (m w^2) ~ 1e13`` at 1e-5 Hz)."""
EXTENSION_POINTS_PER_DECADE = 100
"""Density of the extension grid before refinement."""
JUNCTION_WARN_GAIN = 2.0
"""Model and FRF differing by more than this factor [-] at the junction give a warning."""
JUNCTION_WARN_DEG = 30.0
"""... or by more than this phase [deg]."""
ASYMPTOTE_MIN_GAIN = 10.0
"""Smallest ``|L|`` [-] at the contour's low end of a loop with integrators for the arc to be trusted."""


class BandLimitedError(DataError):
    """The loop's grid starts where its low-frequency asymptote is not established and no extension was given."""


# --------------------------------------------------------------------------------------------- result
@dataclass(frozen=True)
class LoopMetrics:
    """Frequency-domain figures of one loop, exact for the loop it was given (module docstring).

    Attributes
    ----------
    crossovers_hz : list of float
        Every frequency [Hz] where ``|L| = 1`` over the whole contour (below the grid too, from the extension).
    phase_margins_deg : list of float
        Phase margin [deg] at each crossover (``180 + angle L`` wrapped to (-180, 180]).
    phase_margin_deg : float or None
        The worst: the one closest to 0 (a crossing with ``L`` near +1 has a margin near +-180 deg and is harmless).
    gain_margin_db : float or None
        The worst gain margin: ``-20 log10 |L|`` [dB] at the phase crossover closest to 0 dB; negative when the gain
        may only be reduced (conditionally stable loops).
    gain_margins_db, phase_crossovers_hz : list of float
        All gain margins [dB] and the phase-crossover frequencies [Hz] (``angle L = -180 deg``).
    ms, ms_freq_hz : float
        Peak sensitivity ``max |S|`` [-] over the whole contour and its frequency [Hz].
    rejection_bands_hz : list of [float, float]
        Every band [Hz] where ``|S| < 1``; a band reaching the contour's low end of a loop with integrators starts at
        0 Hz.
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
        Lowest frequency of the Nyquist contour [Hz]: the grid's first, or the extension's (``EXTENSION_LOW_HZ``).
    model_extension : dict or None
        :meth:`LoopExtension.to_dict` of the extension used, None without one.
    below_band_crossovers_hz : list of float
        The crossovers [Hz] that lie on the model extension, below the grid.
    disk_margin : float
        Balanced disk margin ``alpha = 1 / max |S - 1/2|`` [-] (:mod:`feedtune.analysis.margins`).
    disk_margin_freq_hz : float or None
        Where ``|S - 1/2|`` peaks [Hz].
    merged_crossovers : list of dict
        Crossover clusters merged as measurement chatter (:func:`~feedtune.analysis.margins.merge_chatter`).
    points : int
        Frequencies the figures were taken from (grid after refinement, extension included) [-].
    interpolation : str or None
        How measured parts were evaluated between their lines; None when the loop is known exactly or as samples.
    nyquist_reliable : bool
        The winding number came out close to an integer (else the count, hence ``stable``, is not trusted).
    band_top_hz, band_top_loop_gain : float or None
        For a measured loop, the FRF's last line [Hz] and ``|L|`` there [-]: above the band the loop is unknown, and
        the limits hold there only if it is small enough (:meth:`feedtune.analysis.limits.Limits.check`).
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
    stable: bool
    nyquist_encirclements: int
    open_loop_rhp_poles: int
    integrators: int
    warnings: list = field(default_factory=list)
    contour_low_hz: float | None = None
    model_extension: dict | None = None
    below_band_crossovers_hz: list = field(default_factory=list)
    disk_margin: float = float("inf")
    disk_margin_freq_hz: float | None = None
    merged_crossovers: list = field(default_factory=list)
    points: int = 0
    interpolation: str | None = None
    nyquist_reliable: bool = True
    band_top_hz: float | None = None
    band_top_loop_gain: float | None = None

    @property
    def rejection_band_hz(self) -> list | None:
        """The first ``|S| < 1`` band [Hz] (kept for scripts written before :attr:`rejection_bands_hz`)."""
        return self.rejection_bands_hz[0] if self.rejection_bands_hz else None

    @property
    def phase_margins(self) -> list[dict]:
        """``[{"freq_hz", "pm_deg"}]`` at every crossover."""
        return [{"freq_hz": float(f), "pm_deg": float(p)}
                for f, p in zip(self.crossovers_hz, self.phase_margins_deg, strict=True)]

    @property
    def gain_margins(self) -> list[dict]:
        """``[{"freq_hz", "gm_db"}]`` at every phase crossover."""
        return [{"freq_hz": float(f), "gm_db": float(g)}
                for f, g in zip(self.phase_crossovers_hz, self.gain_margins_db, strict=True)]

    @property
    def disk_gain_margin_db(self) -> float:
        """Disk-based gain margin [dB]."""
        return disk_margins(self.disk_margin)[0]

    @property
    def disk_phase_margin_deg(self) -> float:
        """Disk-based phase margin [deg]."""
        return disk_margins(self.disk_margin)[1]

    def to_dict(self) -> dict:
        """JSON-ready dict (keys carry units)."""
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
            "disk_margin": _f(self.disk_margin),
            "disk_gain_margin_db": _f(self.disk_gain_margin_db),
            "disk_phase_margin_deg": _f(self.disk_phase_margin_deg),
            "disk_margin_freq_hz": _f(self.disk_margin_freq_hz),
            "rejection_bands_hz": [[float(a), float(b)] for a, b in self.rejection_bands_hz],
            "rejection_band_hz": None if self.rejection_band_hz is None else [float(x) for x in self.rejection_band_hz],
            "stable": bool(self.stable),
            "nyquist_encirclements": int(self.nyquist_encirclements),
            "open_loop_rhp_poles": int(self.open_loop_rhp_poles),
            "integrators": int(self.integrators),
            "nyquist_low_frequency_hz": _f(self.contour_low_hz),
            "model_extension": self.model_extension,
            "merged_crossovers": list(self.merged_crossovers),
            "points": int(self.points),
            "interpolation": self.interpolation,
            "nyquist_reliable": bool(self.nyquist_reliable),
            "band_top_hz": _f(self.band_top_hz),
            "band_top_loop_gain": _f(self.band_top_loop_gain),
            "warnings": list(self.warnings),
        }


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)


def worst(values) -> float | None:
    """The margin closest to 0 (signed), or None for no margins."""
    values = list(values)
    return min(values, key=abs) if values else None


# --------------------------------------------------------------------------------------------- Nyquist
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
    # above the grid: when |L| < 1 at its top, the loop is taken to roll off to 0 without reaching |L| = 1 again
    # (what the band_top limit checks), so 1 + L returns to 1 inside the disk |1 + L - 1| < 1, whose points all
    # have a positive real part: that return adds exactly -angle(1 + L_top). A loop closed at fs / 2 ends on
    # the real axis, where this is 0.
    if abs(L[-1]) < 1:
        along = along - float(np.angle(one_plus[-1]))
    # negative frequencies: conjugate branch from -inf to -0 has the same phase change as 0 -> +inf
    total = 2 * along + arc_change
    return total / (2 * np.pi)


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
    if magnitude_low < ASYMPTOTE_MIN_GAIN and (integrators or 0) > 0:
        out.append(f"|L| is only {magnitude_low:.3g} at the lowest frequency {f0:g} Hz; "
                   "the Nyquist count near 0 Hz is less reliable")
    return out


def check_low_end(freq_hz: np.ndarray, slope: float, magnitude_low: float, integrators: int) -> None:
    """Refuse a contour without extension that starts where a loop with integrators has ``|L| < 10`` (module docstring).

    The indentation arc's turn is the one closing the curve nearest to ``slope`` half turns, right whenever the loop
    below the grid turns between its integer asymptotes; what the arc cannot know is a loop below the grid that
    still comes near -1.

    Raises
    ------
    BandLimitedError
    """
    f0 = float(freq_hz[0])
    if max(integrators, round(slope)) > 0 and magnitude_low < ASYMPTOTE_MIN_GAIN:
        raise BandLimitedError(
            f"the loop's grid starts at {f0:.4g} Hz where |L| = {magnitude_low:.3g} (slope {slope:.2f}): the loop "
            "below the grid may still come near -1, so the Nyquist count depends on what the grid does not show; "
            "give a model extension (extension=), a grid reaching lower frequencies, or below_grid='assume' to count "
            "it as c/s^n")


# --------------------------------------------------------------------------------------------- extension
@dataclass(frozen=True)
class LoopExtension:
    """The loop below an FRF's band, from the model (module docstring).

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
    evaluate : callable, optional
        ``evaluate(f)`` -> the extension's loop at any ``f`` [Hz] below the grid (for refined figures).
    """

    freq_hz: np.ndarray
    L: np.ndarray
    scale: complex
    junction_hz: tuple
    evaluate: Callable[[np.ndarray], np.ndarray] | None = None

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
                       f"{gain:.3g} and {phase:+.0f} deg; the loop below {lo:.4g} Hz uses the model scaled "
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


def scalar_loops(R: np.ndarray) -> list[np.ndarray]:
    """The scalar loops that must stay resolved in a response block: ``L`` itself, or for a 2x2 loop its diagonal
    and ``det(I + L) - 1``."""
    if R.ndim == 1:
        return [R]
    det = (1.0 + R[0, 0]) * (1.0 + R[1, 1]) - R[0, 1] * R[1, 0]
    return [R[0, 0], R[1, 1], det - 1.0]


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
        the scaled plant itself (to form many loops from one extension). With a loop, the extension's grid is
        refined until the loop is resolved (:func:`~feedtune.analysis.resolution.resolve`).
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
    if loop is None:
        def evaluate(fe):
            return scale * model_plant(fe)

        return LoopExtension(f_ext, evaluate(f_ext), scale, band, evaluate)

    def evaluate(fe):
        return loop(fe, scale * model_plant(fe))

    fr, L = resolve(f_ext, evaluate, scalar_loops)
    return LoopExtension(fr, L, scale, band, evaluate)


# --------------------------------------------------------------------------------------------- analysis
@dataclass(frozen=True)
class Margins:
    """Crossovers [Hz] with their phase margins [deg], phase crossovers [Hz] with their gain margins [dB], and the
    crossover clusters merged as chatter (:func:`loop_margins`)."""

    crossovers_hz: list
    phase_margins_deg: list
    phase_crossovers_hz: list
    gain_margins_db: list
    merged: list


def loop_margins(freq_hz: np.ndarray, L: np.ndarray, fn: Callable[[np.ndarray], np.ndarray] | None = None,
                 noise: np.ndarray | None = None) -> Margins:
    """Every crossover and phase crossover of a scalar loop ``L`` on ``freq_hz`` [Hz], refined with ``fn`` (``L``
    at any frequency) when given; ``noise`` [dB] per frequency (a measured loop's scatter) merges chatter of both
    (:func:`~feedtune.analysis.margins.merge_chatter`)."""
    with np.errstate(divide="ignore"):
        db = 20 * np.log10(np.abs(L))
    wc = crossings(freq_hz, db, 0.0, None if fn is None else (lambda fq: 20 * np.log10(np.abs(fn(fq)))))
    w180 = phase_crossovers(freq_hz, L, fn)
    merged: list[dict] = []
    if noise is not None:
        wc, merged = merge_chatter(wc, freq_hz, db, noise)
        noise_deg = np.degrees(np.asarray(noise) * np.log(10) / 20)  # circular scatter: phase [rad] = log-magnitude
        w180, merged_180 = merge_chatter(w180, freq_hz, np.degrees(np.angle(-L)), noise_deg, "phase crossovers",
                                         "deg")
        merged += merged_180
    Lx = fn(wc) if fn is not None and wc.size else interp_complex(freq_hz, L, wc)
    pm = [float(x) for x in np.rad2deg(np.angle(-Lx))] if wc.size else []
    L180 = fn(w180) if fn is not None and w180.size else interp_complex(freq_hz, L, w180)
    gm = [float(-20 * np.log10(abs(x))) for x in L180]
    return Margins([float(x) for x in wc], pm, [float(x) for x in w180], gm, merged)


def scatter_of(L: np.ndarray, noise: np.ndarray | None) -> np.ndarray | None:
    """1-sigma scatter of ``|1 + L|`` [-] from the loop's measured scatter ``noise`` [dB] (None: not measured)."""
    if noise is None:
        return None
    return np.abs(L) * (np.asarray(noise) * np.log(10) / 20)


def piecewise(first_hz: float, below: Callable | None, above: Callable | None) -> Callable | None:
    """One function over the whole contour from the extension's (below ``first_hz`` [Hz]) and the grid's; None when
    the grid has none, the grid's alone when there is no extension. Frequency is the last axis of the result."""
    if above is None or below is None:
        return above if below is None else None

    def fn(fq):
        fq = np.asarray(fq, float)
        lo = fq < first_hz
        a = below(fq[lo]) if lo.any() else None
        b = above(fq[~lo]) if (~lo).any() else None
        ref = a if a is not None else b
        out = np.empty(ref.shape[:-1] + fq.shape, complex)
        if a is not None:
            out[..., lo] = a
        if b is not None:
            out[..., ~lo] = b
        return out

    return fn


def analyze_loop(freq_hz, L=None, *, evaluate: Callable[[np.ndarray], np.ndarray] | None = None, features=None,
                 open_loop_rhp_poles: int = 0, integrators: int | None = None,
                 extension: LoopExtension | None = None, noise_db: np.ndarray | None = None, measured: bool = False,
                 below_grid: str = "refuse") -> LoopMetrics:
    """All loop figures of :class:`LoopMetrics` (module docstring).

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Strictly increasing grid [Hz]: the samples of ``L``, or the base grid (and band) of ``evaluate``.
    L : array_like, shape (n,), optional
        Loop transfer [-] on ``freq_hz``: the loop itself without ``evaluate``; with it, ``evaluate(freq_hz)``
        already computed by the caller (not evaluated again).
    evaluate : callable, optional
        ``evaluate(f)`` -> ``L`` at any ``f`` [Hz] in ``[freq_hz[0], freq_hz[-1]]``; the grid is refined with it.
    features : array_like, shape (k, 2), optional
        Lightly damped poles and zeros (Hz, damping) of the exactly known parts
        (:func:`~feedtune.analysis.resolution.lightly_damped`): points are added around them.
    open_loop_rhp_poles : int
        Open-loop right-half-plane poles [-].
    integrators : int, optional
        Open-loop poles at the origin; default: the rounded low-frequency slope of the contour.
    extension : LoopExtension, optional
        The loop below ``freq_hz[0]`` from a model (:func:`model_extension`).
    noise_db : ndarray, shape (n,), optional
        Measurement scatter of a measured loop on ``freq_hz`` [dB]
        (:func:`~feedtune.analysis.resolution.noise_db`): crossover chatter within it is merged and listed.
    measured : bool
        ``freq_hz`` are an FRF's lines and ``evaluate`` interpolates between them: a warning names where the lines
        do not resolve the loop.
    below_grid : {"refuse", "assume"}
        Without an extension, refuse (default) or accept a grid that starts off the loop's asymptote.

    Raises
    ------
    ResolutionError
        Samples that do not resolve the loop, or a function that cannot be resolved.
    BandLimitedError
        See ``below_grid``.
    """
    if below_grid not in ("refuse", "assume"):
        raise ValueError(f"below_grid must be 'refuse' or 'assume', got {below_grid!r}")
    f0 = np.asarray(freq_hz, float)
    warnings: list[str] = []
    if evaluate is not None:
        L0 = evaluate(f0) if L is None else np.asarray(L, complex)
        f, Lg = resolve(f0, evaluate, lambda R: [R], features, known=L0)
        if measured:
            warnings += line_resolution_warnings(f0, L0)
    else:
        f, Lg = f0, np.asarray(L, complex)
        check_samples(f, [Lg])
    if extension is not None:
        fc, Lc = extension.prepend(f, Lg)
        fn = piecewise(float(f[0]), extension.evaluate, evaluate)
    else:
        fc, Lc, fn = f, Lg, evaluate

    def abs_1pl(fq):
        return np.abs(1.0 + fn(fq))

    def abs_s(fq):
        return 1.0 / np.abs(1.0 + fn(fq))

    def abs_s_half(fq):
        v = fn(fq)
        return np.abs(1.0 - v) / np.abs(2.0 * (1.0 + v))

    noise = None
    if noise_db is not None:
        lines = np.interp(np.log(f), np.log(f0), np.asarray(noise_db, float))
        noise = np.r_[np.zeros(fc.size - f.size), lines]
    mg = loop_margins(fc, Lc, fn, noise)
    if mg.merged:
        warnings.append(f"{len(mg.merged)} cluster(s) of crossings within the FRF's scatter were merged "
                        "(merged_crossovers)")
    wc, pm, w180, gm = mg.crossovers_hz, mg.phase_margins_deg, mg.phase_crossovers_hz, mg.gain_margins_db
    aS = 1.0 / np.abs(1.0 + Lc)
    ms_f, ms = peak(fc, aS, None if fn is None else abs_s)
    dm_f, dm_peak = peak(fc, np.abs(1.0 - Lc) * aS / 2, None if fn is None else abs_s_half)
    slope = low_frequency_slope(fc, Lc)
    n_int = count_integrators(fc, Lc) if integrators is None else int(integrators)
    bands = level_bands(fc, np.abs(1.0 + Lc), 1.0, None if fn is None else abs_1pl)
    bands = prune_bands(bands, fc, np.abs(1.0 + Lc) - 1.0, scatter_of(Lc, noise))
    if bands and bands[0][0] == fc[0] and n_int > 0:
        bands[0][0] = 0.0
    if extension is None and below_grid == "refuse":
        check_low_end(fc, slope, float(abs(Lc[0])), n_int)
    warnings += contour_warnings(fc, slope, abs(Lc[0]), n_int, extension is not None)
    if abs(Lg[-1]) >= 1:
        warnings.append(f"|L| = {abs(Lg[-1]):.3g} >= 1 at the highest frequency {f[-1]:g} Hz; "
                        "extend the frequency grid for a valid Nyquist count")
    if extension is not None:
        ms_grid = float(np.max(1.0 / np.abs(1.0 + Lg)))
        ms_below = float(np.max(1.0 / np.abs(1.0 + extension.L)))
        warnings += extension.warnings(ms_grid, ms_below)
    winding = nyquist_winding(fc, Lc, n_int)
    n_ccw = int(np.round(winding))
    if abs(winding - n_ccw) > 0.2:
        warnings.append(f"Nyquist winding number {winding:.2f} is not close to an integer; grid too coarse")
    n_cw = -n_ccw
    stable = n_cw + int(open_loop_rhp_poles) == 0
    below = [float(x) for x in wc if x < f[0]]
    return LoopMetrics(
        wc,
        pm,
        worst(pm),
        worst(gm),
        gm,
        w180,
        float(ms),
        float(ms_f),
        bands,
        bool(stable),
        n_cw,
        int(open_loop_rhp_poles),
        n_int,
        warnings,
        float(fc[0]),
        None if extension is None else extension.to_dict(),
        below,
        float(1.0 / dm_peak) if dm_peak > 0 else float("inf"),
        float(dm_f),
        mg.merged,
        int(fc.size),
        INTERPOLATION if measured else None,
        abs(winding - n_ccw) <= 0.2,
        float(f0[-1]) if measured else None,
        float(abs(Lg[-1])) if measured else None,
    )


def line_resolution_warnings(lines_hz: np.ndarray, L_lines: np.ndarray) -> list[str]:
    """A warning naming where an FRF's lines are too far apart for the loop (the verdict then rests on the
    interpolation between them)."""
    bad = unresolved([L_lines], SAMPLE_SLACK)
    if not bad.any():
        return []
    idx = np.flatnonzero(bad)
    i = int(idx[0])
    return [f"the FRF's lines do not resolve the loop at {lines_hz[i]:.5g}-{lines_hz[i + 1]:.5g} Hz"
            f"{f' and {idx.size - 1} more interval(s)' if idx.size > 1 else ''}: the figures there rest on the "
            f"interpolation ({INTERPOLATION}); measure with a finer resolution to confirm them"]
