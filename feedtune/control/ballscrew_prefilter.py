"""The trajectory pre-filter of eq. 3.17-3.20 as the ball-screw law runs it: ``x_r' = x_r + sum_n K_n s^n G^(n+1) x_r``
with ``G = w/(s + w)``, discretized bilinearly (Tustin) as second-order sections; its gains and units, its response and
its application to a whole reference."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..errors import DataError, UsageError

ORDERS = ("vel", "acc", "jerk", "snap")
"""Derivative orders of the pre-filter, 1..4."""


GAIN_NAMES = {"vel": "K_vel", "acc": "K_acc", "jerk": "K_jerk", "snap": "K_snap"}


GAIN_UNITS = {"K_vel": "s", "K_acc": "s^2", "K_jerk": "s^3", "K_snap": "s^4"}


DEFAULT_LPF_HZ = 80.0
"""Pole frequency of ``G`` in the thesis [Hz]."""


# ------------------------------------------------------------------------------------------ filters
def _check_rates(lpf_hz: float, fs: float) -> tuple[float, float]:
    if isinstance(fs, bool) or not isinstance(fs, (int, float, np.floating)) or not (math.isfinite(fs) and fs > 0):
        raise UsageError(f"sample rate must be a finite number > 0 Hz, got {fs!r}")
    if (isinstance(lpf_hz, bool) or not isinstance(lpf_hz, (int, float, np.floating))
            or not (math.isfinite(lpf_hz) and 0 < lpf_hz < fs / 4)):
        raise UsageError(f"--lpf-hz must be > 0 and below fs/4 = {fs / 4:g} Hz, got {lpf_hz!r}")
    return float(lpf_hz), float(fs)


def _bilinear_constants(lpf_hz: float, fs: float) -> tuple[float, float, float]:
    """``(w [rad/s], 1 + wT/2, 1 - wT/2)`` of the bilinear low-pass."""
    w = 2 * math.pi * lpf_hz
    h = w / (2 * fs)
    return w, 1 + h, 1 - h


def lowpass_section(lpf_hz: float, fs: float) -> np.ndarray:
    """``G(z)``, the bilinear discretization of ``w / (s + w)``, as one normalised section (shape (1, 6)).

    Parameters
    ----------
    lpf_hz : float
        Pole frequency [Hz].
    fs : float
        Sample rate [Hz].
    """
    lpf_hz, fs = _check_rates(lpf_hz, fs)
    w, al, be = _bilinear_constants(lpf_hz, fs)
    g = w / (2 * fs) / al
    return np.array([[g, g, 0.0, 1.0, -be / al, 0.0]])


def derivative_section(lpf_hz: float, fs: float) -> np.ndarray:
    """``sG(z)``, the bilinear discretization of ``s w / (s + w)`` [1/s], as one normalised section."""
    lpf_hz, fs = _check_rates(lpf_hz, fs)
    w, al, be = _bilinear_constants(lpf_hz, fs)
    return np.array([[w / al, -w / al, 0.0, 1.0, -be / al, 0.0]])


# ------------------------------------------------------------------------------------------ the filter
def gain_vector(gains: Mapping[str, float]) -> list[float]:
    out = []
    for o in ORDERS:
        v = float(gains.get(GAIN_NAMES[o], 0.0))
        if not math.isfinite(v):
            raise UsageError(f"pre-filter gain {GAIN_NAMES[o]} must be finite, got {v}")
        out.append(v)
    return out


def correction_sos(gains: Mapping[str, float], lpf_hz: float, fs: float) -> np.ndarray:
    """Second-order sections of ``F(z) - 1 = sum_k K_k G(z) sG(z)^k`` (bilinear, see the module docstring).

    The target computes ``x_r' = x_r + sosfilt(sections, x_r)``.

    Parameters
    ----------
    gains : dict
        ``K_vel`` [s], ``K_acc`` [s^2], ``K_jerk`` [s^3], ``K_snap`` [s^4] (missing ones are 0).
    lpf_hz : float
        Pole frequency of ``G`` [Hz].
    fs : float
        Sample rate [Hz].

    Returns
    -------
    ndarray, shape (n_sections, 6)
        Normalised sections ``[b0, b1, b2, 1, a1, a2]`` in powers of ``z^-1``; one zero section when all
        gains are 0.
    """
    lpf_hz, fs = _check_rates(lpf_hz, fs)
    K = gain_vector(gains)
    if not any(K):
        return np.array([[0.0, 0.0, 0.0, 1.0, 0.0, 0.0]])
    w, al, be = _bilinear_constants(lpf_hz, fs)
    deg = max(i for i, k in enumerate(K) if k != 0.0)  # B(d) = K_vel + K_acc d + ... has degree deg
    roots = np.roots(K[deg::-1]) if deg > 0 else np.zeros(0)
    g = w / (2 * fs)
    # K_lead G(z) sG(z): K g w (1 + q)(1 - q) / (al - be q)^2, q = z^-1
    rows = [[K[deg] * g * w, 0.0, -K[deg] * g * w, al * al, -2 * al * be, be * be]]
    # each root d of B: sG(z) - d = ((w - d al) + (d be - w) q) / (al - be q)
    num = [(w - d * al, d * be - w) for d in _conjugate_first(roots)]
    i = 0
    while i < len(num):
        p0, p1 = num[i]
        if i + 1 < len(num):
            r0, r1 = num[i + 1]
            b = [p0 * r0, p0 * r1 + p1 * r0, p1 * r1]
            rows.append([float(np.real(c)) for c in b] + [al * al, -2 * al * be, be * be])
            i += 2
        else:
            rows.append([float(np.real(p0)), float(np.real(p1)), 0.0, al, -be, 0.0])
            i += 1
    sos = np.array(rows, dtype=float)
    return sos / sos[:, 3:4]


def _conjugate_first(roots: np.ndarray) -> list:
    """Roots ordered so that complex conjugates are adjacent, real roots (as floats) after them."""
    tol = 1e-9 * max(1.0, float(np.max(np.abs(roots)))) if roots.size else 0.0
    cplx = [r for r in roots if r.imag > tol]
    real = sorted(float(r.real) for r in roots if abs(r.imag) <= tol)
    out: list = []
    for r in cplx:
        out += [complex(r), complex(r).conjugate()]
    return out + real


def prefilter_response(freq_hz, gains: Mapping[str, float], lpf_hz: float, fs: float | None = None) -> np.ndarray:
    """``F = 1 + sum_k K_k s^k G^(k+1)`` on a grid [Hz]: continuous (``fs`` None) or the discrete sections."""
    from ..lti import sos_freqresp

    f = np.asarray(freq_hz, dtype=float)
    if fs is not None:
        return 1.0 + sos_freqresp(correction_sos(gains, lpf_hz, fs), f, fs)
    K = gain_vector(gains)
    s = 2j * np.pi * f
    G = 2 * np.pi * lpf_hz / (s + 2 * np.pi * lpf_hz)
    return 1.0 + sum(k * s ** (i + 1) * G ** (i + 2) for i, k in enumerate(K))


def apply_prefilter(x_ref, gains: Mapping[str, float], lpf_hz: float, fs: float) -> np.ndarray:
    """``x_r' = x_r + (F(z) - 1) x_r`` from zero filter states (as the target runs it) [unit of x_ref]."""
    from scipy.signal import sosfilt

    x = _samples(x_ref, "x_ref")
    return x + sosfilt(correction_sos(gains, lpf_hz, fs), x)


def _samples(x, name: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise DataError(f"{name}: expected a sequence of numbers") from None
    if a.size < 2:
        raise DataError(f"{name}: needs at least 2 samples, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise DataError(f"{name}: contains NaN or infinite values (sample {int(np.flatnonzero(~np.isfinite(a))[0])})")
    return a
