"""Merge FRFs measured one channel per file into one :class:`~feedtune.frf.Frf`.

A drive's analyser writes one Bode file per measurement: the motor encoder over the command in one file, the load
encoder over the command in another, each with the same header. :func:`pick_channel` gives each file's response its
channel name (``x1/u``, ``x2/u``), :func:`merge_frfs` puts the channels side by side on the lines they share:

* every channel comes from one file: two files that would both give ``x2/u`` are an error naming both, never a
  silent average;
* the files share one input unit and one output unit (an FRF holds one unit per side) and one record of sampling
  (``sampling``, ``sampling_fs_hz``, ``sampling_delay_samples``) and table position (``x_m``); a difference is an
  error naming both files;
* the merged grid is that of the first file over the band every file covers; inside that band every line of each file
  must be a line of the others (the same analyser grid, written with any number of digits: lines closer than
  :data:`LINE_MATCH_FRACTION` of the line spacing are one line), else the grids differ and the merge is refused,
  naming both files and their grids; lines outside the common band are dropped and counted in ``meta["merge"]``;
* a file measured as another quantity (velocity, acceleration) is converted to the first file's quantity (powers of
  ``j w``, exact);
* the coherence of a channel comes with it (NaN, "not measured", for a file without one).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .errors import DataError, UsageError
from .frf import Frf

LINE_MATCH_FRACTION = 0.01
"""Two lines of two files are the same line when they differ by less than this fraction of the smaller line spacing
around them [-]: an analyser grid written with six significant digits in one file and seventeen in another still
matches (six digits are 1e-6 relative; spacings of a line grid are at least 1e-4 relative), two different grids do
not."""

AGREEING_META = ("sampling", "sampling_fs_hz", "sampling_delay_samples", "x_m")
"""Metadata every merged file must agree on (a file without the entry differs from one with it): the sampling record
of an FRF estimated from a controller's log (:mod:`feedtune.frf_sampling`) and the table position of a gantry FRF."""


def pick_channel(frf: Frf, channel: str) -> Frf:
    """The FRF as one channel named ``channel``: a single-channel FRF renamed, or one channel of several selected.

    Parameters
    ----------
    frf : Frf
        The response as read.
    channel : str
        ``"OUT/IN"``, e.g. ``"x2/u"``.

    Returns
    -------
    Frf
        One channel named ``channel``; a renamed vendor file's ``meta["columns"]`` says the new name, and
        ``meta["channel_named"]`` is ``"yes"``.

    Raises
    ------
    UsageError
        A malformed channel name.
    DataError
        An FRF of several channels without ``channel``.
    """
    out, sep, inp = str(channel).partition("/")
    if not sep or not out.strip() or not inp.strip() or "/" in inp:
        raise UsageError(f"channel {channel!r} must look like OUT/IN, e.g. x2/u", parameter="channel")
    out, inp = out.strip(), inp.strip()
    meta = {**frf.meta, "channel_named": "yes"}
    if len(frf.channels) == 1:
        old = frf.channels[0]
        if "columns" in meta and old != f"{out}/{inp}":
            meta["columns"] = str(meta["columns"]).replace(f"{old}.", f"{out}/{inp}.")
        return replace(frf, outputs=(out,), inputs=(inp,), meta=meta)
    if not frf.has(f"{out}/{inp}"):
        raise DataError(f"{frf.source}: no channel {out}/{inp} among its {len(frf.channels)} channels "
                        f"({', '.join(frf.channels)})")
    i, j = frf.index(f"{out}/{inp}")
    coh = None if frf.coherence is None else frf.coherence[i:i + 1, j:j + 1]
    return replace(frf, response=frf.response[i:i + 1, j:j + 1], coherence=coh, outputs=(out,), inputs=(inp,),
                   meta=meta)


def _grid_text(frf: Frf) -> str:
    f = frf.freq_hz
    return f"{f.size} lines, {f[0]:.6g}-{f[-1]:.6g} Hz"


def _spacing(f: np.ndarray) -> np.ndarray:
    """The smaller distance [Hz] from each line to its neighbours (the whole band for a single line)."""
    if f.size == 1:
        return np.array([max(abs(f[0]), 1.0)])
    d = np.diff(f)
    return np.minimum(np.concatenate([d[:1], d]), np.concatenate([d, d[-1:]]))


