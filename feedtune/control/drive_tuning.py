"""A drive's own speed controller as its auto-servo-tuning export states it: PI gain, integral time, the current-
setpoint filters in the drive's terms, and the speed-loop sample time.

A CNC's auto-servo-tuning tool measures the speed-loop plant (current setpoint -> motor speed), retunes the speed
controller and exports both the controller it found (``original``) and the one it proposes (``tuned``). These types
hold them as the drive defines them, so that a later step can compare them with feedtune's design on the same FRF:

* :class:`Pt1Filter`: ``1 / (1 + s T)``, time constant ``T`` [s];
* :class:`Pt2Filter`: ``w^2 / (s^2 + 2 D w s + w^2)``, ``w = 2 pi f``, frequency ``f`` [Hz], damping ``D`` [-];
* :class:`SecondOrderFilter`: the general second-order filter
  ``(s^2 + 2 Dz wz s + wz^2) / wz^2 * wp^2 / (s^2 + 2 Dp wp s + wp^2)`` (numerator frequency and damping ``fz, Dz``,
  denominator ``fp, Dp``; a notch when ``fz = fp`` and ``Dz < Dp``), unity gain at 0 Hz;
* :class:`SpeedController`: the PI law ``Kp (1 + 1 / (s Tn))`` from speed error to current setpoint, followed by its
  enabled filters in the order listed.

Units: the export does not state the unit of the gain. ``Kp`` is kept as exported: the current setpoint per speed
error in the drive's own unit (A/(rad/s) when the plant FRF read beside it is taken as (rad/s)/A; drives that
command torque state N m s/rad). Times are in s, frequencies in Hz, dampings and the enable flags unit-free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DataError

FILTER_KINDS = ("PT1", "PT2", "second_order")
"""``kind`` of each drive filter type, as :meth:`to_dict` writes it."""


def _check(value: float, name: str, *, positive: bool = True) -> float:
    v = float(value)
    if not math.isfinite(v) or (v <= 0 if positive else v < 0):
        raise DataError(f"{name} must be a finite number {'> 0' if positive else '>= 0'}, got {value!r}")
    return v


def _second_order(s: np.ndarray, freq_hz: float, damping: float) -> np.ndarray:
    """``s^2 / w^2 + 2 D s / w + 1`` at ``s`` [rad/s] for ``w = 2 pi freq_hz``."""
    w = 2 * math.pi * freq_hz
    return (s / w) ** 2 + 2 * damping * s / w + 1


@dataclass(frozen=True)
class Pt1Filter:
    """First-order low-pass ``1 / (1 + s T)`` of the current setpoint.

    Parameters
    ----------
    time_constant_s : float
        ``T`` [s] (``m_dTimeConst``).
    enabled : bool
        Whether the drive applies it (``m_bFilterIsEnabled``).
    """

    time_constant_s: float
    enabled: bool = True
    kind = "PT1"

    def __post_init__(self) -> None:
        object.__setattr__(self, "time_constant_s", _check(self.time_constant_s, "PT1 time constant [s]"))

    def response(self, freq_hz) -> np.ndarray:
        """Complex frequency response [-] at ``freq_hz`` [Hz]."""
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
        return 1.0 / (1.0 + s * self.time_constant_s)

    def to_dict(self) -> dict:
        """``kind``, ``enabled``, ``time_constant_s`` [s]."""
        return {"kind": self.kind, "enabled": self.enabled, "time_constant_s": self.time_constant_s}

    def __repr__(self) -> str:
        return f"Pt1Filter(T={self.time_constant_s:.4g} s{'' if self.enabled else ', disabled'})"


@dataclass(frozen=True)
class Pt2Filter:
    """Second-order low-pass ``w^2 / (s^2 + 2 D w s + w^2)`` of the current setpoint, ``w = 2 pi f``.

    Parameters
    ----------
    freq_hz : float
        ``f`` [Hz] (``m_Frequency``).
    damping : float
        ``D`` [-] (``m_DampingRatio``).
    enabled : bool
        Whether the drive applies it (``m_bFilterIsEnabled``).
    """

    freq_hz: float
    damping: float
    enabled: bool = True
    kind = "PT2"

    def __post_init__(self) -> None:
        object.__setattr__(self, "freq_hz", _check(self.freq_hz, "PT2 frequency [Hz]"))
        object.__setattr__(self, "damping", _check(self.damping, "PT2 damping [-]"))

    def response(self, freq_hz) -> np.ndarray:
        """Complex frequency response [-] at ``freq_hz`` [Hz]."""
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
        return 1.0 / _second_order(s, self.freq_hz, self.damping)

    def to_dict(self) -> dict:
        """``kind``, ``enabled``, ``freq_hz`` [Hz], ``damping`` [-]."""
        return {"kind": self.kind, "enabled": self.enabled, "freq_hz": self.freq_hz, "damping": self.damping}

    def __repr__(self) -> str:
        return (f"Pt2Filter({self.freq_hz:.4g} Hz, D={self.damping:.3g}"
                f"{'' if self.enabled else ', disabled'})")


@dataclass(frozen=True)
class SecondOrderFilter:
    """General second-order filter (a notch when ``num_freq_hz == den_freq_hz`` and ``num_damping < den_damping``)::

        (s^2 + 2 Dz wz s + wz^2) / wz^2  *  wp^2 / (s^2 + 2 Dp wp s + wp^2),   wz = 2 pi fz, wp = 2 pi fp

    Parameters
    ----------
    num_freq_hz, num_damping : float
        Numerator frequency ``fz`` [Hz] and damping ``Dz`` [-] (``m_NumeratorFrequency``, ``m_NumeratorDampingRatio``).
    den_freq_hz, den_damping : float
        Denominator frequency ``fp`` [Hz] and damping ``Dp`` [-] (``m_DenominatorFrequency``,
        ``m_DenominatorDampingRatio``).
    enabled : bool
        Whether the drive applies it (``m_bFilterIsEnabled``).
    """

    num_freq_hz: float
    num_damping: float
    den_freq_hz: float
    den_damping: float
    enabled: bool = True
    kind = "second_order"

    def __post_init__(self) -> None:
        object.__setattr__(self, "num_freq_hz", _check(self.num_freq_hz, "second-order numerator frequency [Hz]"))
        object.__setattr__(self, "den_freq_hz", _check(self.den_freq_hz, "second-order denominator frequency [Hz]"))
        object.__setattr__(self, "num_damping", _check(self.num_damping, "second-order numerator damping [-]",
                                                       positive=False))
        object.__setattr__(self, "den_damping", _check(self.den_damping, "second-order denominator damping [-]"))

    def response(self, freq_hz) -> np.ndarray:
        """Complex frequency response [-] at ``freq_hz`` [Hz] (1 at 0 Hz)."""
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
        return _second_order(s, self.num_freq_hz, self.num_damping) / _second_order(s, self.den_freq_hz,
                                                                                     self.den_damping)

    def to_dict(self) -> dict:
        """``kind``, ``enabled``, numerator and denominator frequency [Hz] and damping [-]."""
        return {"kind": self.kind, "enabled": self.enabled, "num_freq_hz": self.num_freq_hz,
                "num_damping": self.num_damping, "den_freq_hz": self.den_freq_hz, "den_damping": self.den_damping}

    def __repr__(self) -> str:
        return (f"SecondOrderFilter({self.num_freq_hz:.4g} Hz D={self.num_damping:.3g} / {self.den_freq_hz:.4g} Hz "
                f"D={self.den_damping:.3g}{'' if self.enabled else ', disabled'})")


DriveFilter = Pt1Filter | Pt2Filter | SecondOrderFilter
"""One current-setpoint filter of a drive's speed controller."""


