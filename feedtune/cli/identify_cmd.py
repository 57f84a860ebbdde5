"""``feedtune identify``: models from measurements.

* ``identify ballscrew FRF...``: the 2-mass model (eq. 3.1) fitted to FRFs.
* ``identify rigid LOG``: inertia, viscous/Coulomb friction and offset by IDIM-LS (§2.1.1).
* ``identify friction LOG``: Stribeck friction (eq. 2.1) from the Kalman-filter disturbance (§2.1.3).
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, fmt, parse_float_pair, print_json
from .log_options import FS_OPTION, MAP_OPTION, SCALE_OPTION, SKIP_ROWS_OPTION, TIME_OPTION, UNIT_OPTION

app = typer.Typer(rich_markup_mode=None, help="Identify models from FRFs and logs.", no_args_is_help=True)


@app.command("ballscrew")
def ballscrew(
    frf_files: list[Path] = typer.Argument(..., help="FRF files (CSV, MATLAB .mat, UFF58) with x1/u and/or x2/u."),
    band: tuple[float, float] = typer.Option(
        None, "--band", help="Fit band LO HI [Hz] (default: around the first axial mode)."
    ),
    channel: list[str] = typer.Option(
        None, "--channel", help="Channels to fit, motor side first (default: x1/u and x2/u)."
    ),
    lead: float = typer.Option(None, "--lead", help="Table travel per screw radian [m/rad] for FRFs in m, mm or um."),
    no_delay: bool = typer.Option(
        False, "--no-delay", help="Do not fit a pure delay (current loop) alongside the model."
    ),
    quantity: str = typer.Option(
        None, "--quantity", help="position, velocity or acceleration (overrides file metadata)."
    ),
    mat_freq: str = typer.Option(None, "--mat-freq", help="MATLAB files: name of the frequency variable [Hz]."),
    mat_channel: list[str] = typer.Option(None, "--mat-channel", help="MATLAB files: CHANNEL=VARIABLE, e.g. x2/u=H2."),
    out: Path = typer.Option(None, "--out", "-o", help="Model file to write (.toml, with a .json twin)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
) -> None:
    """Fit the 2-mass ball-screw model (m1, m2, b1, b2, k, c; eq. 3.1) to measured FRFs."""
    from ..identify.ballscrew import fit_ballscrew
    from ..io import read_frf, save_model
    from .frf_options import mat_channels, quantity_option

    b = parse_float_pair(band, "--band")
    quantity = quantity_option(quantity)
    frfs = [read_frf(p, quantity=quantity, freq_var=mat_freq, channels=mat_channels(mat_channel)) for p in frf_files]
    fit = fit_ballscrew(frfs, band_hz=b, channels=channel or None, lead_m_per_rad=lead, fit_delay=not no_delay)
    result = fit.to_dict()
    if out is not None:
        save_model(out, fit.model, fit=result, force=force)
        result["out"] = str(out)
    if as_json:
        print_json(result)
        return
    p = result["params"]
    units = result.get("units", {})
    typer.echo("Ball-screw 2-mass model (eq. 3.1):")
    for name in ("m1", "m2", "b1", "b2", "k", "c"):
        std = result.get("std", {}).get(name)
        typer.echo(
            f"  {name:3s} = {fmt(p[name], units.get(name, ''))}" + (f"  (std {fmt(std)})" if std is not None else "")
        )
    for m in result["modes"]:
        typer.echo(f"  mode: {m['freq_hz']:.2f} Hz, damping {100 * m['zeta']:.2f} %")
    typer.echo(
        f"  real pole: {fmt(result['real_pole_hz'], 'Hz')}; band {result['band_hz'][0]:g}-{result['band_hz'][1]:g} Hz"
    )
    for ch, q in result["fit"].items():
        typer.echo(
            f"  fit {ch}: nrmse {fmt(q.get('nrmse'))}, magnitude rms {fmt(q.get('mag_rms_db'), 'dB')}, "
            f"phase rms {fmt(q.get('phase_rms_deg'), 'deg')}"
        )
    for w in result.get("warnings", []):
        typer.echo(f"  warning: {w}")
    if out is not None:
        typer.echo(f"wrote {out}")


# ------------------------------------------------------------------------------------------ from logs
def _check_model_out(out: Path | None, force: bool) -> None:
    """Fail before any work when a model file cannot be written (wrong suffix, exists without --force)."""
    from ..errors import UsageError
    from ..io import ensure_writable

    if out is None:
        return
    suffix = out.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise UsageError(f"--out {out}: model files are written as .toml (with a .json twin) or .json")
    ensure_writable(out, force)
    if suffix == ".toml":
        ensure_writable(out.with_suffix(".json"), force)


def _std_text(value: float, std: float | None, unit: str) -> str:
    return f"{fmt(value, unit)}" + ("" if std is None else f"  (std {fmt(std)})")


@app.command("rigid")
def rigid(
    log_file: Path = typer.Argument(..., help="Tracking log (.csv, .mat, .mf4) with position and command."),
    position: str = typer.Option("x", "--position", help="Measured position column [m or rad; mm, um, deg]."),
    input_: str = typer.Option("u", "--input", "-i", help="Command or force column (unit from the log or --unit)."),
    asymmetric: bool = typer.Option(False, "--asymmetric", help="Viscous and Coulomb friction per direction."),
    lpf_hz: float = typer.Option(100.0, "--lpf-hz", help="Zero-phase Butterworth cut-off of the position [Hz]."),
    filter_order: int = typer.Option(4, "--filter-order", help="Butterworth order (applied forward and backward)."),
    decimate: int = typer.Option(None, "--decimate", help="Parallel decimation factor (default round(fs / lpf-hz))."),
    velocity_threshold: float = typer.Option(
        None, "--velocity-threshold", help="Drop samples slower than this [m/s or rad/s]."
    ),
    validate: Path = typer.Option(None, "--validate", help="Second log (same columns and options) to cross-check."),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    out: Path = typer.Option(None, "--out", "-o", help="Rigid-body model file (.toml with a .json twin)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
) -> None:
    """Inertia, viscous and Coulomb friction and offset by least squares on filtered derivatives (IDIM-LS)."""
    from ..identify.rigid import fit_rigid, validate_rigid
    from ..io import save_model
    from .log_options import LogOptions

    _check_model_out(out, force)
    options = LogOptions.from_cli(map_, fs, time, scale, unit, skip_rows)
    settings = {"force": input_, "position": position, "cutoff_hz": lpf_hz, "filter_order": filter_order,
                "decimate": decimate, "velocity_threshold": velocity_threshold}
    fit = fit_rigid(options.read(log_file), asymmetric=asymmetric, **settings)
    result = {"log": str(log_file), **fit.to_dict()}
    if validate is not None:
        result["validation"] = validate_rigid(options.read(validate), fit.model, **settings).to_dict()
    if out is not None:
        record = {k: v for k, v in result.items() if k not in ("rigid_model", "validation")}
        result["files"] = [str(p) for p in save_model(out, fit.model, fit=record, force=force)]
    if as_json:
        print_json(result)
        return
    units = result["units"]
    kind = "asymmetric" if asymmetric else "symmetric"
    typer.echo(f"Rigid-body model ({kind} friction, IDIM-LS) from {log_file}:")
    for name, value in result["values"].items():
        typer.echo(f"  {name:12s} = {_std_text(value, result['std'][name], units[name])}")
    typer.echo(f"  relative error {fmt(result['relative_error_pct'], '%')}, residual RMS "
               f"{fmt(result['residual_rms'], units['residual_rms'])}, condition number "
               f"{fmt(result['condition_number'])}, {result['n_samples']} samples after decimation by "
               f"{result['decimate']}, filter {fmt(result['cutoff_hz'], 'Hz')}")
    if "validation" in result:
        v = result["validation"]
        typer.echo(f"  cross-check on {validate}: relative error {fmt(v['relative_error_pct'], '%')}, "
                   f"RMS {fmt(v['residual_rms'], v['units']['residual_rms'])}")
    for w in result.get("warnings", []):
        typer.echo(f"  warning: {w}")
    for p in result.get("files", []):
        typer.echo(f"wrote {p}")


def _friction_model_source(model_file: Path | None):
    """A BallScrewModel or RigidBodyModel from a model file (mass and viscous friction), or None."""
    from ..errors import UsageError
    from ..io import load_model
    from ..models.ballscrew import BallScrewModel
    from ..models.rigid import RigidBodyModel

    if model_file is None:
        return None
    model = load_model(model_file)
    if not isinstance(model, (BallScrewModel, RigidBodyModel)):
        raise UsageError(f"--model {model_file}: a {type(model).__name__} gives no mass; pass a ballscrew or "
                         "rigid model file (feedtune identify ballscrew|rigid --out ...)")
    return model


def _friction_record(result: dict, log_file: Path) -> dict:
    """What goes in the ``[fit]`` table of a friction model file (no lists with missing values)."""
    fit = result["friction"]
    dist = result["disturbance"]
    return {
        "log": str(log_file),
        "method": "Kalman-filter equivalent disturbance, Stribeck eq. 2.1 least squares",
        "mass": result["mass"],
        "viscous": result["viscous"],
        "std": {k: v for k, v in fit["std"].items() if v is not None},
        "rms_error": fit["rms_error"],
        "relative_error_pct": fit["relative_error_pct"],
        "n_pos": fit["n_pos"],
        "n_neg": fit["n_neg"],
        "min_speed": fit["min_speed"],
        "omega_at_bound": fit["omega_at_bound"],
        "observer_poles_hz": dist["observer_poles_hz"],
        "reversal_guard_s": result["reversal_guard_s"],
        "units": {"mass": result["units"]["mass"], "viscous": result["units"]["viscous"],
                  "rms_error": fit["units"]["rms_error"], "relative_error_pct": "%",
                  "min_speed": fit["units"]["min_speed"], "observer_poles_hz": "Hz", "reversal_guard_s": "s"},
    }


@app.command("friction")
def friction(
    log_file: Path = typer.Argument(..., help="Tracking log (.csv, .mat, .mf4) moving both ways at several speeds."),
    model_file: Path = typer.Option(
        None, "--model", help="Ballscrew or rigid model file giving mass and viscous friction (default: IDIM-LS fit)."
    ),
    position: str = typer.Option("x", "--position", help="Position column, e.g. x1 or x2 [rad] or x [m]."),
    input_: str = typer.Option("u", "--input", "-i", help="Command column (unit from the log or --unit)."),
    mass: float = typer.Option(None, "--mass", help="Mass or inertia instead of --model [command/(position/s^2)]."),
    viscous: float = typer.Option(None, "--viscous", help="Viscous friction with --mass [command/(position/s)]."),
    bandwidth_hz: float = typer.Option(
        None, "--bandwidth-hz", help="Kalman observer bandwidth [Hz] (default min(0.05 fs, 50 Hz))."
    ),
    method: str = typer.Option("steady-state", "--method", help="steady-state (fast) or filterpy (per-sample)."),
    min_speed: float = typer.Option(None, "--min-speed", help="Ignore slower samples [m/s or rad/s] (default 2 %)."),
    per_direction_omega: bool = typer.Option(
        False, "--per-direction-omega", help="Separate Stribeck velocity per direction."
    ),
    reversal_guard_s: float = typer.Option(
        None, "--reversal-guard", help="Time left out after each reversal [s] (default: observer settling time)."
    ),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    out: Path = typer.Option(None, "--out", "-o", help="Friction model file (.toml with a .json twin)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
) -> None:
    """Stribeck friction (eq. 2.1, per direction) from the Kalman-filter equivalent disturbance of a log."""
    from ..identify.friction import identify_friction
    from ..io import save_model
    from .log_options import read_log_with_options

    _check_model_out(out, force)
    model = _friction_model_source(model_file)
    log = read_log_with_options(log_file, map_, fs, time, scale, unit, skip_rows)
    ident = identify_friction(log, position=position, command=input_, model=model, mass=mass, viscous=viscous,
                              bandwidth_hz=bandwidth_hz, method=method, min_speed=min_speed,
                              per_direction_omega=per_direction_omega, reversal_guard_s=reversal_guard_s)
    result = {"log": str(log_file), **ident.to_dict()}
    if out is not None:
        record = _friction_record(result, log_file)
        result["files"] = [str(p) for p in save_model(out, ident.friction, fit=record, force=force)]
    if as_json:
        print_json(result)
        return
    fit = result["friction"]
    f, u, std = fit["friction"], fit["units"], fit["std"]
    typer.echo(f"Stribeck friction (eq. 2.1) from {log_file}:")
    for name in ("dc_pos", "ds_pos", "omega_pos", "dc_neg", "ds_neg", "omega_neg"):
        typer.echo(f"  {name:9s} = {_std_text(f[name], std.get(name), u[name])}")
    typer.echo(f"  Coulomb {fmt(fit['coulomb'], u['coulomb'])}, offset {fmt(fit['offset'], u['offset'])}; "
               f"fit RMS {fmt(fit['rms_error'], u['rms_error'])} ({fmt(fit['relative_error_pct'], '%')}), "
               f"{fit['n_pos']} + {fit['n_neg']} samples")
    typer.echo(f"  mass {fmt(result['mass'], result['units']['mass'])}, viscous "
               f"{fmt(result['viscous'], result['units']['viscous'])}; observer poles "
               f"{', '.join(fmt(p, 'Hz') for p in result['disturbance']['observer_poles_hz'])}")
    for w in result.get("warnings", []):
        typer.echo(f"  warning: {w}")
    for p in result.get("files", []):
        typer.echo(f"wrote {p}")
