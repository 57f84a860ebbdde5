"""Input shapers fitted to a measured vibration spectrum, as Klipper fits them; and a notch for a resonance.

A shaper of each type (:mod:`feedtune.control.shapers`) is tried at every frequency from its lowest
(:data:`~feedtune.control.shapers.MIN_FREQ_HZ`) to :data:`MAX_SHAPER_FREQ_HZ` in :data:`FREQ_STEP_HZ` steps, designed
for the damping ratio 0.1. At each, the PSD ``P(f)`` of the vibration (normalised: divided by ``f + 0.1 Hz`` and zero
below 5 Hz, :func:`normalize_psd`) tells what it leaves (:func:`remaining_vibrations`)::

    vibrations = sum_f max(V(f, zeta) P(f) - P_max / 20, 0) / sum_f max(P(f) - P_max / 20, 0)

(a shaper reduces vibration at most 20-fold, so what lies below ``P_max / 20`` is not counted), taken at the worst of
the damping ratios 0.075, 0.1 and 0.15 the machine may have. The frequency with the least vibration is the best; the
one chosen is, among those within 10 % of its vibration, the one of the lowest score
``smoothing * (vibrations^1.5 + 0.2 vibrations + 0.01)``, trading vibration for less smoothing (:func:`fit_shaper`).
Of the types, a later one replaces the chosen when it lowers the score by 20 %, or by 5 % with 10 % less smoothing
(:func:`recommended_shaper`).

This is Klipper's ``shaper_calibrate.py`` (``fit_shaper``, ``_estimate_remaining_vibrations``,
``find_best_shaper``, Klipper3d/klipper commit 4b1536d, March 2023, GPLv3), reimplemented from the formulas and the
rules above, not copied. Its files record the fitted frequencies in their shaper columns; with the same PSD
this gives them again to the 0.2 Hz grid (``tests/test_klipper_shapers.py``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..control.filters import Notch
from ..control.shapers import (
    DEFAULT_DAMPING,
    MIN_FREQ_HZ,
    SHAPER_TYPES,
    InputShaper,
    max_accel,
    residual_vibration,
    shaper_table,
    smoothing,
)
from ..errors import DataError, UsageError

AUTOTUNE_TYPES = ("zv", "mzv", "ei", "2hump_ei", "3hump_ei")
"""The types Klipper fits (``zvd`` is defined but not fitted)."""
TEST_DAMPINGS = (0.075, 0.1, 0.15)
"""Damping ratios the machine is assumed to have, the worst counted [-]."""
VIBRATION_REDUCTION = 20.0
"""The most a shaper reduces vibration [-]: PSD below ``max / 20`` is not counted."""
MIN_PSD_FREQ_HZ = 5.0
"""The PSD below this frequency is zeroed by :func:`normalize_psd` [Hz] (drift, not resonance)."""
MAX_PSD_FREQ_HZ = 200.0
"""The PSD above this frequency is not used [Hz]."""
MAX_SHAPER_FREQ_HZ = 150.0
"""Highest shaper frequency tried [Hz]."""
FREQ_STEP_HZ = 0.2
"""Step of the frequencies tried [Hz]."""
NOTCH_POLE_DAMPING = 0.7
"""Pole damping of :func:`resonance_notch` [-]: the value of feedtune's example notches, a -3 dB width of about 1.4
times the frequency, so that a resonance that moves 10 % stays attenuated."""


def normalize_psd(freq_hz: np.ndarray, psd: np.ndarray) -> np.ndarray:
    """Klipper's normalisation: ``psd / (f + 0.1 Hz)``, zero below :data:`MIN_PSD_FREQ_HZ`."""
    f = np.asarray(freq_hz, dtype=float)
    out = np.asarray(psd, dtype=float) / (f + 0.1)
    out[f < MIN_PSD_FREQ_HZ] = 0.0
    return out


