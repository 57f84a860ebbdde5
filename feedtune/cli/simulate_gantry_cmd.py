"""``feedtune simulate gantry frf|axis-frf|mass|ropesnap|track|contour``: experiments on the gantry digital twin.

Registered in :mod:`feedtune.cli.main` as the ``gantry`` group of ``feedtune simulate``. Every command
writes CSV logs (and FRFs) all-or-nothing, never replaces a file without ``--force``, and exits with status
1 after writing the log of a run a safety limit stopped (the log carries a ``# trip:`` line).
"""

from __future__ import annotations

from pathlib import Path

import typer

from ..control.names import controller_name
from .common import FORCE_OPTION, JSON_OPTION, check_distinct_outputs, fmt, option_names
from .help_text import ENGINES, FEATURES, SHAPES, TRACKING_TESTS, choice
from .progress_display import QUIET_OPTION, show_progress
from .twin_options import twin_from_options

app = typer.Typer(
    rich_markup_mode="rich",
    help="Run experiments on the T-gantry twin (thesis chapter 4).",
    no_args_is_help=True,
)

PARAM_OPTION = typer.Option(
    None, "--param", "-p",
    metavar="NAME=VALUE", help="Twin parameter NAME=VALUE (repeatable), e.g. k=150e3, base_hz=none, mode320.zeta=0.05, "
         "pwm_noise_v=0; see docs/gantry_twin.md.")
IDEAL_OPTION = typer.Option(False, "--ideal", help="Twin without structural, pitching or base modes, noise, "
                                                   "quantization or saturation (eq. 4.16 alone).")
SEED_OPTION = typer.Option(0, "--seed", min=0, metavar="N", help="Seed of the noise (and multisine phases).")
ENGINE_OPTION = typer.Option("auto", "--engine", **choice(ENGINES), help="Plant step: auto, numba or python.")
OUT_OPTION = typer.Option(..., "--out", "-o", metavar="FILE", help="Log file to write (.csv).")
GAINS_OPTION = typer.Option(
    ..., "--gains", "-g", metavar="GAINS",
    help="Gantry gains file (kind gantry) from feedtune design gantry|pid.",
)
OPT_GAINS_OPTION = typer.Option(
    None, "--gains", "-g", metavar="GAINS",
    help="Gantry gains file (kind gantry); default: the built-in holding controller (CoM/yaw PID, 20 Hz).",
)
AXIS_GAINS_OPTION = typer.Option(
    None, "--axis-gains", metavar="GAINS",
    help="x-axis gains file (kind axis) from feedtune design loopshape; default: the built-in holding PID.",
)
X_OPTION = typer.Option(0.0, "--x", metavar="M", help="Table position [m].")
FRF_OUT_OPTION = typer.Option(None, "--frf-out", metavar="FILE",
                              help="FRF file (.csv; default: the log name + _frf.csv).")
F_LO_OPTION = typer.Option(2.0, "--f-lo", metavar="HZ", help="Lowest excited frequency [Hz].")
F_HI_OPTION = typer.Option(1000.0, "--f-hi", metavar="HZ", help="Highest excited frequency [Hz].")
PERIOD_OPTION = typer.Option(0.5, "--period", metavar="S", help="Multisine period [s] (line spacing 1/period).")
KEEP_SAMPLING_OPTION = typer.Option(False, "--keep-sampling", help="Keep the computational delay and the ZOH half "
                                    "sample in the FRF (default: removed, so the file is the continuous plant the "
                                    "analysis expects).")


# ------------------------------------------------------------------------------------------ helpers
def _runtime(path: Path | None, kind: str, option: str):
    """The runtime of a gains file of the given kind ("gantry" or "axis"), or None."""
    if path is None:
        return None
    from ..errors import DataError
    from ..io import read_document
    from ..machines import load_runtime
    from ..machines.gantry.runtime import AxisRuntime, GantryRuntime

    doc = read_document(path)
    rt = load_runtime(doc, str(path))
    expected = GantryRuntime if kind == "gantry" else AxisRuntime
    if not isinstance(rt, expected):
        raise DataError(f"{option} {path}: a gains file of kind {doc.get('kind')!r} ({doc.get('controller')}); this "
                        f"option needs one of kind {kind!r}")
    return rt


