"""SISO loop analysis: every crossover and margin, peak and disk margins, rejection bands, Nyquist stability.

:func:`analyze_loop` takes the loop ``L(j w)`` either as a function that evaluates it at any frequency (the
analysis cases build one: models and controllers exactly, a measured FRF interpolated between its lines) or as
samples on a strictly increasing grid ``freq_hz`` [Hz]. With a function, the grid is refined until the loop is
resolved (:mod:`feedtune.analysis.resolution`: around crossovers, where the phase turns fast, around lightly damped
poles and zeros), crossings are bracketed and peaks zoomed, so that the figures do not depend on the grid. Samples
that do not resolve the loop are refused (:class:`~feedtune.analysis.resolution.ResolutionError`), never judged.

Every crossover is kept: crossings are merged only in a measured loop and only where the FRF's scatter explains them
(:func:`~feedtune.analysis.margins.merge_chatter`, listed in ``merged_crossovers``).

Speed: :func:`analyze_loops` analyses several loops (the cases of a machine) with one pass over each resolved
contour (``|L|``, ``|1 + L|``, sign changes; the angle of ``1 + L`` only where the real axis is crossed) and the
refinement of all crossings and peaks of all loops in three joint rounds, each one call of a caller-supplied
``evaluate_batch`` (the ball screw's evaluates every model, FRF, hold and controller once per round for all cases).

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
    CHATTER_SIGMAS,
    NEGLIGIBLE_LOOP,
    SMOOTH_LINES,
    ClusterEvidence,
    crossings,
    disk_margins,
    interp_complex,
    keep_and_join,
    level_bands,
    line_scatter_at,
    merge_chatter,
    near_misses,
    phase_crossovers,
    prune_bands,
    settle_clusters,
    smooth_verdict,
)
from .resolution import (
    INTERPOLATION,
    MAX_ROUNDS,
    SAMPLE_SLACK,
    SPLIT,
    ResolutionError,
    _describe,
    check_samples,
    contour_steps,
    feature_points,
    pair_unresolved,
    resolve,
    rules_broken,
    unresolved,
)

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
    possible_crossovers, possible_phase_crossovers : list of dict
        For a measured loop, where it comes within the FRF's scatter of ``|L| = 1`` (of -180 deg) without crossing
        and the lines cannot rule a crossing out (:func:`possible_crossings`), with the phase margin (gain margin)
        such a crossing would have. They are listed among the crossovers (phase crossovers) too: the first crossover
        and the worst margins count them.
    band_edge : dict or None
        For a measured loop, :meth:`~feedtune.analysis.band_edge.BandEdge.to_dict`: up to where its lines prove the
        figures (``valid_to_hz``; ``band_top_hz`` is that line) and how the plant is continued above it and where a
        channel turns to noise (``assumes``).
    gain_margin_sigmas_db : list of float
        For a measured loop, the 1-sigma scatter [dB] of each gain margin: the lines' ``|L|`` scatter at its phase
        crossover (:func:`~feedtune.analysis.margins.line_scatter_at`; 0 where the figure rests on the model or the
        roll-off); empty for a known loop. A limit counts as met only beyond
        :data:`~feedtune.analysis.margins.PROOF_SIGMAS` of them (:meth:`feedtune.analysis.limits.Limits.check`).
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
    possible_crossovers: list = field(default_factory=list)
    possible_phase_crossovers: list = field(default_factory=list)
    band_edge: dict | None = None
    gain_margin_sigmas_db: list = field(default_factory=list)

    @property
    def assumes(self) -> list[str]:
        """What the figures assume beyond the measured band (:func:`assumptions`)."""
        return assumptions(self.band_edge, self.band_top_loop_gain)

    @property
    def first_crossover_hz(self) -> float | None:
        """The first crossover the plant may have [Hz] (possible crossovers included); None without one. The
        bandwidth a design guarantees."""
        return float(self.crossovers_hz[0]) if self.crossovers_hz else None

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
        """``[{"freq_hz", "gm_db"}]`` at every phase crossover, with ``sigma_db`` (its 1-sigma line scatter) for a
        measured loop."""
        return gain_margin_entries(self.phase_crossovers_hz, self.gain_margins_db, self.gain_margin_sigmas_db)

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
            "first_crossover_hz": _f(self.first_crossover_hz),
            "possible_crossovers": list(self.possible_crossovers),
            "possible_phase_crossovers": list(self.possible_phase_crossovers),
            "band_edge": self.band_edge,
            "assumes": self.assumes,
            "warnings": list(self.warnings),
        }


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)


SMALL_LOOP = 0.1
"""A loop gain [-] at the top of the measured band above which the verdict states what it assumes beyond it."""


def assumptions(band_edge: dict | None, top_loop_gain: float | None) -> list[str]:
    """What a measured case's figures rest on beyond its lines: ``valid to HZ; assumes ...`` (one line per
    continued channel) when the loop at the top of the band the lines prove is not small (above
    :data:`SMALL_LOOP`), else nothing."""
    if not band_edge or top_loop_gain is None or top_loop_gain <= SMALL_LOOP or not band_edge.get("assumes"):
        return []
    return [f"valid to {band_edge['valid_to_hz']:.4g} Hz (|L| = {top_loop_gain:.2g} there); assumes "
            + "; ".join(band_edge["assumes"])]


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
    return -_fit_slope(np.log(f[sel]), np.log(np.maximum(np.abs(y[sel]), 1e-300)))


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

    Along the grid (0+ to +inf) the change of the angle of ``1 + L`` is what unwrapping its phase adds up: the
    change between the ends plus ``np.unwrap``'s corrections, which only steps whose ends lie on either side of the
    real axis can need (elsewhere both angles lie in one closed half plane), so only those steps are looked at.
    Above the grid: when ``|L| < 1`` at its top, the loop is taken to roll off to 0 without reaching ``|L| = 1``
    again (what the band_top limit checks), so ``1 + L`` returns to 1 inside the disk ``|1 + L - 1| < 1``, whose
    points all have a positive real part: that return adds exactly ``-angle(1 + L_top)`` (0 for a loop closed at
    ``fs / 2``, which ends on the real axis). The negative frequencies (the conjugate branch) add the same change
    again, and the indentation arc around ``s = 0`` (``z = 1``) its own (:func:`arc_phase_change`).
    """
    L = np.asarray(L)
    y = np.signbit(L.imag)
    idx = np.flatnonzero(y[:-1] != y[1:])
    one_plus = 1.0 + L[np.concatenate([[0], idx, idx + 1, [L.size - 1]])]
    ph = np.angle(one_plus)
    along = float(ph[-1] - ph[0])
    if idx.size:
        d = ph[1 + idx.size:1 + 2 * idx.size] - ph[1:1 + idx.size]
        jump = np.abs(d) >= np.pi  # where np.unwrap corrects
        if jump.any():
            d = d[jump]
            dm = np.mod(d + np.pi, 2 * np.pi) - np.pi
            dm[(dm == -np.pi) & (d > 0)] = np.pi
            along += float(np.sum(dm - d))
    if abs(L[-1]) < 1:
        along -= float(np.angle(1.0 + L[-1]))
    return (2 * along + arc_phase_change(complex(L[0]), integrators)) / (2 * np.pi)


