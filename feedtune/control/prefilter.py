"""The trajectory pre-filter of eq. 3.17-3.20 and 4.20, one for every machine:
``x_r' = x_r + sum_n k_n s^n G^(n+1) x_r`` with ``G = w/(s + w)``, n = 1..4 (velocity, acceleration, jerk, snap).

Its gains (:class:`PrefilterGains`), its terms, its response -- continuous, or discrete with the discretization as a
parameter -- and its two discrete realisations:

* ``method="tustin"``: :func:`correction_sos`, ``F(z) - 1 = sum_k K_k G(z) sG(z)^k`` with ``G`` and ``sG`` discretized
  bilinearly, as one cascade of second-order sections (what the ball-screw law runs);
* ``method="matched"``: :func:`reference_filters`, each term ``s^n G^(n+1)`` pole-zero matched as its own filter,
  with the preview the matched ``s^2`` feedforward needs (what the gantry and x-axis laws run).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import DataError, DesignError, UsageError
from ..lti import Zpk
from .discretize import matched
from .filters import TWO_PI, _positive

# ----------------------------------------------------------------------------------------- pre-filter
PREFILTER_ORDERS = {"vel": 1, "acc": 2, "jerk": 3, "snap": 4}


@dataclass(frozen=True)
class PrefilterGains:
    """Trajectory pre-filter gains of eq. 4.20/4.32.

    Attributes
    ----------
    k_vel, k_acc, k_jerk, k_snap : float
        Gains on the low-pass filtered velocity [s], acceleration [s^2], jerk [s^3] and snap [s^4].
    """

    k_vel: float = 0.0
    k_acc: float = 0.0
    k_jerk: float = 0.0
    k_snap: float = 0.0

    def __post_init__(self) -> None:
        for name in PREFILTER_ORDERS:
            v = float(getattr(self, f"k_{name}"))
            if not math.isfinite(v):
                raise UsageError(f"pre-filter gain k_{name} must be finite, got {v}")
            object.__setattr__(self, f"k_{name}", v)

    def values(self) -> tuple[float, float, float, float]:
        """``(k_vel, k_acc, k_jerk, k_snap)`` [s, s^2, s^3, s^4]."""
        return (self.k_vel, self.k_acc, self.k_jerk, self.k_snap)

    @classmethod
    def parse(cls, text: str | None, option: str = "--prefilter") -> PrefilterGains:
        """From ``VEL,ACC,JERK,SNAP`` [s, s^2, s^3, s^4]; ``None`` gives zeros."""
        if text is None:
            return cls()
        parts = [p.strip() for p in str(text).split(",")]
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise UsageError(f"{option} expects four numbers VEL,ACC,JERK,SNAP [s, s^2, s^3, s^4], "
                             f"got {text!r}") from None
        if len(vals) != 4:
            raise UsageError(f"{option} expects four numbers VEL,ACC,JERK,SNAP, got {text!r}")
        return cls(*vals)

    def to_dict(self) -> dict:
        """Gains with a units entry."""
        return {"k_vel": self.k_vel, "k_acc": self.k_acc, "k_jerk": self.k_jerk, "k_snap": self.k_snap,
                "units": {"k_vel": "s", "k_acc": "s^2", "k_jerk": "s^3", "k_snap": "s^4"}}


def prefilter_terms(lpf_hz: float) -> list[Zpk]:
    """``s^n G_lpf^(n+1)`` for ``n = 1..4`` with ``G_lpf = w/(s + w)`` at ``lpf_hz`` [Hz] (eq. 4.20)."""
    w = TWO_PI * _positive(lpf_hz, "pre-filter low-pass frequency [Hz]")
    return [Zpk(np.zeros(n), np.full(n + 1, -w), w ** (n + 1)) for n in PREFILTER_ORDERS.values()]


def prefilter_response(gains, lpf_hz: float, freq_hz, fs: float | None = None, *,
                       method: str = "matched") -> np.ndarray:
    """``F = x_r'/x_r = 1 + sum_n k_n s^n G^(n+1)`` on a grid [Hz].

    Parameters
    ----------
    gains : PrefilterGains or mapping
        The four gains [s, s^2, s^3, s^4] (see :func:`gain_vector` for the mapping spellings).
    lpf_hz : float
        Pole frequency of ``G`` [Hz].
    freq_hz : array_like
        Grid [Hz].
    fs : float, optional
        Sample rate [Hz]: the discrete response of the chosen realisation; None for the continuous one.
    method : {"matched", "tustin"}
        Discretization (see the module docstring); ignored when ``fs`` is None.
    """
    K = gain_vector(gains)
    f = np.asarray(freq_hz, float)
    if fs is None:
        s = 2j * np.pi * f
        G = 2 * np.pi * lpf_hz / (s + 2 * np.pi * lpf_hz)
        return 1.0 + sum(k * s ** (i + 1) * G ** (i + 2) for i, k in enumerate(K))
    if method == "tustin":
        from ..lti import sos_freqresp

        return 1.0 + sos_freqresp(correction_sos(gains, lpf_hz, fs), f, fs)
    if method != "matched":
        raise UsageError(f"pre-filter discretization must be 'matched' or 'tustin', got {method!r}")
    out = np.ones(f.shape, complex)
    for k, term in zip(K, prefilter_terms(lpf_hz), strict=True):
        if k != 0.0:
            out += k * matched(term, fs).tf.freqresp(f)
    return out


def reference_filters(lpf_hz: float, fs: float) -> dict[str, Zpk]:
    """Discrete reference filters shared by the axis and gantry laws (all ``dt = 1/fs``).

    ``prefilter_vel`` .. ``prefilter_snap`` are the matched ``s^n G_lpf^(n+1)`` (proper, no delay);
    ``acceleration`` is the matched ``s^2`` made causal with ``P = 2`` poles at ``z = 0`` and ``position``
    is ``z^-P``: fed with the reference ``P`` samples ahead they realise ``s^2`` and ``1`` without delay.
    """
    from .ballscrew_law import reference_path

    out = {}
    for name, term in zip(PREFILTER_ORDERS, prefilter_terms(lpf_hz), strict=True):
        m = matched(term, fs)
        if m.delay_samples != 0:  # pragma: no cover - s^n G^(n+1) is strictly proper
            raise DesignError(f"pre-filter term {name} is not causal after discretization")
        out[f"prefilter_{name}"] = m.tf
    preview = preview_samples(fs)
    out["acceleration"] = reference_path(Zpk([0.0, 0.0], [], 1.0), fs, preview).discrete
    out["position"] = reference_path(Zpk.constant(1.0), fs, preview).discrete
    return out


def preview_samples(fs: float) -> int:
    """Reference look-ahead ``P`` [samples] the matched ``s^2`` feedforward needs (2)."""
    return matched(Zpk([0.0, 0.0], [], 1.0), fs).delay_samples


ORDERS = ("vel", "acc", "jerk", "snap")
"""Derivative orders of the pre-filter, 1..4."""


# The ball-screw gains file and the pre-filter fit spell the gains K_vel .. K_snap; the gantry and axis files
# k_vel .. k_snap (PrefilterGains). Both name the same four gains.
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
        raise UsageError(f"lpf_hz must be > 0 and below fs/4 = {fs / 4:g} Hz, got {lpf_hz!r}", parameter="lpf_hz")
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
def gain_vector(gains) -> list[float]:
    """``[K_vel, K_acc, K_jerk, K_snap]`` [s, s^2, s^3, s^4] from :class:`PrefilterGains` or a mapping spelled
    ``K_vel``.. (ball-screw files) or ``k_vel``.. (gantry files); missing gains are 0."""
    if isinstance(gains, PrefilterGains):
        return list(gains.values())
    out = []
    for o in ORDERS:
        v = float(gains.get(GAIN_NAMES[o], gains.get(f"k_{o}", 0.0)))
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
