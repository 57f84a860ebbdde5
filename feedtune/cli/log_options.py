"""Options shared by every command that reads a log, and the one function that applies them.

A command declares the options as parameters with these defaults and passes the values on::

    from .log_options import (FS_OPTION, MAP_OPTION, SCALE_OPTION, SKIP_ROWS_OPTION, TIME_OPTION,
                              UNIT_OPTION, read_log_with_options)

    def prefilter(log_file: Path = typer.Argument(...), map_: list[str] = MAP_OPTION, fs: float = FS_OPTION,
                  time: str = TIME_OPTION, scale: list[str] = SCALE_OPTION, unit: list[str] = UNIT_OPTION,
                  skip_rows: int = SKIP_ROWS_OPTION):
        log = read_log_with_options(log_file, map_, fs, time, scale, unit, skip_rows)

``--map NAME=COLUMN`` (rename; MATLAB ``var[k]`` picks a matrix column), ``--fs HZ`` (uniform time base
when the log has no usable time column), ``--time COLUMN``, ``--scale NAME=FACTOR`` (e.g. V to N),
``--unit NAME=UNIT`` and ``--skip-rows N`` (CSV preambles). Files: CSV/TXT, MATLAB ``.mat`` (v5, v7.3)
and MDF4 ``.mf4`` (needs ``pip install feedtune[mdf]``); see :func:`feedtune.io.read_log`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import typer

MAP_OPTION = typer.Option(
    None, "--map", metavar="NAME=COLUMN",
    help="Rename a column: NAME=COLUMN (repeatable); MATLAB matrix columns as NAME=var[k] (0-based).",
)
FS_OPTION = typer.Option(None, "--fs", metavar="HZ", help="Sample rate [Hz] for logs without a usable time column.")
TIME_OPTION = typer.Option(None, "--time", metavar="COLUMN", help="Name of the time column (default t or time) [s].")
SCALE_OPTION = typer.Option(
    None, "--scale", metavar="NAME=FACTOR",
    help="Multiply a signal after renaming: NAME=FACTOR (repeatable), e.g. u=35.15 for V to N.",
)
UNIT_OPTION = typer.Option(
    None, "--unit", metavar="NAME=UNIT",
    help="Unit of a signal: NAME=UNIT (repeatable), e.g. u=N, x=m.",
)
SKIP_ROWS_OPTION = typer.Option(0, "--skip-rows", min=0, metavar="N", help="CSV: lines to skip before the header row.")


@dataclass(frozen=True)
class LogOptions:
    """Parsed log-reading options (see :func:`feedtune.io.read_log` for their meaning).

    Attributes
    ----------
    mapping : dict of str to str
        ``{NEW_NAME: COLUMN}`` from ``--map``.
    fs : float or None
        Sample rate [Hz] from ``--fs``.
    time : str or None
        Time column from ``--time``.
    scale : dict of str to float
        ``{NAME: factor}`` from ``--scale``.
    units : dict of str to str
        ``{NAME: unit}`` from ``--unit``.
    skip_rows : int
        CSV lines skipped before the header.
    """

    mapping: dict[str, str] = field(default_factory=dict)
    fs: float | None = None
    time: str | None = None
    scale: dict[str, float] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    skip_rows: int = 0

    @classmethod
    def from_cli(
        cls,
        map_: list[str] | None = None,
        fs: float | None = None,
        time: str | None = None,
        scale: list[str] | None = None,
        unit: list[str] | None = None,
        skip_rows: int = 0,
    ) -> LogOptions:
        """Parse the raw option values; a malformed item is a UsageError naming the option."""
        from ..errors import UsageError
        from ..io.log_read import FS_MAX_HZ

        if fs is not None and not (math.isfinite(fs) and 0 < fs <= FS_MAX_HZ):
            raise UsageError(f"--fs expects a sample rate in (0, {FS_MAX_HZ / 1e6:g} MHz], got {fs:g}")
        if isinstance(skip_rows, bool) or not isinstance(skip_rows, int) or skip_rows < 0:
            raise UsageError(f"--skip-rows expects an integer >= 0, got {skip_rows!r}")
        if time is not None and not time.strip():
            raise UsageError("--time expects a column name, got an empty string")
        factors = {name: scale_factor(name, text)
                   for name, text in parse_assignments(scale, "--scale", "FACTOR").items()}
        return cls(
            mapping=parse_assignments(map_, "--map", "COLUMN"),
            fs=fs,
            time=None if time is None else time.strip(),
            scale=factors,
            units=parse_assignments(unit, "--unit", "UNIT"),
            skip_rows=skip_rows,
        )

    def read(self, path: str | os.PathLike[str], *, note: bool = True):
        """Read ``path`` with these options; returns a :class:`~feedtune.log.Log`. With ``note``, what the reader
        did beyond the options (rows dropped, a time base in ticks) is one note line each on stderr
        (:func:`log_notes`)."""
        from ..io import read_log

        log = read_log(path, mapping=self.mapping or None, fs=self.fs, time=self.time,
                       scale=self.scale or None, units=self.units or None, skip_rows=self.skip_rows)
        if note:
            for line in log_notes(log):
                typer.echo(f"feedtune: note: {path}: {line}", err=True)
        return log


def log_notes(log) -> list[str]:
    """What the reader did to a log beyond the options, for this read (``meta["read_notes"]``): rows dropped (NaN in
    every column, after a stopped counter), the time base of a time column in ticks."""
    return [str(n) for n in log.meta.get("read_notes", ())]


def parse_assignments(items: list[str] | None, option: str, value_name: str) -> dict[str, str]:
    """``["a=b", ...]`` -> ``{"a": "b"}``; UsageError for an item without ``=``, an empty side or a repeat.

    Parameters
    ----------
    items : list of str or None
        Raw option values.
    option : str
        Option name for messages (``"--map"``).
    value_name : str
        What the right-hand side is (``"COLUMN"``), for messages.
    """
    from ..errors import UsageError

    out: dict[str, str] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise UsageError(f"{option} expects NAME={value_name}, got {item!r}")
        if name in out:
            raise UsageError(f"{option} names {name!r} twice")
        out[name] = value
    return out


def scale_factor(name: str, text: str) -> float:
    """The FACTOR of ``--scale NAME=FACTOR``: a finite non-zero number (UsageError otherwise)."""
    return factor_value(text, f"--scale {name}={text}")


def factor_value(text: str, where: str) -> float:
    """A FACTOR of an option: a finite non-zero number, else a UsageError naming ``where`` (``--scale u=abc``)."""
    from ..errors import UsageError

    try:
        value = float(text)
    except ValueError:
        raise UsageError(f"{where}: FACTOR must be a number") from None
    if not math.isfinite(value) or value == 0:
        raise UsageError(f"{where}: FACTOR must be finite and non-zero")
    return value


def read_log_with_options(
    path: str | os.PathLike[str],
    map_: list[str] | None = None,
    fs: float | None = None,
    time: str | None = None,
    scale: list[str] | None = None,
    unit: list[str] | None = None,
    skip_rows: int = 0,
):
    """Read a log (CSV, MATLAB, MDF4) applying the raw values of the shared log options.

    Parameters
    ----------
    path : path-like
        The log file.
    map_, fs, time, scale, unit, skip_rows
        Raw values of ``--map``, ``--fs`` [Hz], ``--time``, ``--scale``, ``--unit``, ``--skip-rows``.

    Returns
    -------
    Log
        Time [s] and the signals, renamed, scaled and with units.

    Raises
    ------
    UsageError
        Malformed option (``--map x``, ``--scale u=abc``...).
    DataError
        Missing or unreadable file, unknown file type, missing column, no time base.
    """
    return LogOptions.from_cli(map_, fs, time, scale, unit, skip_rows).read(path)
