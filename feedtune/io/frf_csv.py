"""Frequency response functions as CSV text files.

Format (see ``docs/formats.md``)::

    # quantity: acceleration
    # input: u [V]
    # output: x1 [rad]
    # source: bench test 2024-05-02
    freq_hz,x1/u.re,x1/u.im,x1/u.coh,x2/u.mag_db,x2/u.phase_deg
    10,0.12,-3.4,0.99,-20.1,-178.2

Column suffixes per channel ``OUT/IN``: ``re`` + ``im``, or ``mag`` (linear) / ``mag_db`` together with
``phase_deg`` / ``phase_rad``, and an optional ``coh`` (0..1).

Vendor exports (any other header) are read two ways (:func:`read_frf_csv`):

* a column map ``columns={"freq": "Frequency [Hz]", "x1/u.mag_db": "Magnitude [dB]", ...}`` (CLI ``--frf-map``):
  ``freq`` (unit from the header, else Hz), ``freq_hz``, ``freq_khz`` or ``freq_rad_s``, and ``OUT/IN.KIND`` with
  KIND one of :data:`SUFFIXES`; only the mapped channels are read;
* without a map, a single-channel header is recognised when it is unambiguous: one frequency column (name with
  ``freq``, unit Hz, kHz or rad/s), magnitude (dB or linear, by its unit) + phase (deg or rad, by its unit), or
  real + imaginary columns, and an optional coherence column. The channel is ``auto_channel`` (default ``x1/u``).

Units are read from ``NAME [UNIT]`` / ``NAME (UNIT)`` header cells or from a second header row of units
(``Frequency,Magnitude,Phase`` then ``Hz,dB,deg``). The columns used are recorded in ``meta["columns"]`` in the
map's own syntax, e.g. ``freq_hz=Frequency [Hz]; x1/u.mag_db=Magnitude [dB]; x1/u.phase_deg=Phase [deg]``.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import IO

import numpy as np

from ..errors import DataError, UsageError
from ..frf import Frf, normalize_quantity
from ._table import MAX_HEADER_CHARS, TextTable, parse_table, read_table_data
from .atomic import atomic_write_text
from .csv_text import csv_rows

SUFFIXES = ("re", "im", "mag", "mag_db", "phase_deg", "phase_rad", "coh")
FREQ_KEYS = {"freq_hz": 1.0, "freq_khz": 1e3, "freq_rad_s": 1.0 / (2.0 * math.pi)}
"""Column-map keys of the frequency column and their factor to Hz; the key ``freq`` takes the header's unit."""
DEFAULT_CHANNEL = "x1/u"
"""Channel name of a recognised single-channel vendor header when ``auto_channel`` is not given."""
MAP_PARAMETER = "read_frf.columns"
"""The ``parameter`` of errors about the column map; messages name it ``columns=`` (the argument of
:func:`read_frf_csv`), the command line prints its option, ``--frf-map`` (:func:`feedtune.errors.cli_message`)."""
CHANNEL_DEFAULTED = "default"
"""``meta["channel_named"]`` of a recognised single-channel vendor header whose channel nobody named: it is
:data:`DEFAULT_CHANNEL` because the file does not say which encoder it measured."""
RECOGNISED_FORMAT = "csv, recognised header"
MAPPED_FORMAT = "csv, column map"
"""``meta["format"]`` of an FRF read from a vendor header without and with a column map (not written to files)."""
_UNIT_RE = re.compile(r"^(.*?)\s*\[(.*)\]\s*$")
_RESERVED_META = {"quantity", "input", "output", "input_unit", "output_unit"}
_NOT_WRITTEN_META = {"source", "format", "origin", "channel_named", *_RESERVED_META}


def _name_and_unit(text: str) -> tuple[str, str | None]:
    """Split ``"x1 [rad]"`` into ``("x1", "rad")``; no brackets gives ``(text, None)``."""
    m = _UNIT_RE.match(text.strip())
    return (m.group(1).strip(), m.group(2).strip()) if m else (text.strip(), None)


def _one_unit(values: list[str], key: str, default: str, name: str) -> str:
    """The single unit given by ``# key: NAME [UNIT]`` lines (all must agree)."""
    units = {u for _, u in map(_name_and_unit, values) if u}
    if len(units) > 1:
        raise DataError(f"{name}: '# {key}:' lines give different units ({', '.join(sorted(units))}); "
                        "an FRF file holds one unit per side")
    return units.pop() if units else default


def frf_units(metadata: Mapping[str, list[str]], name: str) -> tuple[str, str]:
    """``(input_unit, output_unit)`` from ``# input: u [V]``, ``# output: x1 [rad]``, ``# *_unit:`` lines."""
    input_unit = _one_unit(metadata.get("input", []), "input", "V", name)
    output_unit = _one_unit(metadata.get("output", []), "output", "rad", name)
    if metadata.get("input_unit"):
        input_unit = metadata["input_unit"][-1]
    if metadata.get("output_unit"):
        output_unit = metadata["output_unit"][-1]
    return input_unit, output_unit