def arc_phase_change(L0: complex, integrators: float) -> float:
    """Change of the angle of ``1 + L`` [rad] along the indentation arc of :func:`nyquist_winding`, in closed form.

    ``L`` turns clockwise by about ``integrators * pi`` from ``L(-j w0) = conj(L0)`` to ``L(+j w0) = L0``; the
    exact turn is the one of that size closing the curve. On the arc ``1 + L`` runs on the circle of radius
    ``r = |L0|`` around 1 from angle ``-phi0`` through ``turn``: for ``r < 1`` the angle of ``1 + r e^(j phi)``
    stays within 90 deg of 0, for ``r > 1`` that of ``r + e^(-j phi)`` does, so the change is the difference of
    principal values (plus the turn itself for ``r > 1``). At ``r = 1`` the arc may pass through 0; it is then
    sampled (721 points) and unwrapped.

    Examples
    --------
    >>> round(arc_phase_change(-2.0 + 0j, 2) / (2 * np.pi), 12)  # 1 + L encircles 0 once on the arc
    -1.0
    >>> abs(round(arc_phase_change(-0.5 + 0j, 2), 12))  # r < 1: it does not
    0.0
    """
    r = abs(L0)
    phi0 = float(np.angle(L0))
    k = np.round((-integrators * np.pi - 2 * phi0) / (2 * np.pi))
    turn = 2 * phi0 + 2 * np.pi * k
    a, b = -phi0, -phi0 + turn
    if r < 1:
        return float(np.angle(1 + r * np.exp(1j * b)) - np.angle(1 + r * np.exp(1j * a)))
    if r > 1:
        return float(turn + np.angle(r + np.exp(-1j * b)) - np.angle(r + np.exp(-1j * a)))
    arc = 1.0 + r * np.exp(1j * (a + turn * np.linspace(0.0, 1.0, 721)))  # through 0: as sampled
    arc_ph = np.unwrap(np.angle(arc))
    return float(arc_ph[-1] - arc_ph[0])


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
    m = int(np.searchsorted(f, f[0] * 2.0**octaves, side="right"))  # the band: a prefix of the sorted grid
    P = np.asarray(plant)[..., :m].reshape(-1, m)
    M = np.asarray(model_plant)[..., :m].reshape(-1, m)
    den = np.zeros(m)
    num = np.zeros(m, complex)
    for p_row, m_row in zip(P, M, strict=True):  # a few channels
        den += np.abs(m_row) ** 2
        num += np.conj(m_row) * p_row
    ok = (den > 0) & np.isfinite(num) & np.isfinite(den)
    c = complex(np.mean(num[ok] / den[ok])) if ok.any() else 1.0 + 0j
    return c, (float(f[0]), float(f[m - 1]))


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
                 noise: np.ndarray | None = None, lines: np.ndarray | None = None) -> Margins:
    """Every crossover and phase crossover of a scalar loop ``L`` on ``freq_hz`` [Hz], refined with ``fn`` (``L``
    at any frequency) when given; ``noise`` [dB] per frequency (a measured loop's scatter) settles the clusters of
    both that the scatter may have made (:func:`~feedtune.analysis.margins.merge_chatter`; ``lines``: the points of
    ``freq_hz`` that are FRF lines, boolean, default all)."""
    with np.errstate(divide="ignore"):
        db = 20 * np.log10(np.abs(L))
    wc = crossings(freq_hz, db, 0.0, None if fn is None else (lambda fq: 20 * np.log10(np.abs(fn(fq)))))
    w180 = phase_crossovers(freq_hz, L, fn)
    Lx = fn(wc) if fn is not None and wc.size else interp_complex(freq_hz, L, wc)
    pm = [float(x) for x in np.rad2deg(np.angle(-Lx))] if wc.size else []
    L180 = fn(w180) if fn is not None and w180.size else interp_complex(freq_hz, L, w180)
    gm = [float(-20 * np.log10(abs(x))) for x in L180]
    merged: list[dict] = []
    if noise is not None:
        wc, pm, merged = merge_chatter(wc, pm, freq_hz, db, noise, lines=lines)
        noise_deg = np.degrees(np.asarray(noise) * np.log(10) / 20)  # circular scatter: phase [rad] = log-magnitude
        w180, gm, merged_180 = merge_chatter(w180, gm, freq_hz, np.degrees(np.angle(-L)), noise_deg,
                                             "phase crossovers", "deg", lines=lines)
        merged += merged_180
    return Margins([float(x) for x in wc], list(pm), [float(x) for x in w180], list(gm), merged)


