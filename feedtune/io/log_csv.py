"""Logs as CSV text: reading (any vendor layout with ``skip_rows``) and writing (feedtune's own layout).

Layout written by :func:`write_log_csv` and read back exactly by :func:`~feedtune.io.read_log`::

    # feedtune log
    # source: bench run 3
    t [s],x1 [rad],u [V]
    0.0,0.0,0.1
    0.001,1.2e-06,0.1

Units come from ``NAME [UNIT]`` headers, a units row under them or ``# unit: NAME = UNIT`` lines. Files without a
header row get the column names ``col0``, ``col1``...

Loggers' own layouts read as they are (:mod:`feedtune.io._table`): ``%`` comments, a header commented out above the
numbers (``%timestep (8Hz),voltage`` then ``%[#],[V]``), rows ending in ``;``, rows of NaN only and rows after a tick
counter stopped (dropped and counted in ``meta["dropped_rows"]``). A time column that counts ticks
(:func:`tick_time_base`) becomes the time base at the tick rate the file states (``meta["time_base"]``). What this read
did beyond the options is also in ``meta["read_notes"]`` (a tuple: not written back by :func:`write_log_csv`, so a
converted file does not report it again).
"""

from __future__ import annotations

import os
import re
from typing import IO

import numpy as np

from ..errors import DataError
from ..log import Log
from ._table import parse_table, read_table_data, read_table_file
from .atomic import atomic_output
from .csv_text import csv_row_chunks, csv_rows
from .log_read import RawLog, TickTimeBase

_HEADER_UNIT_RE = re.compile(r"^(.*?)\s*[\[(]([^\[\]()]*)[\])]\s*$")
_UNIT_META_RE = re.compile(r"^\s*([^=]+?)\s*=\s*(.*?)\s*$")


_UNIT_TOKENS = frozenset("""s ms us µs ns min h m mm um µm nm km rad mrad urad deg ° rev rpm rps turn turns Hz kHz V mV
kV A mA N kN mN Nm W kW g kg bar mbar Pa kPa MPa % # pls pulse pulses count counts cnt inc tick ticks K degC""".split())
"""Unit symbols a second header row may hold (combined with ``/ * ^``, powers and spaces: ``N m``, ``m/s^2``)."""


def looks_like_unit(cell: str) -> bool:
    """True for a cell of a units row that is a unit (``ms``, ``m/s^2``, ``N m``), not a description
    (``Servo motor speed``, ``Not selected``)."""
    tokens = [t for t in re.split(r"[/*^()\s.·-]+|\d+", cell.strip()) if t]
    return bool(tokens) and all(t in _UNIT_TOKENS for t in tokens)


def _split_header(name: str) -> tuple[str, str | None]:
    """``"x2 [m]"`` -> ``("x2", "m")``; ``"x2"`` -> ``("x2", None)``."""
    m = _HEADER_UNIT_RE.match(name)
    if m and m.group(1).strip():
        return m.group(1).strip(), m.group(2).strip()
    return name.strip(), None


