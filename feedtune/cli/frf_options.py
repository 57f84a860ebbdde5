"""Options shared by every command that reads FRF files, and the functions that apply them.

A command declares the options as parameters with these defaults and passes the values on::

    from .frf_options import FRF_CHANNEL_OPTION, FRF_MAP_OPTION, FRF_SCALE_OPTION, FRF_SKIP_ROWS_OPTION

    def cmd(frf: Path = ..., frf_map: list[str] = FRF_MAP_OPTION, frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
            frf_scale: list[str] = FRF_SCALE_OPTION, frf_channel: str = FRF_CHANNEL_OPTION):
        options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel)
        measured = read_optional_frf(frf, quantity, options=options)

``--frf-map NAME=COLUMN`` (CSV column map: ``freq``, ``freq_hz``, ``freq_khz``, ``freq_rad_s`` or ``OUT/IN.KIND``),
``--frf-skip-rows N`` (CSV preambles), ``--frf-scale OUT/IN=FACTOR`` (any format, e.g. ``x2/u=-1``) and
``--frf-channel OUT/IN`` (the name of a recognised single-channel vendor header, default ``x1/u``) apply to every
FRF file the command reads; see :func:`feedtune.io.read_frf` and docs/formats.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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
    """

    columns: dict[str, str] | None = None
    skip_rows: int = 0
    scale: dict[str, float] | None = None
    channel: str | None = None

    @classmethod
    def from_cli(
        cls,
        frf_map: list[str] | None = None,
        frf_skip_rows: int = 0,
        frf_scale: list[str] | None = None,
        frf_channel: str | None = None,
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
            try:
                value = float(text)
            except ValueError:
                raise UsageError(f"--frf-scale {channel}={text}: FACTOR must be a number") from None
            if not math.isfinite(value) or value == 0:
                raise UsageError(f"--frf-scale {channel}={text}: FACTOR must be finite and non-zero")
            scale[channel] = value
        channel = None if frf_channel is None else check_channel_name(frf_channel, "--frf-channel")
        return cls(columns, frf_skip_rows, scale or None, channel)

    def kwargs(self) -> dict:
        """Keyword arguments of :func:`feedtune.io.read_frf` for these options."""
        return {"columns": self.columns, "skip_rows": self.skip_rows, "scale": self.scale,
                "auto_channel": self.channel}


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


def read_frf_with_options(path, quantity=None, mat_freq=None, mat_channel=None,
                          options: FrfReadOptions | None = None, *, note: bool = True):
    """Read an FRF file with the shared FRF options.

    Parameters
    ----------
    path : path-like
        The FRF file (CSV, MATLAB, UFF58).
    quantity : str, optional
        ``--quantity`` (position, velocity, acceleration).
    mat_freq, mat_channel : optional
        ``--mat-freq`` and the ``--mat-channel`` items of MATLAB files.
    options : FrfReadOptions, optional
        ``--frf-map``, ``--frf-skip-rows``, ``--frf-scale``, ``--frf-channel``.
    note : bool
        Print one note line on stderr naming the columns of a vendor header recognised without ``--frf-map``.

    Returns
    -------
    Frf
        The response, frequencies in Hz.
    """
    from ..io import read_frf
    from ..io.frf_csv import RECOGNISED_FORMAT

    options = options or FrfReadOptions()
    frf = read_frf(path, quantity=quantity_option(quantity), freq_var=mat_freq, channels=mat_channels(mat_channel),
                   **options.kwargs())
    if note and frf.meta.get("format") == RECOGNISED_FORMAT:
        ignored = frf.meta.get("columns_ignored")
        typer.echo(f"feedtune: note: {path}: columns read as {frf.meta['columns']}"
                   + (f"; ignored: {ignored}" if ignored else "") + " (--frf-map to choose others)", err=True)
    return frf


def read_optional_frf(path, quantity=None, mat_freq=None, mat_channel=None, *, warn: bool = True,
                      options: FrfReadOptions | None = None):
    """Read an FRF file when a path is given, else None.

    With ``warn``, prints one warning line on stderr when the file still contains the zero-order hold and the
    computational delay of a sampled log (the discrete analysis case would count them twice), and the note of
    :func:`read_frf_with_options` on a recognised vendor header. ``options`` are the shared FRF options.
    """
    quantity = quantity_option(quantity)
    if path is None:
        return None
    frf = read_frf_with_options(path, quantity, mat_freq, mat_channel, options, note=warn)
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
