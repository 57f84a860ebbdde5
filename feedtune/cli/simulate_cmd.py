"""``feedtune simulate``: experiments on the digital twin (FRF measurement, tracking, rope snap, cutting)."""

from __future__ import annotations

from pathlib import Path

import typer

from ..control.names import controller_name
from ..machines.registry import machines_of
from .common import FORCE_OPTION, JSON_OPTION, check_distinct_outputs, fmt, option_names
from .help_text import ENGINES, EXCITATIONS, choice
from .progress_display import QUIET_OPTION, show_progress
from .twin_options import twin_from_options

app = typer.Typer(
    rich_markup_mode="rich",
    help="Run experiments on the ball-screw and gantry digital twins.\n\nEvery experiment writes the log a bench "
         "test would (and the FRF of an FRF measurement).",
    no_args_is_help=True,
)

MACHINE_OPTION = typer.Option(
    "ballscrew", "--machine", **choice(machines_of("two_mass")),
    help=f"The two-mass machine whose twin runs the experiment ({', '.join(machines_of('two_mass'))}).",
)
PARAM_OPTION = typer.Option(
    None,
    "--param",
    "-p",
    metavar="NAME=VALUE", help="Twin parameter NAME=VALUE (repeatable), e.g. current_loop_hz=500, k=250, "
    "friction_motor=none, friction_motor.dc_pos=0.05, noise_m=0; see docs/twin.md.",
)
IDEAL_OPTION = typer.Option(
    False,
    "--ideal",
    help="Twin without unmodeled dynamics, friction, quantization, noise or saturation (the 2-mass model alone).",
)
SEED_OPTION = typer.Option(
    0, "--seed", min=0, metavar="N",
    help="Seed of the measurement noise (and multisine phases).",
)
ENGINE_OPTION = typer.Option("auto", "--engine", **choice(ENGINES), help="auto, numba or python.")
OUT_OPTION = typer.Option(..., "--out", "-o", metavar="FILE", help="Log file to write (.csv).")
GAINS_OPTION = typer.Option(
    ..., "--gains", "-g", metavar="GAINS",
    help="Gains file (.toml or .json) from feedtune design.",
)


# ------------------------------------------------------------------------------------------ helpers
def _runtime(gains: Path):
    from ..machines.ballscrew.runtime import GainsRuntime

    return GainsRuntime.from_file(gains)


def _experiments(machine: str):
    """The experiments module of a two-mass machine (:attr:`~feedtune.machines.registry.MachineEntry.experiments`)."""
    from ..machines import get_machine
    from ..structures import resolve

    return resolve(get_machine(machine).experiments)


def _check_csv(out: Path, what: str = "--out") -> None:
    from ..errors import UsageError

    if out.suffix.lower() != ".csv":
        raise UsageError(f"{what} {out}: logs are written as .csv")


def _finish(result, texts: dict, force: bool, as_json: bool, lines: list[str]) -> None:
    """Write the files all-or-nothing, print, and turn a trip into an error after writing its log."""
    from ..errors import DataError
    from ..workflows.files import write_texts

    written = write_texts(texts, force=force)
    out = result.to_dict()
    out["files"] = [str(p) for p in written]
    if as_json:
        from .envelope import emit

        emit(out)
    else:
        for line in lines:
            typer.echo(line)
        for p in written:
            typer.echo(f"wrote {p}")
    if result.tripped:
        raise DataError(f"{result.run.trip_message}; the log up to the trip was written to {written[0]}")


def _trajectory(trajectory_file, distance, waypoints, v_max, a_max, j_max, s_max, fs, dwell_before, dwell_after):
    from ..errors import UsageError
    from .trajectory_cmd import build_trajectory

    if trajectory_file is not None:
        if distance is not None or waypoints:
            raise UsageError("give either --trajectory FILE or --distance/--waypoints, not both")
        from ..machines.ballscrew.experiments import trajectory_from_log

        return trajectory_from_log(trajectory_file, fs)
    return build_trajectory(distance, waypoints, v_max, a_max, j_max, s_max, fs, 0.0, dwell_before, dwell_after)