def read_log_csv_raw(source: str | os.PathLike[str] | IO[str], *, skip_rows: int = 0) -> RawLog:
    """Parse a log CSV into a :class:`RawLog` (columns by header name, units from headers/metadata).

    A path is parsed by :func:`~feedtune.io._table.read_table_file` (the numbers straight from the file, without
    its text in memory), an open file by :func:`~feedtune.io._table.parse_table`; both give the same log and the
    same errors.

    Parameters
    ----------
    source : path-like or file object
        The CSV file.
    skip_rows : int
        Lines to skip before anything else (vendor preambles).

    Returns
    -------
    RawLog
        The columns, units and metadata.
    """
    options = {"skip_rows": skip_rows, "require_header": False, "header_from_comments": True, "drop_nan_rows": True}
    if isinstance(source, (str, os.PathLike)):
        table = read_table_file(source, "CSV", **options)
    else:
        text, name = read_table_data(source, "CSV")
        table = parse_table(text, name, **options)
    name = table.name
    from .psd_csv import is_klipper_header, not_a_spectrum_reader

    if is_klipper_header(table.columns):
        raise not_a_spectrum_reader(name, "a log")
    columns: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    aliases: dict[str, str] = {}
    refused: dict[str, str] = {}
    index = {h: j for j, h in enumerate(table.columns)}
    for j, header in enumerate(table.columns):
        sig, unit = _split_header(header)
        base, dot, k = header.rpartition(".")
        if dot and k.isdigit() and base in index:  # the same header twice (made unique by the parser): which one?
            first = _split_header(base)[0]
            refused[first] = (f"is the name of two columns, col{index[base]} and col{j} ({base!r}); which one is "
                              f"{first}?")
        if sig in columns:
            sig = header
        columns[sig] = table.column_vector(j)
        aliases[header] = sig
        aliases[f"col{j}"] = sig
        below = table.unit_row[j].strip() if table.unit_row else ""
        if unit is None and below and looks_like_unit(below):
            unit = below
        elif below and below not in aliases and below not in table.columns:
            aliases[below] = sig  # a description under the name (``Servo motor speed``): --map may use it
        if unit is not None:
            units[sig] = unit
    for line in table.metadata.get("unit", []):
        m = _UNIT_META_RE.match(line)
        if not m:
            raise DataError(f"{name}: '# unit: {line}' must read '# unit: NAME = UNIT'")
        if m.group(1) not in columns:
            raise DataError(f"{name}: '# unit:' line names {m.group(1)!r}, which is not a column")
        units[m.group(1)] = m.group(2)
    meta: dict[str, object] = {"format": "csv"}
    meta.update({("origin" if k == "source" else k): "; ".join(v) for k, v in table.metadata.items()
                 if k != "unit"})
    dropped = []
    if table.dropped_lines:
        dropped.append(f"{len(table.dropped_lines)} row(s) NaN in every column (a failed read) dropped: "
                       f"line(s) {_line_list(table.dropped_lines)}")
    if table.terminator:
        meta["row_terminator"] = table.terminator
    stopped = _stopped_counter(columns)
    if stopped:
        column, n = stopped
        lines = [int(k) for k in table.line_numbers()[-n:]]
        columns = {k: v[:-n] for k, v in columns.items()}
        dropped.append(f"{n} trailing row(s) with {column} 0 (the counter stopped) dropped: line(s) "
                       f"{_line_list(lines)}")
    if dropped:
        meta["dropped_rows"] = "; ".join(dropped)
        meta["read_notes"] = (meta["dropped_rows"],)
    ticks = tick_time_base(name, columns, units, table.comments)

    def resolve(spec: str) -> np.ndarray:
        if spec in aliases:
            return columns[aliases[spec]]
        raise DataError(f"{name}: no column {spec!r}; columns: {', '.join(columns)}")

    return RawLog(name, columns, units, meta, resolve, aliases={k: v for k, v in aliases.items() if k != v},
                  ticks=ticks, refused=refused)


def _stopped_counter(columns: dict[str, np.ndarray]) -> tuple[str, int] | None:
    """``(column, n)`` when the rows end with ``n`` rows whose tick counter (a column named as one, see
    :func:`tick_time_base`) is 0 after it counted up: rows a logger wrote after its run, without a tick."""
    column = next((c for c in columns if _TICK_NAME_RE.match(c)), None)
    if column is None:
        return None
    ticks = columns[column]
    nonzero = np.flatnonzero(ticks != 0)
    if nonzero.size < 2 or nonzero[-1] == ticks.size - 1 or ticks[nonzero[-1]] <= 0:
        return None
    return column, int(ticks.size - 1 - nonzero[-1])


def _line_list(lines, at_most: int = 8) -> str:
    shown = ", ".join(str(n) for n in lines[:at_most])
    return shown + (f" and {len(lines) - at_most} more" if len(lines) > at_most else "")


_TICK_NAME_RE = re.compile(r"^(?:time[ _-]?step|tick|ticks|tick[ _-]?count|counter)s?$", re.IGNORECASE)
_COUNT_UNITS = ("", "#", "-", "1", "tick", "ticks", "count", "counts", "cnt", "samples")
_RATE_RE = re.compile(r"(\d+(?:\.\d+)?)\s*([kKM]?)Hz\b")
_RATE_STATEMENT_RE = re.compile(r"\b(?:time ?step|tick|sample|clock|counter)\w*\b[^\n]*?(\d+(?:\.\d+)?)\s*([kKM]?)Hz\b",
                                re.IGNORECASE)
_PREFIX = {"": 1.0, "k": 1e3, "K": 1e3, "M": 1e6}


def _rate_of(match: re.Match) -> float:
    return float(match.group(1)) * _PREFIX[match.group(2)]


