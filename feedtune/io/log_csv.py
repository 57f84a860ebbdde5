"""Logs as CSV text: reading (any vendor layout with ``skip_rows``) and writing (feedtune's own layout).

Layout written by :func:`write_log_csv` and read back exactly by :func:`~feedtune.io.read_log`::

    # feedtune log
    # source: bench run 3
    t [s],x1 [rad],u [V]
    0.0,0.0,0.1
    0.001,1.2e-06,0.1

Units come from ``NAME [UNIT]`` headers or ``# unit: NAME = UNIT`` lines. Files without a header row get
the column names ``col0``, ``col1``...
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
from .log_read import RawLog

_HEADER_UNIT_RE = re.compile(r"^(.*?)\s*[\[(]([^\[\]()]*)[\])]\s*$")
_UNIT_META_RE = re.compile(r"^\s*([^=]+?)\s*=\s*(.*?)\s*$")


_UNIT_TOKENS = frozenset("""s ms us µs ns min h m mm um µm nm km rad mrad urad deg ° rev rpm rps Hz kHz V mV kV A mA N
kN mN Nm W kW g kg bar mbar Pa kPa MPa % pls pulse pulses count counts cnt inc K degC""".split())
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
    if isinstance(source, (str, os.PathLike)):
        table = read_table_file(source, "CSV", skip_rows=skip_rows, require_header=False)
    else:
        text, name = read_table_data(source, "CSV")
        table = parse_table(text, name, skip_rows=skip_rows, require_header=False)
    name = table.name
    columns: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    aliases: dict[str, str] = {}
    for j, header in enumerate(table.columns):
        sig, unit = _split_header(header)
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

    def resolve(spec: str) -> np.ndarray:
        if spec in aliases:
            return columns[aliases[spec]]
        raise DataError(f"{name}: no column {spec!r}; columns: {', '.join(columns)}")

    return RawLog(name, columns, units, meta, resolve, aliases={k: v for k, v in aliases.items() if k != v})


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
