"""Options shared by every command that reads FRF files, and the functions that apply them.

A command declares the options as parameters with these defaults and passes the values on::

    from .frf_options import FRF_CHANNEL_OPTION, FRF_INPUT_UNIT_OPTION, FRF_MAP_OPTION, FRF_SCALE_OPTION, ...

    def cmd(frf: Path = ..., frf_map: list[str] = FRF_MAP_OPTION, frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
            frf_scale: list[str] = FRF_SCALE_OPTION, frf_channel: str = FRF_CHANNEL_OPTION,
            frf_input_unit: str = FRF_INPUT_UNIT_OPTION):
        options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
        measured = read_optional_frf(frf, quantity, options=options)

``--frf-map NAME=COLUMN`` (CSV column map: ``freq``, ``freq_hz``, ``freq_khz``, ``freq_rad_s`` or ``OUT/IN.KIND``),
``--frf-skip-rows N`` (CSV preambles), ``--frf-scale OUT/IN=FACTOR`` (any format, e.g. ``x2/u=-1``),
``--frf-channel OUT/IN`` (the name of a recognised single-channel vendor header, default ``x1/u``) and
``--frf-input-unit UNIT`` (the unit of the drive command the FRFs are measured from) apply to every FRF file the
command reads; see :func:`feedtune.io.read_frf` and docs/formats.md.

**One FRF from one file per channel.** Wherever a command takes an FRF file, it takes ``FILE:SPEC`` pieces joined
with ``+`` (:func:`parse_frf_argument`, :func:`read_frf_argument`)::

    feedtune identify ballscrew motor.csv:x1/u+table.csv:x2/u,scale=-1,in=A

SPEC is comma-separated: the channel ``OUT/IN`` the file holds (a single-channel file is named so, a file of several
channels gives that one), ``scale=FACTOR``, ``in=UNIT`` (input unit), ``out=UNIT`` (output position unit) and
``quantity=position|velocity|acceleration``. The pieces are merged into one FRF on their common lines
(:func:`feedtune.frf_merge.merge_frfs`); the global options apply to every piece, ``--frf-scale`` to the merged FRF.
Several FRF arguments stay several FRFs (``tune --frf A --frf B``); ``identify ballscrew`` refuses two or more
single-channel files none of which is named (:func:`check_named_channels`): they would all read as ``x1/u``.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import typer

FRF_MAP_OPTION = typer.Option(
    None, "--frf-map", metavar="NAME=COLUMN",
    help="FRF CSV column map (repeatable): NAME is freq (unit from the header, else Hz), freq_hz, freq_khz, "
    "freq_rad_s or OUT/IN.KIND with KIND re, im, mag, mag_db, phase_deg, phase_rad or coh, e.g. "
    "x1/u.mag_db='Magnitude [dB]'. Only the mapped channels are read.",
)
FRF_SKIP_ROWS_OPTION = typer.Option(
    0, "--frf-skip-rows", min=0, metavar="N", help="FRF CSV: lines to skip before the header row (vendor preambles)."
)
FRF_SCALE_OPTION = typer.Option(
    None, "--frf-scale", metavar="OUT/IN=FACTOR",
    help="Multiply an FRF channel (repeatable, any format), e.g. x2/u=-1 for a load encoder counting the other way.",
)
FRF_INPUT_UNIT_OPTION = typer.Option(
    None, "--frf-input-unit", metavar="UNIT",
    help="Input unit of every FRF file (the drive command: V, A, N) where the file does not say it (default V); a "
    "piece's in=UNIT sets one file's.",
)
FRF_CHANNEL_OPTION = typer.Option(
    None, "--frf-channel", metavar="OUT/IN",
    help="Channel name of an FRF CSV whose single-channel vendor header (frequency, magnitude + phase or real + "
    "imaginary, coherence) is recognised without --frf-map (default x1/u).",
)


@dataclass(frozen=True)
class FrfReadOptions:
    """Parsed FRF-reading options (see :func:`feedtune.io.read_frf` for their meaning).

    Attributes
    ----------
    columns : dict of str to str or None
        ``{NAME: COLUMN}`` from ``--frf-map``.
    skip_rows : int
        CSV lines skipped before the header (``--frf-skip-rows``).
    scale : dict of str to float or None
        ``{"OUT/IN": factor}`` [-] from ``--frf-scale``.
    channel : str or None
        Channel name of a recognised single-channel vendor header (``--frf-channel``).
    input_unit : str or None
        Input unit of every FRF file (``--frf-input-unit``), e.g. ``"A"``.
    """

    columns: dict[str, str] | None = None
    skip_rows: int = 0
    scale: dict[str, float] | None = None
    channel: str | None = None
    input_unit: str | None = None

    @classmethod
    def from_cli(
        cls,
        frf_map: list[str] | None = None,
        frf_skip_rows: int = 0,
        frf_scale: list[str] | None = None,
        frf_channel: str | None = None,
        frf_input_unit: str | None = None,
    ) -> FrfReadOptions:
        """Parse the raw option values; a malformed item is a UsageError naming the option."""
        from ..errors import UsageError
        from ..io.frf_csv import check_channel_name, parse_column_map
        from .log_options import parse_assignments

        if isinstance(frf_skip_rows, bool) or not isinstance(frf_skip_rows, int) or frf_skip_rows < 0:
            raise UsageError(f"--frf-skip-rows expects an integer >= 0, got {frf_skip_rows!r}")
        columns = parse_assignments(frf_map, "--frf-map", "COLUMN") or None
        if columns is not None and frf_channel is not None:
            raise UsageError("--frf-channel names the channel of a recognised vendor header; with --frf-map the "
                             "map names the channels (OUT/IN.KIND=COLUMN)")
        if columns is not None:
            parse_column_map(columns)
        scale = {}
        for channel, text in parse_assignments(frf_scale, "--frf-scale", "FACTOR").items():
            check_channel_name(channel, f"--frf-scale {channel}={text}:")
            scale[channel] = _factor(text, f"--frf-scale {channel}={text}")
        channel = None if frf_channel is None else check_channel_name(frf_channel, "--frf-channel")
        unit = None if frf_input_unit is None else _unit(frf_input_unit, "--frf-input-unit")
        return cls(columns, frf_skip_rows, scale or None, channel, unit)

    def kwargs(self) -> dict:
        """Keyword arguments of :func:`feedtune.io.read_frf` for these options (the scale is applied after a
        merge, :func:`read_frf_argument`)."""
        return {"columns": self.columns, "skip_rows": self.skip_rows, "auto_channel": self.channel}


def _factor(text: str, where: str) -> float:
    """A finite non-zero number, else a UsageError naming ``where``."""
    from .log_options import factor_value

    return factor_value(text, where)


def _unit(text: str, where: str) -> str:
    """A unit as written (``A``, ``N*m``), else a UsageError naming ``where``."""
    from ..errors import UsageError

    unit = str(text).strip()
    if not unit or any(c in unit for c in ',"[]#\n'):
        raise UsageError(f"{where} expects a unit such as V, A or N, got {text!r}")
    return unit


# ------------------------------------------------------------------------------------------ FILE:SPEC pieces
PIECE_KEYS = ("scale", "in", "out", "quantity")
"""Keys of a piece's SPEC besides its channel: ``scale=FACTOR``, ``in=UNIT``, ``out=UNIT``, ``quantity=Q``."""

