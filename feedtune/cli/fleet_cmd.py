"""``feedtune fleet``: many axes over time (docs/fleet.md).

* ``fleet run MANIFEST --history H``: identify and re-certify every new measurement on local processes or a Dask
  cluster, append the Parquet history, judge the drift, forecast, and with ``--retune`` propose certified re-tunes
  (:func:`feedtune.fleet.run_fleet`);
* ``fleet report MANIFEST --history H --out PAGE``: the fleet's HTML page (:func:`feedtune.fleet.write_fleet_report`);
* ``fleet simulate DIR``: a simulated fleet with its truth (:func:`feedtune.fleet.simulate_fleet`).
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, fmt
from .progress_display import QUIET_OPTION, show_progress

app = typer.Typer(rich_markup_mode="rich", help="Many axes over time: history, drift, forecast.",
                  no_args_is_help=True)

MANIFEST_ARGUMENT = typer.Argument(..., metavar="MANIFEST",
                                   help="Fleet manifest (fleet.toml or .csv; docs/fleet.md).")
HISTORY_OPTION = typer.Option(..., "--history", metavar="FOLDER",
                              help="Parquet history (a folder, created when missing; e.g. history.parquet).")
JOBS_OPTION = typer.Option(None, "--jobs", "-j", metavar="N",
                           help="Local worker processes (default: every usable core).")
SCHEDULER_OPTION = typer.Option(None, "--scheduler", metavar="ADDRESS",
                                help="Dask distributed scheduler to run the tasks on, e.g. tcp://host:8786 (every "
                                     "worker needs feedtune and the manifest's files at the same paths).")
HORIZON_OPTION = typer.Option(26.0, "--horizon", metavar="WEEKS",
                              help="How far ahead a failure of the installed gains is forecast [weeks].")


def _engine(jobs: int | None, scheduler: str | None):
    from ..errors import UsageError
    from ..fleet.engine import Engine

    if jobs is not None and scheduler is not None:
        raise UsageError("--jobs sets local processes; with --scheduler the cluster's workers run the tasks (give "
                         "one of them)")
    if jobs is not None and jobs < 1:
        raise UsageError(f"--jobs must be >= 1, got {jobs}")
    try:
        return Engine(jobs=jobs, scheduler=scheduler)
    except ValueError as exc:
        from ..errors import cli_message

        raise UsageError(cli_message(exc)) from None


def _horizon(weeks: float) -> float:
    import math

    from ..errors import UsageError

    if not (math.isfinite(weeks) and weeks > 0):
        raise UsageError(f"--horizon must be a number of weeks > 0, got {weeks:g}")
    return weeks


def _history(path: Path) -> Path:
    from ..fleet.history import history_path, require_pyarrow

    require_pyarrow()
    return history_path(path)


@app.command("run")
def run(
    manifest_file: Path = MANIFEST_ARGUMENT,
    history: Path = HISTORY_OPTION,
    retune: bool = typer.Option(False, "--retune", help="Propose a certified re-tune for every red or amber axis "
                                                        "(written into the history's _proposals folder)."),
    jobs: int = JOBS_OPTION,
    scheduler: str = SCHEDULER_OPTION,
    horizon: float = HORIZON_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Identify and re-certify every new measurement of a fleet.

    Every measurement of the manifest not in the history yet: the 2-mass fit (identify ballscrew), the installed
    gains certified on its FRFs (the analysis of analyze GAINS --frf), the friction fit of its reversal log
    (identify rigid); one history row each, appended in whole Parquet files, so a re-run of the same files writes
    nothing and a killed run goes on where it stopped. Then the drift of every axis, the forecast of when its gains
    fail the limits, and with --retune a certified re-tune for the axes that need one."""
    show_progress(quiet)
    from ..fleet import load_manifest, run_fleet

    horizon = _horizon(horizon)
    history = _history(history)
    manifest = load_manifest(manifest_file)
    with _engine(jobs, scheduler) as engine:
        result = run_fleet(manifest, history, engine=engine, retune=retune, horizon_weeks=horizon)
    summary, status = result.summary.to_dict(), result.status
    if as_json:
        from .envelope import emit

        emit({"history": str(history), "run": summary, "status": status.to_dict(series=False),
              "warnings": list(status.warnings)})
        return
    tasks = summary["tasks"]
    typer.echo(f"{manifest.name}: {summary['measurements']} measurements, {summary['already_in_history']} "
               f"already in {history}, {summary['written']} written in {len(summary['files'])} file(s) on "
               f"{summary['engine']} in {fmt(summary['wall_s'], 's', 3)}"
               + (f" ({fmt(tasks['mean_cpu_s'], 's', 2)} CPU per measurement)" if tasks["count"] else ""))
    for e in summary["not_written"]:
        typer.echo(f"  not written (tried again by the next run): {e['axis_id']} {e['date']}: {e['error']}")
    for e in summary["data_errors"]:
        typer.echo(f"  error (row written): {e['axis_id']} {e['date']}: {e['error']}")
    _print_status(status)
    for p in summary["proposals"]:
        if "file" in p:
            typer.echo(f"  proposed re-tune for {p['axis_id']}: {history / p['file']}")
        else:
            typer.echo(f"  no re-tune for {p['axis_id']}: {p['error']}")


