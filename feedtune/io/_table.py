"""Shared parsing of numeric text tables (FRF and log CSV files).

A table file has optional leading lines to skip (vendor preambles), ``#`` (or MATLAB-style ``%``) comment lines whose
leading ``# key: value`` lines are metadata, one header row of column names (optional for logs), optionally a second
header row under it (units or descriptions: a row with a cell per column and no number), then numeric rows.

What loggers write besides (ODrive's tool, many DAQ scripts), read as it is:

* a header commented out: when the first row is numbers, the comment lines right above it (after the last blank
  line) with as many cells as the rows give the column names, and a units row under them (``%timestep,voltage`` then
  ``%[#],[V]``); only with ``header_from_comments`` (logs);
* a row terminator other than the delimiter (``1.0,2.0;``): taken off every row (:attr:`TextTable.terminator`);
* rows that are NaN in every cell (``nan,nan,nan,nan``: a read that failed) are dropped with ``drop_nan_rows``
  (logs) and their line numbers kept (:attr:`TextTable.dropped_lines`); a NaN among numbers stays an error.
Numbers are parsed with pandas (C engine); errors name the file, the line number and the column. Large files are
parsed straight from the file (:func:`read_table_file`). Writing: :mod:`feedtune.io.csv_text`.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np

from ..errors import DataError

_META_RE = re.compile(r"^[#%]\s*([A-Za-z_][A-Za-z0-9_ .-]*?)\s*:[\s,;]*(.*?)\s*$")
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
    numbers : ndarray, shape (n_rows, n_columns), or tuple of ndarray
        The numbers as parsed: one array, or one float vector per column (:func:`read_table_file`, which does not
        copy them into one array); read them through :attr:`data` or :meth:`column_vector`.
    has_header : bool
        Whether the file had a header row.
    comments : list of str
        The other comment lines before the header.
    text : str or bytes
        The file's content (empty when it was parsed from ``path`` without reading it whole).
    first_data_index : int
        0-based index of the line of the first data row.
    path : str or None
        The file, when ``text`` is empty: :attr:`lines` reads it.
    unit_row : list of str or None
        A second header row under the names, one cell per column (units such as ``ms`` or ``rpm``, or
        descriptions such as ``Servo motor speed``), as written by many vendor tools; None without one.
    dropped_lines : tuple of int
        1-based file lines of rows that were NaN in every cell and were dropped (``drop_nan_rows``).
    terminator : str
        A character ending every row besides the delimiter (``;`` after comma-separated cells), taken off; empty when
        there is none.
    header_comment : bool
        Whether the column names came from a commented-out header (``header_from_comments``).
    """

    name: str
    metadata: dict[str, list[str]]
    columns: list[str]
    numbers: np.ndarray | tuple[np.ndarray, ...] = field(repr=False)
    has_header: bool = True
    comments: list[str] = field(default_factory=list)
    text: str | bytes = field(default="", repr=False)
    first_data_index: int = 0
    path: str | None = None
    unit_row: list[str] | None = None
    dropped_lines: tuple[int, ...] = ()
    terminator: str = ""
    header_comment: bool = False

    @property
    def data(self) -> np.ndarray:
        """Numbers as float, shape (n_rows, n_columns), columns contiguous (column vectors are copied into one
        array on first use)."""
        if isinstance(self.numbers, tuple):
            stacked = np.empty((len(self.numbers[0]), len(self.numbers)), dtype=float, order="F")
            for j, c in enumerate(self.numbers):
                stacked[:, j] = c
            object.__setattr__(self, "numbers", stacked)  # a cache: the same numbers, stacked
        return self.numbers

    def column_vector(self, j: int) -> np.ndarray:
        """Column ``j`` (0-based) as a contiguous float vector, without stacking column vectors into :attr:`data`."""
        return self.numbers[j] if isinstance(self.numbers, tuple) else self.numbers[:, j]

    @property
    def lines(self) -> list[str]:
        """The file's lines (decoded and split on demand: only error messages need them; read again from
        ``path`` when the table was parsed without the text in memory)."""
        text = read_bytes(self.path) if self.path is not None and not self.text else self.text
        return _decoded(text, None).splitlines()

    def column(self, name: str) -> np.ndarray:
        """One column as a float vector."""
        return self.column_vector(self.columns.index(name))

    def line_number(self, row: int) -> int:
        """1-based file line number of data row ``row`` (0-based), for messages."""
        return int(self.line_numbers()[row])

    def line_numbers(self) -> np.ndarray:
        """1-based file line numbers of the data rows kept (rows dropped as NaN left out), for messages."""
        numbers = _data_line_numbers(self.lines, self.first_data_index)
        return numbers[~np.isin(numbers, self.dropped_lines)] if self.dropped_lines else numbers


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


