"""Parsing of FRF-reader options shared by several commands."""

from __future__ import annotations


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


def read_optional_frf(path, quantity=None, mat_freq=None, mat_channel=None, *, warn: bool = True):
    """Read an FRF file when a path is given, else None.

    With ``warn``, prints one warning line on stderr when the file still contains the zero-order hold and the
    computational delay of a sampled log (the discrete analysis case would count them twice).
    """
    quantity = quantity_option(quantity)
    if path is None:
        return None
    from ..io import read_frf

    frf = read_frf(path, quantity=quantity, freq_var=mat_freq, channels=mat_channels(mat_channel))
    if warn:
        warn_sampling(frf, path)
    return frf


def warn_sampling(frf, path) -> None:
    """Print one warning line when an FRF file still contains the ZOH and delay of a sampled log."""
    import typer

    from ..frf_sampling import double_counting_warning

    msg = None if frf is None else double_counting_warning(frf, path)
    if msg:
        typer.echo(f"feedtune: warning: {msg}", err=True)
