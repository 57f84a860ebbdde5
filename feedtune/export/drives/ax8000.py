"""Beckhoff AX8000 axis module: the velocity and position controller objects as a CoE startup list (the ``InitCmd``
elements of an EtherCAT slave's mailbox: transition, index, subindex, data as little-endian bytes in hex).

Written (Beckhoff Information System, AX8xxx object dictionary; docs/drive_export.md):

* ``0x3140:01`` velocity control proportional gain, REAL32 [N m/(rad/s)] (the default scaling of ``0x3005:09``) =
  ``Kp`` in the motor frame;
* ``0x3140:02`` velocity control integral action time, REAL32 [s], 0-5 = ``Tn`` (0: no integral action);
* ``0x30C0:01`` position control proportional gain, REAL32 [1/s] = ``Kv``.

The law the target runs: the cascade law at the file's rates (or ``--fs``/``--position-fs``; the AX8000's loop cycles
are not confirmed, so they are stated as ``requires:`` comments), the three numbers in single precision, and no
current-setpoint filter: the objects of the AX8000's BiquadFilter module are not confirmed, so every filter is
dropped (and the export refused when the law needs it). ``0x3005:09`` (the gain's scaling) is not written: the file
assumes its default.
"""

from __future__ import annotations

import math
import struct

from ...control.cascade import CascadeLaw, describe_filter
from ...errors import DataError, UsageError
from .common import DriveOptions, DriveText, TargetLaw, cycle_lines, float32, rates, read_cycles, to_motor_frame

NAME = "ax8000"
TITLE = "Beckhoff AX8000 (CoE startup list)"
OBJECTS = {(0x3140, 1): "Velocity control proportional gain", (0x3140, 2): "Velocity control integral action time",
           (0x30C0, 1): "Position control proportional gain"}
MAX_TN_S = 5.0
"""``0x3140:02``'s largest value [s]."""
CYCLES = ("velocity loop cycle", "position loop cycle")


def _hex(value: float) -> str:
    return struct.pack("<f", value).hex()


def write(law: CascadeLaw, options: DriveOptions, source: str = "") -> DriveText:
    """The startup list of ``law`` (module docstring)."""
    if law.position_encoder != "motor":
        raise UsageError(f"{NAME}: the position loop closes on the load encoder; this export writes the motor "
                         "encoder's loop only", parameter="gains")
    m, frame = to_motor_frame(law, options, NAME)
    fs, ratio = rates(law, options, None, None)
    tn = 0.0 if math.isinf(m.tn_s) else m.tn_s
    if tn > MAX_TN_S:
        raise UsageError(f"{NAME}: Tn {tn:g} s is above 0x3140:02's range (0-5 s)", parameter="gains")
    dropped = [f"{describe_filter(f)}: the AX8000's filter objects are not confirmed (not written)"
               for f in m.enabled_filters]
    rows = [((0x3140, 1), m.kp, f"[N*m/(rad/s)] = Kp {m.kp:.9g} (default scaling of 0x3005:09)"),
            ((0x3140, 2), tn, "[s] = Tn" + (" (0: no integral action)" if tn == 0 else "")),
            ((0x30C0, 1), m.kv, "[1/s] = Kv")]
    head = [f"<!-- {TITLE}: written by feedtune from {source or 'a cascade gains file'} -->",
            *(f"<!-- conversion: {t} -->" for t in frame),
            *cycle_lines(fs, ratio, CYCLES, "<!--", " -->"),
            *(f"<!-- not written: {d} -->" for d in dropped)]
    body = ["<InitCmds>"]
    params = {}
    for (index, sub), value, what in rows:
        v = float32(value)
        params[f"0x{index:04X}:{sub:02X}"] = v
        body += ["  <InitCmd>", "    <Transition>PS</Transition>", f"    <Index>#x{index:04x}</Index>",
                 f"    <SubIndex>{sub}</SubIndex>", f"    <Data>{_hex(v)}</Data>",
                 f"    <Comment>{OBJECTS[(index, sub)]} {what}: REAL32 {v:.9g}</Comment>", "  </InitCmd>"]
    body.append("</InitCmds>")
    text = '<?xml version="1.0" encoding="utf-8"?>\n' + "\n".join(head + body) + "\n"
    return DriveText(text, tuple(dropped), params)


def _number(text: str, what: str, where: str) -> int:
    t = text.strip()
    try:
        return int(t[2:], 16) if t.lower().startswith("#x") else int(t, 0)
    except ValueError:
        raise DataError(f"{where}: {what} {t!r}: expected a number (#x3140 or 12608)") from None


def read(text: str, where: str, options: DriveOptions, base: CascadeLaw | None = None) -> TargetLaw:
    """The law a startup list of :func:`write`'s form runs (motor frame: rad, N m)."""
    import xml.etree.ElementTree as ET

    if "<!DOCTYPE" in text or "<!ENTITY" in text:
        raise DataError(f"{where}: a document type or entity declaration: not a startup list")
    try:
        root = ET.fromstring(text.encode("utf-8"))
    except ET.ParseError as exc:
        raise DataError(f"{where}: not a readable XML file ({exc})") from None
    values: dict[tuple[int, int], float] = {}
    for cmd in root.iter("InitCmd"):
        index, sub, data = cmd.findtext("Index"), cmd.findtext("SubIndex"), cmd.findtext("Data")
        if index is None or sub is None or data is None:
            raise DataError(f"{where}: an InitCmd without Index, SubIndex and Data")
        key = (_number(index, "Index", where), _number(sub, "SubIndex", where))
        if key not in OBJECTS:
            continue
        try:
            raw = bytes.fromhex(data.strip())
        except ValueError:
            raw = b""
        if len(raw) != 4:
            raise DataError(f"{where}: 0x{key[0]:04X}:{key[1]:02X} data {data.strip()!r}: expected 4 bytes of REAL32 "
                            "in hex")
        v = struct.unpack("<f", raw)[0]
        if not math.isfinite(v) or v < 0:
            raise DataError(f"{where}: 0x{key[0]:04X}:{key[1]:02X} = {v!r}: expected a finite number >= 0")
        values[key] = v
    for key, name in OBJECTS.items():
        if key not in values:
            raise DataError(f"{where}: 0x{key[0]:04X}:{key[1]:02X} ({name}) is missing")
    fs, ratio = read_cycles(text, where, options, CYCLES)
    kp, tn, kv = values[(0x3140, 1)], values[(0x3140, 2)], values[(0x30C0, 1)]
    if kp <= 0:
        raise DataError(f"{where}: 0x3140:01 = 0: no velocity controller gain")
    b = base
    law = CascadeLaw(kp, math.inf if tn == 0 else tn, (), kv, fs, ratio, b.delay_samples if b else 1,
                     b.kv_ff if b else 1.0, b.inertia_ff if b else 0.0, "motor", "N*m", "rad")
    return TargetLaw(law)


__all__ = ["NAME", "OBJECTS", "TITLE", "read", "write"]
