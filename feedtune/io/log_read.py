"""Read time-series logs (CSV, MATLAB v5/v7.3, MDF4) into a :class:`~feedtune.log.Log`.

Each format's reader produces a :class:`RawLog` (the file's columns as found); :func:`assemble_log` then
applies the user's options the same way for every format:

1. time base: the column named by ``time`` (a file column or a name given in ``mapping``), else a column
   ``t``/``time`` (any case), else a mapped name ``t``/``time``; with ``fs`` [Hz] the time is
   ``arange(n) / fs`` instead (``fs`` is required when there is no time column);
2. ``mapping`` ``{NEW_NAME: COLUMN}`` renames (and for MATLAB ``var[k]`` picks column ``k`` of a matrix);
   the other columns keep their names;
3. ``scale`` ``{NAME: factor}`` multiplies signals (or the time, key ``t`` or the time column's name);
4. ``units`` ``{NAME: unit}`` sets units.

A time column must give a plausible sample rate for a servo log, between :data:`FS_MIN_HZ` (100 Hz: slower logs
cannot resolve the mechanics) and :data:`FS_MAX_HZ` (10 MHz), whether the file states its unit, the user scales it
or nobody says (then a time in ms read as s, 1000x too slow, is caught); otherwise it is a
:class:`~feedtune.errors.DataError` naming the file, the column and the fix (:func:`check_time_base`); a uniform
time base given with ``fs`` is taken as it is. Integer time stamps with a step of 100..10000 look like microseconds
(``--scale t=1e-6``), with a step of 1..10 like milliseconds (``--scale t=1e-3``).

A log is refused rather than read wrong: a column name given twice (which one is the signal?), a complex signal, a
vector a little shorter or longer than the time base (a channel cut short) are errors naming the column, unless a
``mapping`` says which column to use.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataError, UsageError
from ..log import Log

CSV_EXTENSIONS = (".csv", ".txt")
MAT_EXTENSIONS = (".mat",)
MDF_EXTENSIONS = (".mf4", ".mdf")
LOG_EXTENSIONS = CSV_EXTENSIONS + MAT_EXTENSIONS + MDF_EXTENSIONS
READ_BYTES_PER_BYTE = {"csv": 2.0, "mat": 3.0, "mdf": 4.0}
"""Memory a reader takes per byte of the file, an upper bound (CSV: the numbers parsed straight from the file, 1.1
bytes measured on a 300 MB log; MAT, MDF: the file and its arrays); checked against the memory budget before the file
is read (:func:`feedtune.budget.check_file`)."""
TIME_NAMES = ("t", "time")
TIME_UNIT_FACTORS = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ns": 1e-9}
#: Plausible sample rates [Hz] of a servo log's time base; outside them the unit is wrong (or the log is no servo log).
FS_MIN_HZ = 100.0
FS_MAX_HZ = 10e6
#: A vector whose length is within this fraction of the time base's is a channel cut short, not metadata [-].
NEAR_LENGTH = 0.1
#: Integer time-stamp steps (inclusive ranges) that look like a unit other than seconds, and the factor to seconds.
INTEGER_STEP_UNITS = (((100.0, 10000.0), "microseconds", "1e-6"), ((1.0, 10.0), "milliseconds", "1e-3"))


@dataclass(frozen=True)
class TickTimeBase:
    """A time column that counts controller ticks, and the tick rate the file states (:func:`~feedtune.io.log_csv.
    tick_time_base`).

    Attributes
    ----------
    column : str
        The tick column.
    rate_hz : float or None
        Ticks per second [Hz]; None when the file states none, or no one rate that gives a plausible sample rate.
    statements : list of (float, str)
        Every rate the file states [Hz] and where.
    source : str
        Where the rate used was stated.
    overruled : tuple of str
        Statements that contradict it (each with the implausible sample rate it would give).
    """

    column: str
    rate_hz: float | None
    statements: list[tuple[float, str]]
    source: str = ""
    overruled: tuple[str, ...] = ()

    def record(self, t_name: str) -> str:
        """``meta["time_base"]`` of a log whose time was read in ticks."""
        text = f"{t_name} = {self.column} / {self.rate_hz:g} Hz (from {self.source})"
        return text + (f"; {'; '.join(self.overruled)}" if self.overruled else "")

    def problem(self) -> str:
        """Why no rate is used (when :attr:`rate_hz` is None)."""
        if not self.statements:
            return "the file states no tick rate"
        told = "; ".join(f"{w}: {r:g} Hz" for r, w in self.statements)
        return f"the rates the file states ({told}) give no one plausible sample rate"


@dataclass
class RawLog:
    """Columns of a log file before the user's options are applied.

    Attributes
    ----------
    name : str
        File name for messages.
    columns : dict of str to ndarray
        Candidate signals (1-D float arrays; may differ in length for MATLAB files).
    units : dict of str to str
        Units found in the file.
    meta : dict
        Metadata (scalars, ``# key: value`` lines, ...).
    resolve : callable, optional
        ``resolve(spec) -> ndarray`` for mapping specs that are not plain column names (``data[3]``).
    aliases : dict of str to str
        Other spellings of column names (``"x2 [m]"``, ``"col3"`` -> ``"x2"``).
    time : ndarray, optional
        A time vector [s] the format carries itself (MDF); then no time column is looked for.
    refused : dict of str to str
        Columns that cannot become signals as they are, with the reason (see the attribute).
    """

    name: str
    columns: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    meta: dict[str, object] = field(default_factory=dict)
    resolve: Callable[[str], np.ndarray] | None = None
    time: np.ndarray | None = None
    aliases: dict[str, str] = field(default_factory=dict)
    ticks: TickTimeBase | None = None
    refused: dict[str, str] = field(default_factory=dict)
    """Columns that cannot be signals as they are, with the reason (``{"u": "is complex"}``, ``{"e2": "names two
    columns: 7 (e2 [m]) and 9 (e2 [m])"}``): an error when they would become signals (a ``mapping`` naming another
    column is the way out)."""

    def canonical(self, spec: str) -> str:
        """The column name a spec refers to (``spec`` itself when it is not an alias)."""
        return self.aliases.get(spec, spec)

    def get(self, spec: str, what: str = "column") -> np.ndarray:
        """A column by name (or by the format's ``resolve``); unknown names list what exists, refused ones say why."""
        if spec in self.refused:
            raise DataError(f"{self.name}: {what} {spec!r} {self.refused[spec]}")
        if spec in self.columns:
            return self.columns[spec]
        if self.resolve is not None:
            return self.resolve(spec)
        raise DataError(f"{self.name}: no {what} {spec!r}; available: {', '.join(self.columns) or 'none'}")


def _find_time_column(raw: RawLog) -> str | None:
    for cand in TIME_NAMES:
        if cand in raw.columns:
            return cand
    lower = {k.lower(): k for k in raw.columns}
    for cand in TIME_NAMES:
        if cand in lower:
            return lower[cand]
    return None


def _time_factor(raw: RawLog, spec: str) -> float:
    unit = raw.units.get(raw.canonical(spec), "").strip()
    return TIME_UNIT_FACTORS.get(unit, 1.0)


def _common_length(raw: RawLog, signals: Mapping[str, np.ndarray]) -> int:
    if signals:
        return next(iter(signals.values())).size
    lengths = Counter(v.size for v in raw.columns.values() if v.size >= 2)
    if not lengths:
        raise DataError(f"{raw.name}: no signal vectors found")
    top = max(lengths.values())
    return max(n for n, c in lengths.items() if c == top)


def _check_fs(fs: float | None) -> None:
    if fs is not None and not (np.isfinite(fs) and 0 < fs <= FS_MAX_HZ):
        raise UsageError(f"fs must be a sample rate in (0, {FS_MAX_HZ:g}] Hz, got {fs}", parameter="fs")


def _time_spec(raw: RawLog, mapping: dict[str, str], time: str | None, fs: float | None
               ) -> tuple[str | None, str]:
    """The file's time column and the name the user calls it by (for ``scale``).

    ``time`` may name a file column or a mapped name (``mapping={"t": "data[0]"}, time="t"``); without
    ``time`` a file column ``t``/``time`` is used, else a mapped name ``t``/``time``. A mapping entry that
    becomes the time base is removed from ``mapping``.
    """
    if raw.time is not None:
        return None, "t"
    if time is not None:
        if time in mapping:
            return mapping.pop(time), time
        return time, time
    found = _find_time_column(raw)
    if found is not None:
        return found, found
    for cand in TIME_NAMES:
        if cand in mapping and fs is None:
            return mapping.pop(cand), cand
    if raw.ticks is not None and fs is None:
        return raw.ticks.column, raw.ticks.column
    return None, "t"


def assemble_log(
    raw: RawLog,
    *,
    mapping: Mapping[str, str] | None = None,
    fs: float | None = None,
    time: str | None = None,
    scale: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
) -> Log:
    """Apply time base, renaming, scaling and units to a :class:`RawLog` (see module docstring)."""
    _check_fs(fs)
    if time is not None and fs is not None:
        raise UsageError("give either time= (a time column) or fs= (a sample rate), not both", parameter=("time", "fs"))
    mapping = dict(mapping or {})
    time_spec, t_name = _time_spec(raw, mapping, time, fs)
    mapped = {new: np.asarray(raw.get(col, "column for " + repr(new)), dtype=float).reshape(-1)
              for new, col in mapping.items()}
    sig_units = {new: raw.units.get(raw.canonical(col), "") for new, col in mapping.items()}
    stated = None  # the unit the file gives the time column
    time_base = None  # how a time column in ticks was converted
    if raw.time is not None:
        t = np.asarray(raw.time, dtype=float)
    elif fs is None and time_spec is not None:
        t = np.asarray(raw.get(time_spec, "time column"), dtype=float).reshape(-1)
        stated = raw.units.get(raw.canonical(time_spec), "").strip() or None
        ticks = raw.ticks if raw.ticks is not None and raw.canonical(time_spec) == raw.ticks.column else None
        if ticks is not None and not any(k in (scale or {}) for k in ("t", t_name, ticks.column)):
            if ticks.rate_hz is None:
                raise DataError(f"{raw.name}: column {ticks.column!r} counts ticks and {ticks.problem()}; give the "
                                f"seconds per tick with scale={t_name}=S (e.g. 0.000125 for 8 kHz)",
                                parameter="read_log.scale")
            t, stated = t / ticks.rate_hz, f"ticks at {ticks.rate_hz:g} Hz"
            time_base = ticks.record("t")
        else:
            t = t * _time_factor(raw, time_spec)
    elif fs is not None:
        t = np.arange(_common_length(raw, mapped)) / fs
    else:
        raise DataError(f"{raw.name}: no time column (t or time); pass fs= (sample rate in Hz) "
                        "or name the time column (time=)", parameter=("fs", "time"))
    n = t.size
    used = {raw.canonical(c) for c in mapping.values()} | ({raw.canonical(time_spec)} if time_spec else set())
    signals: dict[str, np.ndarray] = {}
    for new, x in mapped.items():
        if x.size != n:
            raise DataError(f"{raw.name}: column {mapping[new]!r} (for {new}) has {x.size} samples, "
                            f"the time base has {n}")
        signals[new] = x
    for name, x in raw.columns.items():
        if name in used or name in signals:
            continue
        if x.size == n and name in raw.refused:
            raise DataError(f"{raw.name}: column {name!r} {raw.refused[name]}; name the columns to use with mapping=",
                            parameter="read_log.mapping")
        if x.size == n:
            signals[name] = np.asarray(x, dtype=float)
            sig_units[name] = raw.units.get(name, "")
        elif n > 10 and abs(x.size - n) <= NEAR_LENGTH * n:
            raise DataError(f"{raw.name}: column {name!r} has {x.size} samples, the time base has {n}: a channel cut "
                            "short; give channels of equal length (or name the columns to use with mapping=)",
                            parameter="read_log.mapping")
    t_read = t
    t = _apply_scale(raw.name, signals, t, t_name, scale)  # a new array when the time was scaled
    for name, unit in (units or {}).items():
        if name not in signals:
            raise DataError(f"units: no signal {name!r} in {raw.name}; signals: {', '.join(signals) or 'none'}",
                            parameter="read_log.units")
        sig_units[name] = str(unit)
    meta = dict(raw.meta)
    meta["source"] = raw.name
    if time_base:
        meta["time_base"] = time_base
        meta["read_notes"] = (*meta.get("read_notes", ()), f"time read in ticks: {time_base}")
    if np.any(np.diff(t) <= 0) and fs is None:
        bad = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise DataError(f"{raw.name}: time column {t_name!r} is not strictly increasing at sample {bad + 1}; "
                        "pass fs= to use a uniform time base", parameter="fs")
    if fs is None and time_spec is not None:  # a time base read from a column (in the file's unit, or scaled)
        check_time_base(raw.name, raw.canonical(time_spec), t_name, t,
                        stated=stated if t is t_read else "the scale given")
    return Log(t, signals, sig_units, meta)


def check_time_base(name: str, column: str, t_name: str, t: np.ndarray, stated: str | None = None) -> None:
    """DataError when time stamps in seconds give an implausible sample rate, naming the file, the column and the
    fix.

    Integer stamps of a column whose unit nobody states, with a step of 100..10000, are diagnosed as microseconds,
    with a step of 1..10 as milliseconds (:data:`INTEGER_STEP_UNITS`); a column whose unit the file states (or that
    the user scaled) and other implausible rates get the general fix (a time in ms under a header that says s gives
    a rate 1000 times too low).

    Parameters
    ----------
    name : str
        File name for the message.
    column : str
        The file's time column.
    t_name : str
        The name the user calls the time by (the ``scale`` key to suggest).
    t : ndarray
        The time stamps [s], strictly increasing.
    stated : str, optional
        Where the seconds come from: the unit the file gives the column (``"s"``, ``"ms"``), or ``"the scale
        given"``; None when nobody states it.

    Raises
    ------
    DataError
        The mean sample rate ``(n - 1) / (t[-1] - t[0])`` [Hz] lies outside ``FS_MIN_HZ .. FS_MAX_HZ``.
    """
    if t.size < 2:
        return
    fs = (t.size - 1) / float(t[-1] - t[0])
    if FS_MIN_HZ <= fs <= FS_MAX_HZ:
        return
    where = f"{name}: column {column!r}"
    step = float(np.median(np.diff(t)))
    if stated is None and np.all(t == np.round(t)) and step == round(step):
        for (lo, hi), unit, factor in INTEGER_STEP_UNITS:
            if lo <= step <= hi:
                raise DataError(f"{where}: time stamps are integers with a step of {step:g} (fs would be {fs:.3g} "
                                f"Hz); if they are {unit}, pass scale={t_name}={factor}", parameter="read_log.scale")
    side = f"below {FS_MIN_HZ:g} Hz" if fs < FS_MIN_HZ else f"above {FS_MAX_HZ / 1e6:g} MHz"
    unit = "" if stated is None else (f" (with {stated})" if stated == "the scale given" else
                                      f" (in {stated}, the unit the file states)")
    raise DataError(f"{where}: the time stamps{unit} give fs = {fs:.3g} Hz, {side}, implausible for a servo log; "
                    f"check the time unit: convert it to seconds with scale={t_name}=FACTOR (1e-3 for ms, 1e-6 for "
                    "us), or give the sample rate with fs=", parameter=("read_log.scale", "fs"))


def _apply_scale(name: str, signals: dict[str, np.ndarray], t: np.ndarray, t_name: str,
                 scale: Mapping[str, float] | None) -> np.ndarray:
    for key, factor in (scale or {}).items():
        try:
            k = float(factor)
        except (TypeError, ValueError):
            raise UsageError(f"scale for {key!r} must be a number, got {factor!r}") from None
        if not np.isfinite(k) or k == 0:
            raise UsageError(f"scale for {key!r} must be finite and non-zero, got {factor!r}")
        if key in signals:
            signals[key] = signals[key] * k
        elif key in ("t", t_name):
            if k < 0:
                raise UsageError(f"scale for the time column {key!r} must be > 0, got {factor!r}",
                                 parameter="read_log.scale")
            t = t * k
        else:
            raise DataError(f"scale: no signal {key!r} in {name}; signals: {', '.join(signals) or 'none'}",
                            parameter="read_log.scale")
    return t


def log_format(path: str | os.PathLike[str]) -> str:
    """``"csv"``, ``"mat"`` or ``"mdf"`` from the extension; others are a :class:`DataError`."""
    ext = Path(path).suffix.lower()
    if ext in CSV_EXTENSIONS:
        return "csv"
    if ext in MAT_EXTENSIONS:
        return "mat"
    if ext in MDF_EXTENSIONS:
        return "mdf"
    raise DataError(f"{path}: unknown log file type {ext or '(no extension)'!r}; "
                    f"accepted: {', '.join(LOG_EXTENSIONS)}")


def read_log(
    path: str | os.PathLike[str],
    *,
    mapping: Mapping[str, str] | None = None,
    fs: float | None = None,
    time: str | None = None,
    scale: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
    skip_rows: int = 0,
) -> Log:
    """Read a log from CSV (``.csv``/``.txt``), MATLAB (``.mat``, v5 or v7.3) or MDF4 (``.mf4``/``.mdf``).

    Parameters
    ----------
    path : path-like
        The file.
    mapping : mapping of str to str, optional
        ``{NEW_NAME: COLUMN}`` renames; for MATLAB, COLUMN may be ``var`` or ``var[k]`` (0-based column k
        of a matrix, e.g. ``data[3]``); for headerless CSV the columns are ``col0``, ``col1``...
    fs : float, optional
        Sample rate [Hz]; the time becomes ``arange(n) / fs``. Required when there is no time column.
    time : str, optional
        Name of the time column (default ``t`` or ``time``) [s; CSV headers ``[ms]``/``[us]`` are converted].
    scale : mapping of str to float, optional
        Factors applied after reading, e.g. ``{"u": 35.15}`` (V to N) or ``{"time": 1e-6}`` (us to s).
    units : mapping of str to str, optional
        Units of signals (overrides the file).
    skip_rows : int
        CSV only: lines to skip before the header (vendor preambles).

    Returns
    -------
    Log
        Time [s] and signals (float) with units; ``meta["source"]`` is the file name.

    Raises
    ------
    DataError
        Missing/malformed file, unknown column or variable, no time base.
    UsageError
        Invalid option value.
    """
    fmt = log_format(path)
    from ..budget import check_file
    from ._table import check_regular_file

    check_regular_file(path)  # a FIFO or a device would block or never end
    check_file(path, READ_BYTES_PER_BYTE[fmt], "reading the log")
    if skip_rows and fmt != "csv":
        raise UsageError(f"{path}: skip_rows applies to CSV files only", parameter="read_log.skip_rows")
    if time is not None and fmt == "mdf":
        raise UsageError(f"{path}: MDF4 files carry their own time base; time= does not apply", parameter="time")
    if fmt == "csv":
        from .log_csv import read_log_csv_raw

        raw = read_log_csv_raw(path, skip_rows=skip_rows)
    elif fmt == "mat":
        from .log_mat import read_log_mat_raw

        raw = read_log_mat_raw(path)
    else:
        from .log_mdf import read_log_mdf_raw

        raw = read_log_mdf_raw(path, channels=list(mapping.values()) if mapping else None, fs=fs)
        fs = None
    return assemble_log(raw, mapping=mapping, fs=fs, time=time, scale=scale, units=units)