# ------------------------------------------------------------------------------------------ commands
@app.command("frf")
def frf(
    out: Path = OUT_OPTION,
    frf_out: Path = typer.Option(
        None, "--frf-out", metavar="FILE",
        help="FRF file to write (.csv; default OUT_frf.csv).",
    ),
    excitation: str = typer.Option(
        "multisine", "--excitation", **choice(EXCITATIONS),
        help="multisine, chirp or prbs.",
    ),
    rms: float = typer.Option(1.0, "--rms", metavar="V", help="RMS of the excitation added to the command [V]."),
    f_lo: float = typer.Option(2.0, "--f-lo", metavar="HZ", help="Lowest excited frequency [Hz]."),
    f_hi: float = typer.Option(2000.0, "--f-hi", metavar="HZ", help="Highest excited frequency [Hz]."),
    period: float = typer.Option(0.5, "--period", metavar="S", help="Excitation period [s] (line spacing 1/period)."),
    periods: int = typer.Option(6, "--periods", metavar="N", help="Periods run; the first is dropped as transient."),
    drift: float = typer.Option(
        0.05, "--drift", metavar="M/S",
        help="Constant table speed during the test [m/s] (0: standstill).",
    ),
    gains: Path = typer.Option(
        None, "--gains", "-g", metavar="GAINS",
        help="Stabilising controller (default: a weak P-PI).",
    ),
    keep_sampling: bool = typer.Option(
        False, "--keep-sampling", help="Keep the zero-order hold and computational delay of the logged u[k] -> x[k] "
        "in the FRF file (default: removed, so the file is the continuous plant the analysis expects)."
    ),
    machine: str = MACHINE_OPTION,
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Measure the ball-screw twin's FRF u -> x1, x2.

    Measure the FRF u -> x1, x2 under a weak stabilising controller; write the log and the FRF.

    The FRF file is the continuous plant: the ZOH and the computational delay are divided out unless
    --keep-sampling is given.
    """
    show_progress(quiet)
    from ..workflows.files import experiment_texts

    _check_csv(out)
    frf_path = frf_out or out.with_name(out.stem + "_frf.csv")
    _check_csv(frf_path, "--frf-out")
    check_distinct_outputs(("--out", out), ("--frf-out", frf_path))
    ctrl = _runtime(gains) if gains is not None else None
    twin = twin_from_options(machine, param, ideal)
    res = _experiments(machine).measure_frf(
        twin,
        excitation=excitation,
        rms=rms,
        f_lo=f_lo,
        f_hi=f_hi,
        period_s=period,
        periods=periods,
        drift_m_per_s=drift,
        controller=ctrl,
        seed=seed,
        engine=engine,
        keep_sampling=keep_sampling,
    )
    texts = experiment_texts(res, str(out), None if res.tripped else str(frf_path))
    s = res.summary
    sampling = (f"ZOH and {twin.params.delay_samples}-sample delay at {twin.fs:g} Hz "
                f"{'kept' if keep_sampling else 'removed'}")
    lines = [
        f"FRF measurement ({s['excitation']}, {fmt(s['rms_V'], 'V')} RMS, {s['band_hz'][0]:g}-"
        f"{s['band_hz'][1]:g} Hz, drift {fmt(s['drift_m_per_s'], 'm/s')}): {s.get('n_lines', 0)} lines, "
        f"lowest coherence {fmt(s.get('coherence_min'))}; {sampling}"
    ]
    _finish(res, texts, force, as_json, lines)


@app.command("track")
def track(
    gains: Path = GAINS_OPTION,
    out: Path = OUT_OPTION,
    trajectory_file: Path = typer.Option(
        None, "--trajectory", "-t", metavar="LOG", help="Trajectory log (.csv from feedtune trajectory) with x_ref [m]."
    ),
    distance: float = typer.Option(None, "--distance", metavar="M", help="Move length [m] (instead of --trajectory)."),
    waypoints: str = typer.Option(None, "--waypoints", metavar="X1,X2,...", help="Comma-separated positions [m]."),
    v_max: float = typer.Option(0.2, "--v-max", metavar="M/S", help="Velocity limit [m/s]."),
    a_max: float = typer.Option(5.0, "--a-max", metavar="M/S^2", help="Acceleration limit [m/s^2]."),
    j_max: float = typer.Option(500.0, "--j-max", metavar="M/S^3", help="Jerk limit [m/s^3]."),
    s_max: float = typer.Option(None, "--s-max", metavar="M/S^4", help="Snap limit [m/s^4] (jerk-continuous profile)."),
    dwell_before: float = typer.Option(0.05, "--dwell-before", metavar="S", help="Rest before the move [s]."),
    dwell_after: float = typer.Option(0.2, "--dwell-after", metavar="S", help="Rest after the move [s]."),
    machine: str = MACHINE_OPTION,
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Track a trajectory on the ball-screw twin.

    Run a trajectory under the controller of a gains file; the log holds x_ref and derivatives, x1, x2, u."""
    show_progress(quiet)
    from ..workflows.files import experiment_texts

    _check_csv(out)
    rt = _runtime(gains)
    twin = twin_from_options(machine, param, ideal)
    tr = _trajectory(
        trajectory_file, distance, waypoints, v_max, a_max, j_max, s_max, twin.fs, dwell_before, dwell_after
    )
    res = _experiments(machine).run_tracking(twin, rt, tr, seed=seed, engine=engine)
    lines = (
        []
        if res.tripped
        else [
            f"tracking with {controller_name(rt.controller)} from {gains}: max error "
            f"{fmt(res.summary['max_um'], 'um')}, RMS {fmt(res.summary['rms_um'], 'um')}"
        ]
    )
    _finish(res, experiment_texts(res, str(out)), force, as_json, lines)


@app.command("ropesnap")
def ropesnap(
    gains: Path = GAINS_OPTION,
    out: Path = OUT_OPTION,
    force_v: float = typer.Option(
        0.5, "--rope-force", metavar="V",
        help="Rope force on the table before the release [V].",
    ),
    t_release: float = typer.Option(0.6, "--t-release", metavar="S", help="Release time [s]."),
    after: float = typer.Option(1.0, "--after", metavar="S", help="Time simulated after the release [s]."),
    machine: str = MACHINE_OPTION,
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Rope snap on the ball-screw twin.

    Rope snap: a constant table force released at --t-release; the log holds the table displacement and u."""
    show_progress(quiet)
    from ..workflows.files import experiment_texts

    _check_csv(out)
    rt = _runtime(gains)
    twin = twin_from_options(machine, param, ideal)
    res = _experiments(machine).run_ropesnap(twin, rt, force=force_v, t_release=t_release, after_s=after, seed=seed,
                                             engine=engine)
    lines = []
    if not res.tripped:
        st = res.summary["settling_time_s"]
        lines = [
            f"rope snap with {controller_name(rt.controller)}: peak {fmt(res.summary['peak_um'], 'um')}, 5 % "
            f"settling {'not reached' if st is None else f'{st:.4g} s'}"
        ]
    _finish(res, experiment_texts(res, str(out)), force, as_json, lines)


@app.command("cut")
def cut(
    gains: Path = GAINS_OPTION,
    out: Path = OUT_OPTION,
    speed: float = typer.Option(0.2, "--speed", metavar="M/S", help="Feed speed [m/s]."),
    flutes: int = typer.Option(4, "--flutes", metavar="N", help="Teeth of the end mill."),
    rpm: float = typer.Option(3500.0, "--rpm", metavar="RPM", help="Spindle speed [1/min]."),
    tool_diameter: float = typer.Option(25.4e-3, "--tool-diameter", metavar="M", help="End-mill diameter [m]."),
    cut_start: float = typer.Option(0.05, "--cut-start", metavar="M", help="Workpiece edge [m of table travel]."),
    cut_length: float = typer.Option(0.12, "--cut-length", metavar="M", help="Length of the slot [m]."),
    mean_force: float = typer.Option(0.3, "--mean-force", metavar="V", help="Mean feed force in full engagement [V]."),
    tooth_force: float = typer.Option(0.3, "--tooth-force", metavar="V", help="Tooth-passing force amplitude [V]."),
    a_max: float = typer.Option(5.0, "--a-max", metavar="M/S^2", help="Acceleration limit [m/s^2]."),
    j_max: float = typer.Option(500.0, "--j-max", metavar="M/S^3", help="Jerk limit [m/s^3]."),
    machine: str = MACHINE_OPTION,
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Slotting at constant feed on the ball-screw twin.

    Slotting at constant feed (thesis 3.4): cutting force at the tooth-passing frequency entering and leaving."""
    show_progress(quiet)
    from ..errors import UsageError
    from ..sim.trajectory import point_to_point
    from ..workflows.files import experiment_texts

    _check_csv(out)
    if isinstance(flutes, bool) or flutes < 1:
        raise UsageError(f"--flutes must be an integer >= 1, got {flutes}")
    for name, v in (
        ("--rpm", rpm),
        ("--tool-diameter", tool_diameter),
        ("--cut-length", cut_length),
        ("--speed", speed),
    ):
        if not v > 0:
            raise UsageError(f"{name} must be > 0, got {v:g}")
    rt = _runtime(gains)
    twin = twin_from_options(machine, param, ideal)
    experiments = _experiments(machine)
    sc = experiments.SlotCut(flutes, rpm, tool_diameter, cut_start, cut_length, mean_force, tooth_force)
    if not sc.tooth_hz < twin.fs / 2:
        raise UsageError(f"--flutes {flutes} at --rpm {rpm:g} pass a tooth every {1e3 / sc.tooth_hz:.3g} ms "
                         f"({sc.tooth_hz:.4g} Hz), above the Nyquist frequency {twin.fs / 2:g} Hz of the twin: the "
                         "cutting force would alias")
    with option_names(v_max="--speed", distance="--cut-length"):
        tr = point_to_point(
            cut_start + cut_length + 0.03,
            v_max=speed,
            a_max=a_max,
            j_max=j_max,
            fs=twin.fs,
            dwell_before=0.05,
            dwell_after=0.2,
        )
    res = experiments.run_cut(twin, rt, tr, sc, seed=seed, engine=engine)
    lines = (
        []
        if res.tripped
        else [
            f"slotting at {speed * 1e3:g} mm/s ({sc.tooth_hz:.4g} Hz tooth passing) "
            f"with {controller_name(rt.controller)}: "
            f"max error {fmt(res.summary['max_um'], 'um')}, RMS {fmt(res.summary['rms_um'], 'um')}"
        ]
    )
    _finish(res, experiment_texts(res, str(out)), force, as_json, lines)