def _check_csv(out: Path, option: str = "--out") -> None:
    from ..errors import UsageError

    if out.suffix.lower() != ".csv":
        raise UsageError(f"{option} {out}: logs are written as .csv")


def _with_x(path: Path, x: float, several: bool) -> Path:
    """``log.csv`` -> ``log_x-0.3.csv`` when several positions are run."""
    return path.with_name(f"{path.stem}_x{x:g}{path.suffix}") if several else path


def _positions(xs: list[float] | None) -> list[float]:
    from ..errors import UsageError

    xs = list(xs or [0.0])
    if len(set(xs)) != len(xs):
        raise UsageError(f"--x positions must be distinct, got {', '.join(f'{v:g}' for v in xs)}")
    return xs


def _finish(results: list, texts: dict, force: bool, as_json: bool, lines: list[str], extra: dict | None = None
            ) -> None:
    """Write every file all-or-nothing, print, and turn a trip into an error after writing its log."""
    from ..errors import DataError
    from ..workflows.files import write_texts

    written = write_texts(texts, force=force)
    out = results[0].to_dict() if len(results) == 1 else {"runs": [r.to_dict() for r in results]}
    out.update(extra or {})
    out["files"] = [str(p) for p in written]
    if as_json:
        from .envelope import emit

        emit(out)
    else:
        for line in lines:
            typer.echo(line)
        for p in written:
            typer.echo(f"wrote {p}")
    tripped = [r for r in results if r.tripped]
    if tripped:
        raise DataError(f"{tripped[0].run.trip_message}; the log up to the trip was written")


def _log_text(result) -> str:
    from ..io.log_csv import log_to_csv_text

    return log_to_csv_text(result.log)


