"""Numeric columns as CSV text, fast: the shortest round-trip digits of every float (as ``repr``), a chunk of rows at
a time (:func:`csv_row_chunks`), large float tables by a compiled kernel (:func:`format_float_rows`, the Schubfach
algorithm), small ones by ``%`` formatting.
"""

from __future__ import annotations

import collections
import functools
import itertools
import sys
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._kernel_cache import PendingKernel

CSV_CHUNK_ROWS = 65536
"""Rows formatted per chunk by :func:`csv_rows` and :func:`csv_row_chunks` (bounds the temporary memory)."""

COMPILED_MIN_CELLS = 500_000
"""Smallest table (rows x columns) of float64 columns that :func:`csv_row_chunks` formats with the compiled
kernel; smaller ones take the ``%`` formatting path (about 0.7 us a number: quicker than loading numba and the cached
kernel, about 0.4 s once per process)."""
COMPILED_MIN_CELLS_LOADED = 20_000
"""The same threshold once numba is loaded in the process (a twin ran, as in the demos): only the cached kernel's
load is left to pay (a few ms)."""

_CELL_BYTES = 25
"""Longest cell the compiled kernel writes, with its separator (``-1.2345678901234567e-308,``)."""


def csv_rows(columns: Sequence[np.ndarray]) -> str:
    """Rows of comma-separated numbers, one line per row, in the text ``pandas.DataFrame.to_csv`` writes.

    Floats are written as ``repr`` (the shortest text that reads back to the same value; float32 columns in their
    own precision), integers and booleans as ``str``, NaN as an empty field. See :func:`csv_row_chunks`.

    Parameters
    ----------
    columns : sequence of ndarray
        Equal-length 1-D columns.

    Returns
    -------
    str
        The rows, each ending in ``\\n`` (empty without rows or columns).
    """
    return b"".join(csv_row_chunks(columns)).decode("utf-8")


def csv_row_chunks(columns: Sequence[np.ndarray], chunk_rows: int | None = None) -> Iterator[bytes]:
    """The text of :func:`csv_rows` as UTF-8 bytes, ``chunk_rows`` rows at a time (for writing without the text
    of the whole table in memory).

    Tables of float64 columns only (logs, FRFs) with at least :data:`COMPILED_MIN_CELLS` cells
    (:data:`COMPILED_MIN_CELLS_LOADED` when numba is loaded already) are formatted by a
    compiled kernel (:func:`format_float_rows`: the text of ``repr``, about 5x the ``%`` path on one thread, with
    two chunks at a time on two threads); other tables by one ``%`` formatting per chunk.

    Parameters
    ----------
    columns : sequence of ndarray
        Equal-length 1-D columns.
    chunk_rows : int, optional
        Rows per chunk (default :data:`CSV_CHUNK_ROWS`).

    Yields
    ------
    bytes
        Consecutive whole rows.
    """
    cols = [np.asarray(c) for c in columns]
    n, k = (len(cols[0]), len(cols)) if cols else (0, 0)
    if n == 0 or k == 0:
        return
    if any(len(c) != n for c in cols):
        raise ValueError(f"columns of different lengths: {[len(c) for c in cols]}")
    chunk_rows = chunk_rows or CSV_CHUNK_ROWS
    min_cells = COMPILED_MIN_CELLS_LOADED if "numba" in sys.modules else COMPILED_MIN_CELLS
    if n * k >= min_cells and all(c.dtype == np.float64 and c.ndim == 1 for c in cols) \
            and _row_kernel() is not None:
        yield from _compiled_chunks(cols, chunk_rows)
        return
    row = ",".join(["%s"] * k) + "\n"
    for a in range(0, n, chunk_rows):
        cells = [_cell_values(c[a:a + chunk_rows]) for c in cols]
        m = len(cells[0])
        yield ((row * m) % tuple(itertools.chain.from_iterable(zip(*cells, strict=True)))).encode("utf-8")


def _cell_values(c: np.ndarray) -> list:
    """The values ``%s`` formats for one column: Python numbers (``repr`` of a float64 is its shortest round-trip
    text), numpy's ``str`` of other floats, ``""`` for NaN."""
    vals = c.astype(str).tolist() if c.dtype.kind == "f" and c.dtype != np.float64 else c.tolist()
    if c.dtype.kind == "f" and np.isnan(c).any():
        vals = ["" if np.isnan(x) else v for x, v in zip(c.tolist(), vals, strict=True)]
    return vals


def _compiled_chunks(cols: list[np.ndarray], chunk_rows: int) -> Iterator[bytes]:
    """:func:`csv_row_chunks` of float64 columns by the compiled kernel; two chunks are formatted at a time on
    two threads (the kernel releases the GIL) while the caller writes the previous one."""
    n, k = len(cols[0]), len(cols)

    def chunk(a: int) -> bytes:
        block = np.empty((min(chunk_rows, n - a), k))
        for j, c in enumerate(cols):
            block[:, j] = c[a:a + chunk_rows]
        return format_float_rows(block)

    starts = range(0, n, chunk_rows)
    if len(starts) == 1:
        yield chunk(0)
        return
    with ThreadPoolExecutor(max_workers=2) as pool:
        pending: collections.deque = collections.deque()
        for a in starts:
            pending.append(pool.submit(chunk, a))
            if len(pending) > 2:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()