_CHANNEL_RE = re.compile(r"^[^\s/=,:+]+/[^\s/=,:+]+$")
_SYNTAX = ("FILE:OUT/IN[,scale=FACTOR][,in=UNIT][,out=UNIT][,quantity=Q], pieces joined with +, e.g. "
           "motor.csv:x1/u+table.csv:x2/u,scale=-1")


@dataclass(frozen=True)
class FrfPiece:
    """One FRF file of an FRF argument, with what its SPEC says about it.

    Attributes
    ----------
    path : Path
        The file.
    channel : str or None
        ``OUT/IN`` the file holds (renames a single channel, selects one of several).
    scale : float or None
        Factor [-] on the file's channel (``scale=-1``: a load encoder counting the other way).
    input_unit, output_unit : str or None
        Units of the input (drive command) and of the position output, where the file does not say them.
    quantity : str or None
        What the file's output measures (position, velocity, acceleration).
    """

    path: Path
    channel: str | None = None
    scale: float | None = None
    input_unit: str | None = None
    output_unit: str | None = None
    quantity: str | None = None

    @property
    def has_spec(self) -> bool:
        """Whether the argument said anything about this file beyond its name."""
        return any(v is not None for v in (self.channel, self.scale, self.input_unit, self.output_unit,
                                           self.quantity))