def remaining_vibrations(shaper: InputShaper, damping: float, freq_hz: np.ndarray,
                         psd: np.ndarray) -> tuple[float, np.ndarray]:
    """The vibration a shaper leaves of a PSD (module docstring) and its residual vibration per frequency [-].

    Parameters
    ----------
    shaper : InputShaper
        The shaper.
    damping : float
        Damping ratio of the machine's modes [-].
    freq_hz, psd : ndarray
        The (normalised) PSD on its grid [Hz].

    Returns
    -------
    (float, ndarray)
        The fraction of the vibration above ``max / 20`` it leaves [-], and ``V(f, damping)`` on ``freq_hz``.
    """
    vals = shaper.vibration(freq_hz, damping)
    threshold, total = _threshold_sums(np.asarray(psd, dtype=float))
    return float(np.maximum(vals * psd - threshold, 0.0).sum() / total), vals


@dataclass(frozen=True)
class ShaperFit:
    """One shaper type fitted to a PSD.

    Parameters
    ----------
    shaper : InputShaper
        The shaper at the chosen frequency (designed for damping 0.1).
    vibrations : float
        Fraction of the vibration it leaves, the worst over :data:`TEST_DAMPINGS` [-].
    smoothing_m : float
        Its smoothing at 5 m/s^2 and a 5 mm/s square-corner velocity [m].
    max_accel : float
        Largest acceleration keeping the smoothing at 0.12 mm [m/s^2].
    score : float
        ``smoothing * (vibrations^1.5 + 0.2 vibrations + 0.01)`` [m] (module docstring).
    values : ndarray
        Residual vibration per frequency of the PSD [-], the worst over :data:`TEST_DAMPINGS` (what Klipper writes
        in a shaper column).
    """

    shaper: InputShaper
    vibrations: float
    smoothing_m: float
    max_accel: float
    score: float
    values: np.ndarray

    @property
    def kind(self) -> str:
        """The shaper type."""
        return self.shaper.kind

    @property
    def freq_hz(self) -> float:
        """The chosen frequency [Hz]."""
        return self.shaper.freq_hz

    def to_dict(self) -> dict:
        """``kind``, ``freq_hz`` [Hz], ``vibrations`` [-], ``smoothing_m`` [m], ``max_accel`` [m/s^2], ``score``
        [m], ``shaper`` (:meth:`InputShaper.to_dict`)."""
        return {"kind": self.kind, "freq_hz": self.freq_hz, "vibrations": self.vibrations,
                "smoothing_m": self.smoothing_m, "max_accel": self.max_accel, "score": self.score,
                "shaper": self.shaper.to_dict()}

    def __repr__(self) -> str:
        return (f"ShaperFit({self.kind} at {self.freq_hz:.1f} Hz, vibrations {self.vibrations:.1%}, smoothing "
                f"{self.smoothing_m * 1e3:.3g} mm, max accel {self.max_accel:.4g} m/s^2)")


def _threshold_sums(psd: np.ndarray) -> tuple[float, float]:
    threshold = psd.max() / VIBRATION_REDUCTION
    total = float(np.maximum(psd - threshold, 0.0).sum())
    if total <= 0:
        raise DataError("the PSD holds no vibration above a twentieth of its maximum")
    return threshold, total