@dataclass(frozen=True)
class SpeedController:
    """A drive's speed controller: PI ``Kp (1 + 1 / (s Tn))`` from speed error to current setpoint, then its filters.

    Parameters
    ----------
    kp : float
        Proportional gain ``Kp`` (``m_dKpGain``) in the drive's unit of current setpoint per speed error (module
        docstring).
    tn_s : float
        Integral time ``Tn`` [s] (``m_dIntegralTime``); ``inf`` or 0 in the export: no integral action, kept as
        ``inf``.
    filters : tuple of DriveFilter
        The current-setpoint filters in the order the drive applies them (``m_CurrentFilters``), disabled ones
        included with ``enabled=False``.
    """

    kp: float
    tn_s: float
    filters: tuple[DriveFilter, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "kp", _check(self.kp, "speed controller Kp"))
        tn = float(self.tn_s)
        if tn == 0:
            tn = math.inf
        if not tn > 0 or math.isnan(tn):
            raise DataError(f"speed controller Tn [s] must be > 0 (or 0/inf: no integral action), got {self.tn_s!r}")
        object.__setattr__(self, "tn_s", tn)
        object.__setattr__(self, "filters", tuple(self.filters))

    @property
    def enabled_filters(self) -> tuple[DriveFilter, ...]:
        """The filters the drive applies."""
        return tuple(f for f in self.filters if f.enabled)

    def response(self, freq_hz) -> np.ndarray:
        """Complex response of the PI law times its enabled filters at ``freq_hz`` [Hz] (> 0), in ``Kp``'s unit."""
        f = np.asarray(freq_hz, dtype=float)
        s = 2j * np.pi * f
        pi = self.kp * (1.0 + (0.0 if math.isinf(self.tn_s) else 1.0 / (s * self.tn_s)))
        for filt in self.enabled_filters:
            pi = pi * filt.response(f)
        return pi

    def to_dict(self) -> dict:
        """``kp``, ``tn_s`` [s] (None for no integral action) and ``filters`` (each filter's :meth:`to_dict`)."""
        return {"kp": self.kp, "tn_s": None if math.isinf(self.tn_s) else self.tn_s,
                "filters": [f.to_dict() for f in self.filters]}

    def __repr__(self) -> str:
        n = len(self.enabled_filters)
        return (f"SpeedController(Kp={self.kp:.4g}, Tn={self.tn_s * 1e3:.4g} ms, {n} filter{'s' if n != 1 else ''}"
                f"{f' + {len(self.filters) - n} disabled' if len(self.filters) > n else ''})")


