"""Resonances of a magnitude-only vibration spectrum: frequency and damping of each peak of a PSD.

A PSD peak of a lightly damped mode has, near its top, the shape of the squared magnitude of a second-order
resonance::

    P(f) = P0 / ((1 - r^2)^2 + (2 zeta r)^2) + b,   r = f / f_n

:func:`find_resonances` takes the peaks of a PSD that stand out (a local maximum at least :data:`MIN_FRACTION` of the
largest, with that much prominence, above :data:`MIN_FREQ_HZ`), and for each gives

* the **half-power** estimate: the frequencies ``f1 < f_peak < f2`` where the PSD falls to half its peak
  (interpolated between bins on a log scale), ``zeta = (f2 - f1) / (2 f_peak)`` (exact for ``zeta`` -> 0; 2 % high at
  ``zeta`` = 0.1); a peak the PSD does not fall to half of on both sides is a slope or drift, not a resonance, and is
  left out;
* the **fitted peak**: ``f_n``, ``zeta``, ``P0`` and a floor ``b >= 0`` fitted by least squares to ``log P`` over the
  bins around the peak down to a quarter of it (at least five), started from the half-power estimate: less biased by a
  coarse grid (a Klipper PSD has 1.5 Hz bins, a 50 Hz mode with 5 % damping is 5 Hz wide).

The fitted values are the resonance's; the half-power ones are kept beside them as a check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DataError, UsageError
from ..spectrum import PsdSpectrum

MIN_FRACTION = 1.0 / 20.0
"""A peak counts when it reaches this fraction of the largest, with that much prominence [-] (the vibration an input
shaper can still reduce)."""
MIN_FREQ_HZ = 5.0
"""Peaks below this frequency are not resonances (drift; Klipper zeroes the PSD there) [Hz]."""
FIT_FRACTION = 0.25
"""The fit uses the bins around a peak down to this fraction of it [-]."""
MIN_FIT_POINTS = 5


@dataclass(frozen=True)
class Resonance:
    """One resonance of a PSD.

    Parameters
    ----------
    freq_hz : float
        Natural frequency of the fitted peak [Hz].
    damping : float
        Damping ratio of the fitted peak [-].
    peak_psd : float
        The fitted peak's height ``P0 / (2 zeta sqrt(1 - zeta^2))^2`` above the floor [PSD unit].
    bin_freq_hz : float
        Frequency of the highest bin [Hz].
    half_power_damping : float
        ``(f2 - f1) / (2 f_peak)`` [-].
    half_power_band_hz : tuple of float
        ``(f1, f2)`` [Hz].
    fit_rms : float
        RMS of the fit's residual of ``log10 P`` over its bins [-] (0.05: 12 % scatter).
    """

    freq_hz: float
    damping: float
    peak_psd: float
    bin_freq_hz: float
    half_power_damping: float
    half_power_band_hz: tuple[float, float]
    fit_rms: float

    def to_dict(self) -> dict:
        """The fields; ``half_power_band_hz`` as a list."""
        return {"freq_hz": self.freq_hz, "damping": self.damping, "peak_psd": self.peak_psd,
                "bin_freq_hz": self.bin_freq_hz, "half_power_damping": self.half_power_damping,
                "half_power_band_hz": list(self.half_power_band_hz),
                "fit_rms": self.fit_rms}

    def __repr__(self) -> str:
        return f"Resonance({self.freq_hz:.4g} Hz, damping {self.damping:.3g})"


@dataclass(frozen=True)
class ResonanceResult:
    """The resonances of one PSD of a spectrum.

    Parameters
    ----------
    resonances : tuple of Resonance
        By decreasing peak height.
    column : str
        The PSD they were found in (``"xyz"``, ``"x"`` ...).
    unit : str
        Its unit.
    source : str
        The spectrum's file.
    """

    resonances: tuple[Resonance, ...]
    column: str
    unit: str
    source: str

    def to_dict(self) -> dict:
        """``resonances`` (each :meth:`Resonance.to_dict`), ``column``, ``source`` and ``units``."""
        return {"resonances": [r.to_dict() for r in self.resonances], "column": self.column, "source": self.source,
                "units": {"freq_hz": "Hz", "damping": "-", "peak_psd": self.unit or "-", "bin_freq_hz": "Hz",
                          "half_power_damping": "-", "half_power_band_hz": "Hz", "fit_rms": "log10"}}

    def __repr__(self) -> str:
        return f"ResonanceResult({self.column}: {', '.join(map(repr, self.resonances)) or 'none'})"


def _crossing(f: np.ndarray, p: np.ndarray, k: int, level: float, step: int) -> float | None:
    """Where the PSD falls to ``level`` walking from bin ``k`` by ``step`` (log-linear between bins), else None."""
    j = k
    while 0 <= j + step < f.size and p[j + step] > level:
        j += step
    i = j + step
    if not 0 <= i < f.size or p[i] <= 0:
        return None
    a, b = math.log(p[j]), math.log(p[i])
    return float(f[j] + (math.log(level) - a) / (b - a) * (f[i] - f[j]))


def _model(theta: np.ndarray, f: np.ndarray) -> np.ndarray:
    log_p0, fn, log_zeta, log_floor = theta
    r = f / fn
    zeta = math.exp(log_zeta)
    return np.exp(log_p0) / ((1 - r * r) ** 2 + (2 * zeta * r) ** 2) + np.exp(log_floor)


def _fit_peak(f: np.ndarray, p: np.ndarray, k: int, zeta0: float) -> tuple[float, float, float, float]:
    """``(f_n, zeta, peak height, rms log10 residual)`` of the peak at bin ``k``."""
    from scipy.optimize import least_squares

    lo = hi = k
    while lo > 0 and p[lo - 1] >= FIT_FRACTION * p[k] and p[lo - 1] <= p[lo]:
        lo -= 1
    while hi < f.size - 1 and p[hi + 1] >= FIT_FRACTION * p[k] and p[hi + 1] <= p[hi]:
        hi += 1
    while hi - lo + 1 < MIN_FIT_POINTS and (lo > 0 or hi < f.size - 1):
        lo, hi = max(lo - 1, 0), min(hi + 1, f.size - 1)
    fw, pw = f[lo:hi + 1], np.maximum(p[lo:hi + 1], p[k] * 1e-9)
    zeta0 = min(max(zeta0, 0.005), 0.4)
    start = np.array([math.log(p[k] * (2 * zeta0) ** 2), f[k], math.log(zeta0), math.log(p[k] * 1e-3)])
    lower = [-np.inf, fw[0], math.log(1e-3), math.log(p[k] * 1e-9)]
    upper = [np.inf, fw[-1], math.log(0.5), math.log(p[k])]
    start = np.clip(start, np.array(lower) + 1e-12, np.array(upper) - 1e-12)
    fit = least_squares(lambda th: np.log10(_model(th, fw)) - np.log10(pw), start, bounds=(lower, upper))
    log_p0, fn, log_zeta, _ = fit.x
    zeta = math.exp(log_zeta)
    height = math.exp(log_p0) / (2 * zeta * math.sqrt(max(1 - zeta * zeta, 1e-12))) ** 2
    return float(fn), zeta, float(height), float(np.sqrt(np.mean(fit.fun**2)))


def find_resonances(spectrum: PsdSpectrum, column: str = "xyz", *, min_fraction: float = MIN_FRACTION,
                    max_count: int = 5) -> ResonanceResult:
    """The resonances of one PSD of a spectrum (module docstring).

    Parameters
    ----------
    spectrum : PsdSpectrum
        The measured spectrum.
    column : str
        Which PSD: ``"xyz"`` (the sum, what Klipper fits shapers to), ``"x"``, ``"y"`` or ``"z"``.
    min_fraction : float
        Smallest peak counted, as a fraction of the largest (and its least prominence) [-].
    max_count : int
        At most this many resonances, the highest.

    Returns
    -------
    ResonanceResult
        The resonances by decreasing peak height.

    Raises
    ------
    DataError
        A PSD without a peak above :data:`MIN_FREQ_HZ`.
    UsageError
        An unknown column, ``min_fraction`` outside (0, 1) or ``max_count`` < 1.
    """
    from scipy.signal import find_peaks

    if not 0 < min_fraction < 1:
        raise UsageError(f"min_fraction must be in (0, 1), got {min_fraction!r}", parameter="min_fraction")
    if not (isinstance(max_count, int) and max_count >= 1):
        raise UsageError(f"max_count must be an integer >= 1, got {max_count!r}", parameter="max_count")
    f = spectrum.freq_hz
    p = spectrum.get(column).copy()
    p[f < MIN_FREQ_HZ] = 0.0
    top = float(p.max())
    if top <= 0:
        raise DataError(f"{spectrum.source}: PSD {column!r} is zero above {MIN_FREQ_HZ:g} Hz")
    peaks, _ = find_peaks(np.r_[0.0, p, 0.0], height=min_fraction * top, prominence=min_fraction * top)
    peaks = peaks - 1
    order = np.argsort(-p[peaks])[:max_count]
    found = []
    for k in peaks[order]:
        f1 = _crossing(f, p, int(k), p[k] / 2, -1)
        f2 = _crossing(f, p, int(k), p[k] / 2, +1)
        if f1 is None or f2 is None:
            continue
        hp = (f2 - f1) / (2 * f[k])
        fn, zeta, height, rms = _fit_peak(f, p, int(k), hp)
        found.append(Resonance(fn, zeta, height, float(f[k]), hp, (f1, f2), rms))
    if not found:
        raise DataError(f"{spectrum.source}: no peak in PSD {column!r} above {MIN_FREQ_HZ:g} Hz")
    return ResonanceResult(tuple(found), column, spectrum.unit, spectrum.source)
