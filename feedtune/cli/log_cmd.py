"""``feedtune log``: bring logs from other tools into feedtune's CSV format.

``log convert`` reads one log with the options every log command has (``--map``, ``--scale``, ``--unit``,
``--skip-rows``, ``--time``, ``--fs``) and writes it as a feedtune CSV log; ``log merge`` puts several logs on one
time base (:func:`feedtune.log_merge.merge_logs`): an amplifier trace and a DAQ channel at different rates, one
started late, a sensor offset, a speed to integrate into a position; ``log resample`` puts a log recorded at
irregular instants (a drive polled over USB) on a uniform base (:func:`feedtune.log_resample.resample_log`).
"""

from __future__ import annotations

import math
from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, fmt
from .log_options import FS_OPTION, MAP_OPTION, SCALE_OPTION, SKIP_ROWS_OPTION, TIME_OPTION, UNIT_OPTION
from .progress_display import QUIET_OPTION, show_progress

app = typer.Typer(rich_markup_mode="rich", help="Convert, merge and resample logs from other tools.",
                  no_args_is_help=True)


def _check_log_out(out: Path) -> None:
    """UsageError unless the output is a .csv (or .txt) file: the log commands write feedtune CSV logs."""
    from ..errors import UsageError

    if out.suffix.lower() not in (".csv", ".txt"):
        raise UsageError(f"--out {out}: the log commands write feedtune CSV logs (.csv)")


def _summary(log, out: Path, as_json: bool, extra: dict | None = None) -> None:
    from .log_options import log_notes

    info = {"out": str(out), "n_samples": log.n, "fs_hz": log.fs, "t0_s": float(log.t[0]),
            "duration_s": float(log.t[-1] - log.t[0]), "signals": {k: log.unit(k) for k in log.signals},
            **({"notes": log_notes(log)} if log_notes(log) else {}), **(extra or {})}
    if as_json:
        from .envelope import emit

        emit(info)
        return
    names = ", ".join(f"{k} [{u}]" if u else k for k, u in info["signals"].items())
    typer.echo(f"wrote {out}: {log.n} samples at {fmt(log.fs, 'Hz', 6)} over {fmt(info['duration_s'], 's')}; "
               f"signals {names}")
    for name, what in (extra or {}).get("merge", {}).items():
        typer.echo(f"  {name}: {what}")


