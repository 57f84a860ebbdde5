"""Input shapers for firmwares that run their own: Klipper's ``[input_shaper]`` section and Marlin's ``M593``/``M493``.

Both firmwares rebuild the shaper from its type, frequency and damping ratio with their own definitions, so only those
three numbers travel (sources and what is not confirmed: docs/drive_export.md):

* **Klipper** (``docs/Config_Reference.md`` ``[input_shaper]``; ``klippy/extras/input_shaper.py``):
  ``shaper_type_x``/``_y`` (``zv``, ``mzv``, ``zvd``, ``ei``, ``2hump_ei``, ``3hump_ei``: feedtune's names),
  ``shaper_freq_x``/``_y`` [Hz], ``damping_ratio_x``/``_y`` [-] (Klipper's default 0.1; it accepts 0 to 1). No
  conversion. Klipper's definitions are the ones of :mod:`feedtune.control.shapers` up to its September 2025 refit
  of the EI family, which moves their impulses by a few percent.
* **Marlin** (``docs/gcode/M593.md``): ``M593 X F<Hz> D<zeta>`` sets its ZV shaper (``X``, ``Y``, ``Z`` flags,
  ``F`` frequency [Hz], ``D`` damping ratio [-]). Its fixed-time motion ``M493`` selects other shapers by number, but
  the numbers changed between Marlin versions (``S12`` is EI in one documented version, ZVDD in a later one; ZV 10
  and ZVD 11 in both) and it sets no damping ratio; so a ZVD is written as ``M493 S11 A<Hz>`` (``B`` for Y) with a
  comment that the firmware's own damping applies, and the other types are refused.

:func:`read_klipper_section` reads the section back (the three numbers per axis), so a written file can be checked.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

from ..errors import DataError, UsageError

KLIPPER_TYPES = ("zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei")
"""Shaper types Klipper's ``[input_shaper]`` accepts (its names are feedtune's)."""
KLIPPER_AXES = ("x", "y")
"""Axes of Klipper's ``[input_shaper]`` (``shaper_*_z`` exists only in newer versions: not written)."""
MARLIN_AXES = ("x", "y", "z")
"""Axes ``M593`` flags (``Z`` since Marlin 2.1.3)."""
M493_MODES = {"zv": 10, "zvd": 11}
"""``M493 S`` numbers that every documented Marlin version gives the same type."""
M493_FREQ_LETTER = {"x": "A", "y": "B"}
"""``M493`` letters of the base frequency per axis."""


def _digits(x: float) -> str:
    """A number as a config file writes it: 6 significant digits."""
    return f"{float(x):.6g}"


def _header(lines: Sequence[str]) -> list[str]:
    return [f"# {line}" for line in lines]


def klipper_section(shapers: Sequence[tuple[object, str]], sources: Sequence[str] = ()) -> str:
    """The ``[input_shaper]`` section of ``printer.cfg`` for shapers by axis.

    Parameters
    ----------
    shapers : sequence of (InputShaper, str)
        Each shaper and its axis (``x`` or ``y``), at most one per axis.
    sources : sequence of str
        The files they came from (named in the comment).
    """
    axes = [a for _, a in shapers]
    if not shapers or len(set(axes)) != len(axes) or any(a not in KLIPPER_AXES for a in axes):
        raise UsageError(f"Klipper's [input_shaper] takes one shaper per axis among {', '.join(KLIPPER_AXES)}, got "
                         f"axes {axes}", parameter="shapers")
    out = _header(["Written by feedtune: paste into printer.cfg (replaces any [input_shaper] section).",
                   "Klipper rebuilds each shaper from its type, frequency [Hz] and damping ratio [-]: no conversion.",
                   *([f"From {', '.join(sources)}."] if sources else [])])
    out.append("[input_shaper]")
    for sh, axis in sorted(shapers, key=lambda p: p[1]):
        if sh.kind not in KLIPPER_TYPES:
            raise UsageError(f"Klipper has no {sh.kind!r} shaper; it knows {', '.join(KLIPPER_TYPES)}")
        out += [f"# {axis}: {sh.kind}, {len(sh.amplitudes)} impulses over {sh.duration_s * 1e3:.4g} ms "
                f"(lag {sh.time_shift_s * 1e3:.4g} ms)",
                f"shaper_type_{axis}: {sh.kind}",
                f"shaper_freq_{axis}: {_digits(sh.freq_hz)}",
                f"damping_ratio_{axis}: {_digits(sh.damping)}"]
    return "\n".join(out) + "\n"


