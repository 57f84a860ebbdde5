"""Shared parsing of numeric text tables (FRF and log CSV files).

A table file has optional leading lines to skip (vendor preambles), ``#`` comment lines whose leading
``# key: value`` lines are metadata, one header row of column names (optional for logs), then numeric rows.
Numbers are parsed with pandas (C engine); errors name the file, the line number and the column.
"""

from __future__ import annotations

import csv
import io
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np

from ..errors import DataError

_META_RE = re.compile(r"^#\s*([A-Za-z_][A-Za-z0-9_ .-]*?)\s*:\s*(.*?)\s*$")
_DELIMITERS = (",", ";", "\t")


@dataclass(frozen=True)
class TextTable:
    """A parsed numeric table.

    Attributes
    ----------
    name : str
        File name used in messages.
    metadata : dict of str to list of str
        ``# key: value`` lines before the header (keys lower-case, values in file order).
    columns : list of str
        Column names from the header row (``col0``, ``col1``... when the file has none).
    data : ndarray, shape (n_rows, n_columns)
        Numbers as float.
    has_header : bool
        Whether the file had a header row.
    """

    name: str
    metadata: dict[str, list[str]]
    columns: list[str]
    data: np.ndarray
    has_header: bool = True
    comments: list[str] = field(default_factory=list)
    text: str = field(default="", repr=False)
    first_data_index: int = 0

    @property
    def lines(self) -> list[str]:
        """The file's lines (split on demand: only error messages need them)."""
        return self.text.splitlines()

    def column(self, name: str) -> np.ndarray:
        """One column as a float vector."""
        return self.data[:, self.columns.index(name)]

    def line_number(self, row: int) -> int:
        """1-based file line number of data row ``row`` (0-based), for messages."""
        return int(_data_line_numbers(self.lines, self.first_data_index)[row])


def source_name(source: str | os.PathLike[str] | IO[str]) -> str:
    """Name of a path or an open file for messages."""
    if isinstance(source, (str, os.PathLike)):
        return str(source)
    return str(getattr(source, "name", "<stream>"))