def fit_shaper(kind: str, freq_hz: np.ndarray, psd: np.ndarray, *, max_smoothing: float | None = None,
               dampings: Sequence[float] = TEST_DAMPINGS, design_damping: float = DEFAULT_DAMPING) -> ShaperFit:
    """Fit one shaper type to a normalised PSD as Klipper does (module docstring).

    Parameters
    ----------
    kind : str
        One of :data:`~feedtune.control.shapers.SHAPER_TYPES`.
    freq_hz, psd : ndarray
        The PSD (normalised, :func:`normalize_psd`) on its grid [Hz]; bins above :data:`MAX_PSD_FREQ_HZ` are left out.
    max_smoothing : float, optional
        Largest smoothing accepted [m]: the frequencies are tried from the highest down, and the search stops at the
        first shaper smoother than this once one has been found (Klipper's ``max_smoothing``).
    dampings : sequence of float
        Damping ratios the machine may have [-].
    design_damping : float
        Damping ratio the shapers are designed for [-].

    Returns
    -------
    ShaperFit
        The chosen frequency and its figures.
    """
    if kind not in SHAPER_TYPES:
        raise UsageError(f"shaper type {kind!r} is not one of {', '.join(SHAPER_TYPES)}", parameter="kind")
    f = np.asarray(freq_hz, dtype=float)
    keep = f <= MAX_PSD_FREQ_HZ
    f, p = f[keep], np.asarray(psd, dtype=float)[keep]
    threshold, total = _threshold_sums(p)
    tests = np.arange(MIN_FREQ_HZ[kind], MAX_SHAPER_FREQ_HZ, FREQ_STEP_HZ)[::-1]  # Klipper tries them downwards
    a, t = shaper_table(kind, tests, design_damping)
    values = np.zeros((tests.size, f.size))
    vibrations = np.zeros(tests.size)
    for dr in dampings:
        vals = residual_vibration(a, t, f, dr)
        values = np.maximum(values, vals)
        vibrations = np.maximum(vibrations, np.maximum(vals * p - threshold, 0.0).sum(axis=1) / total)
    smooth = smoothing(a, t)
    scores = smooth * (vibrations**1.5 + vibrations * 0.2 + 0.01)
    accel = max_accel(a, t)

    def result(k: int) -> ShaperFit:
        return ShaperFit(InputShaper(kind, float(tests[k]), float(design_damping), a[k], t[k]), float(vibrations[k]),
                         float(smooth[k]), float(accel[k]), float(scores[k]), values[k])

    best = 0
    for k in range(1, tests.size):
        if max_smoothing and smooth[k] > max_smoothing:
            return result(best)
        if vibrations[best] > vibrations[k]:
            best = k
    selected = best
    for k in range(tests.size - 1, -1, -1):
        if vibrations[k] < vibrations[best] * 1.1 and scores[k] < scores[selected]:
            selected = k
    return result(selected)


def fit_shapers(freq_hz: np.ndarray, psd: np.ndarray, kinds: Sequence[str] = AUTOTUNE_TYPES, *,
                max_smoothing: float | None = None) -> list[ShaperFit]:
    """:func:`fit_shaper` for each of ``kinds`` (default Klipper's five)."""
    return [fit_shaper(k, freq_hz, psd, max_smoothing=max_smoothing) for k in kinds]


def recommended_shaper(fits: Sequence[ShaperFit]) -> ShaperFit:
    """Klipper's pick among fitted shapers, in the order given: a later one replaces the chosen when its score is
    20 % lower, or 5 % lower with 10 % less smoothing."""
    if not fits:
        raise UsageError("no fitted shapers to choose from", parameter="fits")
    best = fits[0]
    for fit in fits[1:]:
        if fit.score * 1.2 < best.score or (fit.score * 1.05 < best.score
                                            and fit.smoothing_m * 1.1 < best.smoothing_m):
            best = fit
    return best


def resonance_notch(freq_hz: float, damping: float, pole_damping: float = NOTCH_POLE_DAMPING) -> Notch:
    """A notch that cancels a resonance: zeros at its frequency [Hz] and damping [-], poles at the same frequency with
    ``pole_damping`` [-] (:data:`NOTCH_POLE_DAMPING`); the depth at the resonance is ``damping / pole_damping``.

    Examples
    --------
    >>> resonance_notch(52.0, 0.06)
    Notch(freq_hz=52.0, zeta_z=0.06, zeta_p=0.7)
    """
    if not (math.isfinite(damping) and 0 <= damping < pole_damping):
        raise UsageError(f"resonance damping must be in [0, {pole_damping:g}) for a notch, got {damping!r}",
                         parameter="damping")
    return Notch(float(freq_hz), float(damping), float(pole_damping))
