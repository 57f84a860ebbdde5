"""Input shapers: impulse sequences that cancel a lightly damped vibration, and their residual vibration and smoothing.

An input shaper convolves the motion command with impulses of amplitudes ``A_i`` (summing to ``D``) at times ``T_i``;
a vibration mode of frequency ``f`` and damping ``zeta`` excited by the shaped command rings with the fraction
(Singhose, Seering & Singer 1990; Singhose 2009, "Command shaping for flexible systems: a review of the first 50
years", eq. 4)::

    V(f, zeta) = sqrt(S^2 + C^2) / D,   S = sum A_i e^(-zeta w (T_n - T_i)) sin(w_d T_i),
                                         C = sum A_i e^(-zeta w (T_n - T_i)) cos(w_d T_i),
    w = 2 pi f,  w_d = w sqrt(1 - zeta^2)

of what the unshaped command leaves (:meth:`InputShaper.vibration`). The shapers, each designed for a frequency
``f_s`` and damping ``zeta_s`` (``K = exp(-zeta_s pi / sqrt(1 - zeta_s^2))``, damped period ``t_d = 1 / (f_s
sqrt(1 - zeta_s^2))``; closed forms of Singer & Seering 1990 (ZV, ZVD), Singhose et al. 1994-1997 (EI, 2-hump and
3-hump EI with the vibration tolerance ``V = 0.05``) and the MZV of Klipper):

====================  =================================================  ==========================================
type                  amplitudes (before dividing by their sum)          times / t_d
====================  =================================================  ==========================================
``zv``                1, K                                               0, 1/2
``zvd``               1, 2K, K^2                                         0, 1/2, 1
``mzv``               1 - 1/sqrt2, (sqrt2 - 1) K', a1 K'^2,              0, 3/8, 3/4
                      K' = exp(-0.75 zeta_s pi / sqrt(1 - zeta_s^2))
``ei``                (1+V)/4, (1-V)/2 K, (1+V)/4 K^2                    0, 1/2, 1
``2hump_ei``          a1, (1/2 - a1) K, (1/2 - a1) K^2, a1 K^3;          0, 1/2, 1, 3/2
                      a1 = (3X^2 + 2X + 3V^2)/(16X),
                      X = (V^2 (sqrt(1 - V^2) + 1))^(1/3)
``3hump_ei``          a1, (1-V)/4 K, ((1+V)/2 - 2 a1) K^2,               0, 1/2, 1, 3/2, 2
                      (1-V)/4 K^3, a1 K^4;
                      a1 = (1 + 3V + 2 sqrt(2 (V + 1) V))/16
====================  =================================================  ==========================================

These are the definitions Klipper used from 2021 to September 2025 (``klippy/extras/shaper_defs.py``, e.g. at commit
4b1536d of March 2023, GPLv3: reimplemented here from the formulas above, not copied); the calibration files of
``shared/data/real/klipper_voron24_resonances`` were fitted with them. Klipper has since refit the EI family over the
damping ratio and generalised the MZV; a shaper of a newer Klipper differs by a few percent in ``A_i`` and ``T_i``.

**Smoothing** (:meth:`InputShaper.smoothing`): how far a shaped move at acceleration ``a`` strays from the commanded
path at a corner, Klipper's figure: with the shaper's time shift ``t_s = sum A_i T_i / D``,
``max(sqrt2 / D sum_{T_i >= t_s} A_i (v_sc + a/2 (T_i - t_s)) (T_i - t_s),  1/D sum A_i a/2 (T_i - t_s)^2)`` for a
90 deg corner taken at the square-corner velocity ``v_sc`` and a 180 deg reversal. It is linear in ``a``, so the
largest acceleration that keeps it at a target (:meth:`InputShaper.max_accel`, Klipper's 0.12 mm at ``v_sc`` = 5 mm/s)
is exact here, where Klipper bisects.

**Sampled** (:meth:`InputShaper.sampled`, :class:`SampledShaper`): a target that runs at ``fs`` applies the shaper to
its position reference as a sparse FIR filter, ``x_s[k] = sum_j w_j x[k - d_j]``. An impulse at ``T_i = (n_i +
phi_i) / fs`` (``0 <= phi_i < 1``) is split between the samples either side by linear interpolation, ``(1 - phi_i)
A_i`` at ``n_i`` and ``phi_i A_i`` at ``n_i + 1``: exact for a reference that is linear between samples, and its
delay error grows as ``(w T)^2 phi (1 - phi) / 2`` (2e-4 at 120 Hz and 20 kHz). The residual vibration of the sampled
taps is the formula above with their amplitudes and times (:meth:`SampledShaper.vibration`), which is what the choice
(:mod:`feedtune.design.shaper_choice`) evaluates when the target's rate is known. :class:`ShaperFilter` runs the taps
one sample at a time over a ring buffer, as the C header does (the sum in tap order in both), and
:meth:`SampledShaper.apply` runs a whole signal with the same operations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

SHAPER_TYPES = ("zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei")
"""The shaper types, by Klipper's names."""
VIBRATION_TOLERANCE = 1.0 / 20.0
"""``V`` of the EI shapers: the vibration they leave at their design point [-] (Klipper's
``1 / SHAPER_VIBRATION_REDUCTION``)."""
DEFAULT_DAMPING = 0.1
"""Damping ratio a shaper is designed for when none is given [-] (Klipper's default)."""
MIN_FREQ_HZ = {"zv": 21.0, "mzv": 23.0, "zvd": 29.0, "ei": 29.0, "2hump_ei": 39.0, "3hump_ei": 48.0}
"""Lowest frequency [Hz] Klipper fits each type at (a projected max accel of about 1500 mm/s^2 below it)."""
SQUARE_CORNER_VELOCITY = 0.005
"""Speed a 90 deg corner is taken at in the smoothing figure [m/s] (Klipper's default 5 mm/s)."""
SMOOTHING_ACCEL = 5.0
"""Acceleration the smoothing of a fit is quoted at [m/s^2] (Klipper's 5000 mm/s^2)."""
TARGET_SMOOTHING = 0.12e-3
"""Smoothing [m] at which :meth:`InputShaper.max_accel` puts the largest acceleration (Klipper's 0.12 mm)."""