def _print_status(status) -> None:
    from .envelope import warn

    counts = status.counts()
    typer.echo("axes: " + ", ".join(f"{v} {k}" for k, v in counts.items()))
    for a in status.axes:
        if a.light in ("red", "amber"):
            typer.echo(f"  {a.light} {a.axis_id}: {a.reason}")
    for w in status.warnings:
        warn(w)


@app.command("report")
def report(
    manifest_file: Path = MANIFEST_ARGUMENT,
    history: Path = HISTORY_OPTION,
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE", help="HTML page to write."),
    jobs: int = JOBS_OPTION,
    scheduler: str = SCHEDULER_OPTION,
    horizon: float = HORIZON_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write the fleet's HTML page from its history.

    One self-contained page: every axis with its traffic light, the binding limit of its newest certificate, the
    drifting parameters with sparklines, the forecast of when its installed gains fail, the proposed re-tune and a
    link to its own report."""
    show_progress(quiet)
    from ..fleet import fleet_status, load_manifest, plan_fleet, write_fleet_report
    from ..io import ensure_writable
    from .report_cmd import HTML_SUFFIXES

    horizon = _horizon(horizon)
    history = _history(history)
    if out.suffix.lower() not in HTML_SUFFIXES:
        from ..errors import UsageError

        raise UsageError(f"--out {out}: the fleet page is an HTML file; give a name ending in .html")
    ensure_writable(out, force)
    manifest = load_manifest(manifest_file)
    if not history.is_dir():
        from ..errors import DataError

        raise DataError(f"{history}: no such history; run feedtune fleet run {manifest_file} --history {history}")
    with _engine(jobs, scheduler) as engine:
        status = fleet_status(manifest, history, plan_fleet(manifest), engine, horizon_weeks=horizon)
    written = write_fleet_report(status, out, force=force)
    if as_json:
        from .envelope import emit

        emit({"out": written["file"], "size_bytes": written["size_bytes"], **status.to_dict(series=False)})
        return
    _print_status(status)
    typer.echo(f"wrote {out}")


@app.command("simulate")
def simulate(
    out: Path = typer.Argument(..., metavar="FOLDER", help="New or empty folder for the fleet's files."),
    axes: int = typer.Option(200, "--axes", metavar="N", help="Axes (two per machine, X and Y)."),
    weeks: int = typer.Option(12, "--weeks", metavar="N", help="Weekly measurements per axis."),
    drift_share: float = typer.Option(0.1, "--drift-share", metavar="SHARE",
                                      help="Share of the axes that drift (half stiffness -2 %/week, half Coulomb "
                                           "friction +5 %/week)."),
    seed: int = typer.Option(1, "--seed", metavar="N", help="Seed of the spread, the drifts and the noise."),
    no_logs: bool = typer.Option(False, "--no-logs", help="No reversal logs (no friction fits)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write a simulated fleet of ball-screw axes and its truth.

    Ball-screw axes with spread parameters, each with a P-PI installed at commissioning, measured weekly (FRF with
    torsional modes, current loop and 2 % noise; a reversal log); a share of them drifts. Writes fleet.toml, the
    gains, FRF and log files, and truth.json (each axis' drift and the week its gains fail on the noise-free plant)."""
    show_progress(quiet)
    from ..errors import UsageError
    from ..fleet import simulate_fleet

    for name, v in (("--axes", axes), ("--weeks", weeks)):
        if v < 1:
            raise UsageError(f"{name} must be >= 1, got {v}")
    if not 0 <= drift_share <= 1:
        raise UsageError(f"--drift-share must be in [0, 1], got {drift_share:g}")
    sim = simulate_fleet(out, axes, weeks, drift_share=drift_share, seed=seed, logs=not no_logs, force=force)
    drifting = {a.id: a.drift for a in sim.axes if a.drift}
    if as_json:
        from .envelope import emit

        emit({"out": str(out), "manifest": str(sim.manifest), "truth": str(sim.truth), "axes": len(sim.axes),
              "weeks": sim.weeks, "files": sim.files, "drifting": drifting})
        return
    typer.echo(f"wrote {sim.manifest}: {len(sim.axes)} axes x {sim.weeks} weeks ({sim.files} measurement files); "
               f"drifting: {', '.join(f'{k} ({v})' for k, v in drifting.items()) or 'none'}; truth in {sim.truth}")
