"""The input shaper for identified modes: the least smoothing that keeps every mode's residual vibration in bounds.

Given the modes a move leaves ringing -- one per FRF of a machine whose mode moves with position or load (the
ball-screw family m70/m100/m130, the gantry at three table positions), each a frequency and a damping ratio --
:func:`choose_shaper` designs each shaper type (:data:`~feedtune.control.shapers.SHAPER_TYPES`) for them and picks
one by the trade-off between residual vibration and smoothing:

1. **The modes in between.** A mode that moves continuously between the identified ones passes every frequency of
   their span: the modes are joined by :data:`SPAN_POINTS` points per gap, frequency and damping interpolated
   (geometrically in frequency), and the vibration is judged on all of them.
2. **Per type**, the shaper frequency ``f_s`` is scanned over ``[f_min / 2, 2 f_max]`` (:data:`SCAN_POINTS`
   geometric steps) at the design damping ``zeta_s`` (the median of the modes' dampings); at each, the worst residual
   vibration over the span (:meth:`~feedtune.control.shapers.InputShaper.vibration`, or the sampled taps' when the
   target's rate ``fs`` is given: what the target runs). The type's frequency is the one of the least worst
   vibration (minimax): the centre of the span as the type sees it, which keeps the margin to a mode that moves a
   little further than measured. (Pushing ``f_s`` up to where the worst vibration just reaches the bound would buy a
   few percent less smoothing for no margin at all.)
3. **Across types**, the chosen shaper is the one of the least smoothing (Klipper's figure at ``accel``:
   the path's deviation at a corner, which grows with the shaper's duration) among those whose worst vibration is
   within ``max_vibration`` (default 5 %); when no type is, the one of the least worst vibration (and
   :attr:`ShaperChoice.meets_target` is False).

The added delay of each (its duration: a move ends that much later; its lag: the mean delay of a shaped ramp) is
reported beside its smoothing and vibration. Klipper's own fit to a measured PSD (:mod:`feedtune.design.input_shaper`)
weighs vibration by the spectrum instead: that is the rule for a printer's accelerometer PSD, which has no modes'
damping to design for.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..control.shapers import (
    SHAPER_TYPES,
    SMOOTHING_ACCEL,
    SQUARE_CORNER_VELOCITY,
    TARGET_SMOOTHING,
    InputShaper,
    max_accel,
    residual_vibration,
    sampled_table,
    shaper_table,
    smoothing,
)
from ..errors import UsageError

MAX_VIBRATION = 0.05
"""Default bound on the residual vibration at every mode, as a fraction of the unshaped move's [-] (the EI family's
design tolerance)."""
SPAN_POINTS = 8
"""Points inserted between two consecutive identified modes (the mode moving between them)."""
SCAN_POINTS = 801
"""Shaper frequencies tried per type, geometrically spaced over ``[f_min / 2, 2 f_max]``."""
MAX_DESIGN_DAMPING = 0.3
"""The design damping is the median of the modes', at most this [-]."""


@dataclass(frozen=True)
class ShaperCandidate:
    """One shaper type designed for the modes.

    Parameters
    ----------
    shaper : InputShaper
        The shaper at its chosen frequency and the design damping.
    vibrations : ndarray
        Residual vibration at each identified mode [-].
    worst_vibration : float
        The largest over the modes and the span between them [-].
    smoothing_m : float
        Klipper's smoothing figure at the choice's ``accel`` [m].
    max_accel : float
        Largest acceleration keeping the smoothing at 0.12 mm [m/s^2].
    duration_s, time_shift_s : float
        Added delay: duration (a move ends that much later) and lag (mean delay) of the shaper as run [s].
    meets_target : bool
        ``worst_vibration <= max_vibration``.
    """

    shaper: InputShaper
    vibrations: np.ndarray
    worst_vibration: float
    smoothing_m: float
    max_accel: float
    duration_s: float
    time_shift_s: float
    meets_target: bool

    @property
    def kind(self) -> str:
        """The shaper type."""
        return self.shaper.kind

    def to_dict(self) -> dict:
        """The figures (units in the keys) and ``shaper`` (:meth:`InputShaper.to_dict`)."""
        return {"kind": self.kind, "freq_hz": self.shaper.freq_hz, "damping": self.shaper.damping,
                "vibrations": self.vibrations.tolist(), "worst_vibration": self.worst_vibration,
                "smoothing_m": self.smoothing_m, "max_accel": self.max_accel, "duration_s": self.duration_s,
                "time_shift_s": self.time_shift_s, "meets_target": self.meets_target,
                "shaper": self.shaper.to_dict()}

    def __repr__(self) -> str:
        return (f"ShaperCandidate({self.kind} at {self.shaper.freq_hz:.4g} Hz: worst vibration "
                f"{self.worst_vibration:.1%}, smoothing {self.smoothing_m * 1e6:.4g} um, duration "
                f"{self.duration_s * 1e3:.4g} ms)")


