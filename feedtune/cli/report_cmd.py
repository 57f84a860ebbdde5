"""``feedtune report``: one self-contained HTML document (optional PDF) showing the tuning from the user's files."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION
from .envelope import cli_text
from .limits_options import (
    DM_MIN_OPTION,
    GM_LOW_MIN_OPTION,
    GM_MIN_OPTION,
    LIMITS_OPTION,
    MS_MAX_OPTION,
    PM_MIN_OPTION,
    limits_from_options,
)
from .log_options import (
    FS_OPTION,
    MAP_OPTION,
    SCALE_OPTION,
    SKIP_ROWS_OPTION,
    TIME_OPTION,
    UNIT_OPTION,
    LogOptions,
)
from .progress_display import QUIET_OPTION, show_progress

HTML_SUFFIXES = (".html", ".htm")


def check_report_paths(out: Path, pdf: bool, force: bool) -> list[Path]:
    """The files the report will write (HTML, and the PDF beside it); refuse them before any work is done."""
    from ..errors import UsageError
    from ..io import ensure_writable
    from ..report.build import pdf_path_for

    if out.suffix.lower() not in HTML_SUFFIXES:
        raise UsageError(f"--out {out}: the report is an HTML file; give a name ending in .html")
    paths = [out] + ([pdf_path_for(out)] if pdf else [])
    return [ensure_writable(p, force) for p in paths]


def report(
    inputs: list[Path] = typer.Argument(
        ..., metavar="FILE",
        help="Model, gains, FRF and log files, or folders holding them (classified by content); an FRF measured one "
             "file per encoder as FILE:OUT/IN pieces joined with + (e.g. motor.csv:x1/u+table.csv:x2/u,scale=-1).",
    ),
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE", help="HTML file to write (.html)."),
    pdf: bool = typer.Option(False, "--pdf", help="Also write a PDF with the same figures and tables (OUT.pdf)."),
    title: str = typer.Option(None, "--title", metavar="TEXT", help="Report title."),
    log_kind: list[str] = typer.Option(
        None, "--log-kind", metavar="FILE=KIND",
        help="FILE=KIND: what run a log holds (track, cut, ropesnap, contour, friction; frf and mass logs are listed "
             "only), for logs without feedtune metadata; repeatable.",
    ),
    strict: bool = typer.Option(
        False, "--strict", help="Files in a folder that cannot be read or classified are errors, not warnings."
    ),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    limits: str = LIMITS_OPTION,
    ms_max: float = MS_MAX_OPTION,
    pm_min: float = PM_MIN_OPTION,
    gm_min: float = GM_MIN_OPTION,
    gm_low_min: float = GM_LOW_MIN_OPTION,
    dm_min: float = DM_MIN_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Build one HTML report from model, gains, FRF and log files.

    Build a report: summary, identification, design and time-domain sections for the files given.

    The log options (--map, --scale, --unit, --time, --fs, --skip-rows) apply to the log files named on the command
    line, as for 'feedtune analyze track' (e.g. --map x_ref=cmd --map x2_table=pos for a foreign tracking log);
    logs inside folders are read as feedtune logs."""
    show_progress(quiet)
    from .. import progress
    from ..report.build import build_report, write_report
    from ..report.collect import parse_log_kinds
    from ..report.sections import ReportLimits

    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    check_report_paths(out, pdf, force)
    options = LogOptions.from_cli(map_, fs, time, scale, unit, skip_rows)
    paths, frfs = split_frf_pieces(inputs)
    built = build_report(paths, title=title, log_kinds=parse_log_kinds(log_kind), strict=strict,
                         limits=ReportLimits(policy), log_reader=options.read, frfs=frfs)
    written = write_report(built, out, pdf=pdf, force=force)
    progress.done()
    result = report_summary(built, written)
    if as_json:
        from .envelope import emit

        emit(result)
        return
    typer.echo(f"report with {result['figures']} figures and {result['tables']} tables: "
               + ", ".join(result["sections"]))
    for w in result["warnings"]:
        typer.echo(f"warning: {cli_text(w)}")
    for p, size in zip(result["files"], result["sizes_bytes"], strict=True):
        typer.echo(f"wrote {p} ({size / 1e6:.2f} MB)")


def split_frf_pieces(inputs: list[Path]) -> tuple[list[Path], list[tuple[str, object]]]:
    """The inputs that are files or folders, and the FRFs read from the others: ``FILE:OUT/IN`` pieces (joined with
    ``+``), each merged into one FRF (:func:`feedtune.cli.frf_options.read_frf_argument`)."""
    from .frf_options import parse_frf_argument, read_frf_argument

    paths, frfs = [], []
    for item in inputs:
        if item.exists():
            paths.append(item)
            continue
        pieces = parse_frf_argument(item)
        if all(p.has_spec for p in pieces) and all(p.path.exists() for p in pieces):
            frfs.append((str(item), read_frf_argument(item)))
        else:
            paths.append(item)  # reported as missing by the collection
    return paths, frfs


def report_summary(built, written: list[Path]) -> dict:
    """The ``--json`` object: files, sizes [bytes], section titles, figure and table counts, warnings."""
    return {
        "files": [str(p) for p in written],
        "sizes_bytes": [p.stat().st_size for p in written],
        "sections": [s.title for s in built.sections],
        "figures": len(built.figures()),
        "tables": len(built.tables()),
        "warnings": list(built.warnings),
        "units": {"sizes_bytes": "bytes"},
    }