def read_text(source: str | os.PathLike[str] | IO[str], what: str = "text") -> tuple[str, str]:
    """Return ``(text, name)`` of a path or an open text file; unreadable input is a :class:`DataError`.

    Parameters
    ----------
    source : path-like or file object
        The file.
    what : str
        Kind of file expected, for messages (``"CSV"``).
    """
    name = source_name(source)
    if isinstance(source, (str, os.PathLike)):
        raw = read_bytes(source)
    else:
        try:
            content = source.read()
        except (OSError, UnicodeDecodeError) as exc:
            raise DataError(f"{name}: cannot read the file ({exc})") from None
        raw = content if isinstance(content, bytes) else None
        if raw is None:
            text = str(content)
            if "\x00" in text:
                raise DataError(f"{name}: binary data, not a {what} text file")
            return text.lstrip("\ufeff"), name
    if b"\x00" in raw:
        raise DataError(f"{name}: binary data, not a {what} text file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return text, name


def read_bytes(path: str | os.PathLike[str]) -> bytes:
    """Read a whole file; missing files, folders and permission problems are a :class:`DataError`."""
    p = Path(path)
    try:
        return p.read_bytes()
    except FileNotFoundError:
        raise DataError(f"{p}: file not found") from None
    except IsADirectoryError:
        raise DataError(f"{p} is a folder, not a file") from None
    except PermissionError:
        raise DataError(f"{p}: permission denied") from None
    except OSError as exc:
        raise DataError(f"{p}: cannot read the file ({exc.strerror or exc})") from None


def check_readable_file(path: str | os.PathLike[str]) -> Path:
    """Return ``path`` as a Path after checking that it is an existing file (else :class:`DataError`)."""
    p = Path(path)
    if not p.exists():
        raise DataError(f"{p}: file not found")
    if p.is_dir():
        raise DataError(f"{p} is a folder, not a file")
    if not os.access(p, os.R_OK):
        raise DataError(f"{p}: permission denied")
    return p


def _is_data_line(line: str) -> bool:
    s = line.strip()
    return bool(s) and not s.startswith("#")


def _split_cells(line: str, sep: str) -> list[str]:
    return [c.strip() for c in next(csv.reader([line], delimiter=sep))]


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _guess_delimiter(line: str) -> str:
    counts = [line.count(d) for d in _DELIMITERS]
    return _DELIMITERS[int(np.argmax(counts))] if max(counts) > 0 else ","


def _unique_names(names: list[str]) -> list[str]:
    """Make column names unique the way pandas does (``a``, ``a.1``, ``a.2``); empty names become ``colK``."""
    out: list[str] = []
    seen: dict[str, int] = {}
    for k, n in enumerate(names):
        base = n or f"col{k}"
        name = base
        while name in seen:
            seen[base] += 1
            name = f"{base}.{seen[base]}"
        seen.setdefault(name, 0)
        out.append(name)
    return out


def parse_table(
    text: str, name: str, *, skip_rows: int = 0, require_header: bool = True, what: str = "CSV"
) -> TextTable:
    """Parse a numeric table from ``text`` (see module docstring).

    Parameters
    ----------
    text : str
        File content.
    name : str
        File name for messages.
    skip_rows : int
        Lines to skip at the top before anything else (vendor preambles).
    require_header : bool
        When true, a first row of numbers is an error; otherwise columns are named ``col0``, ``col1``...
    what : str
        Kind of file, for messages.
    """
    if skip_rows < 0:
        raise DataError(f"{name}: skip_rows must be >= 0, got {skip_rows}")
    metadata: dict[str, list[str]] = {}
    comments: list[str] = []
    head = _lines_with_offsets(text)
    k, line, offset = -1, None, len(text)
    for k, item in enumerate(head):
        line, offset = item
        if k < skip_rows:
            continue
        if _is_data_line(line):
            break
        s = line.strip()
        m = _META_RE.match(s)
        if m:
            metadata.setdefault(m.group(1).strip().lower(), []).append(m.group(2))
        elif s:
            comments.append(s.lstrip("#").strip())
    else:
        raise DataError(f"{name}: empty {what} file (no header and no data rows)")
    sep = _guess_delimiter(line)
    cells = _split_cells(line, sep)
    if all(_is_number(c) for c in cells if c):
        if require_header:
            raise DataError(f"{name}: line {k + 1}: expected a header row of column names, found numbers")
        columns = [f"col{j}" for j in range(len(cells))]
        has_header, first, body = False, k, text[offset:]
    else:
        columns = _unique_names(cells)
        next_line = text.find("\n", offset)
        has_header, first, body = True, k + 1, ("" if next_line < 0 else text[next_line + 1:])
    data = _parse_numbers(body, text, first, columns, sep, name)
    return TextTable(name, metadata, columns, data, has_header, comments, text, first)


def _lines_with_offsets(text: str):
    """``(line, offset)`` of each line of ``text`` in turn, without splitting the whole text."""
    pos, n = 0, len(text)
    while pos < n:
        j = text.find("\n", pos)
        end = n if j < 0 else j
        yield text[pos:end].rstrip("\r"), pos
        pos = end + 1


def _data_line_numbers(lines: list[str], first: int) -> np.ndarray:
    """1-based file line numbers of the data rows starting at index ``first`` (only used for messages)."""
    return np.array([j + 1 for j in range(first, len(lines)) if _is_data_line(lines[j])], dtype=int)


def _parse_numbers(body: str, text: str, first: int, columns: list[str], sep: str, name: str) -> np.ndarray:
    import pandas as pd

    if not any(_is_data_line(line) for line, _ in _lines_with_offsets(body)):
        raise DataError(f"{name}: no data rows below the header")
    lines = _LazyLines(text)
    df = _read_frame(body, sep, len(columns), ".", lines, first, name)
    if sep == ";" and any(df[c].dtype.kind not in "biuf" for c in df.columns):
        comma = _read_frame(body, sep, len(columns), ",", lines, first, name)
        if all(comma[c].dtype.kind in "biuf" for c in comma.columns):
            df = comma  # semicolon-separated file with decimal commas
    if len(df) == 0:
        raise DataError(f"{name}: no data rows below the header")
    values = np.empty(df.shape, dtype=float)
    for j in range(df.shape[1]):
        col = df.iloc[:, j]
        if col.dtype.kind in "biuf":
            values[:, j] = col.to_numpy(dtype=float)
            continue
        num = pd.to_numeric(col, errors="coerce")
        bad = num.isna().to_numpy() & col.notna().to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            line = _data_line_numbers(lines.get(), first)[i]
            cell = str(col.iloc[i])
            hint = "; pass skip_rows to skip extra header lines" if i == 0 else ""
            raise DataError(f"{name}: line {line}, column {columns[j]!r}: {cell!r} is not a number{hint}")
        values[:, j] = num.to_numpy(dtype=float)
    finite = np.isfinite(values)
    if not finite.all():
        i, j = (int(v) for v in np.argwhere(~finite)[0])
        line = _data_line_numbers(lines.get(), first)[i]
        what = "empty or NaN cell" if np.isnan(values[i, j]) else "infinite value"
        raise DataError(f"{name}: line {line}, column {columns[j]!r}: {what} (NaN/inf are not accepted)")
    return values


class _LazyLines:
    """The lines of a text, split only when an error message needs a line number."""

    def __init__(self, text: str) -> None:
        self._text = text
        self._lines: list[str] | None = None

    def get(self) -> list[str]:
        if self._lines is None:
            self._lines = self._text.splitlines()
        return self._lines


def _read_frame(body: str, sep: str, n_columns: int, decimal: str, lines: _LazyLines, first: int, name: str):
    import pandas as pd

    try:
        return pd.read_csv(io.StringIO(body), sep=sep, header=None, names=range(n_columns), comment="#",
                           skip_blank_lines=True, skipinitialspace=True, index_col=False, engine="c",
                           low_memory=False, decimal=decimal)
    except pd.errors.EmptyDataError:
        raise DataError(f"{name}: no data rows below the header") from None
    except (pd.errors.ParserError, ValueError):
        raise DataError(_field_count_message(lines.get(), first, n_columns, sep, name)) from None


def _field_count_message(lines: list[str], first: int, n_columns: int, sep: str, name: str) -> str:
    for j in range(first, len(lines)):
        if _is_data_line(lines[j]):
            cells = _split_cells(lines[j].split("#", 1)[0], sep)
            n = len(cells) - (1 if cells and cells[-1] == "" else 0)
            if n > n_columns:
                return f"{name}: line {j + 1}: {n} fields, but the header has {n_columns} columns"
    return f"{name}: malformed rows below the header (check the delimiter and quoting)"