def _parse_spec(text: str, where: str, strict: bool) -> dict | None:
    """The items of a SPEC (``x2/u,scale=-1``) as FrfPiece fields; None (or, ``strict``, a UsageError naming the
    bad item) when ``text`` is not one."""
    from ..errors import UsageError

    fields: dict[str, object] = {}
    items = [i.strip() for i in text.split(",")]

    def bad(why: str):
        if strict:
            raise UsageError(f"{where}: {why}; an FRF file is given as {_SYNTAX}")
        return None

    if not items or not all(items):
        return bad(f"empty item in {text!r}")
    for item in items:
        key, eq, value = item.partition("=")
        if not eq:
            if not _CHANNEL_RE.match(item):
                return bad(f"{item!r} is neither a channel OUT/IN nor KEY=VALUE")
            if "channel" in fields:
                return bad(f"two channels ({fields['channel']}, {item})")
            fields["channel"] = item
            continue
        key, value = key.strip(), value.strip()
        if key not in PIECE_KEYS or not value:
            return bad(f"{item!r}: KEY is one of {', '.join(PIECE_KEYS)}, with a value")
        name = {"in": "input_unit", "out": "output_unit"}.get(key, key)
        if name in fields:
            return bad(f"{key} given twice")
        if key == "scale":
            try:
                fields[name] = _factor(value, f"{where}: scale={value}")
            except UsageError:
                if strict:
                    raise
                return None
        elif key == "quantity":
            try:
                fields[name] = quantity_option(value)
            except UsageError:
                return bad(f"quantity={value}: expected position, velocity or acceleration")
        else:
            fields[name] = _unit(value, f"{where}: {key}=")
    return fields


def _piece(text: str, strict: bool, base: Path | None = None) -> FrfPiece | None:
    """``FILE`` or ``FILE:SPEC`` as a piece; None when ``text`` is neither an existing file nor ends in a SPEC (a
    relative FILE looked for in ``base`` when given)."""
    path = Path(text)
    if _exists(path, base):
        return FrfPiece(path)
    head, colon, tail = text.rpartition(":")
    if not colon or not head:
        return FrfPiece(path) if strict else None
    fields = _parse_spec(tail, text, strict=strict and _exists(Path(head), base))
    if fields is None:
        return FrfPiece(path) if strict else None
    return FrfPiece(Path(head), **fields)


def _exists(path: Path, base: Path | None) -> bool:
    return (path if base is None or path.is_absolute() else base / path).exists()


def parse_frf_argument(text: str | os.PathLike[str], base: Path | None = None) -> list[FrfPiece]:
    """The files of one FRF argument: ``FILE``, ``FILE:SPEC``, or such pieces joined with ``+`` (module docstring).

    An existing file of that name is always the file itself (a name may hold ``:`` or ``+``). Otherwise the text is cut
    at each ``+`` that follows a complete piece (a SPEC may hold a ``+``, as in ``scale=1e+3``, and a file name too).

    Parameters
    ----------
    text : str or path-like
        The argument as typed.
    base : Path, optional
        The folder relative file names are in (a project file's; default the current folder). The pieces keep the
        names as written.

    Returns
    -------
    list of FrfPiece
        One piece per file, in order.

    Raises
    ------
    UsageError
        A SPEC after an existing file that does not parse (the message names the item and the syntax), a piece
        without a channel in a join.
    """
    text = str(text)
    if _exists(Path(text), base) or "+" not in text:
        return [_piece(text, strict=True, base=base)]
    pieces: list[FrfPiece] = []
    parts = text.split("+")
    pending = ""
    for k, part in enumerate(parts):
        pending = part if not pending else f"{pending}+{part}"
        last = k == len(parts) - 1
        piece = _piece(pending, strict=last, base=base)
        if piece is not None:
            pieces.append(piece)
            pending = ""
    check_pieces_named(pieces, text)
    return pieces