def check_regular_file(path: str | os.PathLike[str]) -> os.stat_result:
    """The ``stat`` of ``path`` after checking it is a regular file (a symbolic link to one is): a FIFO or a device
    would block or never end; missing files, folders and permission problems are a :class:`DataError` too."""
    import stat

    p = Path(path)
    try:
        st = os.stat(p)
    except OSError as exc:
        raise _read_error(p, exc) from None
    if stat.S_ISDIR(st.st_mode):
        raise DataError(f"{p} is a folder, not a file")
    if not stat.S_ISREG(st.st_mode):
        from .atomic import kind_of

        raise DataError(f"{p} is {kind_of(st.st_mode)}; feedtune reads regular files")
    return st


def read_bytes(path: str | os.PathLike[str]) -> bytes:
    """Read a whole file; missing files, folders, FIFOs and devices and permission problems are a
    :class:`DataError`."""
    p = Path(path)
    check_regular_file(p)
    try:
        return p.read_bytes()
    except OSError as exc:
        raise _read_error(p, exc) from None


def _read_error(p: Path, exc: OSError) -> DataError:
    """The one-line error of a file that cannot be read: not found, a folder, permission, or the system's reason."""
    if isinstance(exc, FileNotFoundError):
        return DataError(f"{p}: file not found")
    if isinstance(exc, IsADirectoryError):
        return DataError(f"{p} is a folder, not a file")
    if isinstance(exc, PermissionError):
        return DataError(f"{p}: permission denied")
    from .atomic import os_error_text

    return DataError(f"{p}: cannot read the file ({os_error_text(exc)})")


def check_readable_file(path: str | os.PathLike[str]) -> Path:
    """Return ``path`` as a Path after checking that it is an existing file (else :class:`DataError`)."""
    p = Path(path)
    check_regular_file(p)
    if not os.access(p, os.R_OK):
        raise DataError(f"{p}: permission denied")
    return p


COMMENT_PREFIXES = ("#", "%")
"""Characters that start a comment line (``%``: MATLAB-style loggers)."""


def _is_data_line(line: str) -> bool:
    s = line.strip()
    return bool(s) and not s.startswith(COMMENT_PREFIXES)


