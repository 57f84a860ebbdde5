"""The drive cascade of a one-encoder axis: speed PI with its current-setpoint filters, position P with velocity and
acceleration feedforward, each loop at its own sample time.

What a drive executes (per speed-loop sample ``k`` at ``fs``; the position loop every ``N = position_ratio`` speed
samples, at ``fp = fs / N``)::

    position sample (k mod N = 0):
        v_r = (r - r_prev) fp;  a_r = (v_r - v_r_prev) fp             setpoint velocity and acceleration [pos/s, /s^2]
        w = Kv (r - x_p) + kv_ff v_r                                  speed setpoint [pos/s], held for N samples
        i_ff = J_ff a_r                                               current feedforward [U], held for N samples
    every sample:
        v = (x1 - x1_prev) fs                                         motor speed, backward difference [pos/s]
        e = w - v;  I += Kp Ts / Tn e                                 integral, backward Euler
        u = filters(Kp e + I + i_ff)                                  current setpoint [U], applied delay_samples later

``x_p`` is the motor encoder ``x1`` or, with ``position_encoder = "load"``, the load encoder ``x2`` (a two-encoder
axis). The feedforward enters before the current-setpoint filters: the filters keep the setpoint from exciting the
resonances they address, whatever its source (a feedforward that bypassed them would excite what the notches remove).

Discretization, as drives execute these elements:

* the PI: ``Kp (1 + Ts / (Tn (1 - z^-1)))`` -- the integral updated by the sample's own error (backward Euler), as
  every feedtune law integrates;
* the current-setpoint filters (:mod:`feedtune.control.drive_tuning`: PT1 ``1/(1 + sT)``, PT2
  ``w^2/(s^2 + 2 D w s + w^2)``, the general second-order filter with numerator and denominator frequency and
  damping; a notch is one with equal frequencies): the bilinear (Tustin) transform with the numerator and the
  denominator each prewarped at its own frequency, so that both corner frequencies, and a notch's centre, sit where
  the drive's parameters put them. This is the discretization of a drive's general second-order filter documented
  for a motor-control reference design (Intel AN 669, Drive-On-Chip, "IIR Filter": the bilinear transform with the
  denominator prewarped at its frequency and the numerator at its own); SINAMICS S120 (Function Manual FH1, "Current
  setpoint filter") parameterises its PT2 and general second-order filters by exactly these frequencies and
  dampings, and the SIMODRIVE 611D manual ("Current setpoint filter") requires every band-stop frequency below the
  Shannon frequency of the controller clock: :func:`drive_filter_sos` refuses ``f >= fs / 2`` likewise;
* the speed: the backward difference of the encoder position at ``fs``; the position loop: the setpoint's
  backward differences at ``fp``, its output held (zero order) for ``N`` speed samples.

Units: positions in the axis' unit (rad or m), the command ``U`` in the drive's unit (A, N m, N, V): ``Kp``
[U/(pos/s)], ``Tn`` [s], ``Kv`` [1/s], ``kv_ff`` [-], ``J_ff`` [U/(pos/s^2)].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import DataError, UsageError
from .drive_tuning import DriveFilter, Pt1Filter, Pt2Filter, SecondOrderFilter, SpeedController
from .filters import FilterPack, Notch

POSITION_ENCODERS = ("motor", "load")
"""Which encoder the position loop closes on: the motor's (``x1``) or the load's (``x2``, a two-encoder axis)."""


# ------------------------------------------------------------------------------------------ filters
def _prewarp(freq_hz: float, fs: float, what: str) -> float:
    """``c = 1 / tan(pi f / fs)``: the bilinear transform ``s / w -> c (1 - z^-1) / (1 + z^-1)`` prewarped at ``f``."""
    if not freq_hz < fs / 2:
        raise UsageError(f"{what} {freq_hz:g} Hz is at or above the Nyquist frequency {fs / 2:g} Hz of the speed "
                         "loop (drives refuse a current-setpoint filter frequency at or above the Shannon frequency)",
                         parameter="filters")
    return 1.0 / math.tan(math.pi * freq_hz / fs)


def _quadratic(c: float, damping: float) -> np.ndarray:
    """``(s/w)^2 + 2 D s/w + 1`` under ``s/w -> c (1 - z^-1)/(1 + z^-1)``, times ``(1 + z^-1)^2``: ``[z^0, z^-1,
    z^-2]`` coefficients."""
    return np.array([c * c + 2 * damping * c + 1.0, 2.0 - 2.0 * c * c, c * c - 2 * damping * c + 1.0])


def drive_filter_sos(flt: DriveFilter, fs: float) -> np.ndarray:
    """One drive filter as a second-order section ``[b0, b1, b2, 1, a1, a2]`` at ``fs`` [Hz] (module docstring:
    Tustin, numerator and denominator each prewarped at its own frequency; unity gain at 0 Hz).

    Raises
    ------
    UsageError
        A filter frequency at or above ``fs / 2`` (a PT1's corner ``1 / (2 pi T)``).
    """
    if isinstance(flt, Pt1Filter):
        c = _prewarp(1.0 / (2 * math.pi * flt.time_constant_s), fs, "PT1 corner frequency")
        num, den = np.array([1.0, 1.0, 0.0]), np.array([c + 1.0, 1.0 - c, 0.0])
    elif isinstance(flt, Pt2Filter):
        num, den = np.array([1.0, 2.0, 1.0]), _quadratic(_prewarp(flt.freq_hz, fs, "PT2 frequency"), flt.damping)
    elif isinstance(flt, SecondOrderFilter):
        num = _quadratic(_prewarp(flt.num_freq_hz, fs, "second-order filter numerator frequency"), flt.num_damping)
        den = _quadratic(_prewarp(flt.den_freq_hz, fs, "second-order filter denominator frequency"), flt.den_damping)
    else:
        raise UsageError(f"not a drive filter: {flt!r}", parameter="filters")
    return np.r_[num / den[0], 1.0, den[1:] / den[0]]


def filters_sos(filters, fs: float) -> np.ndarray:
    """The enabled filters' sections in order, ``(n, 6)`` (``(0, 6)`` for none)."""
    rows = [drive_filter_sos(f, fs) for f in filters if f.enabled]
    return np.vstack(rows) if rows else np.zeros((0, 6))


def pack_filters(pack: FilterPack) -> tuple[DriveFilter, ...]:
    """The drive filters of a :class:`~feedtune.control.filters.FilterPack` (the tuners' filter choice): each notch a
    general second-order filter with equal frequencies (zeros ``zeta_z``, poles ``zeta_p``), the low-pass a PT1
    (order 1) or a PT2 (order 2, damping ``lpf_zeta``). A pack with lead stages has no drive equivalent."""
    if pack.leads:
        raise UsageError("a drive's current-setpoint filters hold no lead stage", parameter="filters")
    out: list = [SecondOrderFilter(n.freq_hz, n.zeta_z, n.freq_hz, n.zeta_p) for n in pack.notches]
    if pack.lpf_hz is not None:
        out.append(Pt1Filter(1.0 / (2 * math.pi * pack.lpf_hz)) if pack.lpf_order == 1
                   else Pt2Filter(pack.lpf_hz, pack.lpf_zeta))
    return tuple(out)


def filters_pack(filters) -> FilterPack | None:
    """The :class:`FilterPack` of enabled drive filters when they are notches (equal frequencies) and at most one
    low-pass after them (what the tuners' filter choice searches over), else None."""
    notches, lpf = [], None
    for f in (f for f in filters if f.enabled):
        if lpf is not None:
            return None
        if isinstance(f, SecondOrderFilter) and f.num_freq_hz == f.den_freq_hz and f.num_damping < f.den_damping:
            notches.append(Notch(f.num_freq_hz, f.num_damping, f.den_damping))
        elif isinstance(f, Pt1Filter):
            lpf = (1.0 / (2 * math.pi * f.time_constant_s), 1, 0.7)
        elif isinstance(f, Pt2Filter):
            lpf = (f.freq_hz, 2, f.damping)
        else:
            return None
    return FilterPack(notches) if lpf is None else FilterPack(notches, lpf[0], lpf[1], lpf[2])


def describe_filter(f: DriveFilter) -> str:
    """``notch 440 Hz (D 0.03 / 0.3)``, ``PT2 2000 Hz (D 0.7)``, ``PT1 T 0.1 ms``, ``second order 300 Hz D 0.1 /
    500 Hz D 0.5``."""
    if isinstance(f, Pt1Filter):
        return f"PT1 T {f.time_constant_s * 1e3:.4g} ms ({1 / (2 * math.pi * f.time_constant_s):.4g} Hz)"
    if isinstance(f, Pt2Filter):
        return f"PT2 {f.freq_hz:.4g} Hz (D {f.damping:.3g})"
    if f.num_freq_hz == f.den_freq_hz:
        return f"notch {f.num_freq_hz:.4g} Hz (D {f.num_damping:.3g} / {f.den_damping:.3g})"
    return (f"second order {f.num_freq_hz:.4g} Hz D {f.num_damping:.3g} / {f.den_freq_hz:.4g} Hz "
            f"D {f.den_damping:.3g}")


FILTER_SPELLINGS = {"pt1": "PT1 time constant [s]: pt1:T", "pt2": "PT2 frequency [Hz] and damping: pt2:HZ,D",
                    "notch": "notch frequency [Hz], zero and pole damping: notch:HZ,DZ,DP",
                    "so": "general second order, numerator and denominator frequency [Hz] and damping: "
                          "so:FZ,DZ,FP,DP"}
"""How :func:`parse_filter` spells each drive filter."""


def parse_filter(text: str) -> DriveFilter:
    """A drive filter from ``KIND:NUMBERS`` (:data:`FILTER_SPELLINGS`): ``pt1:0.0001``, ``pt2:2000,0.7``,
    ``notch:440,0.03,0.3``, ``so:300,0.1,500,0.5``.

    Raises
    ------
    UsageError
        Another kind, the wrong count of numbers, or values a filter refuses (named).
    """
    kind, _, rest = str(text).partition(":")
    kind = kind.strip().lower()
    counts = {"pt1": 1, "pt2": 2, "notch": 3, "so": 4}
    if kind not in counts:
        raise UsageError(f"filter {text!r}: expected one of " + "; ".join(FILTER_SPELLINGS.values()),
                         parameter="filter")
    try:
        v = [float(x) for x in rest.split(",")] if rest.strip() else []
    except ValueError:
        raise UsageError(f"filter {text!r}: {FILTER_SPELLINGS[kind]} (numbers)", parameter="filter") from None
    if len(v) != counts[kind]:
        raise UsageError(f"filter {text!r}: {FILTER_SPELLINGS[kind]}", parameter="filter")
    try:
        if kind == "pt1":
            return Pt1Filter(v[0])
        if kind == "pt2":
            return Pt2Filter(v[0], v[1])
        if kind == "notch":
            return SecondOrderFilter(v[0], v[1], v[0], v[2])
        return SecondOrderFilter(*v)
    except DataError as exc:
        raise UsageError(f"filter {text!r}: {exc}", parameter="filter") from None


# ------------------------------------------------------------------------------------------ the law
def _unit_circle(freq_hz, fs: float) -> np.ndarray:
    return np.exp(2j * np.pi * np.asarray(freq_hz, float) / fs)


@dataclass(frozen=True)
class CascadeLaw:
    """The speed/position cascade of a one-encoder axis as a drive executes it (module docstring).

    Parameters
    ----------
    kp : float
        Speed-loop proportional gain ``Kp`` [U/(pos/s)] (> 0).
    tn_s : float
        Speed-loop integral time ``Tn`` [s] (> 0; ``inf``: no integral action).
    filters : tuple of DriveFilter
        The current-setpoint filters in the order applied (disabled ones kept, not executed).
    kv : float
        Position-loop gain ``Kv`` [1/s] (>= 0; 0: the position loop is open, the speed setpoint is the
        feedforward alone).
    fs : float
        Speed-loop sample rate [Hz].
    position_ratio : int
        ``N``: the position loop runs every ``N`` speed samples, at ``fs / N``.
    delay_samples : int
        Computational delay of the current setpoint [speed-loop samples].
    kv_ff : float
        Velocity feedforward factor [-] (1: the setpoint's whole velocity).
    inertia_ff : float
        Acceleration feedforward ``J_ff`` [U/(pos/s^2)] (0: none).
    position_encoder : {"motor", "load"}
        The encoder the position loop closes on.
    command_unit, position_unit : str
        ``U`` (A, N*m, N, V) and the position unit (rad or m).
    """

    kp: float
    tn_s: float
    filters: tuple = field(default_factory=tuple)
    kv: float = 0.0
    fs: float = 8000.0
    position_ratio: int = 8
    delay_samples: int = 1
    kv_ff: float = 1.0
    inertia_ff: float = 0.0
    position_encoder: str = "motor"
    command_unit: str = "A"
    position_unit: str = "rad"

    kind = "cascade"

    def __post_init__(self) -> None:
        def number(name: str, *, positive: bool = False, allow_inf: bool = False) -> float:
            v = float(getattr(self, name))
            if math.isnan(v) or (math.isinf(v) and not allow_inf) or (v <= 0 if positive else v < 0):
                raise UsageError(f"{name} must be a finite number {'> 0' if positive else '>= 0'}, got "
                                 f"{getattr(self, name)!r}", parameter=name)
            object.__setattr__(self, name, v)
            return v

        number("kp", positive=True)
        number("tn_s", positive=True, allow_inf=True)
        number("kv")
        number("fs", positive=True)
        number("inertia_ff")
        v = float(self.kv_ff)
        if not math.isfinite(v):
            raise UsageError(f"kv_ff must be a finite number, got {self.kv_ff!r}", parameter="kv_ff")
        object.__setattr__(self, "kv_ff", v)
        for name in ("position_ratio", "delay_samples"):
            n = getattr(self, name)
            if int(n) != n or n < (1 if name == "position_ratio" else 0):
                raise UsageError(f"{name} must be an integer >= {1 if name == 'position_ratio' else 0}, got {n!r}",
                                 parameter=name)
            object.__setattr__(self, name, int(n))
        if self.position_encoder not in POSITION_ENCODERS:
            raise UsageError(f"position_encoder must be one of {', '.join(POSITION_ENCODERS)}, got "
                             f"{self.position_encoder!r}", parameter="position_encoder")
        object.__setattr__(self, "filters", tuple(self.filters))
        filters_sos(self.filters, self.fs)  # every filter below the Nyquist frequency

    # ---------------------------------------------------------------- derived values
    @property
    def fp(self) -> float:
        """Position-loop sample rate ``fs / N`` [Hz]."""
        return self.fs / self.position_ratio

    @property
    def integral_gain(self) -> float:
        """``Kp / Tn`` [U/pos]: the speed loop's stiffness against a load (0 without integral action)."""
        return 0.0 if math.isinf(self.tn_s) else self.kp / self.tn_s

    @property
    def enabled_filters(self) -> tuple:
        """The filters executed."""
        return tuple(f for f in self.filters if f.enabled)

    def filter_sos(self) -> np.ndarray:
        """The enabled filters' sections at ``fs``, ``(n, 6)``."""
        cached = self.__dict__.get("_sos")
        if cached is None:
            cached = filters_sos(self.filters, self.fs)
            cached.setflags(write=False)
            object.__setattr__(self, "_sos", cached)
        return cached

    def speed_controller(self) -> SpeedController:
        """The speed controller in the drive's terms (:class:`~feedtune.control.drive_tuning.SpeedController`)."""
        return SpeedController(self.kp, self.tn_s, self.filters)

    def with_gains(self, **changes) -> CascadeLaw:
        """A copy with some parameters changed (``kp``, ``tn_s``, ``filters``, ``kv`` ...)."""
        return replace(self, **changes)

    # ---------------------------------------------------------------- frequency responses
    def pi_response(self, freq_hz, discrete: bool) -> np.ndarray:
        """``Kp (1 + 1/(s Tn))``, or as executed ``Kp (1 + Ts / (Tn (1 - z^-1)))`` [U/(pos/s)]."""
        f = np.asarray(freq_hz, float)
        if math.isinf(self.tn_s):
            return np.full(f.shape, self.kp, complex)
        with np.errstate(divide="ignore", invalid="ignore"):
            if discrete:
                zi = 1.0 / _unit_circle(f, self.fs)
                return self.kp * (1.0 + (1.0 / (self.fs * self.tn_s)) / (1.0 - zi))
            return self.kp * (1.0 + 1.0 / (2j * np.pi * f * self.tn_s))

    def filters_response(self, freq_hz, discrete: bool) -> np.ndarray:
        """The enabled current-setpoint filters, continuous or as executed (their sections at ``fs``) [-]."""
        f = np.asarray(freq_hz, float)
        out = np.ones(f.shape, complex)
        if discrete:
            zi = 1.0 / _unit_circle(f, self.fs)
            for b0, b1, b2, _, a1, a2 in self.filter_sos():
                out *= (b0 + zi * (b1 + zi * b2)) / (1.0 + zi * (a1 + zi * a2))
            return out
        for flt in self.enabled_filters:
            out *= flt.response(f)
        return out

    def speed_controller_response(self, freq_hz, discrete: bool) -> np.ndarray:
        """PI times the filters: current setpoint per speed error [U/(pos/s)]."""
        return self.pi_response(freq_hz, discrete) * self.filters_response(freq_hz, discrete)

    def speed_measurement(self, freq_hz, discrete: bool) -> np.ndarray:
        """Speed per position [1/s]: ``s``, or the backward difference ``(1 - z^-1) fs``."""
        f = np.asarray(freq_hz, float)
        if discrete:
            return (1.0 - 1.0 / _unit_circle(f, self.fs)) * self.fs
        return 2j * np.pi * f

    def position_hold(self, freq_hz) -> np.ndarray:
        """The position loop's output held for ``N`` speed samples, seen at the speed loop's rate:
        ``(1 - z^-N) / (N (1 - z^-1))`` (1 at 0 Hz and for ``N = 1``) [-]."""
        f = np.asarray(freq_hz, float)
        n = self.position_ratio
        if n == 1:
            return np.ones(f.shape, complex)
        zi = 1.0 / _unit_circle(f, self.fs)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = (1.0 - zi ** n) / (n * (1.0 - zi))
        out[np.abs(1.0 - zi) < 1e-12] = 1.0
        return out

    # ---------------------------------------------------------------- records
    def gains(self) -> dict:
        """``{Kp, Tn, Kv, kv_ff, J_ff}`` (``Tn`` None without integral action)."""
        return {"Kp": self.kp, "Tn": None if math.isinf(self.tn_s) else self.tn_s, "Kv": self.kv,
                "kv_ff": self.kv_ff, "J_ff": self.inertia_ff}

    def gain_units(self) -> dict:
        """The unit of each of :meth:`gains`."""
        u, p = self.command_unit, self.position_unit
        return {"Kp": f"{u}/({p}/s)", "Tn": "s", "Kv": "1/s", "kv_ff": "-", "J_ff": f"{u}/({p}/s^2)"}

    def to_dict(self) -> dict:
        """JSON-ready description with units."""
        return {"kind": self.kind, **self.gains(), "filters": [f.to_dict() for f in self.filters], "fs_hz": self.fs,
                "position_ratio": self.position_ratio, "position_fs_hz": self.fp,
                "delay_samples": self.delay_samples, "position_encoder": self.position_encoder,
                "command_unit": self.command_unit, "position_unit": self.position_unit, "units": self.gain_units()}

    def __repr__(self) -> str:
        tn = "no integral" if math.isinf(self.tn_s) else f"Tn={self.tn_s * 1e3:.4g} ms"
        filt = ", ".join(describe_filter(f) for f in self.enabled_filters) or "no filters"
        return (f"CascadeLaw(Kp={self.kp:.4g} {self.gain_units()['Kp']}, {tn}, {filt}; Kv={self.kv:.4g} 1/s; "
                f"{self.fs:g} Hz / {self.fp:g} Hz)")


__all__ = ["FILTER_SPELLINGS", "POSITION_ENCODERS", "CascadeLaw", "describe_filter", "drive_filter_sos",
           "filters_pack", "filters_sos", "pack_filters", "parse_filter"]