def check_pieces_named(pieces: list[FrfPiece], where: str) -> None:
    """UsageError when several pieces are merged and one of them does not name its channel."""
    from ..errors import UsageError

    unnamed = [str(p.path) for p in pieces if p.channel is None]
    if len(pieces) > 1 and unnamed:
        raise UsageError(f"{where}: name the channel of every file merged into one FRF ({', '.join(unnamed)} has "
                         f"none); an FRF file is given as {_SYNTAX}")


def _read_piece(piece: FrfPiece, quantity, mat_freq, mat_channel, options: FrfReadOptions):
    """One piece read with the global options, then named, scaled and given its units by its SPEC."""
    from dataclasses import replace

    from ..frf_merge import pick_channel
    from ..io import read_frf
    from ..io.frf_read import scale_channels

    kwargs = options.kwargs()
    frf = read_frf(piece.path, quantity=piece.quantity or quantity, freq_var=mat_freq,
                   channels=mat_channels(mat_channel), **kwargs)
    if piece.channel is not None:
        frf = pick_channel(frf, piece.channel)
    if piece.scale is not None:
        frf = scale_channels(frf, {frf.channels[0]: piece.scale}) if len(frf.channels) == 1 else \
            _scale_error(piece)
    units = {k: v for k, v in (("input_unit", piece.input_unit or options.input_unit),
                               ("output_unit", piece.output_unit)) if v is not None}
    if units:
        frf = replace(frf, **units)
    return frf


def _column_note(path, frf) -> str | None:
    """The note naming the columns of a vendor header recognised without ``--frf-map``, else None."""
    from ..io.frf_csv import RECOGNISED_FORMAT

    if frf.meta.get("format") != RECOGNISED_FORMAT:
        return None
    ignored = frf.meta.get("columns_ignored")
    return (f"feedtune: note: {path}: columns read as {frf.meta['columns']}"
            + (f"; ignored: {ignored}" if ignored else "") + " (--frf-map to choose others)")


def _scale_error(piece: FrfPiece):
    from ..errors import UsageError

    raise UsageError(f"{piece.path}: scale= applies to one channel; this file holds several: name the channel "
                     f"(FILE:OUT/IN,scale=FACTOR)")


def read_frf_argument(text, quantity=None, mat_freq=None, mat_channel=None,
                      options: FrfReadOptions | None = None, *, note: bool = True):
    """Read one FRF argument (``FILE`` or ``FILE:SPEC`` pieces joined with ``+``) with the shared FRF options.

    Parameters
    ----------
    text : str or path-like
        The argument as typed (:func:`parse_frf_argument`).
    quantity : str, optional
        ``--quantity`` (position, velocity, acceleration); a piece's ``quantity=`` overrides it for its file.
    mat_freq, mat_channel : optional
        ``--mat-freq`` and the ``--mat-channel`` items of MATLAB files.
    options : FrfReadOptions, optional
        ``--frf-map``, ``--frf-skip-rows``, ``--frf-scale``, ``--frf-channel``, ``--frf-input-unit``.
    note : bool
        Print one note line on stderr naming the columns of a vendor header recognised without ``--frf-map`` (and,
        for merged pieces, the lines outside their common band that were dropped).

    Returns
    -------
    Frf
        The response, frequencies in Hz; pieces merged (:func:`feedtune.frf_merge.merge_frfs`), ``--frf-scale``
        applied to the result.
    """
    return read_frf_pieces(parse_frf_argument(text), quantity, mat_freq, mat_channel, options, note=note)