def _coefficients(kind: str, freq_hz: float, damping: float, v_tol: float) -> tuple[list[float], list[float]]:
    """Amplitudes (unnormalised) and times [s] of one shaper (module docstring table)."""
    df = math.sqrt(1.0 - damping**2)
    k = math.exp(-damping * math.pi / df)
    t_d = 1.0 / (freq_hz * df)
    half = 0.5 * t_d
    if kind == "zv":
        return [1.0, k], [0.0, half]
    if kind == "zvd":
        return [1.0, 2.0 * k, k * k], [0.0, half, t_d]
    if kind == "mzv":
        k3 = math.exp(-0.75 * damping * math.pi / df)
        a1 = 1.0 - 1.0 / math.sqrt(2.0)
        return [a1, (math.sqrt(2.0) - 1.0) * k3, a1 * k3 * k3], [0.0, 0.375 * t_d, 0.75 * t_d]
    if kind == "ei":
        a1 = 0.25 * (1.0 + v_tol)
        return [a1, 0.5 * (1.0 - v_tol) * k, a1 * k * k], [0.0, half, t_d]
    if kind == "2hump_ei":
        v2 = v_tol**2
        x = (v2 * (math.sqrt(1.0 - v2) + 1.0)) ** (1.0 / 3.0)
        a1 = (3.0 * x * x + 2.0 * x + 3.0 * v2) / (16.0 * x)
        a2 = (0.5 - a1) * k
        return [a1, a2, a2 * k, a1 * k**3], [0.0, half, t_d, 1.5 * t_d]
    if kind == "3hump_ei":
        a1 = 0.0625 * (1.0 + 3.0 * v_tol + 2.0 * math.sqrt(2.0 * (v_tol + 1.0) * v_tol))
        a2 = 0.25 * (1.0 - v_tol) * k
        k2 = k * k
        return ([a1, a2, (0.5 * (1.0 + v_tol) - 2.0 * a1) * k2, a2 * k2, a1 * k2 * k2],
                [0.0, half, t_d, 1.5 * t_d, 2.0 * t_d])
    raise UsageError(f"shaper type {kind!r} is not one of {', '.join(SHAPER_TYPES)}", parameter="kind")