def _group_columns(columns: list[str], name: str) -> dict[str, dict[str, int]]:
    """Map channel ``OUT/IN`` to ``{suffix: column index}``; unknown or misspelled columns are errors."""
    groups: dict[str, dict[str, int]] = {}
    for j, col in enumerate(columns):
        if col.lower() == "freq_hz":
            continue
        channel, dot, suffix = col.rpartition(".")
        if not dot or suffix not in SUFFIXES:
            raise DataError(f"{name}: column {col!r} is not understood; expected freq_hz or OUT/IN.SUFFIX "
                            f"with SUFFIX one of {', '.join(SUFFIXES)} (or map the columns with columns=)",
                            parameter=MAP_PARAMETER)
        parts = channel.split("/")
        if len(parts) != 2 or not all(p.strip() for p in parts):
            raise DataError(f"{name}: column {col!r}: channel {channel!r} must look like OUT/IN, e.g. x2/u")
        if suffix in groups.setdefault(channel, {}):
            raise DataError(f"{name}: column {col!r} appears twice")
        groups[channel][suffix] = j
    return groups


def _channel_response(channel: str, cols: dict[str, int], table: TextTable) -> np.ndarray:
    """Complex response of one channel from its re/im or magnitude/phase columns."""
    name, d = table.name, table.data
    has = set(cols) - {"coh"}
    if has == {"re", "im"}:
        return d[:, cols["re"]] + 1j * d[:, cols["im"]]
    mags = has & {"mag", "mag_db"}
    phases = has & {"phase_deg", "phase_rad"}
    if len(mags) == 1 and len(phases) == 1 and has == mags | phases:
        if "mag" in mags and np.any(d[:, cols["mag"]] < 0):
            i = int(np.flatnonzero(d[:, cols["mag"]] < 0)[0])
            raise DataError(f"{name}: line {table.line_number(i)}, column {table.columns[cols['mag']]!r}: a linear "
                            f"magnitude of {d[i, cols['mag']]:g} (a magnitude is >= 0; in dB map it as "
                            f"{channel}.mag_db)")
        mag = d[:, cols["mag"]] if "mag" in mags else 10.0 ** (d[:, cols["mag_db"]] / 20.0)
        ph = np.deg2rad(d[:, cols["phase_deg"]]) if "phase_deg" in phases else d[:, cols["phase_rad"]]
        return mag * np.exp(1j * ph)
    pairs = {"re": "im", "im": "re", "mag": "phase_deg", "mag_db": "phase_deg", "phase_deg": "mag or mag_db",
             "phase_rad": "mag or mag_db"}
    if len(has) == 1:
        (only,) = has
        raise DataError(f"{name}: column '{channel}.{only}' has no partner column '{channel}.{pairs[only]}'")
    if not has:
        raise DataError(f"{name}: channel {channel!r} has only a coherence column; add its response columns")
    raise DataError(f"{name}: channel {channel!r} has columns {', '.join(sorted(has))}; "
                    "give either re + im or one magnitude column (mag or mag_db) + one phase column")