@dataclass(frozen=True)
class ShaperChoice:
    """The shaper types designed for a set of modes and the one chosen (module docstring).

    Parameters
    ----------
    freqs_hz, dampings : ndarray
        The identified modes [Hz, -].
    candidates : tuple of ShaperCandidate
        One per type tried.
    chosen : ShaperCandidate
    max_vibration : float
        The bound [-].
    design_damping : float
        The shapers' design damping [-].
    fs : float or None
        The target's rate the vibration was judged at [Hz] (None: the continuous shaper).
    accel : float
        Acceleration of the smoothing figure [m/s^2].
    """

    freqs_hz: np.ndarray
    dampings: np.ndarray
    candidates: tuple[ShaperCandidate, ...]
    chosen: ShaperCandidate
    max_vibration: float
    design_damping: float
    fs: float | None
    accel: float

    @property
    def meets_target(self) -> bool:
        """The chosen shaper keeps every mode within :attr:`max_vibration`."""
        return self.chosen.meets_target

    def candidate(self, kind: str) -> ShaperCandidate:
        """The candidate of one type (KeyError naming the types tried)."""
        for c in self.candidates:
            if c.kind == kind:
                return c
        raise KeyError(f"no {kind!r} candidate; tried {', '.join(c.kind for c in self.candidates)}")

    def to_dict(self) -> dict:
        """Modes, rule, candidates and the chosen type, with units."""
        return {"modes": [{"freq_hz": float(f), "damping": float(z)} for f, z in zip(self.freqs_hz, self.dampings,
                                                                                       strict=True)],
                "max_vibration": self.max_vibration, "design_damping": self.design_damping, "fs_hz": self.fs,
                "accel": self.accel, "chosen": self.chosen.kind, "meets_target": self.meets_target,
                "candidates": [c.to_dict() for c in self.candidates],
                "units": {"freq_hz": "Hz", "damping": "-", "vibrations": "-", "worst_vibration": "-",
                          "max_vibration": "-", "smoothing_m": "m", "max_accel": "m/s^2", "duration_s": "s",
                          "time_shift_s": "s", "accel": "m/s^2", "fs_hz": "Hz"}}

    def __repr__(self) -> str:
        return (f"ShaperChoice({self.chosen!r}; {len(self.freqs_hz)} modes "
                f"{self.freqs_hz.min():.4g}-{self.freqs_hz.max():.4g} Hz)")


