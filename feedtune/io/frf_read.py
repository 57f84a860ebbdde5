"""Read or write an FRF file, choosing the format from the file-name extension."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from ..budget import check_file
from ..errors import DataError, UsageError
from ..frf import Frf
from ._table import check_regular_file

CSV_EXTENSIONS = (".csv", ".txt")
MAT_EXTENSIONS = (".mat",)
UFF_EXTENSIONS = (".uff", ".unv", ".uff58")
XML_EXTENSIONS = (".xml",)
FRF_EXTENSIONS = CSV_EXTENSIONS + MAT_EXTENSIONS + UFF_EXTENSIONS + XML_EXTENSIONS
READ_BYTES_PER_BYTE = {"csv": 4.0, "mat": 3.0, "uff": 40.0, "xml": 10.0}
"""Memory a reader takes per byte of the file, an upper bound measured on large files (CSV: the text and the numbers
parsed from it, 2.7 bytes measured on a 1-million-line FRF; MAT: the file and its arrays; UFF: pyuff's Python lists,
about 30; XML: the element tree of an auto-servo-tuning export); checked against the memory budget before the file is
read (:func:`feedtune.budget.check_file`)."""


def frf_format(path: str | os.PathLike[str], *, writing: bool = False) -> str:
    """``"csv"``, ``"mat"``, ``"uff"`` or ``"xml"`` (auto-servo-tuning export, read only) from the extension; other
    extensions are a :class:`DataError` (when ``writing``, and ``.xml`` then, a :class:`UsageError`)."""
    ext = Path(path).suffix.lower()
    if writing and ext in XML_EXTENSIONS:
        raise UsageError(f"{path}: feedtune reads auto-servo-tuning XML exports but writes FRFs as .csv, .mat or "
                         ".uff")
    if ext in CSV_EXTENSIONS:
        return "csv"
    if ext in MAT_EXTENSIONS:
        return "mat"
    if ext in UFF_EXTENSIONS:
        return "uff"
    if ext in XML_EXTENSIONS:
        return "xml"
    error = UsageError if writing else DataError  # an output's name is the command line's, an input's the file's
    accepted = CSV_EXTENSIONS + MAT_EXTENSIONS + UFF_EXTENSIONS if writing else FRF_EXTENSIONS
    raise error(f"{path}: unknown FRF file type {ext or '(no extension)'!r}; accepted: {', '.join(accepted)}")


def read_frf(
    path: str | os.PathLike[str],
    *,
    quantity: str | None = None,
    freq_var: str | None = None,
    channels: Mapping[str, str] | None = None,
    coherence: Mapping[str, str] | None = None,
    columns: Mapping[str, str] | None = None,
    skip_rows: int = 0,
    scale: Mapping[str, float] | None = None,
    auto_channel: str | None = None,
) -> Frf:
    """Read an FRF from CSV (``.csv``/``.txt``), MATLAB (``.mat``), UFF58 (``.uff``/``.unv``/``.uff58``) or a CNC's
    auto-servo-tuning export (``.xml``: the speed-loop plant, :mod:`feedtune.io.servo_tuning_xml`).

    Parameters
    ----------
    path : path-like
        The file.
    quantity : {"position", "velocity", "acceleration"}, optional
        What the outputs measure; overrides what the file says.
    freq_var, coherence : optional
        MATLAB only: frequency variable name [Hz] and ``{"OUT/IN": variable}`` of coherences.
    channels : mapping of str to str, optional
        MATLAB: ``{"OUT/IN": variable}``; UFF: ``{"NODE:DIR/NODE:DIR": "OUT/IN"}``.
    columns : mapping of str to str, optional
        CSV only: column map ``{NAME: COLUMN}`` for vendor headers (CLI ``--frf-map``): NAME ``freq`` (unit from
        the header, else Hz), ``freq_hz``, ``freq_khz``, ``freq_rad_s`` or ``OUT/IN.KIND`` with KIND one of ``re,
        im, mag, mag_db, phase_deg, phase_rad, coh`` (see :func:`feedtune.io.frf_csv.read_frf_csv`).
    skip_rows : int
        CSV only: lines to skip before the header row (CLI ``--frf-skip-rows``).
    scale : mapping of str to float, optional
        ``{"OUT/IN": factor}`` multiplying a channel's response after reading, any format (CLI ``--frf-scale``),
        e.g. ``{"x2/u": -1.0}`` for a load encoder counting the other way. Recorded in ``meta["scale"]``.
    auto_channel : str, optional
        CSV only: name ``OUT/IN`` of the channel of a recognised single-channel vendor header (default ``x1/u``;
        CLI ``--frf-channel``).

    Returns
    -------
    Frf
        The response, frequencies in Hz.

    Raises
    ------
    DataError
        Unknown extension or malformed file.
    UsageError
        An option that the file's format does not use, a malformed column map or scale.
    """
    fmt = frf_format(path)
    csv_only = {"columns": columns, "skip_rows": skip_rows, "auto_channel": auto_channel}
    if fmt == "csv":
        _reject_options(path, "CSV", freq_var=freq_var, channels=channels, coherence=coherence)
    elif fmt == "mat":
        _reject_options(path, "MATLAB", **csv_only)
    elif fmt == "uff":
        _reject_options(path, "UFF", freq_var=freq_var, coherence=coherence, **csv_only)
    else:
        _reject_options(path, "auto-servo-tuning XML", freq_var=freq_var, channels=channels, coherence=coherence,
                        **csv_only)
    check_regular_file(path)  # a FIFO or a device would block or never end
    check_file(path, READ_BYTES_PER_BYTE[fmt], "reading the FRF")
    if fmt == "csv":
        from .frf_csv import read_frf_csv

        frf = read_frf_csv(path, quantity=quantity, columns=columns, skip_rows=skip_rows, auto_channel=auto_channel)
    elif fmt == "mat":
        from .frf_mat import read_frf_mat

        frf = read_frf_mat(path, freq_var=freq_var, channels=channels, coherence=coherence, quantity=quantity)
    elif fmt == "uff":
        from .frf_uff import read_frf_uff

        frf = read_frf_uff(path, channels=channels, quantity=quantity)
    else:
        from .servo_tuning_xml import read_servo_tuning_frf

        frf = read_servo_tuning_frf(path, quantity=quantity)
    return scale_channels(frf, scale) if scale else frf


def scale_channels(frf: Frf, scale: Mapping[str, float]) -> Frf:
    """Multiply channels of an FRF by constant factors (a sign flip, a unit conversion).

    Parameters
    ----------
    frf : Frf
        The response.
    scale : mapping of str to float
        ``{"OUT/IN": factor}``; factors must be finite and non-zero [-].

    Returns
    -------
    Frf
        A copy with the channels scaled (coherence unchanged) and ``meta["scale"]`` recording the factors.

    Raises
    ------
    UsageError
        A factor that is not a finite non-zero number.
    DataError
        A channel the FRF does not have.
    """
    import math
    from dataclasses import replace

    response = frf.response.copy()
    for channel, factor in scale.items():
        try:
            value = float(factor)
        except (TypeError, ValueError):
            raise UsageError(f"scale {channel}={factor}: FACTOR must be a number",
                             parameter="read_frf.scale") from None
        if not math.isfinite(value) or value == 0:
            raise UsageError(f"scale {channel}={factor}: FACTOR must be finite and non-zero",
                             parameter="read_frf.scale")
        if not frf.has(channel):
            raise DataError(f"scale {channel}={factor}: {frf.source} has no channel {channel!r}; "
                            f"channels: {', '.join(frf.channels)}", parameter="read_frf.scale")
        i, j = frf.index(channel)
        response[i, j] *= value
    record = "; ".join(f"{ch}={float(v):g}" for ch, v in scale.items())
    return replace(frf, response=response, meta={**frf.meta, "scale": record})


def _reject_options(path: str | os.PathLike[str], fmt: str, **options: object) -> None:
    given = [k for k, v in options.items() if v]
    if given:
        raise UsageError(f"{path}: option(s) {', '.join(given)} do not apply to {fmt} files",
                         parameter=[f"read_frf.{k}" for k in given])


def write_frf(frf: Frf, path: str | os.PathLike[str], *, force: bool = False) -> None:
    """Write an FRF in the format given by the extension of ``path`` (CSV, MATLAB v5 or ASCII UFF58).

    Parameters
    ----------
    frf : Frf
        The response to write.
    path : path-like
        Destination file.
    force : bool
        Replace an existing file.
    """
    fmt = frf_format(path, writing=True)
    if fmt == "csv":
        from .frf_csv import write_frf_csv

        write_frf_csv(frf, path, force=force)
    elif fmt == "mat":
        from .frf_mat import write_frf_mat

        write_frf_mat(frf, path, force=force)
    else:
        from .frf_uff import write_frf_uff

        write_frf_uff(frf, path, force=force)