@dataclass(frozen=True)
class DriveSpeedTuning:
    """The speed controllers of an auto-servo-tuning export: the drive's before, the tool's proposal, the sample time.

    Parameters
    ----------
    original : SpeedController
        The controller the drive ran when the plant was measured (first element of ``m_listpSpeedLoopRegulators``).
    tuned : SpeedController or None
        The controller the tuning tool proposes (second element), None when the export holds only one.
    sample_time_s : float or None
        Speed-loop sample time [s] (``m_dActValDelayTime``), None when the export does not give it.
    source : str
        The file it was read from.
    """

    original: SpeedController
    tuned: SpeedController | None = None
    sample_time_s: float | None = None
    source: str = ""

    def __post_init__(self) -> None:
        if self.sample_time_s is not None:
            object.__setattr__(self, "sample_time_s", _check(self.sample_time_s, "speed-loop sample time [s]"))

    @property
    def fs_hz(self) -> float | None:
        """Speed-loop sample rate [Hz] (``1 / sample_time_s``)."""
        return None if self.sample_time_s is None else 1.0 / self.sample_time_s

    def to_dict(self) -> dict:
        """``original``, ``tuned`` (:meth:`SpeedController.to_dict`, None without one), ``sample_time_s`` [s],
        ``source`` and ``units``."""
        return {"original": self.original.to_dict(), "tuned": None if self.tuned is None else self.tuned.to_dict(),
                "sample_time_s": self.sample_time_s, "source": self.source,
                "units": {"kp": "drive unit of current setpoint per speed error", "tn_s": "s", "time_constant_s": "s",
                          "freq_hz": "Hz", "num_freq_hz": "Hz", "den_freq_hz": "Hz", "damping": "-",
                          "sample_time_s": "s"}}

    def __repr__(self) -> str:
        ts = "" if self.sample_time_s is None else f", Ts={self.sample_time_s * 1e6:.4g} us"
        return f"DriveSpeedTuning(original={self.original!r}, tuned={self.tuned!r}{ts})"
