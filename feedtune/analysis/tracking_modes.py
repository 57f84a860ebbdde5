"""Lightly damped modes of a closed loop's tracking response: what a move leaves ringing on the load.

The tracking response ``T = x_load / x_r`` of an analysis case (model or measured FRF, with the law that runs) has a
peak at each closed-loop mode the reference excites; a mode the feedforward cancels has none (MC-PPC's
feedforward makes ``T = 1`` on its design model). :func:`tracking_modes` takes the peaks of ``|T|`` that stand
:data:`MIN_PROMINENCE_DB` above their surroundings and fits to each the pole pair of::

    T(s) ~ (b0 + b1 s + b2 s^2) / (s^2 + a1 s + a0)

over the lines around the peak where ``|T|`` is above half its peak's prominence (at least
:data:`MIN_FIT_LINES`): linear least squares on ``N(s) - T(s) D(s)`` (Levy), then :data:`SK_ITERATIONS`
Sanathanan-Koerner re-weightings by ``1 / |D(s)|`` of the previous pass, in ``s / w_peak`` for conditioning. The
numerator absorbs the smooth rest of ``T`` (feedforward, delay, other modes) over the narrow band; the pole pair
gives the mode's frequency ``sqrt(a0)`` and damping ``a1 / (2 sqrt(a0))``. Exact for a second-order section plus a
quadratic background; on the ball screw's P-PI the fit is within 0.2 % and 0.002 of the closed-loop poles computed
from the model (``tests/test_shaper_design.py``). A peak whose fit is not a complex pair with damping below
:data:`MAX_DAMPING` is not a mode a shaper is for and is left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

MIN_PROMINENCE_DB = 3.0
"""A peak of ``|T|`` counts when it stands this far above the lower of its two surrounding minima [dB]."""
MAX_DAMPING = 0.3
"""Modes more damped than this ring for less than a period: not shaped [-]."""
MIN_FIT_LINES = 7
"""The fit uses at least this many lines around the peak."""
SK_ITERATIONS = 3
"""Sanathanan-Koerner re-weightings after the first (Levy) pass."""


@dataclass(frozen=True)
class TrackingMode:
    """One lightly damped mode of a tracking response.

    Parameters
    ----------
    freq_hz : float
        Natural frequency of the fitted pole pair [Hz].
    damping : float
        Its damping ratio [-].
    peak : float
        ``|T|`` at the peak [-].
    peak_freq_hz : float
        The peak's line [Hz].
    source : str
        The case it was found in (``"model"``, an FRF's name).
    """

    freq_hz: float
    damping: float
    peak: float
    peak_freq_hz: float
    source: str = ""

    def to_dict(self) -> dict:
        """The fields (``freq_hz``, ``peak_freq_hz`` [Hz]; ``damping``, ``peak`` [-]; ``source``)."""
        return {"freq_hz": self.freq_hz, "damping": self.damping, "peak": self.peak,
                "peak_freq_hz": self.peak_freq_hz, "source": self.source}

    def __repr__(self) -> str:
        return f"TrackingMode({self.freq_hz:.4g} Hz, damping {self.damping:.3g}, |T| {self.peak:.3g}, {self.source})"


def fit_pole_pair(freq_hz: np.ndarray, response: np.ndarray, center_hz: float) -> tuple[float, float]:
    """``(f_n [Hz], damping [-])`` of the pole pair fitted to ``response`` on ``freq_hz`` (module docstring); NaN
    when the fit has no complex pair."""
    w0 = 2 * math.pi * center_hz
    s = 2j * math.pi * np.asarray(freq_hz, float) / w0
    t = np.asarray(response, complex)
    weight = np.ones(s.size)
    a1 = a0 = math.nan
    for _ in range(SK_ITERATIONS + 1):
        # unknowns b0, b1, b2, a1, a0: b0 + b1 s + b2 s^2 - T (a1 s + a0) = T s^2
        cols = np.stack([np.ones_like(s), s, s * s, -t * s, -t], axis=1) * weight[:, None]
        rhs = t * s * s * weight
        m = np.concatenate([cols.real, cols.imag])
        r = np.concatenate([rhs.real, rhs.imag])
        theta, *_ = np.linalg.lstsq(m, r, rcond=None)
        a1, a0 = float(theta[3]), float(theta[4])
        weight = 1.0 / np.maximum(np.abs(s * s + a1 * s + a0), 1e-12)
    if not (a0 > 0 and a1 * a1 < 4 * a0):
        return math.nan, math.nan
    wn = math.sqrt(a0)
    return float(wn * center_hz), float(a1 / (2 * wn))


def tracking_modes(freq_hz, tracking, *, source: str = "", min_prominence_db: float = MIN_PROMINENCE_DB,
                   max_damping: float = MAX_DAMPING, max_freq_hz: float | None = None) -> list[TrackingMode]:
    """The lightly damped modes of a tracking response (module docstring), by decreasing peak.

    Parameters
    ----------
    freq_hz : array_like
        Grid [Hz], increasing.
    tracking : array_like of complex
        ``x_load / x_r`` on the grid [-].
    source : str
        Name of the case, kept in each mode.
    min_prominence_db : float
        Least prominence of a peak [dB].
    max_damping : float
        Modes above this damping ratio are left out [-].
    max_freq_hz : float, optional
        Peaks above this frequency are left out [Hz] (the Nyquist frequency of the target).
    """
    from scipy.signal import find_peaks

    f = np.asarray(freq_hz, float).reshape(-1)
    t = np.asarray(tracking, complex).reshape(-1)
    if f.size != t.size or f.size < MIN_FIT_LINES:
        raise UsageError(f"tracking response: expected at least {MIN_FIT_LINES} lines on its grid, got {t.size}",
                         parameter="tracking")
    ok = np.isfinite(t) & np.isfinite(f) & (f > 0)
    f, t = f[ok], t[ok]
    mag_db = 20 * np.log10(np.maximum(np.abs(t), 1e-300))
    peaks, props = find_peaks(mag_db, prominence=min_prominence_db)
    found = []
    for k, prom in zip(peaks, props["prominences"], strict=True):
        if max_freq_hz is not None and f[k] > max_freq_hz:
            continue
        level = mag_db[k] - prom / 2
        lo = hi = int(k)
        while lo > 0 and mag_db[lo - 1] >= level and mag_db[lo - 1] <= mag_db[lo]:
            lo -= 1
        while hi < f.size - 1 and mag_db[hi + 1] >= level and mag_db[hi + 1] <= mag_db[hi]:
            hi += 1
        while hi - lo + 1 < MIN_FIT_LINES and (lo > 0 or hi < f.size - 1):
            lo, hi = max(lo - 1, 0), min(hi + 1, f.size - 1)
        fn, zeta = fit_pole_pair(f[lo:hi + 1], t[lo:hi + 1], float(f[k]))
        if not (math.isfinite(fn) and 0 < zeta < max_damping and f[lo] / 2 < fn < 2 * f[hi]):
            continue
        found.append(TrackingMode(fn, zeta, float(abs(t[k])), float(f[k]), source))
    return sorted(found, key=lambda m: -m.peak)