def read_frf_pieces(pieces: list[FrfPiece], quantity=None, mat_freq=None, mat_channel=None,
                    options: FrfReadOptions | None = None, *, note: bool = True):
    """Read FRF pieces and merge them into one FRF (:func:`read_frf_argument`, ``feedtune frf merge``)."""
    from ..frf_merge import merge_frfs
    from ..io.frf_read import scale_channels

    options = options or FrfReadOptions()
    quantity = quantity_option(quantity)
    frfs = [_read_piece(p, quantity, mat_freq, mat_channel, options) for p in pieces]
    frf = merge_frfs(frfs)
    frf = scale_channels(frf, options.scale) if options.scale else frf
    if note:  # once the FRF is read whole: an error is then the only line
        notes = [_column_note(p.path, f) for p, f in zip(pieces, frfs, strict=True)]
        if len(frfs) > 1 and "dropped" in str(frf.meta.get("merge", "")):
            notes.append(f"feedtune: note: {frf.meta['merge']}")
        for line in filter(None, notes):
            typer.echo(line, err=True)
    return frf


def read_frf_with_options(path, quantity=None, mat_freq=None, mat_channel=None,
                          options: FrfReadOptions | None = None, *, note: bool = True):
    """Read an FRF argument with the shared FRF options (:func:`read_frf_argument`)."""
    return read_frf_argument(path, quantity, mat_freq, mat_channel, options, note=note)


def check_named_channels(arguments, frfs) -> None:
    """UsageError when two or more FRF files each hold one channel that no one named (:data:`CHANNEL_DEFAULTED`):
    they would all be read as ``x1/u``, the motor side, whatever encoder measured them.

    Parameters
    ----------
    arguments : sequence
        The FRF arguments as typed.
    frfs : sequence of Frf
        What :func:`read_frf_argument` read from each.
    """
    from ..errors import UsageError
    from ..io.frf_csv import CHANNEL_DEFAULTED

    unnamed = [str(a) for a, f in zip(arguments, frfs, strict=True)
               if f.meta.get("channel_named") == CHANNEL_DEFAULTED]
    if len(unnamed) >= 2:
        example = " ".join(f"{a}:x{k + 1}/u" for k, a in enumerate(unnamed[:2]))
        raise UsageError(f"{', '.join(unnamed)}: each file holds one channel and none is named, so all would be read "
                         f"as {frfs[0].channels[0]}; name the channel of each file, e.g. {example} (or --frf-channel "
                         "when all measure the same channel)")


def mat_channels(items: list[str] | None) -> dict[str, str] | None:
    """``["x2/u=H2", ...]`` -> ``{"x2/u": "H2"}``; UsageError on a malformed item."""
    from ..errors import UsageError

    if not items:
        return None
    out = {}
    for it in items:
        name, sep, var = it.partition("=")
        if not sep or not name or not var:
            raise UsageError(f"--mat-channel expects CHANNEL=VARIABLE (e.g. x2/u=H2), got {it!r}")
        out[name.strip()] = var.strip()
    return out


def quantity_option(quantity: str | None) -> str | None:
    """The ``--quantity`` option as a canonical quantity (position, velocity, acceleration); UsageError otherwise."""
    if quantity is None:
        return None
    from ..errors import DataError, UsageError
    from ..frf import normalize_quantity

    try:
        return normalize_quantity(quantity, "--quantity")
    except DataError as exc:
        raise UsageError(str(exc)) from None


def read_optional_frf(path, quantity=None, mat_freq=None, mat_channel=None, *, warn: bool = True,
                      options: FrfReadOptions | None = None):
    """Read an FRF argument when one is given, else None.

    With ``warn``, prints one warning line on stderr when the file still contains the zero-order hold and the
    computational delay of a sampled log (the discrete analysis case would count them twice), and the note of
    :func:`read_frf_argument` on a recognised vendor header. ``options`` are the shared FRF options.
    """
    quantity = quantity_option(quantity)
    if path is None:
        return None
    frf = read_frf_argument(path, quantity, mat_freq, mat_channel, options, note=warn)
    if warn:
        warn_sampling(frf, path)
    return frf


def warn_sampling(frf, path) -> None:
    """Print one warning line when an FRF file still contains the ZOH and delay of a sampled log (also in the
    ``--json`` envelope's ``warnings``)."""
    from ..frf_sampling import double_counting_warning
    from .envelope import warn

    msg = None if frf is None else double_counting_warning(frf, path)
    if msg:
        warn(msg)