_LINE = re.compile(r"^\s*([A-Za-z0-9_]+)\s*[:=]\s*(.*?)\s*$")


def read_klipper_section(text: str, where: str = "Klipper config") -> dict[str, dict]:
    """``{axis: {"type", "freq_hz", "damping"}}`` of the ``[input_shaper]`` section of a Klipper config (Klipper's
    defaults where a key is missing: type ``mzv`` or ``shaper_type``, damping 0.1; an axis without a frequency, or
    with 0, is not shaped and left out)."""
    section = None
    values: dict[str, str] = {}
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].split(";", 1)[0].rstrip()
        if not line.strip():
            continue
        head = re.fullmatch(r"\s*\[([^\]]+)\]\s*", line)
        if head:
            section = head.group(1).strip()
            continue
        m = _LINE.match(line)
        if section == "input_shaper" and m:
            values[m.group(1)] = m.group(2)
    out = {}
    for axis in KLIPPER_AXES:
        freq = values.get(f"shaper_freq_{axis}")
        if freq is None:
            continue
        try:
            f = float(freq)
            z = float(values.get(f"damping_ratio_{axis}", "0.1"))
        except ValueError:
            raise DataError(f"{where}: [input_shaper] {axis}: a frequency or damping ratio is not a number") from None
        kind = values.get(f"shaper_type_{axis}", values.get("shaper_type", "mzv"))
        if kind not in KLIPPER_TYPES:
            raise DataError(f"{where}: [input_shaper] shaper_type_{axis} = {kind!r} is not one of "
                            f"{', '.join(KLIPPER_TYPES)}")
        if f > 0:
            out[axis] = {"type": kind, "freq_hz": f, "damping": z}
    return out


def marlin_gcode(shapers: Sequence[tuple[object, str]], sources: Sequence[str] = ()) -> str:
    """G-code lines that set Marlin's shapers (module docstring): ``M593`` for ZV, ``M493`` for ZVD.

    Raises
    ------
    UsageError
        A type Marlin cannot be told unambiguously, an unknown or repeated axis.
    """
    axes = [a for _, a in shapers]
    if not shapers or len(set(axes)) != len(axes) or any(a not in MARLIN_AXES for a in axes):
        raise UsageError(f"Marlin takes one shaper per axis among {', '.join(MARLIN_AXES)}, got axes {axes}",
                         parameter="shapers")
    out = _header(["Written by feedtune: send to Marlin (M500 stores the M593 settings in EEPROM).",
                   *([f"From {', '.join(sources)}."] if sources else [])])
    for sh, axis in sorted(shapers, key=lambda p: p[1]):
        if sh.kind == "zv":
            out.append(f"M593 {axis.upper()} F{_digits(sh.freq_hz)} D{_digits(sh.damping)} ; ZV input shaping, "
                       f"{axis}: {_digits(sh.freq_hz)} Hz, damping ratio {_digits(sh.damping)}")
        elif sh.kind in M493_MODES and axis in M493_FREQ_LETTER:
            out.append(f"M493 S{M493_MODES[sh.kind]} {M493_FREQ_LETTER[axis]}{_digits(sh.freq_hz)} ; "
                       f"{sh.kind.upper()} by fixed-time motion (FT_MOTION), {axis}: {_digits(sh.freq_hz)} Hz; M493 "
                       f"sets no damping ratio: the firmware's own applies, not {_digits(sh.damping)}")
        else:
            raise UsageError(f"Marlin cannot be told a {sh.kind} shaper on {axis} unambiguously: M593 shapes ZV only, "
                             "and M493 numbers its other shapers differently between versions (S12 is EI in one, "
                             "ZVDD in another) and takes no damping ratio; choose zv (or zvd on x/y) with design "
                             "shaper --shaper zv", parameter="shapers")
    return "\n".join(out) + "\n"


TARGETS: Mapping[str, object] = {"klipper": klipper_section, "marlin": marlin_gcode}
"""The text writer of each firmware target (``feedtune export klipper|marlin``)."""