def mode_span(freqs_hz, dampings, points: int = SPAN_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """The modes and :data:`SPAN_POINTS` points between each two consecutive (sorted by frequency), frequency
    geometric and damping linear in ``log f`` [Hz, -]."""
    f = np.asarray(freqs_hz, float)
    z = np.asarray(dampings, float)
    order = np.argsort(f)
    f, z = f[order], z[order]
    if f.size < 2:
        return f, z
    u = np.linspace(0.0, 1.0, points + 2)[:-1]
    lf = np.log(f)
    span_f = np.concatenate([np.exp(lf[i] + u * (lf[i + 1] - lf[i])) for i in range(f.size - 1)] + [f[-1:]])
    span_z = np.concatenate([z[i] + u * (z[i + 1] - z[i]) for i in range(f.size - 1)] + [z[-1:]])
    return span_f, span_z


def _impulses(a: np.ndarray, t: np.ndarray, fs: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The impulses the target runs: the shaper's own, or its sampled taps at ``fs``."""
    if fs is None:
        return a, t
    d, w = sampled_table(a, t, fs)
    return w, d / fs


def _worst(a: np.ndarray, t: np.ndarray, span_f: np.ndarray, span_z: np.ndarray) -> np.ndarray:
    """Worst residual vibration of each shaper row over the span [-]."""
    worst = np.zeros(a.shape[0])
    for z in np.unique(span_z):
        worst = np.maximum(worst, residual_vibration(a, t, span_f[span_z == z], float(z)).max(axis=1))
    return worst


def _check_modes(freqs_hz, dampings) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(freqs_hz, float).reshape(-1)
    z = np.asarray(dampings, float).reshape(-1)
    if f.size == 0 or f.size != z.size:
        raise UsageError("choose_shaper needs at least one mode: equally many frequencies and damping ratios",
                         parameter="modes")
    if not (np.all(np.isfinite(f)) and np.all(f > 0)):
        raise UsageError("mode frequencies must be finite and > 0 Hz", parameter="modes")
    if not (np.all(np.isfinite(z)) and np.all((z >= 0) & (z < 1))):
        raise UsageError("mode damping ratios must be in [0, 1)", parameter="modes")
    return f, z


def choose_shaper(freqs_hz, dampings, *, kinds: Sequence[str] = SHAPER_TYPES, max_vibration: float = MAX_VIBRATION,
                  design_damping: float | None = None, fs: float | None = None, accel: float = SMOOTHING_ACCEL,
                  scv: float = SQUARE_CORNER_VELOCITY) -> ShaperChoice:
    """Design each shaper type for the modes and choose one (module docstring).

    Parameters
    ----------
    freqs_hz, dampings : array_like
        The identified modes: frequencies [Hz] and damping ratios [-] (one per FRF of a family, or several).
    kinds : sequence of str
        Types to try (default all six).
    max_vibration : float
        Bound on the residual vibration at every mode and between them [-].
    design_damping : float, optional
        Damping ratio the shapers are designed for [-]; default the median of the modes' (at most 0.3).
    fs : float, optional
        The target's sample rate [Hz]: the vibration of the sampled taps is judged (what the target runs).
    accel : float
        Acceleration the smoothing figure is taken at [m/s^2].
    scv : float
        Square-corner velocity of the smoothing figure [m/s].

    Returns
    -------
    ShaperChoice

    Examples
    --------
    A mode moving from 100 to 140 Hz: ZV cannot hold it within 5 %, the wider shapers can.

    >>> c = choose_shaper([100.0, 120.0, 140.0], [0.02, 0.02, 0.02])
    >>> c.candidate("zv").meets_target, c.chosen.kind, c.meets_target
    (False, 'ei', True)
    """
    f, z = _check_modes(freqs_hz, dampings)
    bad = [k for k in kinds if k not in SHAPER_TYPES]
    if bad or not kinds:
        raise UsageError(f"shaper types must be among {', '.join(SHAPER_TYPES)}, got {list(kinds)!r}",
                         parameter="kinds")
    if not (math.isfinite(max_vibration) and 0 < max_vibration < 1):
        raise UsageError(f"max_vibration must be in (0, 1), got {max_vibration!r}", parameter="max_vibration")
    if not (math.isfinite(accel) and accel > 0):
        raise UsageError(f"accel must be > 0 m/s^2, got {accel!r}", parameter="accel")
    zeta_s = min(float(np.median(z)), MAX_DESIGN_DAMPING) if design_damping is None else float(design_damping)
    if not 0 <= zeta_s < 1:
        raise UsageError(f"design_damping must be in [0, 1), got {design_damping!r}", parameter="design_damping")
    if fs is not None and not (math.isfinite(fs) and fs > 0):
        raise UsageError(f"fs must be > 0 Hz, got {fs!r}", parameter="fs")
    span_f, span_z = mode_span(f, z)
    scan = np.geomspace(f.min() / 2, f.max() * 2, SCAN_POINTS)
    if fs is not None:
        scan = scan[scan < fs / 4]
        if scan.size == 0:
            raise UsageError(f"the modes ({f.min():g} Hz and up) are too close to the sample rate {fs:g} Hz for a "
                             "shaper of at least a few samples", parameter="fs")
    candidates = []
    for kind in kinds:
        a, t = shaper_table(kind, scan, zeta_s)
        w, tt = _impulses(a, t, fs)
        worst = _worst(w, tt, span_f, span_z)
        k = int(np.argmin(worst))
        shaper = InputShaper(kind, float(scan[k]), zeta_s, a[k], t[k])
        wk, tk = w[k:k + 1], tt[k:k + 1]
        vib = np.array([residual_vibration(wk, tk, np.array([fm]), float(zm))[0, 0] for fm, zm in zip(f, z,
                                                                                                      strict=True)])
        shift = float((wk * tk).sum())
        candidates.append(ShaperCandidate(shaper, vib, float(worst[k]), float(smoothing(wk, tk, accel, scv)[0]),
                                          float(max_accel(wk, tk, TARGET_SMOOTHING, scv)[0]),
                                          float(tk[0][wk[0] != 0].max() - tk[0][wk[0] != 0].min()), shift,
                                          bool(worst[k] <= max_vibration)))
    ok = [c for c in candidates if c.meets_target]
    chosen = min(ok, key=lambda c: c.smoothing_m) if ok else min(candidates, key=lambda c: c.worst_vibration)
    return ShaperChoice(f, z, tuple(candidates), chosen, float(max_vibration), zeta_s, None if fs is None
                        else float(fs), float(accel))
