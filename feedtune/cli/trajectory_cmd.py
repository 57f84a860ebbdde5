"""``feedtune trajectory``: write a jerk- or snap-limited reference trajectory as a CSV log."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION
from .progress_display import QUIET_OPTION, show_progress


def build_trajectory(distance, waypoints, v_max, a_max, j_max, s_max, fs, dwell, dwell_before, dwell_after):
    """A point-to-point move (``distance``) or a multi-segment one (``waypoints`` "0,0.1,0") [m, m/s, ... s]."""
    from ..errors import UsageError
    from ..sim.trajectory import multi_segment, point_to_point

    if (distance is None) == (not waypoints):
        raise UsageError("give either --distance or --waypoints")
    if distance is not None:
        return point_to_point(
            distance,
            v_max=v_max,
            a_max=a_max,
            j_max=j_max,
            s_max=s_max,
            fs=fs,
            dwell_before=dwell_before,
            dwell_after=dwell_after,
        )
    try:
        points = [float(x) for x in str(waypoints).split(",")]
    except ValueError:
        raise UsageError(f"--waypoints expects comma-separated positions in m, got {waypoints!r}") from None
    return multi_segment(points, v_max=v_max, a_max=a_max, j_max=j_max, s_max=s_max, fs=fs, dwell=dwell)


def trajectory(
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE", help="Trajectory log to write (.csv)."),
    distance: float = typer.Option(None, "--distance", metavar="M", help="Move length [m] (point to point)."),
    waypoints: str = typer.Option(
        None, "--waypoints", metavar="X1,X2,...",
        help="Comma-separated positions [m], e.g. 0,0.1,0.",
    ),
    v_max: float = typer.Option(..., "--v-max", metavar="M/S", help="Velocity limit [m/s]."),
    a_max: float = typer.Option(..., "--a-max", metavar="M/S^2", help="Acceleration limit [m/s^2]."),
    j_max: float = typer.Option(..., "--j-max", metavar="M/S^3", help="Jerk limit [m/s^3]."),
    s_max: float = typer.Option(
        None, "--s-max", metavar="M/S^4",
        help="Snap limit [m/s^4] (jerk-continuous 15-segment profile).",
    ),
    fs: float = typer.Option(20000.0, "--fs", metavar="HZ", help="Sample rate [Hz]."),
    dwell: float = typer.Option(0.0, "--dwell", metavar="S", help="Rest between waypoint moves [s]."),
    dwell_before: float = typer.Option(0.0, "--dwell-before", metavar="S", help="Rest before a --distance move [s]."),
    dwell_after: float = typer.Option(0.0, "--dwell-after", metavar="S", help="Rest after a --distance move [s]."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write a jerk- or snap-limited reference trajectory (CSV).

    Write a reference trajectory (x_ref, v_ref, a_ref, j_ref, s_ref in m, m/s, ...) as a CSV log."""
    show_progress(quiet)
    from ..errors import UsageError
    from ..io import write_log_csv

    if out.suffix.lower() != ".csv":
        raise UsageError(f"--out {out}: trajectories are written as .csv logs")
    if waypoints and (dwell_before or dwell_after):
        raise UsageError("--dwell-before/--dwell-after apply to --distance moves; use --dwell with --waypoints")
    if distance is not None and dwell:
        raise UsageError("--dwell is the rest between --waypoints moves; use --dwell-before/--dwell-after with "
                         "--distance")
    tr = build_trajectory(distance, waypoints, v_max, a_max, j_max, s_max, fs, dwell, dwell_before, dwell_after)
    write_log_csv(tr.to_log(), out, force=force)
    result = tr.to_dict()
    result.pop("moves", None)
    result["out"] = str(out)
    if as_json:
        from .envelope import emit

        emit(result)
        return
    pk = result["peaks"]
    typer.echo(
        f"{result['profile']} trajectory: {result['distance']:.6g} m in {result['duration']:.6g} s "
        f"({result['n_samples']} samples at {result['fs']:g} Hz); peaks {pk['velocity']:.4g} m/s, "
        f"{pk['acceleration']:.4g} m/s^2, {pk['jerk']:.4g} m/s^3"
    )
    typer.echo(f"wrote {out}")
