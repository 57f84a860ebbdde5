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
    text: str | bytes = field(default="", repr=False)
    first_data_index: int = 0

    @property
    def lines(self) -> list[str]:
        """The file's lines (decoded and split on demand: only error messages need them)."""
        return _decoded(self.text, None).splitlines()

    def column(self, name: str) -> np.ndarray:
        """One column as a float vector."""
        return self.data[:, self.columns.index(name)]

    def line_number(self, row: int) -> int:
        """1-based file line number of data row ``row`` (0-based), for messages."""
        return int(_data_line_numbers(self.lines, self.first_data_index)[row])


CSV_CHUNK_ROWS = 65536
"""Rows formatted per chunk by :func:`csv_rows` (bounds the temporary memory)."""


def csv_rows(columns) -> str:
    """Rows of comma-separated numbers, one line per row, in the text ``pandas.DataFrame.to_csv`` writes.

    Floats are written as ``repr`` (the shortest text that reads back to the same value; float32 columns in their
    own precision), integers and booleans as ``str``, NaN as an empty field. One ``%`` formatting per chunk of
    :data:`CSV_CHUNK_ROWS` rows instead of a writer per row: about 3x ``to_csv``.

    Parameters
    ----------
    columns : sequence of ndarray
        Equal-length 1-D columns.
    """
    cols = [np.asarray(c) for c in columns]
    n, k = (len(cols[0]), len(cols)) if cols else (0, 0)
    if n == 0 or k == 0:
        return ""
    cells = np.empty((n, k), dtype=object)
    for j, c in enumerate(cols):
        vals = c.astype(str).tolist() if c.dtype.kind == "f" and c.dtype != np.float64 else c.tolist()
        if c.dtype.kind == "f" and np.isnan(c).any():
            vals = ["" if np.isnan(x) else v for x, v in zip(c.tolist(), vals, strict=True)]
        cells[:, j] = vals
    row = ",".join(["%s"] * k) + "\n"
    out = []
    for a in range(0, n, CSV_CHUNK_ROWS):
        part = cells[a:a + CSV_CHUNK_ROWS]
        out.append((row * part.shape[0]) % tuple(part.ravel().tolist()))
    return "".join(out)


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


def read_table_data(source: str | os.PathLike[str] | IO[str], what: str = "text") -> tuple[bytes | str, str]:
    """``(data, name)`` of a table file for :func:`parse_table`: the raw bytes of a path (not decoded: the numbers
    go to the parser as bytes, without a text copy of the file), the text of an open text file."""
    if not isinstance(source, (str, os.PathLike)):
        return read_text(source, what)
    name = source_name(source)
    raw = read_bytes(source)
    if b"\x00" in raw[:1 << 16]:  # a binary file shows it at once; later NULs fail in the number parser
        raise DataError(f"{name}: binary data, not a {what} text file")
    return raw, name