def _channel_coherence(channel: str, col: int, table: TextTable) -> np.ndarray:
    coh = table.data[:, col]
    bad = (coh < 0) | (coh > 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise DataError(f"{table.name}: line {table.line_number(i)}, column {table.columns[col]!r}: "
                        f"coherence {coh[i]:g} is outside 0..1")
    return coh


def _no_freq_message(name: str, header: str) -> str:
    return (f"{name}: no frequency column (expected 'freq_hz', a header such as 'Frequency [Hz]', or a "
            f"columns=freq=COLUMN; the header is: {header})")


def _assemble(table: TextTable, f: np.ndarray, channels: dict[str, np.ndarray],
              coherence: dict[str, np.ndarray], quantity: str | None, extra_meta: Mapping[str, str]) -> Frf:
    """The :class:`Frf` of a table's channels: quantity, units and metadata from its ``# key: value`` lines."""
    name = table.name
    q_meta = table.metadata.get("quantity", ["position"])[-1]
    q = normalize_quantity(quantity if quantity is not None else q_meta, f"{name}: quantity")
    input_unit, output_unit = frf_units(table.metadata, name)
    meta = {"source": name, "format": "csv"}
    for key, values in table.metadata.items():
        if key not in _RESERVED_META:
            meta["origin" if key == "source" else key] = "; ".join(values)
    meta.update(extra_meta)
    return Frf.from_channels(f, channels, coherence=coherence or None, quantity=q, input_unit=input_unit,
                             output_unit=output_unit, meta=meta)


def frf_from_table(table: TextTable, quantity: str | None = None) -> Frf:
    """Build an :class:`Frf` from a parsed CSV table (header ``freq_hz``, channel columns)."""
    name = table.name
    lower = [c.lower() for c in table.columns]
    if "freq_hz" not in lower:
        raise DataError(_no_freq_message(name, ", ".join(table.columns)), parameter=MAP_PARAMETER)
    f = table.data[:, lower.index("freq_hz")]
    groups = _group_columns(table.columns, name)
    if not groups:
        raise DataError(f"{name}: no channel columns (OUT/IN.re, OUT/IN.im ...) besides freq_hz")
    channels = {ch: _channel_response(ch, cols, table) for ch, cols in groups.items()}
    coherence = {ch: _channel_coherence(ch, cols["coh"], table)
                 for ch, cols in groups.items() if "coh" in cols}
    return _assemble(table, f, channels, coherence, quantity, {})


# ----------------------------------------------------------------------------------------- vendor headers
_CELL_UNIT_RE = re.compile(r"^(.*?)\s*[\[(]([^\[\]()]*)[\])]\s*$")
_NATIVE_COLUMN_RE = re.compile(r"^[^/\s]+/[^/\s]+\.(?:" + "|".join(SUFFIXES) + r")$", re.IGNORECASE)
_FREQ_UNITS = {"hz": "freq_hz", "1/s": "freq_hz", "khz": "freq_khz", "rad/s": "freq_rad_s", "rad/sec": "freq_rad_s",
               "radian/s": "freq_rad_s", "radians/s": "freq_rad_s"}
_DEG_UNITS = ("deg", "degree", "degrees", "°")
_RAD_UNITS = ("rad", "radian", "radians")
_UNIT_TOKENS = ("hz", "khz", "db", "deg", "rad", "°")
_UNITS_ROW_MAX_CHARS = 24


@dataclass(frozen=True)
class ColumnMap:
    """A parsed FRF column map (see :func:`parse_column_map`).

    Attributes
    ----------
    freq_key : str or None
        ``"freq"`` (unit from the header, else Hz), ``"freq_hz"``, ``"freq_khz"`` or ``"freq_rad_s"``; None lets
        the reader find the frequency column.
    freq_column : str or None
        The column named for the frequency.
    channels : dict of str to dict of str to str
        ``{"OUT/IN": {KIND: column}}`` with KIND one of :data:`SUFFIXES`.
    """

    freq_key: str | None
    freq_column: str | None
    channels: dict[str, dict[str, str]]


def parse_column_map(columns: Mapping[str, str]) -> ColumnMap:
    """Check and split an FRF column map ``{NAME: COLUMN}``.

    Parameters
    ----------
    columns : mapping of str to str
        NAME is ``freq`` (unit from the header, else Hz), ``freq_hz``, ``freq_khz``, ``freq_rad_s`` or
        ``OUT/IN.KIND`` with KIND one of ``re, im, mag, mag_db, phase_deg, phase_rad, coh``; COLUMN is a header
        cell (``Magnitude [dB]``), the name without its unit (``Magnitude``) or ``colK`` (0-based).

    Returns
    -------
    ColumnMap

    Raises
    ------
    UsageError
        An unknown NAME, a channel that is not ``OUT/IN``, the frequency given twice, or a channel without a
        complete response (re + im, or one magnitude + one phase).
    """
    freq_key = freq_column = None
    channels: dict[str, dict[str, str]] = {}
    kinds = ", ".join(SUFFIXES)
    for key, column in columns.items():
        key, column = str(key).strip(), str(column).strip()
        if not key or not column:
            raise UsageError(f"columns= expects NAME=COLUMN, got {key}={column}", parameter=MAP_PARAMETER)
        if key == "freq" or key in FREQ_KEYS:
            if freq_key is not None:
                raise UsageError(f"columns= names the frequency column twice ({freq_key}, {key})",
                                 parameter=MAP_PARAMETER)
            freq_key, freq_column = key, column
            continue
        channel, dot, kind = key.rpartition(".")
        if not dot:
            raise UsageError(f"columns={key}={column}: NAME must be freq, freq_hz, freq_khz, freq_rad_s or "
                             f"OUT/IN.KIND (KIND one of {kinds}), e.g. x1/u.mag_db", parameter=MAP_PARAMETER)
        if kind not in SUFFIXES:
            raise UsageError(f"columns={key}={column}: unknown KIND {kind!r}; expected one of {kinds}",
                             parameter=MAP_PARAMETER)
        parts = channel.split("/")
        if len(parts) != 2 or not all(p.strip() for p in parts):
            raise UsageError(f"columns={key}={column}: channel {channel!r} must look like OUT/IN, e.g. x2/u",
                             parameter=MAP_PARAMETER)
        if kind in channels.setdefault(channel, {}):
            raise UsageError(f"columns= names {key} twice", parameter=MAP_PARAMETER)
        channels[channel][kind] = column
    if not channels:
        raise UsageError("columns= maps no channel; give OUT/IN.KIND=COLUMN entries, e.g. "
                         "x1/u.mag_db='Magnitude [dB]' and x1/u.phase_deg='Phase [deg]'", parameter=MAP_PARAMETER)
    for channel, cols in channels.items():
        _check_kinds(channel, set(cols))
    return ColumnMap(freq_key, freq_column, channels)


def _check_kinds(channel: str, kinds: set[str]) -> None:
    """UsageError unless ``kinds`` is re + im or one magnitude + one phase (each with an optional coh)."""
    has = kinds - {"coh"}
    mags, phases = has & {"mag", "mag_db"}, has & {"phase_deg", "phase_rad"}
    if has == {"re", "im"} or (len(mags) == 1 and len(phases) == 1 and has == mags | phases):
        return
    hint = (f"give {channel}.re + {channel}.im, or {channel}.mag_db (or .mag) + {channel}.phase_deg "
            "(or .phase_rad)")
    what = ", ".join(sorted(has)) if has else "only a coherence"
    raise UsageError(f"columns=: channel {channel} has {what}; {hint}", parameter=MAP_PARAMETER)


def check_channel_name(channel: str, option: str = "auto_channel", parameter: str | None = None) -> str:
    """``channel`` stripped when it looks like ``OUT/IN``; UsageError naming ``option`` (the error's ``parameter``)
    otherwise."""
    parts = str(channel).strip().split("/")
    if len(parts) != 2 or not all(p.strip() and p == p.strip() for p in parts) or any("," in p for p in parts):
        raise UsageError(f"{option} expects a channel name OUT/IN such as x1/u or x2/u, got {channel!r}",
                         parameter=parameter)
    return "/".join(parts)


@dataclass(frozen=True)
class _Column:
    """One column of a vendor table: index, header cell, name without unit, unit (None when not given), and the
    label messages show (``NAME [UNIT]`` when the unit comes from a units row)."""

    index: int
    cell: str
    name: str
    unit: str | None
    label: str


def _split_cell(cell: str) -> tuple[str, str | None]:
    """``"Magnitude [dB]"`` / ``"Magnitude (dB)"`` -> ``("Magnitude", "dB")``; else ``(cell, None)``."""
    m = _CELL_UNIT_RE.match(cell.strip())
    if m and m.group(1).strip():
        return m.group(1).strip(), (m.group(2).strip() or None)
    return cell.strip(), None


def _tokens(text: str) -> list[str]:
    return re.findall(r"[^\W_]+|°", text.lower())


def _unit_hint(name: str) -> str | None:
    """A unit written as the last word of a name: ``Magnitude_dB``, ``Phase deg``, ``freq_rad_s``."""
    t = _tokens(name)
    if len(t) > 2 and t[-2:] == ["rad", "s"]:
        return "rad/s"
    return t[-1] if len(t) > 1 and t[-1] in _UNIT_TOKENS else None


def _columns(table: TextTable, units_row: list[str] | None) -> list[_Column]:
    out = []
    for j, cell in enumerate(table.columns):
        name, unit = _split_cell(cell)
        label = cell
        if units_row is not None and j < len(units_row) and units_row[j]:
            unit = units_row[j]
            label = f"{name} [{unit}]"
        out.append(_Column(j, cell, name, unit or _unit_hint(name), label))
    return out


def _header(cols: list[_Column]) -> str:
    return ", ".join(c.label for c in cols)


def _role(col: _Column) -> str | None:
    """What a vendor column holds by its name: freq, coh, phase, re, im, mag, or None."""
    low, t = col.name.lower(), _tokens(col.name)
    if "coh" in low or "koh" in low:
        return "coh"
    if any(w.startswith("phas") for w in t) or any(w in ("phi", "angle", "arg", "winkel") for w in t):
        return "phase"
    if any(w == "re" or w.startswith("real") for w in t):
        return "re"
    if any(w == "im" or w.startswith("imag") for w in t):
        return "im"
    if any(w.startswith(("mag", "ampl")) or w in ("amp", "gain", "betrag", "abs") for w in t):
        return "mag"
    if "freq" in low or "frequenz" in low or t in (["f"], ["omega"]):
        return "freq"
    return None


def _unit_key(unit: str | None) -> str:
    return "" if unit is None else unit.lower().replace(" ", "")


def _freq_key_of(col: _Column, name: str) -> str:
    """``freq_hz``/``freq_khz``/``freq_rad_s`` from a frequency column's unit (Hz without a unit; omega: rad/s)."""
    u = _unit_key(col.unit)
    if not u:
        return "freq_rad_s" if _tokens(col.name) == ["omega"] else "freq_hz"
    if u not in _FREQ_UNITS:
        raise DataError(f"{name}: frequency column {col.label!r}: unit {col.unit!r} not understood (expected Hz, "
                        f"kHz or rad/s); map it as columns=freq_hz=COLUMN, freq_khz=... or freq_rad_s=...",
                        parameter=MAP_PARAMETER)
    return _FREQ_UNITS[u]


def _magnitude_kind(col: _Column, name: str, channel: str) -> str:
    u = _unit_key(col.unit)
    if "db" in u:
        return "mag_db"
    if u:
        return "mag"
    raise DataError(f"{name}: magnitude column {col.label!r} gives no unit (dB or linear?); write it in the header "
                    f"('{col.name} [dB]') or map it as columns={channel}.mag_db=COLUMN (or {channel}.mag)",
                    parameter=MAP_PARAMETER)


def _phase_kind(col: _Column, name: str, channel: str) -> str:
    u = _unit_key(col.unit)
    if u in _DEG_UNITS:
        return "phase_deg"
    if u in _RAD_UNITS:
        return "phase_rad"
    what = f"unit {col.unit!r} not understood" if u else "gives no unit (deg or rad?)"
    raise DataError(f"{name}: phase column {col.label!r} {what}; write deg or rad in the header "
                    f"('{col.name} [deg]') or map it as columns={channel}.phase_deg=COLUMN (or .phase_rad)",
                    parameter=MAP_PARAMETER)


def _check_unit(col: _Column, kind: str, key: str, name: str) -> None:
    """DataError when a mapped column's own unit contradicts the KIND it is mapped as."""
    u = _unit_key(col.unit)
    if not u:
        return
    channel = key.rpartition(".")[0]
    wrong = None
    if kind == "mag" and "db" in u:
        wrong = f"{channel}.mag_db"
    elif kind == "mag_db" and "db" not in u:
        wrong = f"{channel}.mag"
    elif kind == "phase_deg" and u in _RAD_UNITS:
        wrong = f"{channel}.phase_rad"
    elif kind == "phase_rad" and u in _DEG_UNITS:
        wrong = f"{channel}.phase_deg"
    elif kind in FREQ_KEYS and u in _FREQ_UNITS and _FREQ_UNITS[u] != kind:
        wrong = f"{_FREQ_UNITS[u]} (or freq)"
    if wrong:
        raise DataError(f"{name}: columns={key}={col.cell}: the column's unit is {col.unit}; map it as {wrong}",
                        parameter=MAP_PARAMETER)


def _find_column(spec: str, cols: list[_Column], key: str, name: str) -> _Column:
    """The column a map names: header cell, name without unit, either ignoring case, or ``colK``."""
    candidates = (spec, _split_cell(spec)[0])
    for match in (lambda c, s: c.cell == s, lambda c, s: c.cell.lower() == s.lower(),
                  lambda c, s: c.name.lower() == s.lower()):
        for s in candidates:
            found = [c for c in cols if match(c, s)]
            if len(found) == 1:
                return found[0]
            if len(found) > 1:
                raise DataError(f"{name}: columns={key}={spec}: several columns are called that "
                                f"({', '.join(f'col{c.index}' for c in found)}); name one as colK",
                                parameter=MAP_PARAMETER)
    m = re.fullmatch(r"col(\d+)", spec)
    if m and int(m.group(1)) < len(cols):
        return cols[int(m.group(1))]
    raise DataError(f"{name}: columns={key}={spec}: no such column; the header is: {_header(cols)}",
                    parameter=MAP_PARAMETER)


def _auto_freq(cols: list[_Column], name: str) -> tuple[str, _Column]:
    """The frequency column of a header: ``freq_hz`` itself, else the one column whose name says frequency."""
    native = [c for c in cols if c.cell.lower() == "freq_hz"]
    if native:
        return "freq_hz", native[0]
    found = [c for c in cols if _role(c) == "freq"]
    if not found:
        raise DataError(_no_freq_message(name, _header(cols)), parameter=MAP_PARAMETER)
    if len(found) > 1:
        raise DataError(f"{name}: several frequency columns ({', '.join(c.label for c in found)}); pick one with "
                        "columns=freq=COLUMN", parameter=MAP_PARAMETER)
    return _freq_key_of(found[0], name), found[0]


def _auto_channel(cols: list[_Column], channel: str, name: str) -> dict[str, _Column]:
    """``{KIND: column}`` of the single channel a vendor header holds (DataError when it is not unambiguous)."""
    roles: dict[str, list[_Column]] = {}
    for c in cols:
        r = _role(c)
        if r is not None and r != "freq":
            roles.setdefault(r, []).append(c)
    hint = "map the columns with columns=OUT/IN.KIND=COLUMN"
    for r, found in roles.items():
        if len(found) > 1:
            what = {"coh": "coherence", "re": "real-part", "im": "imaginary-part", "mag": "magnitude"}.get(r, r)
            raise DataError(f"{name}: several {what} columns ({', '.join(c.label for c in found)}), so more than "
                            f"one channel or an ambiguous header; {hint} (the header is: {_header(cols)})",
                            parameter=MAP_PARAMETER)
    polar, cartesian = {"mag", "phase"} & set(roles), {"re", "im"} & set(roles)
    if polar and cartesian:
        raise DataError(f"{name}: both magnitude/phase and real/imaginary columns; {hint}, e.g. "
                        f"{channel}.re=COLUMN and {channel}.im=COLUMN (the header is: {_header(cols)})",
                        parameter=MAP_PARAMETER)
    if polar == {"mag", "phase"}:
        mag, ph = roles["mag"][0], roles["phase"][0]
        out = {_magnitude_kind(mag, name, channel): mag, _phase_kind(ph, name, channel): ph}
    elif cartesian == {"re", "im"}:
        out = {"re": roles["re"][0], "im": roles["im"][0]}
    else:
        have = polar | cartesian
        missing = {"mag": "phase", "phase": "magnitude", "re": "imaginary-part", "im": "real-part"}
        what = (f"{missing[next(iter(have))]} column to go with {roles[next(iter(have))][0].label!r}" if have
                else "response columns (magnitude + phase, or real + imaginary part)")
        raise DataError(f"{name}: no {what}; the header is: {_header(cols)} (or {hint})", parameter=MAP_PARAMETER)
    if "coh" in roles:
        out["coh"] = roles["coh"][0]
    return out


def frf_from_vendor_table(
    table: TextTable,
    quantity: str | None = None,
    *,
    columns: Mapping[str, str] | None = None,
    units_row: list[str] | None = None,
    auto_channel: str | None = None,
) -> Frf:
    """Build an :class:`Frf` from a table with a vendor header (see the module docstring).

    Parameters
    ----------
    table : TextTable
        The parsed file.
    quantity : {"position", "velocity", "acceleration"}, optional
        What the outputs measure; overrides the file's ``# quantity:`` line.
    columns : mapping of str to str, optional
        Column map (:func:`parse_column_map`); without it the header must be a recognisable single channel.
    units_row : list of str, optional
        Units of a second header row, one per column.
    auto_channel : str, optional
        Name ``OUT/IN`` of a recognised single channel (default :data:`DEFAULT_CHANNEL`).

    Returns
    -------
    Frf
        Frequencies in Hz; ``meta["columns"]`` records the columns used as ``NAME=COLUMN; ...`` and
        ``meta["format"]`` is :data:`RECOGNISED_FORMAT` or :data:`MAPPED_FORMAT`.
    """
    name = table.name
    cols = _columns(table, units_row)
    if columns is not None:
        cmap = parse_column_map(columns)
        if cmap.freq_column is None:
            freq_key, freq_col = _auto_freq(cols, name)
        else:
            freq_col = _find_column(cmap.freq_column, cols, cmap.freq_key, name)
            freq_key = cmap.freq_key
            if freq_key == "freq":
                freq_key = _freq_key_of(freq_col, name)
            else:
                _check_unit(freq_col, freq_key, freq_key, name)
        groups: dict[str, dict[str, _Column]] = {}
        for channel, kinds in cmap.channels.items():
            for kind, spec in kinds.items():
                col = _find_column(spec, cols, f"{channel}.{kind}", name)
                _check_unit(col, kind, f"{channel}.{kind}", name)
                groups.setdefault(channel, {})[kind] = col
    else:
        channel = (DEFAULT_CHANNEL if auto_channel is None
                   else check_channel_name(auto_channel, parameter="read_frf.auto_channel"))
        freq_key, freq_col = _auto_freq(cols, name)
        groups = {channel: _auto_channel(cols, channel, name)}
    used = [(freq_key, freq_col)] + [(f"{ch}.{k}", c) for ch, kinds in groups.items() for k, c in kinds.items()]
    seen: dict[int, str] = {}
    for key, col in used:
        if col.index in seen:
            raise UsageError(f"{name}: columns=: column {col.label!r} is mapped twice ({seen[col.index]}, {key})",
                             parameter=MAP_PARAMETER)
        seen[col.index] = key
    f = table.data[:, freq_col.index] * FREQ_KEYS[freq_key]
    index_groups = {ch: {k: c.index for k, c in kinds.items()} for ch, kinds in groups.items()}
    channels = {ch: _channel_response(ch, cols_, table) for ch, cols_ in index_groups.items()}
    coherence = {ch: _channel_coherence(ch, cols_["coh"], table)
                 for ch, cols_ in index_groups.items() if "coh" in cols_}
    meta = {"format": RECOGNISED_FORMAT if columns is None else MAPPED_FORMAT,
            "columns": "; ".join(f"{key}={col.cell}" for key, col in used)}
    if columns is None and auto_channel is None:
        meta["channel_named"] = CHANNEL_DEFAULTED
    ignored = [c.label for c in cols if c.index not in seen]
    if ignored:
        meta["columns_ignored"] = "; ".join(ignored)
    return _assemble(table, f, channels, coherence, quantity, meta)


def _delimiter(line: str) -> str:
    counts = [line.count(d) for d in (",", ";", "\t")]
    return (",", ";", "\t")[int(np.argmax(counts))] if max(counts) > 0 else ","


def _cells(line: str, sep: str) -> list[str]:
    try:
        return [c.strip() for c in next(csv.reader([line], delimiter=sep))]
    except csv.Error:  # a stray carriage return inside the line: parse_table reports the file
        return [c.strip() for c in line.split(sep)]


def _numberish(cell: str) -> bool:
    for text in (cell, cell.replace(",", ".")):
        try:
            float(text)
        except ValueError:
            continue
        return True
    return False


def _head_rows(data: str | bytes, skip_rows: int, n: int = 2) -> list[tuple[str, int]]:
    """The first ``n`` lines after ``skip_rows`` that are neither blank nor ``#`` comments: ``(text, offset)``."""
    is_bytes = isinstance(data, bytes)
    nl = b"\n" if is_bytes else "\n"
    pos = 3 if is_bytes and data.startswith(b"\xef\xbb\xbf") else 0
    out: list[tuple[str, int]] = []
    k = 0
    while pos < len(data) and len(out) < n:
        j = data.find(nl, pos)
        end = len(data) if j < 0 else j
        raw = data[pos:end]
        if is_bytes:
            try:
                line = raw.decode("utf-8")
            except UnicodeDecodeError:
                line = raw.decode("latin-1")
        else:
            line = raw
        line = line.rstrip("\r")
        s = line.strip()
        if k >= skip_rows and s and not s.startswith("#"):
            out.append((line, pos))
        k += 1
        pos = end + 1
    return out


@dataclass(frozen=True)
class _Head:
    """What the header row says before the table is parsed."""

    native: bool
    units_row: list[str] | None
    data: str | bytes


def _inspect_head(data: str | bytes, skip_rows: int) -> _Head:
    """Whether the header is feedtune's own, and a second header row of units (commented out of ``data``)."""
    nl, cr = (b"\n", b"\r") if isinstance(data, bytes) else ("\n", "\r")
    if cr in data[:1 << 16] and nl not in data[:1 << 16]:  # old Mac line endings, as parse_table reads them
        data = data.replace(cr, nl)
    rows = _head_rows(data, skip_rows)
    if not rows or len(rows[0][0]) > MAX_HEADER_CHARS:
        return _Head(True, None, data)  # parse_table reports it
    sep = _delimiter(rows[0][0])
    header = _cells(rows[0][0], sep)
    if any(c.lower() == "freq_hz" or _NATIVE_COLUMN_RE.match(c) for c in header):
        return _Head(True, None, data)
    if all(_numberish(c) for c in header if c) or len(rows) < 2:
        return _Head(False, None, data)
    line, offset = rows[1]
    units = _cells(line, sep)
    given = [u for u in units if u]
    if given and len(units) <= len(header) + 1 and len(line) <= MAX_HEADER_CHARS \
            and not any(_numberish(u) for u in given) and all(len(u) <= _UNITS_ROW_MAX_CHARS for u in given):
        units = [u.strip("[]() ") for u in units]
        mark = b"#" if isinstance(data, bytes) else "#"
        return _Head(False, units, data[:offset] + mark + data[offset:])  # line numbers stay those of the file
    return _Head(False, None, data)


def read_frf_csv(
    source: str | os.PathLike[str] | IO[str],
    *,
    quantity: str | None = None,
    columns: Mapping[str, str] | None = None,
    skip_rows: int = 0,
    auto_channel: str | None = None,
) -> Frf:
    """Read an FRF from a CSV file: feedtune's own header, a vendor header, or any header with a column map.

    Parameters
    ----------
    source : path-like or open text file
        The CSV file.
    quantity : {"position", "velocity", "acceleration"}, optional
        What the outputs measure; overrides the file's ``# quantity:`` line (default position).
    columns : mapping of str to str, optional
        Column map ``{NAME: COLUMN}`` (CLI ``--frf-map NAME=COLUMN``): NAME ``freq`` (unit from the header, else
        Hz), ``freq_hz``, ``freq_khz``, ``freq_rad_s`` or ``OUT/IN.KIND`` with KIND one of :data:`SUFFIXES`.
        Only the mapped channels are read; without ``freq`` the frequency column is found as without a map.
    skip_rows : int
        Lines to skip before the header row (vendor preambles).
    auto_channel : str, optional
        Channel name ``OUT/IN`` given to a recognised single-channel vendor header (default ``x1/u``).

    Returns
    -------
    Frf
        Response in ``output_unit / input_unit`` (default rad/V), frequencies in Hz. A vendor or mapped header
        records the columns used in ``meta["columns"]`` (and unused ones in ``meta["columns_ignored"]``).

    Raises
    ------
    DataError
        The file is missing, unreadable or malformed (the message names the file, line and column), or its
        header cannot be read without a column map.
    UsageError
        A malformed column map or channel name, or ``auto_channel`` for a file that names its channels.
    """
    if isinstance(skip_rows, bool) or not isinstance(skip_rows, int) or skip_rows < 0:
        raise UsageError(f"skip_rows expects an integer >= 0, got {skip_rows!r}", parameter="read_frf.skip_rows")
    if columns is not None:
        parse_column_map(columns)  # option errors before the file is read
        if auto_channel is not None:
            raise UsageError("columns= names the channels itself; drop auto_channel",
                             parameter=("read_frf.auto_channel", MAP_PARAMETER))
    if auto_channel is not None:
        check_channel_name(auto_channel, parameter="read_frf.auto_channel")
    text, name = read_table_data(source, "CSV")
    first = _head_rows(text, skip_rows, 1)
    if first and columns is None:
        from .psd_csv import is_klipper_header, not_a_spectrum_reader

        if is_klipper_header(_cells(first[0][0], _delimiter(first[0][0]))):
            raise not_a_spectrum_reader(name, "an FRF")
    head = _inspect_head(text, skip_rows)
    try:
        table = parse_table(head.data, name, skip_rows=skip_rows, require_header=True)
    except DataError as exc:
        if head.native or "pass skip_rows" not in str(exc):
            raise
        raise DataError(str(exc).replace("pass skip_rows", "pass skip_rows=N"),
                        parameter="read_frf.skip_rows") from None
    if head.native and columns is None:
        if auto_channel is not None:
            raise UsageError(f"{name}: auto_channel names the channel of a vendor header; this file's "
                             "header names its channels (OUT/IN.KIND columns)", parameter="read_frf.auto_channel")
        return frf_from_table(table, quantity)
    return frf_from_vendor_table(table, quantity, columns=columns, units_row=head.units_row,
                                 auto_channel=auto_channel)


def _single_line(value: object) -> str:
    return " ".join(str(value).split())


def frf_to_csv_text(frf: Frf) -> str:
    """The CSV text of an FRF: metadata lines, header, re/im (+ coh) columns with full float precision."""
    lines = ["# feedtune FRF", f"# quantity: {frf.quantity}"]
    lines += [f"# input: {i} [{frf.input_unit}]" for i in frf.inputs]
    lines += [f"# output: {o} [{frf.output_unit}]" for o in frf.outputs]
    lines.append(f"# source: {_single_line(frf.source)}")
    for key, value in frf.meta.items():
        if key not in _NOT_WRITTEN_META and re.fullmatch(r"[A-Za-z_]\w*", key):
            lines.append(f"# {key}: {_single_line(value)}")
    cols: dict[str, np.ndarray] = {"freq_hz": frf.freq_hz}
    for o_idx, o in enumerate(frf.outputs):
        for i_idx, i in enumerate(frf.inputs):
            h = frf.response[o_idx, i_idx]
            cols[f"{o}/{i}.re"] = h.real
            cols[f"{o}/{i}.im"] = h.imag
            if frf.coherence is not None and np.all(np.isfinite(frf.coherence[o_idx, i_idx])):
                cols[f"{o}/{i}.coh"] = frf.coherence[o_idx, i_idx]
    for key in cols:
        if "," in key or '"' in key:
            raise DataError(f"{frf.source}: channel name in {key!r} contains a comma or quote; rename it")
    body = csv_rows(list(cols.values()))
    return "\n".join([*lines, ",".join(cols)]) + "\n" + body


def write_frf_csv(frf: Frf, path: str | os.PathLike[str], *, force: bool = False) -> None:
    """Write an FRF as CSV (re/im columns, full precision) atomically.

    Parameters
    ----------
    frf : Frf
        The response to write.
    path : path-like
        Destination ``.csv`` file.
    force : bool
        Replace an existing file.
    """
    atomic_write_text(path, frf_to_csv_text(frf), force=force)
