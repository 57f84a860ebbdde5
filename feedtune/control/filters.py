"""Continuous-time filters of the filter pack and loop-shaping elements (thesis eq. 3.9-3.10, 4.17-4.18).

All filters are returned as continuous :class:`~feedtune.lti.Zpk` with unit gain at 0 Hz (notch, low-pass)
or as documented. Frequencies are given in Hz and converted to rad/s internally.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError
from ..lti import Zpk

TWO_PI = 2 * np.pi


def _positive(value: float, name: str) -> float:
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise UsageError(f"{name} must be a finite number > 0, got {value!r}")
    return v


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
            raise UsageError(f"--notch expects HZ,ZETA_Z,ZETA_P (e.g. 420,0.55,0.7), got {text!r}")
        try:
            return cls(*(float(p) for p in parts))
        except ValueError:
            raise UsageError(f"--notch expects three numbers HZ,ZETA_Z,ZETA_P, got {text!r}") from None


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


@dataclass(frozen=True)
class FilterPack:
    """Notches in series with an optional first-order low-pass (eq. 3.10).

    Parameters
    ----------
    notches : sequence of Notch
    lpf_hz : float or None
        Pole frequency of the first-order low-pass [Hz]; None for no low-pass.
    """

    notches: Sequence[Notch] = field(default_factory=tuple)
    lpf_hz: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "notches", tuple(self.notches))
        if self.lpf_hz is not None:
            _positive(self.lpf_hz, "low-pass frequency [Hz]")

    def zpk(self) -> Zpk:
        """The combined continuous transfer function ``G_fp(s)``."""
        g = Zpk.constant(1.0)
        for n in self.notches:
            g = g * n.zpk()
        if self.lpf_hz is not None:
            g = g * lowpass1(self.lpf_hz)
        return g

    def check_nyquist(self, fs: float) -> None:
        """Raise UsageError when a filter frequency is at or above the Nyquist frequency ``fs / 2``."""
        for n in self.notches:
            if n.freq_hz >= fs / 2:
                raise UsageError(f"--notch {n.freq_hz:g} Hz is at or above the Nyquist frequency {fs / 2:g} Hz")
        if self.lpf_hz is not None and self.lpf_hz >= fs / 2:
            raise UsageError(f"--lpf {self.lpf_hz:g} Hz is at or above the Nyquist frequency {fs / 2:g} Hz")

    def to_dict(self) -> dict:
        """Plain description with units."""
        return {
            "notches": [{"freq_hz": n.freq_hz, "zeta_z": n.zeta_z, "zeta_p": n.zeta_p} for n in self.notches],
            "lpf_hz": self.lpf_hz,
        }

    @classmethod
    def from_dict(cls, d: dict) -> FilterPack:
        """Inverse of :meth:`to_dict`."""
        notches = [Notch(float(n["freq_hz"]), float(n["zeta_z"]), float(n["zeta_p"])) for n in d.get("notches", [])]
        lpf = d.get("lpf_hz")
        return cls(notches, None if lpf in (None, 0, "none") else float(lpf))


THESIS_FILTER_PACK = FilterPack([Notch(420.0, 0.55, 0.7), Notch(1080.0, 0.05, 0.7)], 2000.0)
"""The ball-screw filter pack of thesis §3.2.2: notches at 420 and 1080 Hz, low-pass at 2000 Hz."""