@dataclass(frozen=True)
class InputShaper:
    """An input shaper: impulses ``amplitudes`` [-] (summing to 1) at ``times_s`` [s] (module docstring); build one
    with :meth:`design`.

    Parameters
    ----------
    kind : str
        One of :data:`SHAPER_TYPES`.
    freq_hz : float
        Frequency it is designed for [Hz].
    damping : float
        Damping ratio it is designed for [-].
    amplitudes : ndarray
        Impulse amplitudes [-], normalised to sum 1.
    times_s : ndarray
        Impulse times [s], the first 0.
    """

    kind: str
    freq_hz: float
    damping: float
    amplitudes: np.ndarray
    times_s: np.ndarray

    @classmethod
    def design(cls, kind: str, freq_hz: float, damping: float = DEFAULT_DAMPING,
               vibration_tolerance: float = VIBRATION_TOLERANCE) -> InputShaper:
        """The shaper of type ``kind`` for a mode at ``freq_hz`` [Hz] with ``damping`` [-] (module docstring).

        Examples
        --------
        >>> zv = InputShaper.design("zv", 50.0, 0.0)
        >>> zv.amplitudes.tolist(), zv.times_s.tolist()
        ([0.5, 0.5], [0.0, 0.01])
        >>> round(float(zv.vibration(50.0, 0.0)), 12)
        0.0
        """
        if kind not in SHAPER_TYPES:
            raise UsageError(f"shaper type {kind!r} is not one of {', '.join(SHAPER_TYPES)}", parameter="kind")
        if not (math.isfinite(freq_hz) and freq_hz > 0):
            raise UsageError(f"shaper frequency must be > 0 Hz, got {freq_hz!r}", parameter="freq_hz")
        if not (math.isfinite(damping) and 0 <= damping < 1):
            raise UsageError(f"shaper damping ratio must be in [0, 1), got {damping!r}", parameter="damping")
        a, t = _coefficients(kind, float(freq_hz), float(damping), float(vibration_tolerance))
        a = np.asarray(a, dtype=float)
        return cls(kind, float(freq_hz), float(damping), a / a.sum(), np.asarray(t, dtype=float))

    @property
    def duration_s(self) -> float:
        """Time from the first to the last impulse [s]: the delay the shaper adds to a move's end."""
        return float(self.times_s[-1])

    @property
    def time_shift_s(self) -> float:
        """Amplitude-weighted mean impulse time [s] (the shaped path's lag)."""
        return float(self.amplitudes @ self.times_s)

    def vibration(self, freq_hz, damping: float) -> np.ndarray:
        """Residual vibration [-] of modes at ``freq_hz`` [Hz] with ``damping`` [-] (module docstring): 1 is what
        the unshaped command leaves, 0 none."""
        f = np.asarray(freq_hz, dtype=float)
        return residual_vibration(self.amplitudes[None], self.times_s[None], f.reshape(-1), damping)[0].reshape(
            f.shape)

    def smoothing(self, accel: float = SMOOTHING_ACCEL, scv: float = SQUARE_CORNER_VELOCITY) -> float:
        """Klipper's smoothing figure [m] at acceleration ``accel`` [m/s^2] and square-corner velocity ``scv``
        [m/s] (module docstring; any one length unit works throughout)."""
        return float(smoothing(self.amplitudes[None], self.times_s[None], accel, scv)[0])

    def max_accel(self, target: float = TARGET_SMOOTHING, scv: float = SQUARE_CORNER_VELOCITY) -> float:
        """Largest acceleration [m/s^2] whose smoothing stays at ``target`` [m] (Klipper's suggested ``max_accel``).

        Examples
        --------
        >>> s = InputShaper.design("mzv", 54.2)
        >>> a = s.max_accel()
        >>> round(s.smoothing(a) * 1e3, 9)
        0.12
        """
        return float(max_accel(self.amplitudes[None], self.times_s[None], target, scv)[0])

    def sampled(self, fs: float) -> SampledShaper:
        """The shaper as a target sampling at ``fs`` [Hz] runs it (module docstring: linear interpolation).

        Examples
        --------
        >>> s = InputShaper.design("zv", 40.0, 0.0).sampled(1000.0)
        >>> s.delays.tolist(), s.weights.tolist()
        ([0, 12, 13], [0.5, 0.25, 0.25])
        """
        delays, weights = sampled_impulses(self.amplitudes, self.times_s, fs)
        return SampledShaper(delays, weights, float(fs))

    def to_dict(self) -> dict:
        """``kind``, ``freq_hz`` [Hz], ``damping`` [-], ``amplitudes`` [-], ``times_s`` [s], ``duration_s`` [s]."""
        return {"kind": self.kind, "freq_hz": self.freq_hz, "damping": self.damping,
                "amplitudes": self.amplitudes.tolist(), "times_s": self.times_s.tolist(),
                "duration_s": self.duration_s}

    def __repr__(self) -> str:
        return (f"InputShaper({self.kind} at {self.freq_hz:.4g} Hz, damping {self.damping:.3g}, "
                f"{self.amplitudes.size} impulses over {self.duration_s * 1e3:.4g} ms)")


