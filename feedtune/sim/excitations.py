"""Excitation and disturbance signals every machine's experiments share (one period or one run, sampled at fs).

Amplitudes are in the unit of the input they drive (a command [V/A] or an external force in command units);
positions in m, speeds in m/s, times in s, frequencies in Hz.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import UsageError

# ------------------------------------------------------------------------------------------ excitations
MIN_PERIOD_SAMPLES = 16
"""Fewest samples in one excitation period."""


def period_samples(fs: float, period_s: float) -> int:
    """Samples in one excitation period of ``period_s`` [s] at ``fs`` [Hz]; UsageError below
    :data:`MIN_PERIOD_SAMPLES` (or beyond 2^31)."""
    n = period_s * fs
    if not (MIN_PERIOD_SAMPLES <= n <= 2**31):
        raise UsageError(f"the excitation period period_s={period_s:g} s holds {n:.3g} samples at fs = {fs:g} Hz; "
                         f"give a period of {MIN_PERIOD_SAMPLES / fs:g} s or more (and at most {2**31 / fs:g} s)",
                         parameter="period_s")
    return round(n)


def multisine(fs: float, period_s: float, f_lo: float, f_hi: float, rms: float, rng) -> np.ndarray:
    """One period of a random-phase multisine with flat amplitude on the lines ``f_lo..f_hi`` [V]."""
    n = period_samples(fs, period_s)
    df = fs / n
    k = np.arange(n // 2 + 1)
    lines = (k * df >= f_lo) & (k * df <= f_hi) & (k > 0)
    if not lines.any():
        raise UsageError(f"no excitation line between {f_lo:g} and {f_hi:g} Hz at {df:g} Hz spacing; "
                         "lengthen the period or widen the band")
    spec = np.zeros(k.size, complex)
    spec[lines] = np.exp(2j * np.pi * rng.random(int(lines.sum())))
    x = np.fft.irfft(spec, n)
    return x * rms / np.sqrt(np.mean(x**2))


def chirp_period(fs: float, period_s: float, f_lo: float, f_hi: float, rms: float) -> np.ndarray:
    """One period of a logarithmic sweep ``f_lo -> f_hi`` with amplitude ``sqrt(2) rms`` [V]."""
    from scipy.signal import chirp

    n = period_samples(fs, period_s)
    t = np.arange(n) / fs
    return np.sqrt(2) * rms * chirp(t, f_lo, t[-1], f_hi, method="logarithmic", phi=-90)


def prbs_period(fs: float, period_s: float, f_hi: float, rms: float) -> np.ndarray:
    """About ``period_s`` of a maximum-length binary sequence (+-rms) clocked at about ``2.5 f_hi`` [V]."""
    from scipy.signal import max_len_seq

    period_samples(fs, period_s)
    hold = max(1, int(fs / (2.5 * f_hi)))
    nbits = int(np.clip(np.ceil(np.log2(period_s * fs / hold + 1)), 6, 20))
    seq = max_len_seq(nbits)[0].astype(float) * 2 - 1
    return rms * np.repeat(seq, hold)


# ------------------------------------------------------------------------------------------ FRF
def drift_reference(fs: float, n: int, speed: float, ramp_s: float) -> np.ndarray:
    """Table reference [m] reaching ``speed`` [m/s] with a raised-cosine velocity over ``ramp_s`` [s]."""
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not math.isfinite(speed):
        raise UsageError(f"drift speed must be a finite number in m/s, got {speed!r}")
    t = np.arange(n) / fs
    # integral of speed * (1 - cos(pi t / ramp)) / 2 during the ramp, then constant speed
    during = speed * (t / 2 - ramp_s / (2 * np.pi) * np.sin(np.pi * t / ramp_s))
    after = speed * (t - ramp_s / 2)
    return np.where(t < ramp_s, during, after)


# ------------------------------------------------------------------------------------------ rope snap
def ropesnap_force(fs: float, duration: float, force: float, t_release: float, preload_s: float = 0.1) -> np.ndarray:
    """External table force [V]: ``-force`` ramped in over ``preload_s`` (raised cosine), 0 from ``t_release``."""
    n = round(duration * fs) + 1
    t = np.arange(n) / fs
    ramp = np.clip(t / preload_s, 0.0, 1.0)
    d2 = -force * 0.5 * (1 - np.cos(np.pi * ramp))
    d2[t >= t_release - 0.5 / fs] = 0.0
    return d2