def format_float_rows(block: np.ndarray) -> bytes:
    """Format a float64 table as CSV rows with the compiled kernel: each number as its ``repr`` (the shortest
    decimal that reads back to the same double, Python's layout: ``0.0001``, ``1e-05``, ``1e+16``,
    ``1000000000000000.0``, ``-0.0``, ``inf``), NaN as an empty field, ``,`` between cells, ``\\n`` after each row.

    Parameters
    ----------
    block : ndarray, shape (n_rows, n_columns)
        The numbers (converted to a C-ordered float64 array).

    Returns
    -------
    bytes
        ASCII text.

    Raises
    ------
    RuntimeError
        numba is not installed.
    """
    kernel = _row_kernel()
    if kernel is None:
        raise RuntimeError("the compiled CSV row formatter needs numba")
    bits = np.ascontiguousarray(np.atleast_2d(block), dtype=np.float64).view(np.uint64)
    g_hi, g_lo = _pow10_table()
    out = np.empty(bits.size * _CELL_BYTES + bits.shape[0], dtype=np.uint8)
    end = kernel(bits, g_hi, g_lo, out)
    return out[:end].tobytes()


_POW10_K_MIN, _POW10_K_MAX = -292, 324


@functools.cache
def _pow10_table() -> tuple[np.ndarray, np.ndarray]:
    """High and low 64-bit halves of ``g = ceil(10**k / 2**r)`` with ``2**127 <= g < 2**128``, for
    ``k = -292 ... 324`` (the powers of ten of the Schubfach algorithm, exact from Python integers)."""
    hi = np.empty(_POW10_K_MAX - _POW10_K_MIN + 1, dtype=np.uint64)
    lo = np.empty_like(hi)
    for i, k in enumerate(range(_POW10_K_MIN, _POW10_K_MAX + 1)):
        if k >= 0:
            p = 10 ** k
            r = p.bit_length() - 128
            g = (p + (1 << r) - 1) >> r if r > 0 else p << -r
        else:
            d = 10 ** -k
            g = -(-(1 << (127 + d.bit_length())) // d)
        hi[i], lo[i] = g >> 64, g & ((1 << 64) - 1)
    return hi, lo


_KERNEL: list = []

_PENDING = PendingKernel()
"""The kernel compiling in another process (a first run's background compile), waited for at its first use."""

set_kernel_pending = _PENDING.set


def _row_kernel():
    """The compiled row formatter of :func:`format_float_rows` (compiled once, cached on disk); None without
    numba."""
    if not _KERNEL:
        try:
            import numba
        except ImportError:  # pragma: no cover - numba is a dependency; the % path still works without it
            _KERNEL.append(None)
            return None
        _KERNEL.append(numba.njit(cache=True, nogil=True)(_format_rows))
    _PENDING.wait()  # compiled elsewhere into the cache: loaded from it at the first call
    return _KERNEL[0]


def _format_rows(bits: np.ndarray, g_hi: np.ndarray, g_lo: np.ndarray, out: np.ndarray) -> int:
    """Write the rows of the doubles ``bits`` (their IEEE bit patterns, shape (n, k)) into ``out``; return the
    number of bytes written.

    The digits are those of the Schubfach algorithm (R. Giulietti, "The Schubfach way to render doubles", 2020):
    the shortest decimal in the rounding interval of the double, the closest one to it when there are several
    (ties to an even last digit): the digits of Python's ``repr``. ``g_hi``/``g_lo`` are :func:`_pow10_table`.
    """

    def mul64(a, b):
        # full product of two uint64 as (high, low) 64-bit halves
        m = np.uint64(0xFFFFFFFF)
        s = np.uint64(32)
        a0, a1, b0, b1 = a & m, a >> s, b & m, b >> s
        p00, p01, p10, p11 = a0 * b0, a0 * b1, a1 * b0, a1 * b1
        mid1 = p10 + (p00 >> s)
        mid2 = p01 + (mid1 & m)
        return p11 + (mid1 >> s) + (mid2 >> s), (p00 & m) | (mid2 << s)

    def round_to_odd(gh, gl, cp):
        # floor(g * cp / 2**128), with its lowest bit set when the division is inexact
        xh, _ = mul64(gl, cp)
        yh, yl = mul64(gh, cp)
        yl2 = yl + xh
        if yl2 < xh:
            yh += np.uint64(1)
        if yl2 > np.uint64(1):
            yh |= np.uint64(1)
        return yh

    one, two, four, ten, forty = np.uint64(1), np.uint64(2), np.uint64(4), np.uint64(10), np.uint64(40)
    digits = np.empty(24, dtype=np.uint8)
    n, k = bits.shape
    pos = 0
    for i in range(n):
        for j in range(k):
            if j > 0:
                out[pos] = 44  # ,
                pos += 1
            b = bits[i, j]
            be = np.int64((b >> np.uint64(52)) & np.uint64(0x7FF))
            fr = b & np.uint64(0xFFFFFFFFFFFFF)
            if be == 0x7FF and fr != np.uint64(0):
                continue  # NaN: an empty field
            if (b >> np.uint64(63)) != np.uint64(0):
                out[pos] = 45  # -
                pos += 1
            if be == 0x7FF:
                out[pos], out[pos + 1], out[pos + 2] = 105, 110, 102  # inf
                pos += 3
                continue
            if be == 0 and fr == np.uint64(0):
                out[pos], out[pos + 1], out[pos + 2] = 48, 46, 48  # 0.0
                pos += 3
                continue
            # the double is c * 2**q; its rounding interval is [cbl, cbr] * 2**(q - 2)
            if be != 0:
                c = fr | np.uint64(1 << 52)
                q = be - 1075
            else:
                c = fr
                q = -1074
            cb = c << two
            cbr = cb + two
            if fr == np.uint64(0) and be > 1:  # the lower neighbour is twice as close
                cbl = cb - one
                e10 = (q * 1262611 - 524031) >> 22  # floor(log10(3/4 * 2**q))
            else:
                cbl = cb - two
                e10 = (q * 1262611) >> 22  # floor(log10(2**q))
            h = np.uint64(q + (((-e10) * 1741647) >> 19) + 1)  # q + floor(log2(10**-e10)) + 1
            gh = g_hi[-e10 - _POW10_K_MIN]
            gl = g_lo[-e10 - _POW10_K_MIN]
            vbl = round_to_odd(gh, gl, cbl << h)
            vb = round_to_odd(gh, gl, cb << h)
            vbr = round_to_odd(gh, gl, cbr << h)
            if (c & one) == np.uint64(0):  # an even significand keeps the interval ends
                lower, upper = vbl, vbr
            else:
                lower, upper = vbl + one, vbr - one
            s = vb >> two
            d = np.uint64(0)
            found = False
            if s >= ten:  # one digit fewer: the multiple of 10 in the interval, if just one is
                sp = s // ten
                up_in = lower <= forty * sp
                wp_in = forty * sp + forty <= upper
                if up_in != wp_in:
                    d = sp + one if wp_in else sp
                    e10 += 1
                    found = True
            if not found:
                u_in = lower <= four * s
                w_in = four * s + four <= upper
                if u_in != w_in:
                    d = s + one if w_in else s
                else:  # both in: the closer one, ties to even
                    mid = four * s + two
                    d = s + one if (vb > mid or (vb == mid and (s & one) != np.uint64(0))) else s
            while d % ten == np.uint64(0) and d > np.uint64(0):
                d //= ten
                e10 += 1
            nd = 0
            while d > np.uint64(0):
                digits[nd] = np.uint8(d % ten) + 48  # least significant first
                d //= ten
                nd += 1
            dp = nd + e10  # the number is 0.DIGITS * 10**dp; repr's layout follows
            if dp <= -4 or dp > 16:
                out[pos] = digits[nd - 1]
                pos += 1
                if nd > 1:
                    out[pos] = 46
                    pos += 1
                    for t in range(nd - 2, -1, -1):
                        out[pos] = digits[t]
                        pos += 1
                e = dp - 1
                out[pos] = 101  # e
                out[pos + 1] = 45 if e < 0 else 43
                pos += 2
                e = abs(e)
                if e >= 100:
                    out[pos] = 48 + e // 100
                    pos += 1
                    e %= 100
                out[pos], out[pos + 1] = 48 + e // 10, 48 + e % 10
                pos += 2
            elif dp <= 0:
                out[pos], out[pos + 1] = 48, 46  # 0.
                pos += 2
                for _ in range(-dp):
                    out[pos] = 48
                    pos += 1
                for t in range(nd - 1, -1, -1):
                    out[pos] = digits[t]
                    pos += 1
            elif dp < nd:
                for t in range(nd - 1, nd - 1 - dp, -1):
                    out[pos] = digits[t]
                    pos += 1
                out[pos] = 46
                pos += 1
                for t in range(nd - 1 - dp, -1, -1):
                    out[pos] = digits[t]
                    pos += 1
            else:
                for t in range(nd - 1, -1, -1):
                    out[pos] = digits[t]
                    pos += 1
                for _ in range(dp - nd):
                    out[pos] = 48
                    pos += 1
                out[pos], out[pos + 1] = 46, 48  # .0
                pos += 2
        out[pos] = 10
        pos += 1
    return pos