def _split_cells(line: str, sep: str) -> list[str]:
    try:
        return [c.strip() for c in next(csv.reader([line], delimiter=sep))]
    except csv.Error:  # a stray carriage return, a huge or broken quoted field: the plain split, the parser names it
        return [c.strip() for c in line.split(sep)]


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
    text: str | bytes, name: str, *, skip_rows: int = 0, require_header: bool = True, what: str = "CSV",
    header_from_comments: bool = False, drop_nan_rows: bool = False,
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
    header_from_comments : bool
        Take the column names (and units) of a file whose first row is numbers from the comment lines above it.
    drop_nan_rows : bool
        Drop the rows that are NaN in every cell (their lines in :attr:`TextTable.dropped_lines`) instead of
        refusing them.

    Returns
    -------
    TextTable
        The table.
    """
    head = _parse_head(text, name, skip_rows, require_header, what, header_from_comments=header_from_comments)
    assert head is not None  # only a partial text has no answer
    body = head.text
    if head.terminator:  # every row's end taken off (the lines stay where they were: the messages' line numbers)
        body = body[:head.start] + _without_terminator(body[head.start:], head.terminator)
    data, dropped = _parse_numbers(_Body(body, head.start, head.encoding), body, head.first, head.columns,
                                   head.sep, name, drop_nan_rows)
    return TextTable(name, head.metadata, head.columns, data, head.has_header, head.comments, head.text, head.first,
                     unit_row=head.unit_row, dropped_lines=dropped, terminator=head.terminator,
                     header_comment=head.header_comment)


def _without_terminator(text: str | bytes, terminator: str) -> str | bytes:
    """``text`` with ``terminator`` (and blanks after it) taken off the end of every line."""
    if isinstance(text, bytes):
        return re.sub(re.escape(terminator.encode()) + rb"[ \t]*(?=\r?\n|$)", b"", text)
    return re.sub(re.escape(terminator) + r"[ \t]*(?=\r?\n|$)", "", text)


@dataclass(frozen=True)
class _Head:
    """What the lines above the numbers of a table say (see :func:`_parse_head`)."""

    text: str | bytes
    encoding: str | None
    metadata: dict[str, list[str]]
    comments: list[str]
    columns: list[str]
    has_header: bool
    first: int
    start: int
    sep: str
    unit_row: list[str] | None = None
    terminator: str = ""
    header_comment: bool = False


def _unit_row(text: str | bytes, start: int, encoding: str | None, sep: str, n_columns: int,
              partial: bool) -> tuple[list[str] | None, int] | None:
    """A second header row under the names (units such as ``ms, V, rpm`` or descriptions; no cell a number, with a
    decimal point or a decimal comma) and the
    offset after it; ``(None, start)`` when the next line is not one, None when ``partial`` text ends inside it."""
    nl = b"\n" if isinstance(text, bytes) else "\n"
    end = text.find(nl, start)
    if end < 0:
        if partial:
            return None
        end = len(text)
    raw = text[start:end]
    line = _decoded(raw, encoding).rstrip("\r") if isinstance(raw, bytes) else raw.rstrip("\r")
    if not _is_data_line(line):
        return None, start
    cells = _split_cells(line, sep)
    if len(cells) != n_columns or not any(cells) or any(_is_number(c.replace(",", ".")) for c in cells if c):
        return None, start
    return cells, min(end + 1, len(text))


def _parse_head(text: str | bytes, name: str, skip_rows: int, require_header: bool, what: str,
                partial: bool = False, header_from_comments: bool = False) -> _Head | None:
    """Metadata, comments, column names, delimiter and where the numbers start (``first``: 0-based line index,
    ``start``: offset in ``text``).

    With ``partial``, ``text`` is only the beginning of a longer file: None when the answer needs more of it
    (the header row or the first row of numbers is not complete in ``text``) or when the file must be read whole
    (old Mac line endings, rows with a terminator); the errors raised are those of the whole file. With
    ``header_from_comments``, a file whose first row is numbers takes its header from the comment lines above
    (module docstring).
    """
    if skip_rows < 0:
        raise DataError(f"{name}: skip_rows must be >= 0, got {skip_rows}")
    nl, cr = (b"\n", b"\r") if isinstance(text, bytes) else ("\n", "\r")
    if cr in text[:1 << 16] and nl not in text[:1 << 16]:  # old Mac line endings (CR only)
        if partial:
            return None
        text = text.replace(cr, nl)
    encoding = _encoding_of(text)
    metadata: dict[str, list[str]] = {}
    comments: list[str] = []
    block: list[str] = []  # the comment lines since the last blank line: a commented-out header is their end
    head = _lines_with_offsets(text, encoding)
    k, line, offset = -1, None, len(text)
    for k, item in enumerate(head):
        line, offset = item
        if k < skip_rows:
            continue
        if _is_data_line(line):
            break
        s = line.strip()
        block = [*block, s[1:].strip()] if s else []
        m = _META_RE.match(s)
        if m:
            metadata.setdefault(m.group(1).strip().lower(), []).append(m.group(2))
        elif s:
            comments.append(s.lstrip("#%").strip())
    else:
        if partial:
            return None
        raise DataError(f"{name}: empty {what} file (no header and no data rows)")
    next_line = text.find(nl, offset)
    if partial and next_line < 0:
        return None
    if len(line) > MAX_HEADER_CHARS:
        raise DataError(f"{name}: line {k + 1} is {len(line):,} characters long; expected a header row of column "
                        f"names or a row of numbers (at most {MAX_HEADER_CHARS:,} characters)")
    sep = _guess_delimiter(line)
    terminator = _terminator(line, sep)
    cells = _split_cells(line.split("#", 1)[0].rstrip()[:-1] if terminator else line, sep)
    unit_row, header_comment = None, False
    if all(_is_number(c) for c in cells if c):
        named = _commented_header(block, sep, len(cells))
        if named is not None and header_from_comments:
            columns, unit_row = named
            comments = comments[:len(comments) - (1 if unit_row is None else 2)]  # the header is no comment
            has_header, first, start, header_comment = True, k, offset, True
        elif require_header:
            raise DataError(f"{name}: line {k + 1}: expected a header row of column names, found numbers")
        else:
            columns = [f"col{j}" for j in range(len(cells))]
            has_header, first, start = False, k, offset
    else:
        columns = _unique_names(cells)
        has_header, first, start = True, k + 1, (len(text) if next_line < 0 else next_line + 1)
    if has_header and not header_comment:
        found = _unit_row(text, start, encoding, sep, len(columns), partial)
        if found is None:
            return None
        unit_row, after = found
        if unit_row is not None:
            first, start = first + 1, after
    terminator = _terminator(_first_data_line(text, start, encoding), sep)
    if terminator and partial:
        return None
    return _Head(text, encoding, metadata, comments, columns, has_header, first, start, sep, unit_row, terminator,
                 header_comment)


_TERMINATORS = (";", ",", "\t")


def _terminator(line: str | None, sep: str) -> str:
    """A delimiter other than ``sep`` that ends a row of numbers (``1.0,2.0;``), else ``""``."""
    s = (line or "").split("#", 1)[0].rstrip(" \r\n")
    return s[-1] if s and s[-1] in _TERMINATORS and s[-1] != sep else ""


def _first_data_line(text: str | bytes, start: int, encoding: str | None) -> str | None:
    for line, _ in _lines_with_offsets(text, encoding, start):
        if _is_data_line(line):
            return line
    return None


def _looks_like_units(cells: list[str]) -> bool:
    """A commented units row: every cell empty or bracketed (``[V]``, ``(turns/s)``, ``[#]``)."""
    return all(not c or (c[0], c[-1]) in (("[", "]"), ("(", ")")) for c in cells)


def _commented_header(block: list[str], sep: str, n: int) -> tuple[list[str], list[str] | None] | None:
    """Column names (and a units row under them) from the last comment lines above the first row of numbers, when
    they have ``n`` cells and are not numbers; None otherwise."""
    rows = [_split_cells(b, sep) for b in block[-2:]]

    def names(r: list[str]) -> bool:
        return len(r) == n and not all(_is_number(c) for c in r if c) and not _looks_like_units(r)

    if not rows or len(rows[-1]) != n:
        return None
    if _looks_like_units(rows[-1]):
        if len(rows) == 2 and names(rows[0]):
            return _unique_names(rows[0]), [c.strip("[]()") for c in rows[-1]]
        return None
    return (_unique_names(rows[-1]), None) if names(rows[-1]) else None


READ_HEAD_BYTES = 1 << 16
"""Bytes :func:`read_table_file` reads first to find the header (the size of the encoding sample); smaller files
are read whole."""


def read_table_file(path: str | os.PathLike[str], what: str = "CSV", *, skip_rows: int = 0,
                    require_header: bool = True, header_from_comments: bool = False,
                    drop_nan_rows: bool = False) -> TextTable:
    """:func:`parse_table` of a file, without holding the file in memory.

    The same table and the same errors as ``parse_table(*read_table_data(path, what), ...)``. The first
    :data:`READ_HEAD_BYTES` give the metadata and the header; pandas then parses the numbers from the file
    itself, from the first row on (in two halves on two threads for a large file when a core is free, see
    :data:`READ_PARTS_MIN_BYTES`), and the column vectors it makes are the table's (:attr:`TextTable.numbers`; no
    copy into one array unless :attr:`TextTable.data` is asked for). Whatever that fast path does not take as it is
    (a cell that is not a number, a decimal comma, NaN or inf, a Latin-1 character past the sample, a malformed
    row, old Mac line endings, a small file) goes through :func:`parse_table` on the whole file, which gives the
    result or the error message with its line number.

    Parameters
    ----------
    path : path-like
        The file.
    what : str
        Kind of file, for messages.
    skip_rows : int
        Lines to skip at the top before anything else (vendor preambles).
    require_header : bool
        When true, a first row of numbers is an error; otherwise columns are named ``col0``, ``col1``...
    header_from_comments, drop_nan_rows : bool
        As for :func:`parse_table` (a commented-out header, rows NaN in every cell).

    Returns
    -------
    TextTable
        The table (its :attr:`~TextTable.lines` read the file again when an error message needs them).
    """
    table = _read_table_fast(path, what, skip_rows, require_header, header_from_comments)
    if table is None:
        raw, name = read_table_data(path, what)
        table = parse_table(raw, name, skip_rows=skip_rows, require_header=require_header, what=what,
                            header_from_comments=header_from_comments, drop_nan_rows=drop_nan_rows)
    return table


def _read_table_fast(path: str | os.PathLike[str], what: str, skip_rows: int,
                     require_header: bool, header_from_comments: bool = False) -> TextTable | None:
    """The fast path of :func:`read_table_file`; None when the whole file must go through :func:`parse_table`."""
    name = source_name(path)
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            head = fh.read(READ_HEAD_BYTES)
    except OSError:
        return None
    if len(head) < READ_HEAD_BYTES or size <= len(head) or b"\x00" in head:
        return None
    h = _parse_head(head, name, skip_rows, require_header, what, partial=True,
                    header_from_comments=header_from_comments)
    if h is None:
        return None
    data = _read_numbers_fast(path, h.start, len(h.columns), h.sep, h.encoding)
    if data is None:
        return None
    return TextTable(name, h.metadata, h.columns, data, h.has_header, h.comments, b"", h.first, str(path),
                     unit_row=h.unit_row, header_comment=h.header_comment)


class _FileRange(io.RawIOBase):
    """Bytes ``start`` to ``stop`` of a file, read as a stream (what pandas reads a table body from)."""

    def __init__(self, path: str | os.PathLike[str], start: int, stop: int) -> None:
        super().__init__()
        self._fh = open(path, "rb", buffering=0)  # closed by close()
        self._fh.seek(start)
        self._left = stop - start

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        n = min(len(buffer), self._left)
        if n <= 0:
            return 0
        with memoryview(buffer) as view:
            got = self._fh.readinto(view[:n]) or 0
        self._left -= got
        return got

    def close(self) -> None:
        self._fh.close()
        super().close()


READ_PARTS_MIN_BYTES = 8 << 20
"""Table bodies at least this large are parsed in two parts on two threads by :func:`read_table_file` when a
second core is at least half idle (:func:`_idle_cores`); the parts then cost one copy of the numbers."""


def _idle_cores() -> float:
    """Cores this process may run on minus the machine's 1-minute load average (the cores minus one where the load
    is unknown): a second parsing thread only pays when it gets most of a core."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    try:
        return cores - os.getloadavg()[0]
    except (AttributeError, OSError):  # no load average (Windows)
        return cores - 1.0


def _plain_row(line: bytes, sep: bytes, n_columns: int) -> bool:
    """Whether a line is a whole row of ``n_columns`` unquoted fields: where pandas may start parsing a second part
    (it takes the first row of a stream more leniently than the others: an extra trailing field is dropped)."""
    cells = line.split(b"#", 1)[0]
    return line.endswith(b"\n") and b'"' not in line and cells.count(sep) == n_columns - 1 and bool(cells.strip())


def _read_numbers_fast(path: str | os.PathLike[str], start: int, n_columns: int, sep: str,
                       encoding: str | None) -> tuple[np.ndarray, ...] | None:
    """The numbers of a table from byte ``start`` on, one float vector per column, parsed by pandas as
    :func:`_read_frame` does, when they are all finite numbers (else None).

    Unlike :func:`_read_frame`, pandas does not look for NaN markers (``na_filter=False``: a cell such as ``NA`` or
    an empty one is then not a number, and the file goes to :func:`parse_table`, which names it); the vectors pandas
    parsed are kept as they are, not copied into one array.
    """
    import warnings

    import pandas as pd

    enc = "latin-1" if encoding == "latin-1" else "utf-8"
    cuts = [start]
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if size - start >= READ_PARTS_MIN_BYTES and _idle_cores() >= 0.5:
                fh.seek(start + (size - start) // 2)
                rest = fh.readline(MAX_HEADER_CHARS)  # the parts split between two lines
                cut = fh.tell()
                if rest.endswith(b"\n") and _plain_row(fh.readline(MAX_HEADER_CHARS), sep.encode(), n_columns):
                    cuts.append(cut)
    except OSError:
        return None
    cuts.append(size)

    def part(i: int) -> list[np.ndarray]:
        with io.BufferedReader(_FileRange(path, cuts[i], cuts[i + 1]), 1 << 18) as fh:
            frame = pd.read_csv(fh, sep=sep, header=None, names=range(n_columns), comment="#",
                                skip_blank_lines=True, index_col=False, engine="c", decimal=".", encoding=enc,
                                na_filter=False)
        return [frame.iloc[:, j].to_numpy() for j in range(n_columns)]

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", pd.errors.DtypeWarning)
            warnings.simplefilter("ignore", pd.errors.ParserWarning)
            if len(cuts) == 2:
                parts = [part(0)]
            else:
                with ThreadPoolExecutor(max_workers=len(cuts) - 1) as pool:
                    parts = list(pool.map(part, range(len(cuts) - 1)))
    except (ValueError, OSError):  # pandas' parser and decoding errors are ValueErrors
        return None
    if any(c.dtype.kind not in "iuf" for p in parts for c in p) or sum(len(p[0]) for p in parts) == 0:
        return None
    if len(parts) == 1:
        columns = tuple(_own_float_vector(c) for c in parts[0])
    else:
        columns = tuple(np.concatenate([p[j] for p in parts]).astype(float, copy=False) for j in range(n_columns))
    del parts
    if not all(np.isfinite(c).all() for c in columns):
        return None
    return columns


def _own_float_vector(c: np.ndarray) -> np.ndarray:
    """A column pandas parsed as a writable float vector: the array itself when pandas only lent it read-only
    (the frame that held it is gone), else a float copy."""
    if c.dtype != np.float64 or not c.flags.c_contiguous:
        return np.ascontiguousarray(c, dtype=float)
    if not c.flags.writeable:
        try:
            c.flags.writeable = True  # pandas (copy-on-write) hands out read-only views of its own arrays
        except ValueError:
            return c.copy()
    return c


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
                   name: str, drop_nan_rows: bool = False) -> tuple[np.ndarray, tuple[int, ...]]:
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
        try:
            num = pd.to_numeric(col, errors="coerce")
            values[:, j] = num.to_numpy(dtype=float)
        except OverflowError:  # integers beyond the float range: their text parses to inf, named below
            num = pd.Series([_float_or_nan(v) for v in col], index=col.index)
        bad = num.isna().to_numpy() & col.notna().to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            line = _data_line_numbers(lines.get(), first)[i]
            cell = str(col.iloc[i]).strip()
            hint = "; pass skip_rows to skip extra header lines" if i == 0 else ""
            raise DataError(f"{name}: line {line}, column {columns[j]!r}: {cell!r} is not a number{hint}")
        values[:, j] = num.to_numpy(dtype=float)
    dropped: tuple[int, ...] = ()
    empty = np.isnan(values).all(axis=1) if drop_nan_rows else None
    if empty is not None and empty.any():
        if empty.all():
            raise DataError(f"{name}: every row below the header is NaN (no data)")
        rows = _data_line_numbers(lines.get(), first)
        dropped = tuple(int(rows[i]) for i in np.flatnonzero(empty))
        values = np.asfortranarray(values[~empty])
    finite = np.isfinite(values)
    if not finite.all():
        if dropped:  # the line numbers of the rows left
            lines_left = np.delete(_data_line_numbers(lines.get(), first), np.flatnonzero(empty))
        i, j = (int(v) for v in np.argwhere(~finite)[0])
        line = (lines_left if dropped else _data_line_numbers(lines.get(), first))[i]
        what = ("empty or NaN cell" if np.isnan(values[i, j]) else
                "infinite value, or a number beyond the range of a float")
        raise DataError(f"{name}: line {line}, column {columns[j]!r}: {what} (NaN/inf are not accepted)")
    return values, dropped


def _float_or_nan(v) -> float:
    """A cell as a float (decimal text of any length; beyond the float range: inf), NaN when it is not a number."""
    try:
        return float(str(v).strip())
    except ValueError:
        return math.nan


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
    import warnings

    import pandas as pd

    enc = None if body.encoding is None else ("latin-1" if body.encoding == "latin-1" else "utf-8")
    try:
        with warnings.catch_warnings():  # a short row: pandas warns, the checks below name it
            warnings.simplefilter("ignore", pd.errors.ParserWarning)
            return _read_csv(body, sep, n_columns, decimal, enc)
    except pd.errors.EmptyDataError:
        raise DataError(f"{name}: no data rows below the header") from None
    except (pd.errors.ParserError, ValueError):
        raise DataError(_field_count_message(lines.get(), first, n_columns, sep, name)) from None


def _read_csv(body: _Body, sep: str, n_columns: int, decimal: str, enc: str | None):
    """``pandas.read_csv`` of the body (again as Latin-1 when a character beyond the encoding sample is not UTF-8)."""
    import pandas as pd

    try:
        return pd.read_csv(body.handle(), sep=sep, header=None, names=range(n_columns), comment="#",
                           skip_blank_lines=True, index_col=False, engine="c", decimal=decimal, encoding=enc)
    except UnicodeDecodeError:  # a Latin-1 character beyond the sample that chose UTF-8
        return pd.read_csv(body.handle(), sep=sep, header=None, names=range(n_columns), comment="#",
                           skip_blank_lines=True, index_col=False, engine="c", decimal=decimal, encoding="latin-1")


def _field_count_message(lines: list[str], first: int, n_columns: int, sep: str, name: str) -> str:
    for j in range(first, len(lines)):
        if _is_data_line(lines[j]):
            cells = _split_cells(lines[j].split("#", 1)[0], sep)
            n = len(cells) - (1 if cells and cells[-1] == "" else 0)
            if n > n_columns:
                return f"{name}: line {j + 1}: {n} fields, but the header has {n_columns} columns"
    return f"{name}: malformed rows below the header (check the delimiter and quoting)"
