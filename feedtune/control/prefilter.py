"""The trajectory pre-filter of eq. 4.20 (``x_r' = x_r + sum_n k_n s^n G_lpf^(n+1) x_r``, ``G_lpf = w_f/(s + w_f)``,
n = 1..4: velocity, acceleration, jerk, snap): its gains, its terms, its response and its discrete reference filters
with the preview they need."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DesignError, UsageError
from ..lti import Zpk
from .discretize import matched
from .filters import (
    TWO_PI,
    _positive,
)

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


def prefilter_response(gains: PrefilterGains, lpf_hz: float, freq_hz, fs: float | None = None) -> np.ndarray:
    """``x_r'/x_r = 1 + sum_n k_n s^n G_lpf^(n+1)`` on a grid [Hz]; discrete (matched) when ``fs`` is given."""
    f = np.asarray(freq_hz, float)
    out = np.ones(f.shape, complex)
    for k, term in zip(gains.values(), prefilter_terms(lpf_hz), strict=True):
        if k != 0.0:
            out += k * (term.freqresp(f) if fs is None else matched(term, fs).tf.freqresp(f))
    return out


def reference_filters(lpf_hz: float, fs: float) -> dict[str, Zpk]:
    """Discrete reference filters shared by the axis and gantry laws (all ``dt = 1/fs``).

    ``prefilter_vel`` .. ``prefilter_snap`` are the matched ``s^n G_lpf^(n+1)`` (proper, no delay);
    ``acceleration`` is the matched ``s^2`` made causal with ``P = 2`` poles at ``z = 0`` and ``position``
    is ``z^-P``: fed with the reference ``P`` samples ahead they realise ``s^2`` and ``1`` without delay.
    """
    from ..control.ballscrew_law import reference_path

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