def _common_lines(first: Frf, other: Frf, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices into ``first`` and ``other`` of their shared lines in ``lo..hi``; DataError when the grids differ."""
    fa, fb = first.freq_hz, other.freq_hz
    tol_a, tol_b = LINE_MATCH_FRACTION * _spacing(fa), LINE_MATCH_FRACTION * _spacing(fb)
    in_a = np.flatnonzero((fa >= lo - tol_a) & (fa <= hi + tol_a))
    in_b = np.flatnonzero((fb >= lo - tol_b) & (fb <= hi + tol_b))
    if in_a.size == in_b.size:
        tol = np.minimum(tol_a[in_a], tol_b[in_b])
        if np.all(np.abs(fa[in_a] - fb[in_b]) <= tol):
            return in_a, in_b
    k = np.clip(np.searchsorted(fb, fa[in_a]), 1, max(fb.size - 1, 1))
    nearest = np.minimum(np.abs(fa[in_a] - fb[k - 1]), np.abs(fa[in_a] - fb[np.minimum(k, fb.size - 1)]))
    shared = int(np.count_nonzero(nearest <= tol_a[in_a]))
    raise DataError(f"{first.source} and {other.source} have different frequency grids ({first.source}: "
                    f"{_grid_text(first)}; {other.source}: {_grid_text(other)}; {shared} of the {in_a.size} lines "
                    f"of {first.source} in {lo:.6g}-{hi:.6g} Hz are lines of {other.source}); merge needs one grid: "
                    "measure the channels on the same lines")


def _agree(pieces: Sequence[Frf], what: str, value) -> None:
    first = value(pieces[0])
    for p in pieces[1:]:
        if value(p) != first:
            raise DataError(f"{pieces[0].source} and {p.source} differ in their {what} ({first or 'none'} and "
                            f"{value(p) or 'none'}); one FRF holds one {what}")


def merge_frfs(pieces: Sequence[Frf]) -> Frf:
    """Merge FRFs of different channels (one file per channel) into one FRF on their common lines (module docstring).

    Parameters
    ----------
    pieces : sequence of Frf
        The responses, each with its channels named (:func:`pick_channel`); every channel in one piece only.

    Returns
    -------
    Frf
        All channels on the first piece's grid over the band every piece covers, in the first piece's quantity;
        ``meta["source"]`` joins the sources with ``+``, ``meta["merge"]`` says which channel came from which file
        and which lines were dropped. One piece is returned as it is.

    Raises
    ------
    DataError
        A channel in two pieces, different input or output units, sampling records or positions, grids that differ
        inside the common band, no common band, or channels that do not complete an OUT x IN matrix.
    UsageError
        No pieces.

    Examples
    --------
    >>> import numpy as np
    >>> f = np.array([10.0, 20.0, 30.0])
    >>> motor = Frf(f, np.ones((1, 1, 3)), ("x1",), ("u",), meta={"source": "motor.csv"})
    >>> table = Frf(f[1:], -np.ones((1, 1, 2)), ("x2",), ("u",), meta={"source": "table.csv"})
    >>> both = merge_frfs([motor, table])
    >>> both.channels, both.freq_hz.tolist(), both.source
    (['x1/u', 'x2/u'], [20.0, 30.0], 'motor.csv + table.csv')
    """
    pieces = list(pieces)
    if not pieces:
        raise UsageError("merge_frfs needs at least one FRF", parameter="pieces")
    if len(pieces) == 1:
        return pieces[0]
    owner: dict[str, Frf] = {}
    for p in pieces:
        for ch in p.channels:
            if ch in owner:
                raise DataError(f"{owner[ch].source} and {p.source} both give channel {ch}; each channel comes from "
                                "one file: name each file's channel")
            owner[ch] = p
    _agree(pieces, "input unit", lambda p: p.input_unit)
    _agree(pieces, "output unit", lambda p: p.output_unit)
    for key in AGREEING_META:
        _agree(pieces, f"'{key}' record", lambda p, k=key: str(p.meta.get(k, "")))
    quantity = pieces[0].quantity
    pieces = [p.as_quantity(quantity) for p in pieces]
    lo = max(p.freq_hz[0] for p in pieces)
    hi = min(p.freq_hz[-1] for p in pieces)
    if lo > hi:
        spans = "; ".join(f"{p.source}: {_grid_text(p)}" for p in pieces)
        raise DataError(f"the files share no frequency band ({spans})")
    first = pieces[0]
    rows = {id(first): None}
    keep = None
    for p in pieces[1:]:
        ia, ib = _common_lines(first, p, lo, hi)
        keep = ia if keep is None else keep
        if not np.array_equal(ia, keep):
            raise DataError(f"{first.source}: the files share different lines; merge needs one grid")
        rows[id(p)] = ib
    rows[id(first)] = keep
    channels, coherence = {}, {}
    for p in pieces:
        idx = rows[id(p)]
        for ch in p.channels:
            channels[ch] = p.channel(ch)[idx]
            coh = p.channel_coherence(ch)
            if coh is not None and np.all(np.isfinite(coh[idx])):
                coherence[ch] = coh[idx]
    dropped = [f"{p.source} {p.freq_hz.size - rows[id(p)].size}" for p in pieces
               if p.freq_hz.size > rows[id(p)].size]
    record = "; ".join(f"{ch} from {owner[ch].source}" + (f" (scale {owner[ch].meta['scale']})"
                                                           if owner[ch].meta.get("scale") else "")
                       for ch in channels)
    if dropped:
        record += (f"; lines outside the common band {first.freq_hz[keep[0]]:.6g}-{first.freq_hz[keep[-1]]:.6g} Hz "
                   f"dropped: {', '.join(dropped)}")
    shared = {k: v for k, v in first.meta.items()
              if all(str(p.meta.get(k)) == str(v) for p in pieces[1:])
              and k not in ("source", "scale", "columns", "columns_ignored", "channel_named", "merge")}
    meta = {**shared, "source": " + ".join(p.source for p in pieces), "merge": record}
    try:
        return Frf.from_channels(first.freq_hz[keep], channels, coherence=coherence or None, quantity=quantity,
                                 input_unit=first.input_unit, output_unit=first.output_unit, meta=meta)
    except DataError as exc:
        raise DataError(f"{meta['source']}: {str(exc).split(': ', 1)[-1]}") from None
