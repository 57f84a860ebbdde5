"""Pole-zero matching (matched z-transform) of any continuous zeros-poles-gain transfer function.

Each pole and zero ``s_i`` maps to ``exp(s_i T)``; integrators (``s = 0``) map to ``z = 1``. Excess poles
(zeros at infinity) become zeros at ``z = -1``; an improper transfer function (more zeros than poles)
gets poles at ``z = 0``, i.e. a delay of as many samples, which a real-time target compensates by
reading the reference that many samples ahead (preview). The gain is matched at 0 Hz after removing the
factors at ``s = 0`` (``s`` corresponds to ``(z - 1) / T``), so integrators and differentiators keep their
low-frequency gain; when that is impossible it is matched at ``match_hz``.

Unlike ``python-control``'s ``sample_system(..., 'matched')`` this works with poles at ``s = 0`` and on
zeros-poles-gain data directly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..frf_sampling import MAX_DELAY_SAMPLES
from ..lti import Zpk


@dataclass(frozen=True)
class Matched:
    """Result of :func:`matched`.

    Attributes
    ----------
    tf : Zpk
        Discrete transfer function, proper (causal) when ``delay_samples`` were added.
    delay_samples : int
        Number of poles at ``z = 0`` added to make an improper transfer function causal [samples].
    """

    tf: Zpk
    delay_samples: int


def _is_origin(r: np.ndarray, scale: float) -> np.ndarray:
    return np.abs(r) <= 1e-12 * max(scale, 1.0)


def matched(
    g: Zpk, fs: float, *, excess_zeros: str = "all", causal: bool = True, match_hz: float | None = None
) -> Matched:
    """Discretize ``g`` by pole-zero matching at sample rate ``fs`` [Hz].

    Parameters
    ----------
    g : Zpk
        Continuous transfer function.
    fs : float
        Sample rate [Hz], > 0.
    excess_zeros : {"all", "all-but-one", "none"}
        How many of the ``n_poles - n_zeros`` zeros at infinity become zeros at ``z = -1``: all of them
        (Franklin-Powell's matched method), all but one (keeps a one-sample delay), or none.
    causal : bool
        Add poles at ``z = 0`` to an improper result (reported in ``delay_samples``).
    match_hz : float, optional
        Frequency [Hz] at which the gain is matched when it cannot be matched at 0 Hz.

    Returns
    -------
    Matched
    """
    if g.dt is not None:
        raise UsageError("matched(): transfer function is already discrete")
    if not (np.isfinite(fs) and fs > 0):
        raise UsageError(f"sample rate must be > 0 Hz, got {fs}")
    T = 1.0 / fs
    scale = max([1.0, *(float(np.max(np.abs(r))) for r in (g.zeros, g.poles) if r.size)])
    z_at0 = _is_origin(g.zeros, scale)
    p_at0 = _is_origin(g.poles, scale)
    for name, roots in (("pole", g.poles), ("zero", g.zeros)):
        if np.any(np.abs(roots.imag) * T >= np.pi):
            raise UsageError(f"a {name} of the filter lies at or above the Nyquist frequency {fs / 2:g} Hz")
    zd = np.exp(g.zeros * T)
    pd = np.exp(g.poles * T)
    zd[z_at0] = 1.0
    pd[p_at0] = 1.0
    n_excess = g.poles.size - g.zeros.size
    if n_excess > 0:
        n_add = {"all": n_excess, "all-but-one": n_excess - 1, "none": 0}.get(excess_zeros)
        if n_add is None:
            raise UsageError(f"excess_zeros must be 'all', 'all-but-one' or 'none', got {excess_zeros!r}")
        zd = np.concatenate([zd, -np.ones(n_add)])
    delay = 0
    if causal and zd.size > pd.size:
        delay = zd.size - pd.size
        pd = np.concatenate([pd, np.zeros(delay)])
    gd = _match_gain(g, zd, pd, z_at0, p_at0, T, match_hz)
    return Matched(Zpk(zd, pd, gd, T), delay)


def _match_gain(
    g: Zpk, zd: np.ndarray, pd: np.ndarray, z_at0: np.ndarray, p_at0: np.ndarray, T: float, match_hz: float | None
) -> float:
    """Gain so that the low-frequency asymptotes (or the response at ``match_hz``) agree."""
    n_diff = int(z_at0.sum() - p_at0.sum())  # net power of s at the origin
    c_red = g.gain * np.prod(-g.zeros[~z_at0]) / np.prod(-g.poles[~p_at0])
    # s^n <-> ((z - 1) / T)^n, so G(s)/s^n at s=0 must equal Gd(z)/((z-1)/T)^n at z=1
    zd_red = np.concatenate([zd[:z_at0.size][~z_at0], zd[z_at0.size:]])  # the roots not at s = 0, in order
    pd_red = np.concatenate([pd[:p_at0.size][~p_at0], pd[p_at0.size:]])
    d_red = np.prod(1 - zd_red) / np.prod(1 - pd_red) * T**n_diff
    if match_hz is None and np.isfinite(c_red) and abs(d_red) > 0 and abs(c_red) > 0:
        return float(np.real(c_red / d_red))
    f = match_hz if match_hz is not None else 0.01 / T
    hc = g.freqresp([f])[0]
    hd = Zpk(zd, pd, 1.0, T).freqresp([f])[0]
    if not (np.isfinite(hc) and abs(hd) > 0):
        raise UsageError(f"cannot match the gain of the discretized filter at {f:g} Hz")
    return float(abs(hc) / abs(hd) * np.sign(np.real(hc / hd)))


def matched_stages_response(stages, fs: float, freq_hz) -> np.ndarray:
    """``matched(prod(stage.zpk() for stage in stages), fs).tf.freqresp(freq_hz)`` in closed form, for a cascade of
    first-order lead or lag stages (:class:`~feedtune.control.filters.LeadStage`) whose roots lie off the origin.

    :func:`matched` maps every root on its own and matches the gain at 0 Hz, which for such stages is the product of
    their own gains, so the cascade's response is the product of the stages': each ``(wp/wz) (s + wz)/(s + wp)``
    becomes ``g (z - e^(-wz T))/(z - e^(-wp T))`` with ``g = (1 - e^(-wp T))/(1 - e^(-wz T))``. The designs iterate
    on it (equal to :func:`matched` to rounding).
    """
    T = 1.0 / fs
    z = np.exp(2j * np.pi * np.asarray(freq_hz, float) * T)
    out = np.ones(z.shape, complex)
    for stage in stages:
        wz, wp = 2 * np.pi * stage.zero_hz, 2 * np.pi * stage.pole_hz
        zd, pd = math.exp(-wz * T), math.exp(-wp * T)
        gain = (wp / wz) * wz / wp / ((1 - zd) / (1 - pd))
        out = out * (gain * (z - zd) / (z - pd))
    return out


def backward_difference(fs: float) -> Zpk:
    """Backward-Euler differentiator ``(1 - z^-1) / T`` (velocity estimator of eq. 3.5)."""
    return Zpk([1.0], [0.0], fs, 1.0 / fs)


def backward_euler_integrator(fs: float) -> Zpk:
    """Backward-Euler integrator ``T / (1 - z^-1)`` (``y[k] = y[k-1] + T u[k]``)."""
    return Zpk([0.0], [1.0], 1.0 / fs, 1.0 / fs)


def unit_delay(n: int, fs: float) -> Zpk:
    """``z^-n``."""
    return Zpk([], np.zeros(int(n)), 1.0, 1.0 / fs)


FS_MIN_HZ = 100.0
"""Lowest sample rate of a controller [Hz]: a loop sampled slower cannot act on a drive's mechanics (its first modes
lie at tens of Hz and more)."""
FS_MAX_HZ = 10e6
"""Highest sample rate of a controller [Hz] (the fastest current loops run at a few hundred kHz)."""


def check_sampling(fs: float, delay_samples: int) -> None:
    """UsageError unless ``fs`` [Hz] lies in :data:`FS_MIN_HZ` .. :data:`FS_MAX_HZ` and ``delay_samples`` is an
    integer in 0 .. :data:`MAX_DELAY_SAMPLES`."""
    if not (isinstance(fs, (int, float)) and math.isfinite(fs) and FS_MIN_HZ <= fs <= FS_MAX_HZ):
        raise UsageError(f"fs must be a controller's sample rate in {FS_MIN_HZ:g} .. {FS_MAX_HZ:g} Hz, got {fs:g}",
                         parameter="fs")
    if int(delay_samples) != delay_samples or not 0 <= delay_samples <= MAX_DELAY_SAMPLES:
        raise UsageError(f"delay_samples must be an integer in 0 .. {MAX_DELAY_SAMPLES} (a drive's computational "
                         f"delay), got {delay_samples}", parameter="delay_samples")
