"""Read or write an FRF file, choosing the format from the file-name extension."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from ..errors import DataError, UsageError
from ..frf import Frf

CSV_EXTENSIONS = (".csv", ".txt")
MAT_EXTENSIONS = (".mat",)
UFF_EXTENSIONS = (".uff", ".unv", ".uff58")
FRF_EXTENSIONS = CSV_EXTENSIONS + MAT_EXTENSIONS + UFF_EXTENSIONS


def frf_format(path: str | os.PathLike[str]) -> str:
    """``"csv"``, ``"mat"`` or ``"uff"`` from the extension; other extensions are a :class:`DataError`."""
    ext = Path(path).suffix.lower()
    if ext in CSV_EXTENSIONS:
        return "csv"
    if ext in MAT_EXTENSIONS:
        return "mat"
    if ext in UFF_EXTENSIONS:
        return "uff"
    raise DataError(f"{path}: unknown FRF file type {ext or '(no extension)'!r}; "
                    f"accepted: {', '.join(FRF_EXTENSIONS)}")


def read_frf(
    path: str | os.PathLike[str],
    *,
    quantity: str | None = None,
    freq_var: str | None = None,
    channels: Mapping[str, str] | None = None,
    coherence: Mapping[str, str] | None = None,
) -> Frf:
    """Read an FRF from CSV (``.csv``/``.txt``), MATLAB (``.mat``) or UFF58 (``.uff``/``.unv``/``.uff58``).

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

    Returns
    -------
    Frf
        The response, frequencies in Hz.

    Raises
    ------
    DataError
        Unknown extension or malformed file.
    UsageError
        An option that the file's format does not use.
    """
    fmt = frf_format(path)
    if fmt == "csv":
        _reject_options(path, "CSV", freq_var=freq_var, channels=channels, coherence=coherence)
        from .frf_csv import read_frf_csv

        return read_frf_csv(path, quantity=quantity)
    if fmt == "mat":
        from .frf_mat import read_frf_mat

        return read_frf_mat(path, freq_var=freq_var, channels=channels, coherence=coherence,
                            quantity=quantity)
    _reject_options(path, "UFF", freq_var=freq_var, coherence=coherence)
    from .frf_uff import read_frf_uff

    return read_frf_uff(path, channels=channels, quantity=quantity)


def _reject_options(path: str | os.PathLike[str], fmt: str, **options: object) -> None:
    given = [k for k, v in options.items() if v]
    if given:
        raise UsageError(f"{path}: option(s) {', '.join(given)} do not apply to {fmt} files")


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
    fmt = frf_format(path)
    if fmt == "csv":
        from .frf_csv import write_frf_csv

        write_frf_csv(frf, path, force=force)
    elif fmt == "mat":
        from .frf_mat import write_frf_mat

        write_frf_mat(frf, path, force=force)
    else:
        from .frf_uff import write_frf_uff

        write_frf_uff(frf, path, force=force)
