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
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from typing import IO

import numpy as np

from ..errors import DataError
from ..frf import Frf, normalize_quantity
from ._table import TextTable, csv_rows, parse_table, read_table_data
from .atomic import atomic_write_text

SUFFIXES = ("re", "im", "mag", "mag_db", "phase_deg", "phase_rad", "coh")
_UNIT_RE = re.compile(r"^(.*?)\s*\[(.*)\]\s*$")
_RESERVED_META = {"quantity", "input", "output", "input_unit", "output_unit"}


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
                            f"with SUFFIX one of {', '.join(SUFFIXES)}")
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
        raise DataError(f"{table.name}: line {table.line_number(i)}, column '{channel}.coh': "
                        f"coherence {coh[i]:g} is outside 0..1")
    return coh


def frf_from_table(table: TextTable, quantity: str | None = None) -> Frf:
    """Build an :class:`Frf` from a parsed CSV table (header ``freq_hz``, channel columns)."""
    name = table.name
    lower = [c.lower() for c in table.columns]
    if "freq_hz" not in lower:
        raise DataError(f"{name}: no 'freq_hz' column; the header has {', '.join(table.columns)}")
    f = table.data[:, lower.index("freq_hz")]
    groups = _group_columns(table.columns, name)
    if not groups:
        raise DataError(f"{name}: no channel columns (OUT/IN.re, OUT/IN.im ...) besides freq_hz")
    channels = {ch: _channel_response(ch, cols, table) for ch, cols in groups.items()}
    coherence = {ch: _channel_coherence(ch, cols["coh"], table)
                 for ch, cols in groups.items() if "coh" in cols}
    q_meta = table.metadata.get("quantity", ["position"])[-1]
    q = normalize_quantity(quantity if quantity is not None else q_meta, f"{name}: quantity")
    input_unit, output_unit = frf_units(table.metadata, name)
    meta = {"source": name, "format": "csv"}
    for key, values in table.metadata.items():
        if key not in _RESERVED_META:
            meta["origin" if key == "source" else key] = "; ".join(values)
    return Frf.from_channels(f, channels, coherence=coherence or None, quantity=q, input_unit=input_unit,
                             output_unit=output_unit, meta=meta)


def read_frf_csv(source: str | os.PathLike[str] | IO[str], *, quantity: str | None = None) -> Frf:
    """Read an FRF from a CSV file.

    Parameters
    ----------
    source : path-like or open text file
        The CSV file.
    quantity : {"position", "velocity", "acceleration"}, optional
        What the outputs measure; overrides the file's ``# quantity:`` line (default position).

    Returns
    -------
    Frf
        Response in ``output_unit / input_unit`` (default rad/V), frequencies in Hz.

    Raises
    ------
    DataError
        The file is missing, unreadable or malformed (the message names the file, line and column).
    """
    text, name = read_table_data(source, "CSV")
    table = parse_table(text, name, require_header=True)
    return frf_from_table(table, quantity)


def _single_line(value: object) -> str:
    return " ".join(str(value).split())


def frf_to_csv_text(frf: Frf) -> str:
    """The CSV text of an FRF: metadata lines, header, re/im (+ coh) columns with full float precision."""
    lines = ["# feedtune FRF", f"# quantity: {frf.quantity}"]
    lines += [f"# input: {i} [{frf.input_unit}]" for i in frf.inputs]
    lines += [f"# output: {o} [{frf.output_unit}]" for o in frf.outputs]
    lines.append(f"# source: {_single_line(frf.source)}")
    for key, value in frf.meta.items():
        if key not in {"source", "format", "origin", *_RESERVED_META} and re.fullmatch(r"[A-Za-z_]\w*", key):
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