# ------------------------------------------------------------------------------------------ many shapers at once
def shaper_table(kind: str, freqs_hz: np.ndarray, damping: float = DEFAULT_DAMPING,
                 vibration_tolerance: float = VIBRATION_TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
    """Amplitudes [-] (rows summing to 1) and times [s] of the shapers of one type at each of ``freqs_hz`` [Hz], shape
    (n, impulses): what :meth:`InputShaper.design` gives, one row per frequency."""
    rows = [_coefficients(kind, float(f), float(damping), float(vibration_tolerance)) for f in freqs_hz]
    a = np.array([r[0] for r in rows], dtype=float)
    return a / a.sum(axis=1, keepdims=True), np.array([r[1] for r in rows], dtype=float)


def residual_vibration(amplitudes: np.ndarray, times_s: np.ndarray, freq_hz: np.ndarray,
                       damping: float) -> np.ndarray:
    """Residual vibration [-] of shapers (rows of ``amplitudes`` summing to 1 and ``times_s`` [s]) for modes at
    ``freq_hz`` [Hz] with ``damping`` [-]: shape (shapers, frequencies) (module docstring)."""
    w = 2.0 * np.pi * np.asarray(freq_hz, dtype=float)[None, :, None]
    a, t = amplitudes[:, None, :], times_s[:, None, :]
    phasor = a * np.exp(-damping * w * (t[..., -1:] - t) + 1j * w * math.sqrt(1.0 - damping**2) * t)
    return np.abs(phasor.sum(axis=-1))


def smoothing_terms(amplitudes: np.ndarray, times_s: np.ndarray,
                    scv: float = SQUARE_CORNER_VELOCITY) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(c0, c1, d1)`` per shaper: smoothing of a 90 deg corner ``c0 + c1 a`` and of a reversal ``d1 a`` [m] at
    acceleration ``a`` [m/s^2] (module docstring)."""
    dt = times_s - (amplitudes * times_s).sum(axis=1, keepdims=True)
    after = dt >= 0
    root2 = math.sqrt(2.0)
    c0 = root2 * np.where(after, amplitudes * scv * dt, 0.0).sum(axis=1)
    c1 = root2 * np.where(after, amplitudes * 0.5 * dt**2, 0.0).sum(axis=1)
    d1 = (amplitudes * 0.5 * dt**2).sum(axis=1)
    return c0, c1, d1


def smoothing(amplitudes: np.ndarray, times_s: np.ndarray, accel: float = SMOOTHING_ACCEL,
              scv: float = SQUARE_CORNER_VELOCITY) -> np.ndarray:
    """Klipper's smoothing figure [m] of each shaper at ``accel`` [m/s^2] and ``scv`` [m/s] (module docstring)."""
    c0, c1, d1 = smoothing_terms(amplitudes, times_s, scv)
    return np.maximum(c0 + c1 * accel, d1 * accel)


def max_accel(amplitudes: np.ndarray, times_s: np.ndarray, target: float = TARGET_SMOOTHING,
              scv: float = SQUARE_CORNER_VELOCITY) -> np.ndarray:
    """Largest acceleration [m/s^2] of each shaper whose smoothing stays at ``target`` [m]: the smaller of the two
    linear pieces' solutions (module docstring)."""
    c0, c1, d1 = smoothing_terms(amplitudes, times_s, scv)
    with np.errstate(divide="ignore", invalid="ignore"):
        corner = np.where(c1 > 0, (target - c0) / c1, np.inf)
        reversal = np.where(d1 > 0, target / d1, np.inf)
    return np.maximum(0.0, np.minimum(corner, reversal))


# ------------------------------------------------------------------------------------------ sampled shapers
PHASE_SNAP = 1e-9
"""A fractional sample position ``phi`` within this of 0 or 1 is taken as the sample itself [-] (the rounding of
``T fs``)."""


def _check_rate(fs: float) -> float:
    if isinstance(fs, bool) or not isinstance(fs, (int, float, np.floating)) or not (math.isfinite(fs) and fs > 0):
        raise UsageError(f"sample rate must be a finite number > 0 Hz, got {fs!r}", parameter="fs")
    return float(fs)


def sampled_table(amplitudes: np.ndarray, times_s: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample positions [samples] and weights [-] of shapers (rows of ``amplitudes`` and ``times_s`` [s]) sampled at
    ``fs`` [Hz] by linear interpolation (module docstring): shape (shapers, 2 impulses), columns ``n_i, n_i + 1`` per
    impulse, so the last column holds the latest sample. Weights may be zero."""
    fs = _check_rate(fs)
    pos = np.asarray(times_s, dtype=float) * fs
    n = np.floor(pos)
    phi = pos - n
    up = phi > 1.0 - PHASE_SNAP
    n = np.where(up, n + 1.0, n)
    phi = np.where(up | (phi < PHASE_SNAP), 0.0, phi)
    a = np.asarray(amplitudes, dtype=float)
    delays = np.stack([n, n + 1.0], axis=-1).reshape(*n.shape[:-1], -1)
    weights = np.stack([a * (1.0 - phi), a * phi], axis=-1).reshape(*a.shape[:-1], -1)
    return delays, weights


def sampled_impulses(amplitudes, times_s, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """``(delays [samples], weights [-])`` of one shaper sampled at ``fs`` [Hz] (:func:`sampled_table`), taps on the
    same sample merged and zero taps dropped, in increasing delay."""
    d, w = sampled_table(np.asarray(amplitudes, float)[None], np.asarray(times_s, float)[None], fs)
    delays = np.unique(d[0]).astype(np.int64)
    weights = np.array([w[0][d[0] == k].sum() for k in delays])
    keep = weights != 0.0
    return delays[keep], weights[keep]


@dataclass(frozen=True)
class SampledShaper:
    """An input shaper as a target at ``fs`` runs it: ``x_s[k] = sum_j weights[j] x[k - delays[j]]`` (module
    docstring).

    Parameters
    ----------
    delays : ndarray of int
        Tap delays [samples], strictly increasing, the first >= 0.
    weights : ndarray
        Tap weights [-], summing to 1 (the shaper keeps a position at rest where it is).
    fs : float
        Sample rate [Hz].
    """

    delays: np.ndarray
    weights: np.ndarray
    fs: float

    def __post_init__(self) -> None:
        d = np.asarray(self.delays)
        w = np.asarray(self.weights, dtype=float)
        if d.ndim != 1 or d.size == 0 or d.size != w.size:
            raise UsageError("shaper taps: delays and weights must be two equally long non-empty lists",
                             parameter="taps")
        if not np.all(np.isfinite(d)) or np.any(d != np.round(d)) or d[0] < 0 or np.any(np.diff(d) <= 0):
            raise UsageError("shaper taps: delays must be whole samples >= 0, strictly increasing", parameter="taps")
        if not np.all(np.isfinite(w)) or abs(w.sum() - 1.0) > 1e-9:
            raise UsageError(f"shaper taps: weights must be finite and sum to 1, got sum {w.sum()!r}",
                             parameter="taps")
        object.__setattr__(self, "delays", d.astype(np.int64))
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "fs", _check_rate(self.fs))

    @property
    def length(self) -> int:
        """Samples of history the filter keeps: the largest delay plus one."""
        return int(self.delays[-1]) + 1

    @property
    def duration_s(self) -> float:
        """Time from the first to the last tap [s]: what a move's end is delayed by."""
        return float(self.delays[-1] - self.delays[0]) / self.fs

    @property
    def time_shift_s(self) -> float:
        """Weighted mean delay [s]: the lag of a shaped ramp."""
        return float(self.weights @ self.delays) / self.fs

    def vibration(self, freq_hz, damping: float) -> np.ndarray:
        """Residual vibration [-] of modes at ``freq_hz`` [Hz] with ``damping`` [-] after these taps (module
        docstring)."""
        f = np.asarray(freq_hz, dtype=float)
        v = residual_vibration(self.weights[None], self.delays[None] / self.fs, f.reshape(-1), damping)[0]
        return v.reshape(f.shape)

    def response(self, freq_hz) -> np.ndarray:
        """Frequency response ``sum_j w_j exp(-j w d_j / fs)`` [-] on a grid [Hz]."""
        f = np.asarray(freq_hz, dtype=float)
        return np.exp(-2j * np.pi * f[..., None] * self.delays / self.fs) @ self.weights

    def apply(self, x) -> np.ndarray:
        """The shaped signal of ``x`` from rest (zero history), as :class:`ShaperFilter` computes it sample by
        sample [unit of ``x``]."""
        x = np.asarray(x, dtype=float)
        y = np.zeros(x.shape)
        for d, w in zip(self.delays.tolist(), self.weights.tolist(), strict=True):
            if d == 0:
                y += w * x
            elif d < x.size:
                y[d:] += w * x[:-d]
        return y

    def to_dict(self) -> dict:
        """``delays`` [samples], ``weights`` [-], ``fs`` [Hz], ``duration_s`` [s], ``time_shift_s`` [s]."""
        return {"delays": self.delays.tolist(), "weights": self.weights.tolist(), "fs": self.fs,
                "duration_s": self.duration_s, "time_shift_s": self.time_shift_s}


class ShaperFilter:
    """A :class:`SampledShaper` run one sample at a time over a ring buffer (what the C header does).

    Parameters
    ----------
    taps : SampledShaper
    """

    __slots__ = ("_buf", "_pairs", "_pos", "taps")

    def __init__(self, taps: SampledShaper) -> None:
        self.taps = taps
        self._buf = [0.0] * taps.length
        self._pairs = list(zip(taps.delays.tolist(), taps.weights.tolist(), strict=True))
        self._pos = 0

    def reset(self) -> None:
        """Zero the history (the reference was at 0 before)."""
        self._buf = [0.0] * self.taps.length
        self._pos = 0

    def step(self, x: float) -> float:
        """Store ``x`` and return the shaped sample [unit of ``x``]."""
        buf, n = self._buf, len(self._buf)
        buf[self._pos] = x
        y = 0.0
        for d, w in self._pairs:
            j = self._pos - d
            y += w * buf[j + n if j < 0 else j]
        self._pos = self._pos + 1 if self._pos + 1 < n else 0
        return y