# ------------------------------------------------------------------------------------------ commands
@app.command("frf")
def frf(
    out: Path = OUT_OPTION,
    x: list[float] = typer.Option(
        None, "--x", metavar="M",
        help="Table position [m] (repeatable: one run per position; file names get _x<POS> appended).",
    ),
    frf_out: Path = FRF_OUT_OPTION,
    rms: float = typer.Option(0.5, "--rms", metavar="V", help="RMS of the multisine added to u1, then u2 [V]."),
    f_lo: float = F_LO_OPTION,
    f_hi: float = F_HI_OPTION,
    period: float = PERIOD_OPTION,
    periods: int = typer.Option(4, "--periods", metavar="N", help="Periods per input; the first of each is dropped."),
    keep_delay: bool = KEEP_SAMPLING_OPTION,
    gains: Path = OPT_GAINS_OPTION,
    axis_gains: Path = AXIS_GAINS_OPTION,
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Measure the gantry twin's 2x2 FRF at each table position.

    Measure the 2x2 FRF (u1, u2) -> (y1, y2) [m/V] at each table position under a stabilising controller."""
    show_progress(quiet)
    from ..io.frf_csv import frf_to_csv_text
    from ..machines.gantry.experiments import measure_gantry_frf

    _check_csv(out)
    if frf_out is not None:
        _check_csv(frf_out, "--frf-out")
    check_distinct_outputs(("--out", out), ("--frf-out", frf_out))
    xs = _positions(x)
    g, a = _runtime(gains, "gantry", "--gains"), _runtime(axis_gains, "axis", "--axis-gains")
    twin = twin_from_options("gantry", param, ideal, plant="gantry")
    several = len(xs) > 1
    results, texts, lines = [], {}, []
    for xi in xs:
        res = measure_gantry_frf(twin, xi, rms=rms, f_lo=f_lo, f_hi=f_hi, period_s=period, periods=periods,
                                 controller=g, axis=a, remove_delay=not keep_delay, seed=seed, engine=engine)
        results.append(res)
        log_path = _with_x(out, xi, several)
        texts[str(log_path)] = _log_text(res)
        if res.tripped:
            break
        frf_path = _with_x(frf_out, xi, several) if frf_out is not None else log_path.with_name(
            log_path.stem + "_frf.csv")
        texts[str(frf_path)] = frf_to_csv_text(res.frf)
        s = res.summary
        lines.append(f"FRF at x = {xi:g} m ({fmt(s['rms_V'], 'V')} RMS per input, {s['band_hz'][0]:g}-"
                     f"{s['band_hz'][1]:g} Hz): {s['n_lines']} lines, lowest coherence {fmt(s['coherence_min'])}")
    _finish(results, texts, force, as_json, lines)


@app.command("axis-frf")
def axis_frf(
    out: Path = OUT_OPTION,
    x: float = X_OPTION,
    frf_out: Path = FRF_OUT_OPTION,
    rms: float = typer.Option(0.5, "--rms", metavar="V", help="RMS of the multisine added to ux [V]."),
    f_lo: float = F_LO_OPTION,
    f_hi: float = F_HI_OPTION,
    period: float = PERIOD_OPTION,
    periods: int = typer.Option(4, "--periods", metavar="N", help="Periods; the first is dropped."),
    keep_delay: bool = KEEP_SAMPLING_OPTION,
    gains: Path = OPT_GAINS_OPTION,
    axis_gains: Path = AXIS_GAINS_OPTION,
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Measure the gantry twin's x-axis FRF ux -> x.

    Measure the x-axis FRF ux -> x [m/V] (for feedtune design loopshape FRF)."""
    show_progress(quiet)
    from ..io.frf_csv import frf_to_csv_text
    from ..machines.gantry.experiments import measure_axis_frf

    _check_csv(out)
    if frf_out is not None:
        _check_csv(frf_out, "--frf-out")
    check_distinct_outputs(("--out", out), ("--frf-out", frf_out))
    g, a = _runtime(gains, "gantry", "--gains"), _runtime(axis_gains, "axis", "--axis-gains")
    twin = twin_from_options("gantry", param, ideal, plant="gantry")
    res = measure_axis_frf(twin, x, rms=rms, f_lo=f_lo, f_hi=f_hi, period_s=period, periods=periods, controller=g,
                           axis=a, remove_delay=not keep_delay, seed=seed, engine=engine)
    texts = {str(out): _log_text(res)}
    lines = []
    if not res.tripped:
        texts[str(frf_out or out.with_name(out.stem + "_frf.csv"))] = frf_to_csv_text(res.frf)
        s = res.summary
        lines.append(f"x-axis FRF at x = {x:g} m ({fmt(s['rms_V'], 'V')} RMS, {s['band_hz'][0]:g}-{s['band_hz'][1]:g} "
                     f"Hz): {s['n_lines']} lines, lowest coherence {fmt(s['coherence_min'])}")
    _finish([res], texts, force, as_json, lines)


@app.command("mass")
def mass(
    out: Path = OUT_OPTION,
    x: list[float] = typer.Option(
        None, "--x", metavar="M",
        help="Table position [m] (repeatable; file names get _x<POS>).",
    ),
    axis_run: bool = typer.Option(True, "--axis/--no-axis", help="Also run the table back and forth "
                                                                 "(OUT_axis.csv) for m_x."),
    distance: float = typer.Option(0.1, "--distance", metavar="M", help="Length of the back-and-forth move [m]."),
    v_max: float = typer.Option(0.1, "--v-max", metavar="M/S", help="Velocity limit [m/s]."),
    a_max: float = typer.Option(0.5, "--a-max", metavar="M/S^2", help="Acceleration limit [m/s^2]."),
    j_max: float = typer.Option(2.5, "--j-max", metavar="M/S^3", help="Jerk limit [m/s^3]."),
    cycles: int = typer.Option(1, "--cycles", metavar="N", help="Back-and-forth cycles."),
    gains: Path = OPT_GAINS_OPTION,
    axis_gains: Path = AXIS_GAINS_OPTION,
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Mass runs on the gantry twin, for identify mass.

    Mass runs: slow y moves at each table position (u1, u2, ay_ref logged) for feedtune identify mass."""
    show_progress(quiet)
    from ..machines.gantry.experiments import run_axis_mass, run_mass

    _check_csv(out)
    xs = _positions(x)
    g, a = _runtime(gains, "gantry", "--gains"), _runtime(axis_gains, "axis", "--axis-gains")
    twin = twin_from_options("gantry", param, ideal, plant="gantry")
    move = {"distance": distance, "v_max": v_max, "a_max": a_max, "j_max": j_max}
    several = len(xs) > 1
    results, texts, lines = [], {}, []
    for xi in xs:
        res = run_mass(twin, xi, controller=g, axis=a, move=move, cycles=cycles, seed=seed, engine=engine)
        results.append(res)
        texts[str(_with_x(out, xi, several))] = _log_text(res)
        lines.append(f"mass run at x = {xi:g} m: {fmt(res.run.t[-1], 's')}")
    if axis_run and not any(r.tripped for r in results):
        res = run_axis_mass(twin, x_start=min(xs), controller=g, axis=a, move=move, cycles=cycles, seed=seed,
                            engine=engine)
        results.append(res)
        texts[str(out.with_name(f"{out.stem}_axis{out.suffix}"))] = _log_text(res)
        lines.append(f"x-axis run from x = {min(xs):g} m: {fmt(res.run.t[-1], 's')}")
    lines.append("identify with: feedtune identify mass LOGS --x POSITIONS [--axis-log AXIS_LOG]")
    _finish(results, texts, force, as_json, lines)


@app.command("ropesnap")
def ropesnap(
    gains: Path = GAINS_OPTION,
    out: Path = OUT_OPTION,
    axis_gains: Path = AXIS_GAINS_OPTION,
    x: float = X_OPTION,
    force_n: float = typer.Option(
        57.0, "--rope-force", metavar="N",
        help="Rope force on the table before the release [N] (converted with force_constant_n_per_v).",
    ),
    t_release: float = typer.Option(0.5, "--t-release", metavar="S", help="Release time [s]."),
    after: float = typer.Option(0.5, "--after", metavar="S", help="Time simulated after the release [s]."),
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Rope snap on the gantry twin.

    Rope snap (thesis 4.5): a table force released at --t-release; logs the table displacement y_table."""
    show_progress(quiet)
    from ..machines.gantry.experiments import run_gantry_ropesnap

    _check_csv(out)
    g, a = _runtime(gains, "gantry", "--gains"), _runtime(axis_gains, "axis", "--axis-gains")
    twin = twin_from_options("gantry", param, ideal, plant="gantry")
    res = run_gantry_ropesnap(twin, g, a, force_n=force_n, x=x, t_release=t_release, after_s=after, seed=seed,
                              engine=engine)
    lines = []
    if not res.tripped:
        st = res.summary["settling_time_s"]
        lines = [f"rope snap ({fmt(force_n, 'N')} = {fmt(res.summary['force_V'], 'V')}) with "
                 f"{controller_name(g.controller)}: "
                 f"peak {fmt(res.summary['peak_um'], 'um')}, 5 % settling "
                 f"{'not reached' if st is None else f'{st:.4g} s'}"]
    _finish([res], {str(out): _log_text(res)}, force, as_json, lines)


@app.command("track")
def track(
    gains: Path = GAINS_OPTION,
    out: Path = OUT_OPTION,
    axis_gains: Path = AXIS_GAINS_OPTION,
    x: float = X_OPTION,
    test: str = typer.Option(
        None, "--test", **choice(TRACKING_TESTS),
        help="Thesis test: 1mm_s (1 mm/s, 2.8 mm/s^2, 10 mm/s^3, 2 mm) or 200mm_s (200 mm/s, 2 m/s^2, 50 m/s^3, 100 "
             "mm).",
    ),
    distance: float = typer.Option(0.1, "--distance", metavar="M", help="Move length [m] (without --test)."),
    v_max: float = typer.Option(0.2, "--v-max", metavar="M/S", help="Velocity limit [m/s]."),
    a_max: float = typer.Option(2.0, "--a-max", metavar="M/S^2", help="Acceleration limit [m/s^2]."),
    j_max: float = typer.Option(50.0, "--j-max", metavar="M/S^3", help="Jerk limit [m/s^3]."),
    s_max: float = typer.Option(None, "--s-max", metavar="M/S^4", help="Snap limit [m/s^4] (jerk-continuous profile)."),
    dwell_before: float = typer.Option(0.05, "--dwell-before", metavar="S", help="Rest before the move [s]."),
    dwell_after: float = typer.Option(0.2, "--dwell-after", metavar="S", help="Rest after the move [s]."),
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Track a y move on the gantry twin.

    Track a y move with the table at --x; logs y_ref and derivatives, y1, y2, u1, u2 and the errors e1, e2."""
    show_progress(quiet)
    from ..machines.gantry.experiments import run_gantry_tracking, tracking_trajectory

    _check_csv(out)
    g, a = _runtime(gains, "gantry", "--gains"), _runtime(axis_gains, "axis", "--axis-gains")
    twin = twin_from_options("gantry", param, ideal, plant="gantry")
    move = test if test is not None else {"distance": distance, "v_max": v_max, "a_max": a_max, "j_max": j_max,
                                          "s_max": s_max}
    tr = tracking_trajectory(move, twin.fs, dwell_before=dwell_before, dwell_after=dwell_after)
    res = run_gantry_tracking(twin, g, tr, a, x=x, seed=seed, engine=engine)
    lines = [] if res.tripped else [
        f"tracking {tr.limits['v_max'] * 1e3:g} mm/s at x = {x:g} m with {controller_name(g.controller)}: max error "
        f"{fmt(res.summary['max_um'], 'um')}, RMS {fmt(res.summary['rms_um'], 'um')} (y1 and y2)"]
    _finish([res], {str(out): _log_text(res)}, force, as_json, lines)


@app.command("contour")
def contour(
    gains: Path = GAINS_OPTION,
    axis_gains: Path = typer.Option(
        ..., "--axis-gains", metavar="GAINS",
        help="x-axis gains file (kind axis) from feedtune design loopshape.",
    ),
    out: Path = OUT_OPTION,
    shape: str = typer.Option("circle", "--shape", **choice(SHAPES), help="circle or diamond."),
    feature: str = typer.Option(
        None, "--feature", **choice(FEATURES),
        help="Thesis test: 1um, 1mm or 200mm (size, feed and limits of 4.5).",
    ),
    size: float = typer.Option(
        0.2, "--size", metavar="M",
        help="Circle diameter or diamond side [m] (without --feature).",
    ),
    v_max: float = typer.Option(0.2, "--v-max", metavar="M/S", help="Feed limit [m/s]."),
    a_max: float = typer.Option(2.0, "--a-max", metavar="M/S^2", help="Tangential acceleration limit [m/s^2]."),
    j_max: float = typer.Option(50.0, "--j-max", metavar="M/S^3", help="Tangential jerk limit [m/s^3]."),
    clockwise: bool = typer.Option(False, "--clockwise", help="Run clockwise (default counter-clockwise)."),
    x0: float = typer.Option(
        0.1, "--x0", metavar="M",
        help="Table position at the start point [m] (circle: its rightmost point; diamond: its lowest corner).",
    ),
    param: list[str] = PARAM_OPTION,
    ideal: bool = IDEAL_OPTION,
    seed: int = SEED_OPTION,
    engine: str = ENGINE_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Run an x-y contour on the gantry twin.

    x-y contour: the table on x under --axis-gains, the gantry on y under --gains; logs the contour error."""
    show_progress(quiet)
    from ..machines.gantry.experiments import run_contour
    from ..sim.contour import THESIS_FEATURES, contour_path

    _check_csv(out)
    g, a = _runtime(gains, "gantry", "--gains"), _runtime(axis_gains, "axis", "--axis-gains")
    twin = twin_from_options("gantry", param, ideal, plant="gantry")
    lim = {"size_m": size, "v_max": v_max, "a_max": a_max, "j_max": j_max}
    if feature is not None:
        from ..errors import UsageError

        if feature not in THESIS_FEATURES:
            raise UsageError(f"--feature must be one of {', '.join(THESIS_FEATURES)}, got {feature!r}")
        lim = THESIS_FEATURES[feature]
    travel = twin.params.x_max_m - twin.params.x_min_m
    if not 0 < lim["size_m"] <= travel:
        from ..errors import UsageError

        raise UsageError(f"--size {lim['size_m']:g} m: a contour must fit the table travel of {travel:g} m")
    with option_names(distance="--size", waypoints="--size"):
        path = contour_path(shape, lim["size_m"], v_max=lim["v_max"], a_max=lim["a_max"], j_max=lim["j_max"],
                            fs=twin.fs, start=(x0, 0.0), clockwise=clockwise, dwell_before=0.05, dwell_after=0.2)
    res = run_contour(twin, g, a, path, seed=seed, engine=engine)
    lines = [] if res.tripped else [
        f"{path.shape} {path.size_m * 1e3:g} mm at {lim['v_max'] * 1e3:g} mm/s with {controller_name(g.controller)}: "
        f"contour "
        f"error max {fmt(res.summary['max_um'], 'um')}, RMS {fmt(res.summary['rms_um'], 'um')}"]
    _finish([res], {str(out): _log_text(res)}, force, as_json, lines)
