"""Continuous-time filters of the filter pack and loop-shaping elements (thesis eq. 3.9-3.10, 4.17-4.18).

All filters are returned as continuous :class:`~feedtune.lti.Zpk` with unit gain at 0 Hz (notch, low-pass)
or as documented. Frequencies are given in Hz and converted to rad/s internally.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import DataError, UsageError
from ..lti import Zpk

TWO_PI = 2 * np.pi


def _damping(value: float, name: str) -> float:
    v = float(value)
    if not np.isfinite(v) or v < 0:
        raise UsageError(f"{name} must be a finite damping ratio >= 0, got {value!r}")
    return v


def _pair(wn: float, zeta: float) -> np.ndarray:
    """Roots of ``s^2 + 2 zeta wn s + wn^2``."""
    return np.roots([1.0, 2 * zeta * wn, wn * wn]).astype(complex)


@dataclass(frozen=True)
class Notch:
    """Notch ``(s^2 + 2 zz wn s + wn^2) / (s^2 + 2 zp wn s + wn^2)`` (eq. 3.9 with the typo fixed).

    Parameters
    ----------
    freq_hz : float
        Centre frequency [Hz].
    zeta_z, zeta_p : float
        Damping of the zeros and poles [-]; the depth at ``freq_hz`` is ``zeta_z / zeta_p``.
    """

    freq_hz: float
    zeta_z: float
    zeta_p: float

    def __post_init__(self) -> None:
        _positive(self.freq_hz, "notch frequency [Hz]")
        _damping(self.zeta_z, "notch zero damping")
        _damping(self.zeta_p, "notch pole damping")
        if self.zeta_p == 0:
            raise UsageError("notch pole damping must be > 0")

    def zpk(self) -> Zpk:
        """Continuous transfer function (unit gain at 0 Hz)."""
        wn = TWO_PI * self.freq_hz
        return Zpk(_pair(wn, self.zeta_z), _pair(wn, self.zeta_p), 1.0)

    @classmethod
    def parse(cls, text: str) -> Notch:
        """From the command-line form ``HZ,ZETA_Z,ZETA_P`` (e.g. ``420,0.55,0.7``)."""
        parts = [p.strip() for p in str(text).split(",")]
        if len(parts) != 3:
            raise UsageError(f"notch expects HZ,ZETA_Z,ZETA_P (e.g. 420,0.55,0.7), got {text!r}", parameter="notch")
        try:
            return cls(*(float(p) for p in parts))
        except ValueError:
            raise UsageError(f"notch expects three numbers HZ,ZETA_Z,ZETA_P, got {text!r}", parameter="notch") from None


def lowpass1(freq_hz: float) -> Zpk:
    """First-order low-pass ``w / (s + w)`` with pole frequency ``freq_hz`` [Hz]."""
    w = TWO_PI * _positive(freq_hz, "low-pass frequency [Hz]")
    return Zpk([], [-w], w)


def lowpass2(freq_hz: float, zeta: float = 0.7) -> Zpk:
    """Second-order low-pass ``w^2 / (s^2 + 2 zeta w s + w^2)`` [Hz, -]."""
    w = TWO_PI * _positive(freq_hz, "low-pass frequency [Hz]")
    return Zpk([], _pair(w, _damping(zeta, "low-pass damping")), w * w)


def lead(center_hz: float, phase_deg: float) -> Zpk:
    """Lead filter ``(s/wz + 1) / (s/wp + 1)`` with maximum phase ``phase_deg`` at ``center_hz``.

    ``gamma = (1 + sin(phi)) / (1 - sin(phi))``, ``wz = wc / sqrt(gamma)``, ``wp = wc sqrt(gamma)``; unit
    gain at 0 Hz and ``sqrt(gamma)`` at the centre frequency (eq. 4.17-4.18).
    """
    wc = TWO_PI * _positive(center_hz, "lead centre frequency [Hz]")
    phi = np.deg2rad(float(phase_deg))
    if not 0 < phi < np.pi / 2:
        raise UsageError(f"lead phase must be between 0 and 90 deg, got {phase_deg}")
    gamma = (1 + np.sin(phi)) / (1 - np.sin(phi))
    wz, wp = wc / np.sqrt(gamma), wc * np.sqrt(gamma)
    return Zpk([-wz], [-wp], wp / wz)


def lead_gamma(phase_deg: float) -> float:
    """Pole/zero ratio ``gamma`` of a lead stage giving ``phase_deg`` of phase [-]."""
    phi = np.deg2rad(float(phase_deg))
    return float((1 + np.sin(phi)) / (1 - np.sin(phi)))


def pi_controller(kp: float, ki: float) -> Zpk:
    """PI controller ``kp + ki / s = (kp s + ki) / s``."""
    if kp == 0:
        return Zpk([], [0.0], ki)
    return Zpk([-ki / kp], [0.0], kp)


def integrator(gain: float = 1.0) -> Zpk:
    """``gain / s``."""
    return Zpk([], [0.0], gain)


def differentiator(gain: float = 1.0) -> Zpk:
    """``gain * s`` (improper; only used inside larger proper expressions or for feedforward)."""
    return Zpk([0.0], [], gain)


def thesis_gamma(phase_deg: float) -> float:
    """Thesis lead ratio ``gamma = a / wc = sqrt((1 + sin phi)/(1 - sin phi))`` [-] of one stage.

    Examples
    --------
    >>> round(thesis_gamma(63.0), 2)
    4.17
    """
    phi = math.radians(float(phase_deg))
    if not -math.pi / 2 < phi < math.pi / 2:
        raise UsageError(f"a lead stage gives between -90 and 90 deg, got {phase_deg}")
    return math.sqrt((1 + math.sin(phi)) / (1 - math.sin(phi)))


def split_lead(phase_deg: float, max_stage_deg: float = 70.0) -> list[float]:
    """Equal stages [deg] that add up to ``phase_deg``, none larger than ``max_stage_deg`` in magnitude.

    Examples
    --------
    >>> split_lead(126.0)
    [63.0, 63.0]
    """
    if not 0 < max_stage_deg < 90:
        raise UsageError(f"max_stage_deg must lie in (0, 90) deg, got {max_stage_deg}")
    if abs(phase_deg) < 1e-9:
        return []
    n = math.ceil(abs(phase_deg) / max_stage_deg - 1e-12)
    return [float(phase_deg) / n] * n


@dataclass(frozen=True)
class LeadStage:
    """One lead (or lag, for a negative phase) stage ``(s/wz + 1)/(s/wp + 1)`` centred at ``center_hz``.

    Parameters
    ----------
    center_hz : float
        Frequency of the largest phase [Hz].
    phase_deg : float
        Phase at ``center_hz`` [deg], in (-90, 90); unit gain at 0 Hz.
    """

    center_hz: float
    phase_deg: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center_hz", _positive(self.center_hz, "lead centre frequency [Hz]"))
        object.__setattr__(self, "phase_deg", float(self.phase_deg))
        thesis_gamma(self.phase_deg)

    @property
    def gamma(self) -> float:
        """Thesis lead ratio ``a / wc`` [-]."""
        return thesis_gamma(self.phase_deg)

    @property
    def zero_hz(self) -> float:
        """Zero frequency ``1/(2 pi Td)`` [Hz]."""
        return self.center_hz / self.gamma

    @property
    def pole_hz(self) -> float:
        """Pole frequency ``a/(2 pi)`` [Hz]."""
        return self.center_hz * self.gamma

    def zpk(self) -> Zpk:
        """Continuous ``(Td s + 1)/(s/a + 1)``, unit gain at 0 Hz."""
        wz, wp = TWO_PI * self.zero_hz, TWO_PI * self.pole_hz
        return Zpk([-wz], [-wp], wp / wz)

    def to_dict(self) -> dict:
        """``center_hz, phase_deg, gamma, zero_hz, pole_hz``."""
        return {"center_hz": self.center_hz, "phase_deg": self.phase_deg, "gamma": self.gamma,
                "zero_hz": self.zero_hz, "pole_hz": self.pole_hz}

    @classmethod
    def parse(cls, text: str) -> LeadStage:
        """From the command-line form ``HZ,DEG`` (e.g. ``154,70``)."""
        parts = [p.strip() for p in str(text).split(",")]
        if len(parts) != 2:
            raise UsageError(f"lead expects HZ,DEG (e.g. 154,70), got {text!r}", parameter="lead")
        try:
            hz, deg = (float(p) for p in parts)
        except ValueError:
            raise UsageError(f"lead expects two numbers HZ,DEG, got {text!r}", parameter="lead") from None
        if not 0 < deg < 90:
            raise UsageError(f"lead phase must lie between 0 and 90 deg, got {deg:g}", parameter="lead")
        return cls(hz, deg)


def _positive(v, name: str, parameter: str | None = None) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, got {v!r}", parameter=parameter) from None
    if not (math.isfinite(x) and x > 0):
        raise UsageError(f"{name} must be a finite number > 0, got {v!r}", parameter=parameter)
    return x


# --------------------------------------------------------------------------------------- filter pack
@dataclass(frozen=True)
class FilterPack:
    """The filter pack of every controller: notches, a 1st- or 2nd-order low-pass and extra lead stages (eq. 3.10,
    4.18).

    Parameters
    ----------
    notches : sequence of Notch
        ``(s^2 + 2 zz wn s + wn^2)/(s^2 + 2 zp wn s + wn^2)`` each.
    lpf_hz : float or None
        Low-pass frequency [Hz]; None for none.
    lpf_order : int
        1 (``w/(s + w)``) or 2 (``w^2/(s^2 + 2 zeta w s + w^2)``).
    lpf_zeta : float
        Damping of the 2nd-order low-pass [-].
    leads : sequence of LeadStage
        Extra lead stages inside the pack (the gantry's second lead at 154 Hz, 70 deg).
    """

    notches: Sequence[Notch] = field(default_factory=tuple)
    lpf_hz: float | None = None
    lpf_order: int = 1
    lpf_zeta: float = 0.7
    leads: Sequence[LeadStage] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        object.__setattr__(self, "notches", tuple(self.notches))
        object.__setattr__(self, "leads", tuple(self.leads))
        if self.lpf_hz is not None:
            object.__setattr__(self, "lpf_hz", _positive(self.lpf_hz, "low-pass frequency lpf_hz [Hz]",
                                                         "FilterPack.lpf_hz"))
        if self.lpf_order not in (1, 2):
            raise UsageError(f"low-pass order lpf_order must be 1 or 2, got {self.lpf_order!r}", parameter="lpf_order")
        if not (math.isfinite(self.lpf_zeta) and self.lpf_zeta > 0):
            raise UsageError(f"low-pass damping lpf_zeta must be > 0, got {self.lpf_zeta!r}", parameter="lpf_zeta")

    def zpk(self) -> Zpk:
        """The combined continuous transfer function (unit gain at 0 Hz); computed once per pack."""
        cached = self.__dict__.get("_zpk")
        if cached is None:
            cached = self._build_zpk()
            object.__setattr__(self, "_zpk", cached)
        return cached

    def _build_zpk(self) -> Zpk:
        g = Zpk.constant(1.0)
        for n in self.notches:
            g = g * n.zpk()
        for stage in self.leads:
            g = g * stage.zpk()
        if self.lpf_hz is not None:
            g = g * (lowpass1(self.lpf_hz) if self.lpf_order == 1 else lowpass2(self.lpf_hz, self.lpf_zeta))
        return g

    def check_nyquist(self, fs: float) -> None:
        """UsageError when a filter frequency is at or above the Nyquist frequency ``fs/2`` [Hz]."""
        for n in self.notches:
            if n.freq_hz >= fs / 2:
                raise UsageError(f"notch {n.freq_hz:g} Hz is at or above the Nyquist frequency {fs / 2:g} Hz",
                                 parameter="notch")
        for stage in self.leads:
            if stage.pole_hz >= fs / 2:
                raise UsageError(f"lead {stage.center_hz:g} Hz has its pole at {stage.pole_hz:g} Hz, at or "
                                 f"above the Nyquist frequency {fs / 2:g} Hz", parameter="lead")
        if self.lpf_hz is not None and self.lpf_hz >= fs / 2:
            raise UsageError(f"lpf_hz {self.lpf_hz:g} Hz is at or above the Nyquist frequency {fs / 2:g} Hz",
                             parameter="FilterPack.lpf_hz")

    def to_dict(self) -> dict:
        """Plain description (frequencies in Hz, phases in deg)."""
        return {
            "notches": [{"freq_hz": n.freq_hz, "zeta_z": n.zeta_z, "zeta_p": n.zeta_p} for n in self.notches],
            "lpf_hz": self.lpf_hz,
            "lpf_order": self.lpf_order,
            "lpf_zeta": self.lpf_zeta,
            "leads": [{"center_hz": s.center_hz, "phase_deg": s.phase_deg} for s in self.leads],
        }

    @classmethod
    def from_dict(cls, d, where: str = "filters") -> FilterPack:
        """Inverse of :meth:`to_dict`; DataError names the bad entry."""
        if not isinstance(d, dict):
            raise DataError(f"{where}: expected a table with notches, lpf_hz, lpf_order, leads")
        try:
            notches = [Notch(float(n["freq_hz"]), float(n["zeta_z"]), float(n["zeta_p"]))
                       for n in d.get("notches", [])]
            leads = [LeadStage(float(s["center_hz"]), float(s["phase_deg"])) for s in d.get("leads", [])]
            lpf = d.get("lpf_hz")
            return cls(notches, None if lpf in (None, 0, "none") else float(lpf), int(d.get("lpf_order", 1)),
                       float(d.get("lpf_zeta", 0.7)), leads)
        except (KeyError, TypeError, ValueError, UsageError) as exc:
            raise DataError(f"{where}: invalid filter description ({exc})") from None


THESIS_FILTER_PACK = FilterPack([Notch(420.0, 0.55, 0.7), Notch(1080.0, 0.05, 0.7)], 2000.0)
"""The ball-screw filter pack of thesis §3.2.2: notches at 420 and 1080 Hz, low-pass at 2000 Hz."""