def gain_margin_entries(freqs_hz, margins_db, sigmas_db) -> list[dict]:
    """``[{"freq_hz", "gm_db"}]`` of the phase crossovers ``freqs_hz`` [Hz] and their margins [dB], each with its
    1-sigma line scatter ``sigma_db`` [dB] when ``sigmas_db`` holds one per margin (a measured loop)."""
    out = [{"freq_hz": float(f), "gm_db": float(g)} for f, g in zip(freqs_hz, margins_db, strict=True)]
    if sigmas_db:
        for e, sigma in zip(out, sigmas_db, strict=True):
            e["sigma_db"] = float(sigma)
    return out


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
                 below_grid: str = "refuse", band_edge=None) -> LoopMetrics:
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
        The loop below ``freq_hz[0]`` from a model (:func:`model_extension`); with ``evaluate``, its grid is
        resolved with the rest of the contour (a :func:`model_extension` without ``loop`` needs no resolving first).
    noise_db : ndarray or LineNoise, shape (n,), optional
        Measurement scatter of a measured loop on ``freq_hz`` [dB]
        (:func:`~feedtune.frf_quality.noise_db`): crossover chatter within it is merged and listed.
    measured : bool
        ``freq_hz`` are an FRF's lines and ``evaluate`` interpolates between them: a warning names where the lines
        do not resolve the loop.
    below_grid : {"refuse", "assume"}
        Without an extension, refuse (default) or accept a grid that starts off the loop's asymptote.
    band_edge : BandEdge, optional
        A measured case's record of where its plant is continued (:mod:`feedtune.analysis.band_edge`): the band
        top of the figures is the top of the band the lines prove, and the metrics say what the rest assumes.

    Raises
    ------
    ResolutionError
        Samples that do not resolve the loop, or a function that cannot be resolved.
    BandLimitedError
        See ``below_grid``.
    """
    case = LoopCase(freq_hz, L, evaluate, features, open_loop_rhp_poles, integrators, extension, noise_db, measured,
                    below_grid, band_edge)
    return analyze_loops([case])[0]


# --------------------------------------------------------------------------------------------- batched analysis
ROOT_ROUNDS = 2
ROOT_POINTS = 24
"""Rounds and interior points per bracket of the crossings' refinement: each bracket narrowed to 1/25 per round (to
1/625 of a grid interval), then the crossing from the cubic through the last samples around it (:func:`_crossing`:
an error of the fourth power of the final spacing). Every round is one joint evaluation: few, wide rounds."""
PEAK_ROUNDS = 2
PEAK_POINTS = 32
"""Sampling rounds and interior points per bracket of the peaks' refinement (each zooming on the largest sample to
2/33 of the bracket), then the loop at the vertex of the parabola through the three largest samples
(:func:`_refine`): the peak's value within about 1e-13 of the true one, and always one of the loop's own values."""


@dataclass
class LoopCase:
    """One scalar loop for :func:`analyze_loops`: the arguments of :func:`analyze_loop`."""

    freq_hz: np.ndarray
    L: np.ndarray | None = None
    evaluate: Callable[[np.ndarray], np.ndarray] | None = None
    features: np.ndarray | None = None
    open_loop_rhp_poles: int = 0
    integrators: int | None = None
    extension: LoopExtension | None = None
    noise_db: object = None
    measured: bool = False
    below_grid: str = "refuse"
    band_edge: object = None

    def contour_function(self) -> Callable[[np.ndarray], np.ndarray] | None:
        """``L`` anywhere on the contour (the extension's below the grid); None when the loop is only sampled."""
        if self.extension is None:
            return self.evaluate
        return piecewise(float(np.asarray(self.freq_hz)[0]), self.extension.evaluate, self.evaluate)


BatchEvaluator = Callable[[list], list]
"""``evaluate_batch([(case index, frequencies [Hz]), ...])`` -> ``[L at those frequencies, ...]``."""


def analyze_loops(cases, evaluate_batch: BatchEvaluator | None = None) -> list[LoopMetrics]:
    """:func:`analyze_loop` of several loops, with the refinement of all of them evaluated in joint rounds.

    Each loop is first resolved on its own (its contour checked once, then only the intervals that break a rule are
    split, :mod:`~feedtune.analysis.resolution`); the quantities every figure needs are taken from one pass over the
    resolved contour. Then every crossing (crossovers, phase crossovers, band edges) and every peak (``|S|``,
    ``|S - 1/2|``) of every loop is refined together: each round asks for ``L`` at all the bracket points of all loops
    at once, by one call of ``evaluate_batch`` (default: each loop's own function), three rounds in all
    (:data:`ROOT_ROUNDS` for the crossings and :data:`PEAK_ROUNDS` for the peaks; the margins at the crossings and the
    peaks' last zoom with the third). Cases may be given by an
    iterator: each is made when it is asked for, so what it needs only to be formed (its plant on the grid) can go
    before the next one is made.

    Parameters
    ----------
    cases : iterable of LoopCase
    evaluate_batch : callable, optional
        ``evaluate_batch([(i, f), ...])`` -> ``[L_i(f), ...]`` over the contours of the cases ``i`` (the
        extension's function below the grid). It may evaluate the common parts of the loops once for all.

    Returns
    -------
    list of LoopMetrics
        In the order of ``cases``.
    """
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # inf and nan are handled where they arise
        return _drive(cases, evaluate_batch)


def _drive(cases, evaluate_batch: BatchEvaluator | None) -> list[LoopMetrics]:
    results: list = []
    functions: list = []
    pending: dict[int, tuple] = {}
    for k, c in enumerate(cases):  # one after the other (an iterator of cases may make each as it is asked for)
        results.append(None)
        fn = c.contour_function()
        functions.append(fn)
        gen = _loop_analysis(c)
        try:
            kind, fq = next(gen)
            while kind == "resolve":
                kind, fq = gen.send(fn(fq) if evaluate_batch is None else evaluate_batch([(k, fq)])[0])
            pending[k] = (gen, fq)
        except StopIteration as stop:
            results[k] = stop.value
        del c
    while pending:
        keys = list(pending)
        if evaluate_batch is None:
            values = [functions[k](pending[k][1]) for k in keys]
        else:
            values = evaluate_batch([(k, pending[k][1]) for k in keys])
        for k, v in zip(keys, values, strict=True):
            gen = pending[k][0]
            try:
                pending[k] = (gen, gen.send(v)[1])
            except StopIteration as stop:
                results[k] = stop.value
                del pending[k]
    return results


_CHUNK = 4096
"""Points per piece where a complex temporary is formed piecewise (the same values, less memory at once)."""


def _abs_one(L: np.ndarray, op: np.ufunc) -> np.ndarray:
    """``abs(op(1, L))`` of a 1-d ``L`` (``op``: :func:`numpy.add` or :func:`numpy.subtract`), the complex ``op(1, L)``
    formed :data:`_CHUNK` points at a time."""
    out = np.empty(L.shape)
    tmp = np.empty(min(L.size, _CHUNK), complex)
    for k in range(0, L.size, _CHUNK):
        t = tmp[:min(_CHUNK, L.size - k)]
        op(1.0, L[k:k + _CHUNK], out=t)
        np.abs(t, out=out[k:k + _CHUNK])
    return out


class _Contour:
    """A loop on its contour and the magnitudes every figure reads: ``|L|`` and ``|1 + L|``."""

    __slots__ = ("L", "a", "a1", "f")

    def __init__(self, f: np.ndarray, L: np.ndarray, a=None, a1=None) -> None:
        self.f, self.L = f, L
        if a is None:
            a = np.abs(L)
            a1 = _abs_one(L, np.add)
        self.a, self.a1 = a, a1

    def insert(self, f_new: np.ndarray, L_new: np.ndarray) -> _Contour:
        """Add the points ``f_new`` [Hz] (not on the contour, none twice) in order, in place (each old array is
        released as its successor is made, when nothing else holds it); returns the contour."""
        if f_new.size == 0:
            return self
        order = np.argsort(f_new, kind="stable")
        f_new, L_new = f_new[order], L_new[order]
        at = np.searchsorted(self.f, f_new)
        at += np.arange(at.size)  # where the new points go (as numpy.insert places them)
        keep = np.ones(self.f.size + at.size, bool)
        keep[at] = False

        def merged(old: np.ndarray, new: np.ndarray) -> np.ndarray:
            out = np.empty(keep.shape, old.dtype)
            out[at] = new
            out[keep] = old
            return out

        self.f = merged(self.f, f_new)
        self.L = merged(self.L, L_new)
        self.a = merged(self.a, np.abs(L_new))
        self.a1 = merged(self.a1, np.abs(1.0 + L_new))
        return self


def _new_points(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The points of ``x`` [Hz] (sorted, unique) that are not already in the sorted grid ``f``."""
    x = np.unique(x)
    if x.size == 0:
        return x
    i = np.clip(np.searchsorted(f, x), 0, f.size - 1)
    return x[f[i] != x]


def _resolve_contour(q: _Contour, bad: np.ndarray, f0: np.ndarray, features):
    """Generator: resolve the contour ``q`` (module docstring of :mod:`~feedtune.analysis.resolution`), asking for
    the loop at new points with ``("resolve", f)``; returns the resolved :class:`_Contour`.

    ``bad`` marks the intervals that break a rule (of those the rules apply to: not the junction of an extension and
    the grid). Intervals are checked once; afterwards only the ones that break a rule are split and their new
    intervals checked.
    """
    f, L = q.f, q.L
    bad_idx = np.flatnonzero(bad)
    extra = _new_points(f, feature_points(features if features is not None else np.empty((0, 2)), f0[0], f0[-1]))
    add_f, add_L = [], []
    if extra.size:
        Lx = np.asarray((yield ("resolve", extra)), complex)
        add_f.append(extra)
        add_L.append(Lx)
        k = np.searchsorted(f, extra) - 1  # interval of each new point
        step = k[1:] != k[:-1]
        first = np.concatenate([[True], step])
        last = np.concatenate([step, [True]])
        fl = np.where(first, f[k], np.concatenate([[0.0], extra[:-1]]))
        Ll = np.where(first, L[k], np.concatenate([[0.0], Lx[:-1]]))
        pairs = [(fl, Ll, extra, Lx), (extra[last], Lx[last], f[k[last] + 1], L[k[last] + 1])]
        split = np.zeros(f.size + 1, bool)  # intervals with new points (k + 1: k is -1 below the contour) ...
        split[k + 1] = True
        bad_idx = bad_idx[~split[bad_idx + 1]]  # ... are replaced by their pieces
        del split
    else:
        pairs = []
    pairs.append((f[bad_idx], L[bad_idx], f[bad_idx + 1], L[bad_idx + 1]))
    fl, Ll, fr, Lr = (np.concatenate(p) for p in zip(*pairs, strict=True))
    del f, L, pairs  # the contour's arrays are replaced when the points are inserted
    keep = pair_unresolved(Ll, Lr)
    keep[len(fl) - bad_idx.size:] = True  # the grid's bad intervals were found bad already
    fl, Ll, fr, Lr = fl[keep], Ll[keep], fr[keep], Lr[keep]
    t = np.arange(1, SPLIT + 1) / (SPLIT + 1)
    for rnd in range(MAX_ROUNDS + 1):
        if fl.size == 0:
            return q.insert(np.concatenate(add_f), np.concatenate(add_L)) if add_f else q
        can = fr > fl * (1 + 1e-12)
        if not can.any() or rnd == MAX_ROUNDS:
            i = int(np.argmin(fl))
            raise ResolutionError(f"the loop cannot be resolved: "
                                  f"{_describe(np.array([fl[i], fr[i]]), [np.array([Ll[i], Lr[i]])], 0)} (it passes "
                                  "through or next to -1 there)")
        lo, hi = np.log(fl[can]), np.log(fr[can])
        fn = np.exp(lo[:, None] + (hi - lo)[:, None] * t[None, :])  # (m, SPLIT)
        Ln = np.asarray((yield ("resolve", fn.ravel())), complex).reshape(fn.shape)
        add_f.append(fn.ravel())
        add_L.append(Ln.ravel())
        cf = np.column_stack([fl[can], fn, fr[can]])  # the chain of each split interval
        cL = np.column_stack([Ll[can], Ln, Lr[can]])
        sub_fl, sub_Ll, sub_fr, sub_Lr = cf[:, :-1].ravel(), cL[:, :-1].ravel(), cf[:, 1:].ravel(), cL[:, 1:].ravel()
        b = pair_unresolved(sub_Ll, sub_Lr)
        fl = np.concatenate([sub_fl[b], fl[~can]])
        Ll = np.concatenate([sub_Ll[b], Ll[~can]])
        fr = np.concatenate([sub_fr[b], fr[~can]])
        Lr = np.concatenate([sub_Lr[b], Lr[~can]])
    raise AssertionError("unreachable")


def _line_warnings(lines_hz: np.ndarray, bad: np.ndarray) -> list[str]:
    if not bad.any():
        return []
    idx = np.flatnonzero(bad)
    i = int(idx[0])
    return [f"the FRF's lines do not resolve the loop at {lines_hz[i]:.5g}-{lines_hz[i + 1]:.5g} Hz"
            f"{f' and {idx.size - 1} more interval(s)' if idx.size > 1 else ''}: the figures there rest on the "
            f"interpolation ({INTERPOLATION}); measure with a finer resolution to confirm them"]


def _fit_slope(x: np.ndarray, y: np.ndarray) -> float:
    """Slope of the least-squares line through ``(x, y)``."""
    xm = x - x.mean()
    return float(np.dot(xm, y - y.mean()) / np.dot(xm, xm))


def _local_maxima(y: np.ndarray, near: float = 0.9) -> tuple[int, np.ndarray]:
    """Index of the largest ``y`` and the interior local maxima within ``near`` of it (as :func:`peak`)."""
    i = int(np.argmax(y))
    if y.size < 3:
        return i, np.empty(0, int)
    inner = np.flatnonzero(y[1:-1] >= near * y[i]) + 1  # near the largest, then the local maxima among them
    return i, inner[(y[inner] >= y[inner - 1]) & (y[inner] >= y[inner + 1])]


def _root_values(kind: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The crossing quantities of the refinement: ``20 log10 |L|`` (kind 0), ``Im L / |L|`` (1), ``log |1 + L|`` (2)."""
    y = np.empty(v.shape)
    for k, fn in ((0, lambda w: 20 * np.log10(np.abs(w))),
                  (1, lambda w: w.imag / np.maximum(np.abs(w), 1e-300)),
                  (2, lambda w: np.log(np.maximum(np.abs(1.0 + w), 1e-300)))):
        sel = kind == k
        if sel.any():
            y[sel] = fn(v[sel])
    return y


def _peak_values(kind: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The peaked quantities: ``|S|`` (kind 0) and ``|S - 1/2|`` (1)."""
    y = np.empty(v.shape)
    sel = kind == 0
    if sel.any():
        y[sel] = 1.0 / np.abs(1.0 + v[sel])
    sel = ~sel
    if sel.any():
        w = v[sel]
        y[sel] = np.abs(1.0 - w) / np.abs(2.0 * (1.0 + w))
    return y


class _ContourNoise:
    """The measured scatter [dB] at contour points (0 on the extension), computed only where asked."""

    def __init__(self, noise, f: np.ndarray, f0: np.ndarray, first: int) -> None:
        self.f, self.f0, self.first = f, f0, first
        shared = hasattr(noise, "log_freq") and getattr(noise, "freq_hz", None) is f0  # the FRF's cases share it
        self.lf0 = noise.log_freq() if shared else np.log(f0)
        self.lines = noise.lines if hasattr(noise, "lines") else np.asarray(noise, float).__getitem__

    def at(self, i0: int, i1: int) -> np.ndarray:
        """Scatter [dB] at the contour points ``i0 .. i1 - 1``."""
        out = np.zeros(max(i1 - i0, 0))
        g0 = max(i0, self.first)
        if g0 < i1:
            x = np.log(self.f[g0:i1])
            n0 = self.lf0.size
            jl = max(int(np.searchsorted(self.lf0, x[0], "right")) - 1, 0)
            jr = min(int(np.searchsorted(self.lf0, x[-1], "left")), n0 - 1)
            out[g0 - i0:] = np.interp(x, self.lf0[jl:jr + 1], self.lines(np.arange(jl, jr + 1)))
        return out

    def around(self, lo_hz: float, hi_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """The FRF's lines from :data:`~feedtune.analysis.margins.SMOOTH_LINES` below ``lo_hz`` to as many above
        ``hi_hz`` [Hz]: their contour indices and their scatter [dB]."""
        j0 = max(int(np.searchsorted(self.f0, lo_hz, "left")) - SMOOTH_LINES, 0)
        j1 = min(int(np.searchsorted(self.f0, hi_hz, "right")) + SMOOTH_LINES, self.f0.size)
        j = np.arange(j0, j1)
        return np.searchsorted(self.f, self.f0[j]), np.asarray(self.lines(j), float)


def _merge_chatter(wc: np.ndarray, values: list, f: np.ndarray, deviation: Callable, noise: _ContourNoise | None,
                   what: str, unit: str, to_unit: Callable = lambda sigma_db: sigma_db
                   ) -> tuple[np.ndarray, list, list[dict]]:
    """:func:`~feedtune.analysis.margins.merge_chatter` with the deviation (``deviation(idx)`` at the contour points
    ``idx``) and the scatter (``to_unit`` of the scatter in dB) read only over the clusters and the lines around
    them."""
    if noise is None or wc.size < 2:
        return wc, values, []

    def measure(c: list[float]) -> ClusterEvidence:
        i0, i1 = int(np.searchsorted(f, c[0], "left")), int(np.searchsorted(f, c[-1], "right"))
        if i1 > i0:
            excursion, sigma = float(np.max(np.abs(deviation(np.arange(i0, i1))))), float(np.max(to_unit(
                noise.at(i0, i1))))
        else:  # between two points: the scatter interpolated at the first crossing
            j = min(max(int(np.searchsorted(f, c[0], "right")) - 1, 0), f.size - 2)
            excursion, sigma = 0.0, float(np.interp(c[0], f[j:j + 2], to_unit(noise.at(j, j + 2))))
        idx, sig = noise.around(c[0], c[-1])
        below = max(i0 - 1, 0)
        side = 1.0 if deviation(np.array([below]))[0] >= 0 else -1.0
        smooth = smooth_verdict(np.log(f[idx]), deviation(idx), to_unit(sig), float(np.log(c[0])),
                                float(np.log(c[-1])), side)
        return ClusterEvidence(excursion, sigma, smooth)

    return settle_clusters(wc, values, measure, what, unit)


def _prune_bands(bands: list, f: np.ndarray, L: np.ndarray, noise: _ContourNoise) -> list:
    """:func:`~feedtune.analysis.margins.prune_bands` on the contour ``f``, ``L`` with the scatter read only where the
    decision needs it (first where ``(|1 + L| - 1) / |L|`` is largest: enough when the band passes there)."""
    if not bands:
        return bands

    def strongest(lo, hi, sign):
        i0, i1 = int(np.searchsorted(f, lo, "left")), int(np.searchsorted(f, hi, "right"))
        if i1 <= i0:
            return 0.0
        l = L[i0:i1]
        a = np.abs(l)
        ex = np.abs(1.0 + l) - 1.0
        if sign < 0:
            np.negative(ex, out=ex)
        r = ex / a
        r[np.isnan(r)] = -np.inf
        j = int(np.argmax(r))
        z = ex[j] / max(float(a[j] * (noise.at(i0 + j, i0 + j + 1)[0] * np.log(10) / 20)), 1e-300)
        if z >= CHATTER_SIGMAS:  # enough for the decision: the largest is at least this
            return float(z)
        sigma = a * (noise.at(i0, i1) * np.log(10) / 20)
        return float(np.max(ex / np.maximum(sigma, 1e-300)))

    return keep_and_join(bands, strongest)


def _loop_analysis(c: LoopCase):
    """Generator computing :class:`LoopMetrics` of one loop: yields ``("resolve", f)`` while it resolves the
    contour and ``("refine", f)`` in each joint refinement round, and is sent ``L`` at ``f`` [Hz]."""
    if c.below_grid not in ("refuse", "assume"):
        raise ValueError(f"below_grid must be 'refuse' or 'assume', got {c.below_grid!r}")
    f0 = np.asarray(c.freq_hz, float)
    warnings: list[str] = []
    extension = c.extension
    if c.evaluate is not None:
        L0 = c.evaluate(f0) if c.L is None else np.asarray(c.L, complex)
    else:
        L0 = np.asarray(c.L, complex)
    fn = c.contour_function()
    if extension is not None:
        nx = extension.freq_hz.size
        q = _Contour(np.concatenate([extension.freq_hz, f0]), np.concatenate([extension.L, L0]))
    else:
        nx = 0
        q = _Contour(f0, L0)
    if c.evaluate is None:
        check_samples(f0, [L0])
    else:
        steps = contour_steps(q.L, q.a, q.a1)
        if c.measured:  # the FRF's lines alone: the intervals of the grid, rules relaxed as for samples
            warnings += _line_warnings(f0, rules_broken(steps, SAMPLE_SLACK, start=nx))
        bad = rules_broken(steps)
        del steps
        if nx:
            bad[nx - 1] = False  # the junction of the extension and the grid
            if extension.evaluate is None:
                bad[:nx] = False
        q = yield from _resolve_contour(q, bad, f0, c.features)
        del bad
    g = _GridFigures(q, f0, c.integrators)
    if extension is None and c.below_grid == "refuse":
        check_low_end(q.f, g.slope, g.a_low, g.n_int)
    # the warnings that follow the one on merged crossings, and the Nyquist count: from the contour as it is
    later = contour_warnings(q.f, g.slope, g.a_low, g.n_int, extension is not None)
    L_top = complex(q.L[-1])
    if abs(L_top) >= 1:
        later.append(f"|L| = {abs(L_top):.3g} >= 1 at the highest frequency {q.f[-1]:g} Hz; "
                     "extend the frequency grid for a valid Nyquist count")
    if extension is not None:
        later += extension.warnings(g.ms_grid, g.ms_below)
    winding = nyquist_winding(q.f, q.L, g.n_int)
    f_low, n_points = float(q.f[0]), int(q.f.size)
    noise = None if c.noise_db is None else _ContourNoise(c.noise_db, q.f, f0, g.first)

    if fn is None:  # samples: figures interpolated between them
        f, L = q.f, q.L
        noise_arr = None if noise is None else noise.at(0, f.size)
        mg = loop_margins(f, L, None, noise_arr, np.arange(f.size) >= g.first)
        wc, pm, w180, gm, merged = (mg.crossovers_hz, mg.phase_margins_deg, mg.phase_crossovers_hz,
                                    mg.gain_margins_db, mg.merged)
        bands = level_bands(f, q.a1, 1.0)
        bands = prune_bands(bands, f, q.a1 - 1.0, scatter_of(L, noise_arr))
        (ms_f, ms), (dm_f, dm_peak) = g.ms_at_grid, g.dm_at_grid
    else:
        # only a measured loop reads the contour again (its scatter, around clusters and bands): f and L
        f, L = (q.f, q.L) if noise is not None else (None, None)
        del q
        wc, w180, edges, merged, pm, gm, ms_pk, dm_pk = yield from _refine(g, f, L, noise)
        (ms_f, ms), (dm_f, dm_peak) = ms_pk, dm_pk
        bands = _bands(g, edges)
        if noise is not None:
            bands = _prune_bands(bands, f, L, noise)
    if merged:
        warnings.append(f"{len(merged)} cluster(s) of crossings within the FRF's scatter were merged "
                        "(merged_crossovers)")
    possible_x, possible_180 = ([], []) if noise is None else possible_crossings(f, L, f0, noise.lines, wc, w180,
                                                                                   merged)
    if possible_x or possible_180:
        warnings.append(possible_warning(possible_x, possible_180))
        wc, pm = with_possible(wc, pm, possible_x, "pm_deg")
        w180, gm = with_possible(w180, gm, possible_180, "gm_db")
    warnings += later
    if bands and bands[0][0] == f_low and g.n_int > 0:
        bands[0][0] = 0.0
    n_ccw = int(np.round(winding))
    if abs(winding - n_ccw) > 0.2:
        warnings.append(f"Nyquist winding number {winding:.2f} is not close to an integer; grid too coarse")
    n_cw = -n_ccw
    stable = n_cw + int(c.open_loop_rhp_poles) == 0
    i_top = band_top_index(f0, c.band_edge)
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
        int(c.open_loop_rhp_poles),
        g.n_int,
        warnings,
        f_low,
        None if extension is None else extension.to_dict(),
        [float(x) for x in wc if x < f0[0]],
        float(1.0 / dm_peak) if dm_peak > 0 else float("inf"),
        float(dm_f),
        merged,
        n_points,
        INTERPOLATION if c.measured else None,
        abs(winding - n_ccw) <= 0.2,
        float(f0[i_top]) if c.measured else None,
        float(abs(L0[i_top])) if c.measured else None,
        possible_x,
        possible_180,
        None if c.band_edge is None else c.band_edge.to_dict(),
        [] if noise is None else line_scatter_at(f0, noise.lines, w180, float(f0[i_top])),
    )


def band_top_index(f0: np.ndarray, edge) -> int:
    """Index into the lines ``f0`` [Hz] of a measured case of the last line of the band its lines prove
    (:attr:`~feedtune.analysis.band_edge.BandEdge.valid_to_hz`; the last line without a band edge)."""
    if edge is None:
        return f0.size - 1
    return min(int(np.searchsorted(f0, edge.valid_to_hz)), f0.size - 1)


NEAR_BOUND_DB = 7.0
"""Largest twice-scatter [dB] of a line the possible-crossing search judges: a line whose 2-sigma relative error
reaches 1 (20 log10 1.5 = 3.5 dB) proves nothing (its disk holds the origin)."""


def possible_crossings(f: np.ndarray, L: np.ndarray, lines_hz: np.ndarray, scatter_db: Callable,
                       crossovers_hz, phase_crossovers_hz, merged: list[dict] = ()) -> tuple[list[dict], list[dict]]:
    """The possible crossovers and phase crossovers of a measured loop (:func:`~feedtune.analysis.margins.
    near_misses`) with the margin each would have: ``[{"freq_hz", "pm_deg", "gap_db", "scatter_db", "smooth"}]`` and
    ``[{"freq_hz", "gm_db", "gap_deg", "scatter_deg", "smooth"}]``.

    ``f``, ``L`` are the contour (the FRF's ``lines_hz`` [Hz] among its points), ``scatter_db(index)`` the scatter [dB]
    of the lines ``index``; the crossings of the ``merged`` clusters are decided already.
    """
    settled = {what: [x for r in merged if r["of"] == what for x in r["freq_hz"]]
               for what in ("crossovers", "phase crossovers")}
    at = np.searchsorted(f, lines_hz)

    def db_at(i):
        with np.errstate(divide="ignore"):
            return 20 * np.log10(np.abs(L[at[i]]))

    def phase_at(i):  # the angle of -L where L is on the negative real side and not negligible, else 180 deg
        Li = L[at[i]]
        return np.where((np.abs(Li) >= NEGLIGIBLE_LOOP) & (Li.real < 0), np.degrees(np.angle(-Li)), 180.0)

    def deg_at(i):
        return np.degrees(np.asarray(scatter_db(i), float) * np.log(10) / 20)

    out_x = [{"freq_hz": p["freq_hz"], "pm_deg": float(np.degrees(np.angle(-L[at[p["index"]]]))), "gap_db": p["gap"],
              "scatter_db": p["scatter"], "smooth": p["smooth"]}
             for p in near_misses(lines_hz, db_at, scatter_db, [*crossovers_hz, *settled["crossovers"]],
                                  NEAR_BOUND_DB)]
    out_p = [{"freq_hz": p["freq_hz"], "gm_db": float(-db_at(np.array([p["index"]]))[0]), "gap_deg": p["gap"],
              "scatter_deg": p["scatter"], "smooth": p["smooth"]}
             for p in near_misses(lines_hz, phase_at, deg_at, [*phase_crossovers_hz, *settled["phase crossovers"]],
                                  float(np.degrees(NEAR_BOUND_DB * np.log(10) / 20)))]
    return out_x, out_p


def with_possible(crossings_hz: list, margins: list, possible: list[dict], key: str) -> tuple[list, list]:
    """The crossings [Hz] and their margins with the possible ones (``possible[i]["freq_hz"]``, ``[key]``) added, in
    order of frequency."""
    pairs = sorted([*zip(crossings_hz, margins, strict=True), *((p["freq_hz"], p[key]) for p in possible)])
    return [float(f) for f, _ in pairs], [float(v) for _, v in pairs]


def possible_warning(possible_x: list[dict], possible_180: list[dict]) -> str:
    """One line naming where the lines leave a crossing open (:func:`possible_crossings`)."""
    parts = []
    if possible_x:
        parts.append("|L| = 1 at " + ", ".join(f"{p['freq_hz']:.4g} Hz" for p in possible_x[:4]))
    if possible_180:
        parts.append("-180 deg at " + ", ".join(f"{p['freq_hz']:.4g} Hz" for p in possible_180[:4]))
    return ("the loop comes within the FRF's scatter of " + " and of ".join(parts) + " without crossing and the "
            "lines cannot rule a crossing out: counted as possible crossings (the first crossover and the worst "
            "margins include them; possible_crossovers)")


class _GridFigures:
    """What one pass over the resolved contour gives: the brackets of every crossing (crossovers, phase crossovers,
    ``|S| = 1``) and of every peak near the largest (``|S|``, ``|S - 1/2|``), the grid's peaks, the low-frequency
    slope and the peak sensitivity above and below the grid's first line."""

    def __init__(self, q: _Contour, f0: np.ndarray, integrators: int | None) -> None:
        f, L, a, a1 = q.f, q.L, q.a, q.a1
        self.first = int(np.searchsorted(f, f0[0]))  # contour points below the grid (the extension)
        aS = 1.0 / a1
        below = a < 1.0
        idx_c = np.flatnonzero(below[:-1] != below[1:])
        del below
        neg = np.signbit(L.imag)
        idx_p = np.flatnonzero(neg[:-1] != neg[1:])  # the imaginary axis crossed; then on the negative real axis
        del neg
        re = L.real
        idx_p = idx_p[(re[idx_p] + re[idx_p + 1] < 0) & ((a[idx_p] >= NEGLIGIBLE_LOOP)
                                                         | (a[idx_p + 1] >= NEGLIGIBLE_LOOP))]
        del re
        out_band = a1 > 1.0
        idx_b = np.flatnonzero(out_band[:-1] != out_band[1:])
        self.band_ends = (bool(out_band[0]), bool(out_band[-1]), bool(out_band.any()))
        self.band_rising = out_band[idx_b + 1]
        del out_band
        self.f_ends = (float(f[0]), float(f[-1]))
        i_ms, in_ms = _local_maxima(aS)
        half = _abs_one(L, np.subtract)
        half *= aS
        half /= 2
        i_dm, in_dm = _local_maxima(half)
        self.ms_at_grid = float(f[i_ms]), float(aS[i_ms])
        self.dm_at_grid = float(f[i_dm]), float(half[i_dm])
        del half
        self.ms_grid = float(np.max(aS[self.first:]))
        self.ms_below = float(np.max(aS[:self.first])) if self.first else 0.0
        del aS
        ends = np.concatenate([idx_c, idx_p, idx_b])
        lf = np.log(f[np.concatenate([ends, ends + 1])])
        nr = idx_c.size + idx_p.size + idx_b.size
        self.root_kind = np.repeat(np.arange(3), [idx_c.size, idx_p.size, idx_b.size])
        self.root_lo, self.root_hi = lf[:nr], lf[nr:]
        if f.size >= 3:
            p_idx = np.concatenate([in_ms, in_dm])
            self.peak_kind = np.repeat(np.arange(2), [in_ms.size, in_dm.size])
        else:
            p_idx = self.peak_kind = np.empty(0, int)
        self.peak_lo, self.peak_hi = np.log(f[p_idx - 1]), np.log(f[p_idx + 1])
        m = int(np.searchsorted(f, f[0] * 2.0, side="right"))  # the lines f <= 2 f[0]: a prefix of the sorted f
        if m < 3:
            m = min(3, f.size)
        # (copies, as a selection makes them: numpy's log may differ in the last bit with the alignment)
        self.slope = 0.0 if m < 2 else -_fit_slope(np.log(f[:m].copy()), np.log(np.maximum(a[:m], 1e-300)))
        self.n_int = max(0, int(np.round(self.slope))) if integrators is None else int(integrators)
        self.a_low = float(a[0])


def _refine(g: _GridFigures, f: np.ndarray | None, L: np.ndarray | None, noise: _ContourNoise | None):
    """Generator: refine every crossing and peak of :class:`_GridFigures` in joint rounds (``("refine", points)``,
    sent ``L`` there) and return ``(crossovers, phase crossovers, band edges, merged clusters, phase margins, gain
    margins, (f, |S|) peak, (f, |S - 1/2|) peak)``; with ``noise``, the clusters of crossings that the scatter may
    have made are settled on the contour ``f``, ``L`` with their margins (:func:`_merge_chatter`).

    Rounds: the crossings' brackets sampled :data:`ROOT_ROUNDS` times (then :func:`_crossing`), the peaks' brackets
    :data:`PEAK_ROUNDS` times (each round zooming on the largest sample), and one last round with the loop at the
    crossings (their margins) and at the vertex of the parabola through the three largest samples of each peak (the
    peak is the largest value evaluated: always one of the loop's own).
    """
    t, tp = np.linspace(0.0, 1.0, ROOT_POINTS + 2), np.linspace(0.0, 1.0, PEAK_POINTS + 2)
    rlo, rhi, plo, phi = g.root_lo, g.root_hi, g.peak_lo, g.peak_hi
    nr, npk = rlo.size, plo.size
    rk, pk = np.repeat(g.root_kind, t.size), np.repeat(g.peak_kind, tp.size)
    rows_r, rows_p = np.arange(nr), np.arange(npk)
    wc = w180 = edges = np.empty(0)
    best_x = best_y = vertex = np.empty(0)
    merged: list[dict] = []
    pm: list = []
    gm: list = []
    last = max(ROOT_ROUNDS, PEAK_ROUNDS)
    for rnd in range(last + 1):
        parts = []
        xr = xp = None
        if rnd < ROOT_ROUNDS and nr:
            xr = rlo[:, None] + (rhi - rlo)[:, None] * t[None, :]
            parts.append(np.exp(xr.ravel()))
        if rnd < PEAK_ROUNDS and npk:
            xp = plo[:, None] + (phi - plo)[:, None] * tp[None, :]
            parts.append(np.exp(xp.ravel()))
        if rnd == last:
            parts += [wc, w180, np.exp(vertex)]
        if not any(p.size for p in parts):
            if rnd == last:
                break
            v = np.empty(0, complex)
        else:
            v = np.asarray((yield ("refine", np.concatenate(parts))), complex)
        pos = 0
        if xr is not None:
            y = _root_values(rk, v[:xr.size]).reshape(xr.shape)
            pos = xr.size
            s = np.signbit(y)
            change = s[:, :-1] != s[:, 1:]
            j = np.where(change.any(axis=1), np.argmax(change, axis=1), 0)
            if rnd < ROOT_ROUNDS - 1:
                rlo, rhi = xr[rows_r, j], xr[rows_r, j + 1]
            else:
                roots = np.exp(_crossing(xr, y, j))
                kind = g.root_kind
                wc, w180, edges = roots[kind == 0], roots[kind == 1], roots[kind == 2]
        if xp is not None:
            y = _peak_values(pk, v[pos:pos + xp.size]).reshape(xp.shape)
            pos += xp.size
            j = np.argmax(y, axis=1)
            if rnd < PEAK_ROUNDS - 1:
                plo = xp[rows_p, np.maximum(j - 1, 0)]
                phi = xp[rows_p, np.minimum(j + 1, PEAK_POINTS + 1)]
            else:
                best_x, best_y = xp[rows_p, j], y[rows_p, j]
                vertex = _vertex(xp, y, j)
        if rnd == last:
            Lx, L180, Lv = v[pos:pos + wc.size], v[pos + wc.size:pos + wc.size + w180.size], v[pos + wc.size
                                                                                                + w180.size:]
            pm = [float(x) for x in np.rad2deg(np.angle(-Lx))] if wc.size else []
            gm = [float(x) for x in -20 * np.log10(np.abs(L180))]
            if noise is not None:  # the clusters the scatter may have made, settled with their members' margins
                wc, pm, merged = _merge_chatter(wc, pm, f, lambda i: 20 * np.log10(np.abs(L[i])), noise,
                                                "crossovers", "dB")
                w180, gm, merged_180 = _merge_chatter(w180, gm, f, lambda i: np.degrees(np.angle(-L[i])), noise,
                                                      "phase crossovers", "deg",
                                                      lambda s_db: np.degrees(s_db * np.log(10) / 20))
                merged += merged_180
            yv = _peak_values(g.peak_kind, Lv)
            take = yv > best_y
            best_x, best_y = np.where(take, vertex, best_x), np.where(take, yv, best_y)
    fp = np.exp(best_x)
    ms_pk = _best_peak(fp[g.peak_kind == 0], best_y[g.peak_kind == 0], *g.ms_at_grid)
    dm_pk = _best_peak(fp[g.peak_kind == 1], best_y[g.peak_kind == 1], *g.dm_at_grid)
    return [float(x) for x in wc], [float(x) for x in w180], edges, merged, pm, gm, ms_pk, dm_pk


def _vertex(x: np.ndarray, y: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Vertex (log frequency) of the parabola through the samples ``j - 1, j, j + 1`` of each row (the three nearest
    inside the row at its ends), kept inside them; the largest sample where it is undefined."""
    rows = np.arange(x.shape[0])
    k = np.clip(j, 1, x.shape[1] - 2)
    x0, x1, x2 = x[rows, k - 1], x[rows, k], x[rows, k + 1]
    y0, y1, y2 = y[rows, k - 1], y[rows, k], y[rows, k + 1]
    num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
    den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
    xv = x1 - 0.5 * num / den
    ok = np.isfinite(xv) & (xv >= x0) & (xv <= x2)
    return np.where(ok, xv, x[rows, j])


def _crossing(x: np.ndarray, y: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Where ``y`` crosses 0 between the samples ``j`` and ``j + 1`` of each row (``x``: log frequency).

    The linear interpolation in the bracket (as :func:`~feedtune.analysis.resolution.refine_roots`), then one Newton
    step on the cubic through the four samples around it: an error of the fourth power of the sample spacing instead
    of the square; the step is kept only when it stays inside the bracket (at an FRF's line, where the interpolated
    loop has a kink, the linear estimate is as good as any).
    """
    rows = np.arange(x.shape[0])
    xa, xb, ya, yb = x[rows, j], x[rows, j + 1], y[rows, j], y[rows, j + 1]
    frac = np.where(ya != yb, ya / (ya - yb), 0.5)
    x0 = xa + np.clip(frac, 0.0, 1.0) * (xb - xa)
    if x.shape[1] < 4:
        return x0
    k = np.clip(j - 1, 0, x.shape[1] - 4)[:, None] + np.arange(4)[None, :]
    X, Y = x[rows[:, None], k], y[rows[:, None], k]
    # Newton's divided differences of the cubic through the four samples
    d1 = (Y[:, 1:] - Y[:, :-1]) / (X[:, 1:] - X[:, :-1])
    d2 = (d1[:, 1:] - d1[:, :-1]) / (X[:, 2:] - X[:, :-2])
    d3 = (d2[:, 1:] - d2[:, :-1]) / (X[:, 3:] - X[:, :-3])
    c0, c1, c2, c3 = Y[:, 0], d1[:, 0], d2[:, 0], d3[:, 0]
    u0, u1, u2 = x0 - X[:, 0], x0 - X[:, 1], x0 - X[:, 2]
    p = c0 + u0 * (c1 + u1 * (c2 + u2 * c3))
    dp = c1 + c2 * (u0 + u1) + c3 * (u0 * u1 + u0 * u2 + u1 * u2)
    x1 = x0 - p / dp
    ok = np.isfinite(x1) & (x1 >= np.minimum(xa, xb)) & (x1 <= np.maximum(xa, xb)) & (ya != yb)
    return np.where(ok, x1, x0)


def _best_peak(fp: np.ndarray, yp: np.ndarray, f_grid: float, y_grid: float) -> tuple[float, float]:
    """The largest refined peak when it is at least the grid's, else the grid's (as :func:`peak`)."""
    if fp.size:
        k = int(np.argmax(yp))
        if yp[k] >= y_grid:
            return float(fp[k]), float(yp[k])
    return f_grid, y_grid


def _bands(g: _GridFigures, edges: np.ndarray) -> list[list[float]]:
    """The ``|S| < 1`` bands from the refined edges (as :func:`~feedtune.analysis.margins.level_bands`)."""
    first, last, any_band = g.band_ends
    if not any_band:
        return []
    starts = [float(x) for x in edges[g.band_rising]]
    ends = [float(x) for x in edges[~g.band_rising]]
    if first:
        starts.insert(0, g.f_ends[0])
    if last:
        ends.append(g.f_ends[1])
    return [[s, e] for s, e in zip(starts, ends, strict=True)]


def line_resolution_warnings(lines_hz: np.ndarray, L_lines: np.ndarray) -> list[str]:
    """A warning naming where an FRF's lines are too far apart for the loop (the verdict then rests on the
    interpolation between them)."""
    return _line_warnings(lines_hz, unresolved([L_lines], SAMPLE_SLACK))