@app.command("convert")
def convert(
    log_file: Path = typer.Argument(..., metavar="LOG", help="Log to read (.csv, .mat, .mf4)."),
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE", help="feedtune CSV log to write."),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    keep: str = typer.Option(None, "--keep", metavar="NAMES", help="Comma-separated signals to keep (default: all)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write a log from another tool as a feedtune CSV log.

    Read a log with the usual log options and write it as a feedtune CSV log (names, units, time in s).

    An amplifier trace with a 3-line preamble, time in ms: feedtune log convert a3MR.csv --skip-rows 3 --time Time
    --scale Time=1e-3 --map n="Analog 1" --unit n=rpm --keep n --out amp.csv"""
    show_progress(quiet)
    from ..errors import DataError, UsageError
    from ..io import write_log_csv
    from ..io.atomic import ensure_writable
    from ..log import Log
    from .log_options import read_log_with_options

    ensure_writable(out, force)
    _check_log_out(out)
    names = None
    if keep is not None:
        names = [n.strip() for n in keep.split(",")]
        if not names or any(not n for n in names):
            raise UsageError(f"--keep expects comma-separated signal names such as u,x2, got {keep!r}")
    log = read_log_with_options(log_file, map_, fs, time, scale, unit, skip_rows)
    if names:
        missing = [n for n in names if n not in log.signals]
        if missing:
            raise DataError(f"--keep {missing[0]!r}: no such signal in {log_file} (signals: "
                            f"{', '.join(log.signals)})")
        log = Log(log.t, {n: log[n] for n in names}, {n: log.unit(n) for n in names}, log.meta)
    write_log_csv(log, out, force=force)
    _summary(log, out, as_json)


@app.command("merge")
def merge(
    log_files: list[Path] = typer.Argument(
        ..., metavar="LOG",
        help="feedtune CSV logs (or any log the log commands read with their defaults), each with its own time column.",
    ),
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE", help="Merged feedtune CSV log to write."),
    fs: float = typer.Option(
        None, "--fs", metavar="HZ",
        help="Sample rate of the merged log [Hz] (default: the lowest rate among the logs).",
    ),
    shift: list[str] = typer.Option(None, "--shift", metavar="NAME=SECONDS",
                                    help="Add SECONDS to the time stamps of a signal (repeatable)."),
    offset: list[str] = typer.Option(None, "--offset", metavar="NAME=VALUE|mean:N",
                                     help="Subtract a constant from a signal, or the mean of its first N samples."),
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    integrate: list[str] = typer.Option(None, "--integrate", metavar="NEW=NAME",
                                        help="Add NEW, the running integral of NAME (e.g. x=v: a position from a "
                                             "measured speed in m/s)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Put several logs on one uniform time base.

    Put several logs on one uniform time base: shift, offset, scale, anti-alias and resample, integrate.

    Order per signal: shift, offset, scale; then low-pass the signals faster than the base (zero-phase, 0.4 x the
    base rate), interpolate (modified Akima cubic), integrate. A DAQ log and an amplifier trace: feedtune log merge
    daq.csv amp.csv --shift f=0.004 --offset f=mean:10 --scale f=-200 --unit f=N --integrate x=v --out merged.csv"""
    show_progress(quiet)
    from ..errors import UsageError
    from ..io import read_log, write_log_csv
    from ..io.atomic import ensure_writable
    from ..log_merge import merge_logs
    from .log_options import parse_assignments, scale_factor

    ensure_writable(out, force)
    _check_log_out(out)
    if len(log_files) < 2:
        raise UsageError("log merge needs two or more logs")
    from ..io.log_read import FS_MAX_HZ

    if fs is not None and not 0 < fs <= FS_MAX_HZ:
        raise UsageError(f"--fs expects a sample rate in (0, {FS_MAX_HZ / 1e6:g} MHz], got {fs:g}")
    shifts = {}
    for name, text in parse_assignments(shift, "--shift", "SECONDS").items():
        try:
            shifts[name] = float(text)
        except ValueError:
            raise UsageError(f"--shift {name}={text}: SECONDS must be a number") from None
        if not math.isfinite(shifts[name]):
            raise UsageError(f"--shift {name}={text}: SECONDS must be a finite number")
    offsets: dict[str, float | str] = {}
    for name, text in parse_assignments(offset, "--offset", "VALUE").items():
        try:
            offsets[name] = float(text)
        except ValueError:
            offsets[name] = text  # "mean:N", checked by merge_logs
        if isinstance(offsets[name], float) and not math.isfinite(offsets[name]):
            raise UsageError(f"--offset {name}={text}: VALUE must be a finite number")
    for item in integrate or []:
        if "=" not in item:
            raise UsageError(f"--integrate expects NEW=NAME (e.g. x=v), got {item!r}")
    factors = {name: scale_factor(name, text) for name, text in parse_assignments(scale, "--scale", "FACTOR").items()}
    logs = [read_log(p) for p in log_files]
    merged = merge_logs(logs, fs=fs, shift_s=shifts, offset=offsets, scale=factors,
                        units=parse_assignments(unit, "--unit", "UNIT"),
                        integrate=parse_assignments(integrate, "--integrate", "NAME"))
    write_log_csv(merged, out, force=force)
    _summary(merged, out, as_json, {"merge": merged.meta["merge"], "logs": [str(p) for p in log_files]})


@app.command("resample")
def resample(
    log_file: Path = typer.Argument(..., metavar="LOG", help="Log with a time column (.csv, .mat, .mf4)."),
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE", help="feedtune CSV log to write."),
    fs: float = typer.Option(
        None, "--fs", metavar="HZ",
        help="Sample rate of the resampled log [Hz] (default: the log's median rate, 3 significant digits).",
    ),
    max_gap: float = typer.Option(
        3.0, "--max-gap", metavar="FACTOR",
        help="Longest interval accepted, in median intervals; a longer gap is refused (resampling would invent its "
             "samples) unless this is raised.",
    ),
    map_: list[str] = MAP_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Put a log sampled at irregular instants on a uniform base.

    Report how irregular the log's time stamps are (smallest, largest and median interval, jitter, largest gap),
    refuse gaps longer than --max-gap median intervals, low-pass (zero phase, 0.4 x the new rate) when the new rate
    is below the log's, and interpolate (modified Akima cubic) at uniform instants: what 'feedtune frf' and
    'identify rigid' need."""
    show_progress(quiet)
    from ..errors import UsageError
    from ..io import write_log_csv
    from ..io.atomic import ensure_writable
    from ..log_resample import resample_log, time_base_report
    from .log_options import LogOptions

    _check_log_out(out)
    ensure_writable(out, force)
    if fs is not None and not fs > 0:
        raise UsageError(f"--fs expects a sample rate > 0 Hz, got {fs:g}")
    log = LogOptions.from_cli(map_, None, time, scale, unit, skip_rows).read(log_file)
    report = time_base_report(log.t)
    done = resample_log(log, fs, max_gap=max_gap)
    write_log_csv(done, out, force=force)
    extra = {"time_base": report.to_dict(), "resample": done.meta["resample"]}
    if not as_json:
        typer.echo(f"time base of {log_file}: {report}")
        typer.echo(f"  {done.meta['resample']}")
    _summary(done, out, as_json, extra)