MAX_HEADER_CHARS = 100_000
"""Longest first row (header or numbers) accepted [characters]."""


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
    text: str | bytes, name: str, *, skip_rows: int = 0, require_header: bool = True, what: str = "CSV"
) -> TextTable:
    """Parse a numeric table from ``text`` (see module docstring).

    Parameters
    ----------
    text : str or bytes
        File content; bytes (UTF-8 with or without BOM, else Latin-1) are parsed without decoding the body.
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
    nl, cr = (b"\n", b"\r") if isinstance(text, bytes) else ("\n", "\r")
    if cr in text[:1 << 16] and nl not in text[:1 << 16]:  # old Mac line endings (CR only)
        text = text.replace(cr, nl)
    encoding = _encoding_of(text)
    metadata: dict[str, list[str]] = {}
    comments: list[str] = []
    head = _lines_with_offsets(text, encoding)
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
    if len(line) > MAX_HEADER_CHARS:
        raise DataError(f"{name}: line {k + 1} is {len(line):,} characters long; expected a header row of column "
                        f"names or a row of numbers (at most {MAX_HEADER_CHARS:,} characters)")
    sep = _guess_delimiter(line)
    cells = _split_cells(line, sep)
    if all(_is_number(c) for c in cells if c):
        if require_header:
            raise DataError(f"{name}: line {k + 1}: expected a header row of column names, found numbers")
        columns = [f"col{j}" for j in range(len(cells))]
        has_header, first, start = False, k, offset
    else:
        columns = _unique_names(cells)
        next_line = text.find(b"\n" if isinstance(text, bytes) else "\n", offset)
        has_header, first, start = True, k + 1, (len(text) if next_line < 0 else next_line + 1)
    data = _parse_numbers(_Body(text, start, encoding), text, first, columns, sep, name)
    return TextTable(name, metadata, columns, data, has_header, comments, text, first)


def _encoding_of(text: str | bytes) -> str | None:
    """``utf-8-sig`` for bytes that decode as UTF-8 (checked on a sample: the parser rechecks the rest), else
    ``latin-1``; None for text."""
    if not isinstance(text, bytes):
        return None
    try:
        text[:1 << 16].decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        if exc.start < (1 << 16) - 4:  # not just a character cut at the end of the sample
            return "latin-1"
    return "utf-8-sig"


def _decoded(text: str | bytes, encoding: str | None) -> str:
    """``text`` as str (decoded lazily only by callers that need it: error messages)."""
    if not isinstance(text, bytes):
        return text
    try:
        return text.decode(encoding or "utf-8-sig")
    except UnicodeDecodeError:
        return text.decode("latin-1")


@dataclass(frozen=True)
class _Body:
    """The data rows: ``text[start:]`` without copying it."""

    text: str | bytes
    start: int
    encoding: str | None

    def lines(self):
        return _lines_with_offsets(self.text, self.encoding, self.start)

    def handle(self) -> IO:
        if isinstance(self.text, bytes):
            h = io.BytesIO(self.text)  # shares the bytes
            h.seek(self.start)
            return h
        return io.StringIO(self.text[self.start:])


def _lines_with_offsets(text: str | bytes, encoding: str | None = None, pos: int = 0):
    """``(line, offset)`` of each line of ``text`` (decoded when bytes) from ``pos``, without splitting it all."""
    nl = b"\n" if isinstance(text, bytes) else "\n"
    n = len(text)
    if isinstance(text, bytes) and pos == 0 and text.startswith(b"\xef\xbb\xbf"):
        pos = 3
    while pos < n:
        j = text.find(nl, pos)
        end = n if j < 0 else j
        line = text[pos:end]
        if isinstance(line, bytes):
            try:
                line = line.decode("utf-8" if encoding != "latin-1" else "latin-1")
            except UnicodeDecodeError:
                line = line.decode("latin-1")
        yield line.rstrip("\r"), pos
        pos = end + 1


def _data_line_numbers(lines: list[str], first: int) -> np.ndarray:
    """1-based file line numbers of the data rows starting at index ``first`` (only used for messages)."""
    return np.array([j + 1 for j in range(first, len(lines)) if _is_data_line(lines[j])], dtype=int)


def _parse_numbers(body: _Body, text: str | bytes, first: int, columns: list[str], sep: str,
                   name: str) -> np.ndarray:
    import pandas as pd

    if not any(_is_data_line(line) for line, _ in body.lines()):
        raise DataError(f"{name}: no data rows below the header")
    lines = _LazyLines(text, body.encoding)
    df = _read_frame(body, sep, len(columns), ".", lines, first, name)
    if sep == ";" and any(df[c].dtype.kind not in "biuf" for c in df.columns):
        comma = _read_frame(body, sep, len(columns), ",", lines, first, name)
        if all(comma[c].dtype.kind in "biuf" for c in comma.columns):
            df = comma  # semicolon-separated file with decimal commas
    if len(df) == 0:
        raise DataError(f"{name}: no data rows below the header")
    values = np.empty(df.shape, dtype=float, order="F")  # columns contiguous: filled and used by column
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
            cell = str(col.iloc[i]).strip()
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

    def __init__(self, text: str | bytes, encoding: str | None = None) -> None:
        self._text = text
        self._encoding = encoding
        self._lines: list[str] | None = None

    def get(self) -> list[str]:
        if self._lines is None:
            self._lines = _decoded(self._text, self._encoding).splitlines()
        return self._lines


def _read_frame(body: _Body, sep: str, n_columns: int, decimal: str, lines: _LazyLines, first: int, name: str):
    import pandas as pd

    enc = None if body.encoding is None else ("latin-1" if body.encoding == "latin-1" else "utf-8")
    try:
        try:
            return pd.read_csv(body.handle(), sep=sep, header=None, names=range(n_columns), comment="#",
                               skip_blank_lines=True, index_col=False, engine="c", decimal=decimal, encoding=enc)
        except UnicodeDecodeError:  # a Latin-1 character beyond the sample that chose UTF-8
            return pd.read_csv(body.handle(), sep=sep, header=None, names=range(n_columns), comment="#",
                               skip_blank_lines=True, index_col=False, engine="c", decimal=decimal, encoding="latin-1")
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