def tick_time_base(name: str, columns: dict[str, np.ndarray], units: dict[str, str],
                   comments: list[str]) -> TickTimeBase | None:
    """The time base of a log whose time column counts controller ticks, at the tick rate the file states.

    A column is a tick counter when it is named ``timestep``, ``tick(s)`` or ``counter`` and its unit is a count
    (``#``, none) or a rate (``timestep (8 kHz)``), and there is no ``t``/``time`` column. Rates are read from the
    column's unit and from comment lines that state one (``Timestep increments at 8kHz``). Of these, the ones that
    give a plausible sample rate (:data:`~feedtune.io.log_read.FS_MIN_HZ` .. ``FS_MAX_HZ``) count: one rate is used
    (and a contradicting implausible statement named in the record); none, or two plausible rates that differ, leave
    the choice to the user (``scale=``), the error of the time check names it.

    Parameters
    ----------
    name : str
        File name, for the record.
    columns, units : dict
        The file's columns and units.
    comments : list of str
        Its comment lines.

    Returns
    -------
    TickTimeBase or None
        The column, the rate [Hz] and where it was stated; None when no tick column, or no usable rate.
    """
    from .log_read import FS_MAX_HZ, FS_MIN_HZ, TIME_NAMES

    if any(c.lower() in TIME_NAMES for c in columns):
        return None
    column = next((c for c in columns if _TICK_NAME_RE.match(c)), None)
    if column is None:
        return None
    unit = units.get(column, "").strip()
    statements = []
    m = _RATE_RE.fullmatch(unit)
    if m:
        statements.append((_rate_of(m), f"the header's {column} ({unit})"))
    elif unit not in _COUNT_UNITS:
        return None
    for line in comments:
        m = _RATE_STATEMENT_RE.search(line)
        if m:
            statements.append((_rate_of(m), f"the comment '{line}'"))
    ticks = columns[column]
    finite = ticks[np.isfinite(ticks)]
    span = float(finite[-1] - finite[0]) if finite.size > 1 else 0.0
    if span <= 0:
        return None
    if not statements:
        return TickTimeBase(column, None, [])
    plausible = [(r, w) for r, w in statements if FS_MIN_HZ <= (finite.size - 1) * r / span <= FS_MAX_HZ]
    if len({r for r, _ in plausible}) != 1:
        return TickTimeBase(column, None, statements)
    rate, where = plausible[0]
    others = [f"{w} says {r:g} Hz, which would sample at {(finite.size - 1) * r / span:.3g} Hz"
              for r, w in statements if r != rate]
    return TickTimeBase(column, rate, statements, where, tuple(others))


def _csv_head(log: Log) -> str:
    """The lines above the numbers: ``# feedtune log``, ``# source:`` and other metadata, the header row."""
    for key in log.signals:
        if any(c in key for c in ',"[]#') or key != key.strip() or not key:
            raise DataError(f"{log.source}: signal name {key!r} cannot be a CSV column name "
                            "(no commas, quotes, brackets or #)")
        if any(c in log.units.get(key, "") for c in ',"[]#\n'):
            raise DataError(f"{log.source}: unit {log.units[key]!r} of {key!r} cannot go in a CSV header")
        if key.lower() in ("t", "time"):
            raise DataError(f"{log.source}: a signal may not be named {key!r}; that name is the time column")
    lines = ["# feedtune log", f"# source: {' '.join(log.source.split())}"]
    for key, value in log.meta.items():
        if key not in ("source", "format", "origin", "unit") and isinstance(value, (str, int, float)) \
                and re.fullmatch(r"[A-Za-z_]\w*", key):
            lines.append(f"# {key}: {' '.join(str(value).split())}")
    header = ["t [s]"] + [f"{k} [{log.units.get(k, '')}]" if log.units.get(k) else k for k in log.signals]
    return "\n".join([*lines, ",".join(header)]) + "\n"


def log_to_csv_text(log: Log) -> str:
    """CSV text of a log: ``# source:`` metadata, header ``t [s],NAME [UNIT],...``, full float precision.

    Parameters
    ----------
    log : Log
        The log.

    Returns
    -------
    str
        The text :func:`write_log_csv` writes.
    """
    return _csv_head(log) + csv_rows([log.t, *log.signals.values()])


def write_log_csv(log: Log, path: str | os.PathLike[str], *, force: bool = False) -> None:
    """Write a log as CSV (time [s] first, full precision) atomically.

    The text is that of :func:`log_to_csv_text`, written a chunk of rows at a time (see
    :func:`~feedtune.io.csv_text.csv_row_chunks`): the text of the whole log is never in memory.

    Parameters
    ----------
    log : Log
        The log.
    path : path-like
        Destination ``.csv`` file.
    force : bool
        Replace an existing file.
    """
    head = _csv_head(log).encode("utf-8")
    with atomic_output(path, force=force) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(head)
            for chunk in csv_row_chunks([log.t, *log.signals.values()]):
                fh.write(chunk)
            fh.flush()
            os.fsync(fh.fileno())
