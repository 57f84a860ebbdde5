"""What every drive target shares: the options a conversion may need, the motor frame (rad, N m), the rounding a
target's number format implies, and what a target writes and reads (docs/drive_export.md).

A target (one module each: :mod:`.sinamics`, :mod:`.odrive`, :mod:`.linuxcnc_pid`) knows its parameter names, units,
loop rates and number format, which parts of the cascade law (:class:`~feedtune.control.cascade.CascadeLaw`) it can
express, ``write(law, options) -> DriveText`` in its own form with every conversion in a comment, and
``read(text, options) -> TargetLaw``: the law the target runs, rebuilt from the written numbers alone.

Units (the unit traps the exporters own): a target whose speed controller is a torque per speed takes the law in the
motor frame, positions in rad and the command in N m (:func:`to_motor_frame`): a command in A needs the torque
constant ``Kt`` [N m/A], a position in m (a ball screw's table, the law on the load side) the lead [m per motor
revolution]; a command in V maps to no torque and is refused.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

import numpy as np

from ...errors import UsageError


@dataclass(frozen=True)
class DriveOptions:
    """What a conversion may need beyond the gains file (each None unless given).

    Attributes
    ----------
    torque_constant : float or None
        ``Kt`` [N m/A]: a command in A into a torque parameter.
    lead_m : float or None
        Lead [m per motor revolution]: positions in m (and a command in N) into the motor's rad (and N m).
    fs_hz : float or None
        The target's speed-loop rate [Hz] (default: the target's, or the file's where the target has none of its own).
    position_fs_hz : float or None
        The target's position-loop rate [Hz] (a SINUMERIK's position control cycle).
    u_max : float or None
        Output limit in the command unit (LinuxCNC ``MAX_OUTPUT``).
    machine_unit : str or None
        LinuxCNC's machine unit of the joint (``mm``, ``m``, ``inch``, ``deg``, ``rad``, ``turn``).
    command_unit : str or None
        The unit of the command a read-back file's gains are in, where the file does not say (LinuxCNC).
    axis : str
        The axis' name in a SINUMERIK's machine data (``AX1``).
    encoder_bandwidth : float or None
        ODrive's ``encoder.config.bandwidth`` [rad/s] (default: the law's PT2 with D = 1, else the firmware's).
    inertia : float or None
        The motor-side inertia [kg m^2] a drive's speed gain in Hz refers to (Yaskawa: ``J_M (1 + Pn103/100)``).
    """

    torque_constant: float | None = None
    lead_m: float | None = None
    fs_hz: float | None = None
    position_fs_hz: float | None = None
    u_max: float | None = None
    machine_unit: str | None = None
    command_unit: str | None = None
    axis: str = "AX1"
    encoder_bandwidth: float | None = None
    inertia: float | None = None

    def __post_init__(self) -> None:
        for name in ("torque_constant", "lead_m", "fs_hz", "position_fs_hz", "u_max", "encoder_bandwidth", "inertia"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(float(v)) and float(v) > 0):
                raise UsageError(f"{name} must be a finite number > 0, got {v!r}", parameter=name)


@dataclass(frozen=True)
class DriveText:
    """A target's parameter file.

    Attributes
    ----------
    text : str
        The file, in the target's own form, every conversion in a comment.
    dropped : tuple of str
        Parts of the law the target cannot express (left out of the file), one line each.
    parameters : dict
        ``{written name: value}`` as written (for ``--json``).
    """

    text: str
    dropped: tuple[str, ...] = ()
    parameters: dict = field(default_factory=dict)


@dataclass(frozen=True)
class TargetLaw:
    """The law a target runs, rebuilt from its parameter file.

    Attributes
    ----------
    law : CascadeLaw
        The cascade law in the frame the target's parameters are in (the motor frame, or the file's units for a
        target that takes them as they are).
    notes : tuple of str
        What the target runs beside the law that the rebuilt law does not hold (one line each).
    extras : dict
        Target parameters outside the cascade law (ODrive's ``encoder_bandwidth`` [rad/s]).
    """

    law: object
    notes: tuple[str, ...] = ()
    extras: dict = field(default_factory=dict)


# ------------------------------------------------------------------------------------------ the motor frame
COMMAND_TORQUE = "N*m"
POSITION_ROTARY = "rad"


def _frame_factors(command_unit: str, position_unit: str, options: DriveOptions, target: str) -> tuple[float, float]:
    """``(cu, pu)``: the motor frame's command per the file's command [N m/U], and the file's position per motor rad
    [pos/rad]."""
    if position_unit == POSITION_ROTARY:
        pu = 1.0
    elif position_unit == "m":
        if options.lead_m is None:
            raise UsageError(f"{target}: the gains are per m; give the lead --lead [m per motor revolution] to write "
                             "them per motor rad", parameter="lead_m")
        pu = options.lead_m / (2 * math.pi)
    else:
        raise UsageError(f"{target}: positions in {position_unit!r}; expected rad or m", parameter="gains")
    if command_unit == COMMAND_TORQUE:
        cu = 1.0
    elif command_unit == "A":
        if options.torque_constant is None:
            raise UsageError(f"{target}: the command is in A and the drive's gains are torques; give the torque "
                             "constant --torque-constant [N*m/A]", parameter="torque_constant")
        cu = options.torque_constant
    elif command_unit == "N":
        if options.lead_m is None:
            raise UsageError(f"{target}: the command is a force in N; give the lead --lead [m per motor revolution] "
                             "to write it as the motor's torque", parameter="lead_m")
        cu = options.lead_m / (2 * math.pi)
    else:
        raise UsageError(f"{target}: a command in {command_unit!r} maps to no torque of the drive; give gains in "
                         "N*m, A (with --torque-constant) or N (with --lead)", parameter="gains")
    return cu, pu


def to_motor_frame(law, options: DriveOptions, target: str):
    """``law`` with positions in the motor's rad and the command in N m (module docstring), and the conversion as
    text: ``Kp [N m/(rad/s)] = Kp [U/(pos/s)] * cu * pu``, ``J_ff`` likewise; ``Tn``, ``Kv``, ``kv_ff`` unchanged."""
    cu, pu = _frame_factors(law.command_unit, law.position_unit, options, target)
    k = cu * pu
    text = []
    if law.command_unit != COMMAND_TORQUE:
        text.append(f"command {law.command_unit} -> N*m: x {cu:.9g} ("
                    + ("Kt" if law.command_unit == "A" else "lead / 2 pi") + ")")
    if law.position_unit != POSITION_ROTARY:
        text.append(f"position m -> motor rad: gains per (m/s) x {pu:.9g} m/rad (lead / 2 pi)")
    out = replace(law, kp=law.kp * k, inertia_ff=law.inertia_ff * k, command_unit=COMMAND_TORQUE,
                  position_unit=POSITION_ROTARY)
    return out, text


def from_motor_frame(law, command_unit: str, position_unit: str, options: DriveOptions, target: str):
    """The inverse of :func:`to_motor_frame`: a motor-frame law back in the file's units."""
    cu, pu = _frame_factors(command_unit, position_unit, options, target)
    k = cu * pu
    return replace(law, kp=law.kp / k, inertia_ff=law.inertia_ff / k, command_unit=command_unit,
                   position_unit=position_unit)


# ------------------------------------------------------------------------------------------ numbers
def float32(x: float) -> float:
    """``x`` rounded to IEEE single precision (a drive's REAL32 / float32 parameter)."""
    return float(np.float32(x))


def f32_text(x: float) -> str:
    """A single-precision value written so that reading it back gives the same single (9 significant digits)."""
    return f"{float32(x):.9g}"


def rates(law, options: DriveOptions, fs_default: float | None, ratio_fixed: int | None) -> tuple[float, int]:
    """``(fs, N)`` the target runs: ``--fs`` or the target's default or the file's; the position loop every ``N``
    speed samples (``ratio_fixed`` for a target whose loops share one rate; else from ``--position-fs``, or the
    file's ratio)."""
    fs = options.fs_hz or fs_default or law.fs
    if ratio_fixed is not None:
        if options.position_fs_hz is not None and abs(options.position_fs_hz * ratio_fixed - fs) > 1e-9 * fs:
            raise UsageError(f"position_fs_hz: this target runs its position loop at {fs / ratio_fixed:g} Hz",
                             parameter="position_fs_hz")
        return fs, ratio_fixed
    if options.position_fs_hz is None:
        return fs, law.position_ratio
    n = fs / options.position_fs_hz
    if abs(n - round(n)) > 1e-9 * n or round(n) < 1:
        raise UsageError(f"position_fs_hz {options.position_fs_hz:g} Hz: the speed-loop rate {fs:g} Hz must be a "
                         "whole multiple of it", parameter="position_fs_hz")
    return fs, round(n)


def cycle_lines(fs: float, ratio: int, names: tuple[str, str], comment: str, end: str = "") -> list[str]:
    """The ``requires:`` comment lines that state the speed and the position loop's cycle [us] a target's file was
    certified at (``names``: what the vendor calls them), read back by :func:`read_cycles`."""
    return [f"{comment} requires: {names[0]} = {1e6 / fs:.17g} us (the rate this law is certified at){end}",
            f"{comment} requires: {names[1]} = {1e6 * ratio / fs:.17g} us{end}"]


def read_cycles(text: str, where: str, options: DriveOptions, names: tuple[str, str]) -> tuple[float, int]:
    """``(fs, N)`` from ``--fs``/``--position-fs``, else from the ``requires:`` lines of :func:`cycle_lines` (DataError
    when neither states them, or when the speed cycle does not divide the position cycle)."""
    from ...errors import DataError

    stated = {m.group(1): float(m.group(2)) for m in
              re.finditer(rf"requires:\s*({re.escape(names[0])}|{re.escape(names[1])})\s*=\s*([0-9.eE+-]+)\s*us",
                          text)}
    fs = options.fs_hz or (1e6 / stated[names[0]] if stated.get(names[0]) else None)
    fp = options.position_fs_hz or (1e6 / stated[names[1]] if stated.get(names[1]) else None)
    if fs is None or fp is None:
        raise DataError(f"{where}: the {names[0]} and {names[1]} are not stated; give them with --fs and --position-fs "
                        "[Hz]")
    ratio = fs / fp
    if abs(ratio - round(ratio)) > 1e-6 * ratio or round(ratio) < 1:
        raise DataError(f"{where}: the {names[0]} {1e6 / fs:g} us does not divide the {names[1]} {1e6 / fp:g} us")
    return fs, round(ratio)


def parse_assignments(text: str, where: str, comment: str, sep: str = "=") -> dict[str, str]:
    """``{name: value text}`` of ``name = value`` lines (after stripping ``comment`` to the end of line; blank lines
    and section headers ``[...]`` skipped); a line of another form: DataError naming it."""
    from ...errors import DataError

    out: dict[str, str] = {}
    for i, raw in enumerate(text.splitlines(), 1):
        line = raw.split(comment, 1)[0].strip()
        if not line or (line.startswith("[") and line.endswith("]")):
            continue
        name, eq, value = line.partition(sep)
        if not eq or not name.strip() or not value.strip():
            raise DataError(f"{where}: line {i}: expected NAME {sep} VALUE, got {raw.strip()!r}")
        out[name.strip()] = value.strip()
    return out


def number(values: dict[str, str], key: str, where: str, default: float | None = None) -> float:
    """The finite number of ``key`` (DataError naming the key and the file)."""
    from ...errors import DataError

    if key not in values:
        if default is not None:
            return default
        raise DataError(f"{where}: {key} is missing")
    try:
        v = float(values[key])
    except ValueError:
        raise DataError(f"{where}: {key} = {values[key]!r}: expected a number") from None
    if not math.isfinite(v):
        raise DataError(f"{where}: {key} = {values[key]!r}: expected a finite number")
    return v


__all__ = ["COMMAND_TORQUE", "POSITION_ROTARY", "DriveOptions", "DriveText", "TargetLaw", "cycle_lines", "f32_text",
           "float32", "from_motor_frame", "number", "parse_assignments", "rates", "read_cycles", "to_motor_frame"]
