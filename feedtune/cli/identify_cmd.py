"""``feedtune identify``: models from measurements.

* ``identify ballscrew FRF...``: the 2-mass model (eq. 3.1) fitted to FRFs.
* ``identify rigid LOG``: inertia, viscous/Coulomb friction and offset by IDIM-LS (§2.1.1).
* ``identify friction LOG``: Stribeck friction (eq. 2.1) from the Kalman-filter disturbance (§2.1.3).
"""

from __future__ import annotations

from pathlib import Path

import typer

from ..models.ballscrew import LOWER_BOUNDS
from .common import FORCE_OPTION, JSON_OPTION, fmt, fmt_band, fmt_param, parse_float_pair
from .envelope import cli_text, emit, quantities, quantity
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import FRICTION_LAWS, KALMAN_METHODS, QUANTITIES, choice
from .log_options import FS_OPTION, MAP_OPTION, SCALE_OPTION, SKIP_ROWS_OPTION, TIME_OPTION, UNIT_OPTION
from .progress_display import QUIET_OPTION, show_progress

app = typer.Typer(rich_markup_mode="rich", help="Identify models from FRFs and logs.", no_args_is_help=True)




@app.command("ballscrew")
def ballscrew(
    frf_files: list[Path] = typer.Argument(
        ..., metavar="FRF",
        help="FRF files (CSV, MATLAB .mat, UFF58, drive XML) with x1/u and/or x2/u; one file per encoder as "
             "FILE:OUT/IN pieces joined with +, e.g. motor.csv:x1/u+table.csv:x2/u,scale=-1.",
    ),
    band: tuple[float, float] = typer.Option(
        None, "--band", metavar="LO HI", help="Fit band LO HI [Hz] (default: around the first axial mode)."
    ),
    channel: list[str] = typer.Option(
        None, "--channel", metavar="OUT/IN", help="Channels to fit, motor side first (default: x1/u and x2/u)."
    ),
    lead: float = typer.Option(
        None, "--lead", metavar="M/RAD",
        help="Table travel per screw radian [m/rad] for FRFs in m, mm or um.",
    ),
    no_delay: bool = typer.Option(
        False, "--no-delay", help="Do not fit a pure delay (current loop) alongside the model."
    ),
    quantity: str = typer.Option(
        None, "--quantity", **choice(QUANTITIES, "QUANTITY"),
        help="position, velocity or acceleration (overrides file metadata).",
    ),
    mat_freq: str = typer.Option(
        None, "--mat-freq", metavar="VARIABLE",
        help="MATLAB files: name of the frequency variable [Hz].",
    ),
    mat_channel: list[str] = typer.Option(
        None, "--mat-channel", metavar="CHANNEL=VARIABLE",
        help="MATLAB files: CHANNEL=VARIABLE, e.g. x2/u=H2.",
    ),
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    out: Path = typer.Option(
        None, "--out", "-o", metavar="FILE",
        help="Model file to write (.toml, with a .json twin).",
    ),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Fit the 2-mass ball-screw model to measured FRFs.

    Fit the 2-mass ball-screw model (m1, m2, b1, b2, k, c; eq. 3.1) to measured FRFs."""
    show_progress(quiet)
    from ..identify.ballscrew import fit_ballscrew
    from ..io import save_model
    from .frf_options import FrfReadOptions, check_named_channels, quantity_option, read_frf_argument

    b = parse_float_pair(band, "--band")
    quantity = quantity_option(quantity)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    frfs = [read_frf_argument(p, quantity, mat_freq, mat_channel, frf_options) for p in frf_files]
    check_named_channels(frf_files, frfs)
    fit = fit_ballscrew(frfs, band_hz=b, channels=channel or None, lead_m_per_rad=lead, fit_delay=not no_delay)
    result = fit.to_dict()
    if out is not None:
        save_model(out, fit.model, fit=result, force=force)
        result["out"] = str(out)
    if as_json:
        emit({**result, "params": ballscrew_params(result)})
        return
    p = result["params"]
    units = result.get("units", {})
    typer.echo("Ball-screw 2-mass model (eq. 3.1):")
    for name in ("m1", "m2", "b1", "b2", "k", "c"):
        std = result.get("std", {}).get(name)
        typer.echo(f"  {name:3s} = {fmt_param(p[name], units.get(name, ''), std, LOWER_BOUNDS.get(name))}")
    for m in result["modes"]:
        typer.echo(f"  mode: {m['freq_hz']:.2f} Hz, damping {100 * m['zeta']:.2f} %")
    typer.echo(f"  real pole: {fmt(result['real_pole_hz'], 'Hz')}; band {fmt_band(*result['band_hz'])}")
    for ch, q in result["fit"].items():
        typer.echo(
            f"  fit {ch}: nrmse {fmt(q.get('nrmse'))}, magnitude rms {fmt(q.get('mag_rms_db'), 'dB')}, "
            f"phase rms {fmt(q.get('phase_rms_deg'), 'deg')}"
        )
    for w in result.get("warnings", []):
        typer.echo(f"  warning: {cli_text(w)}")
    if out is not None:
        typer.echo(f"wrote {out}")


# ------------------------------------------------------------------------------------------ from logs
def _check_model_out(out: Path | None, force: bool) -> None:
    """Fail before any work when a model file cannot be written (wrong suffix, exists without --force)."""
    from ..errors import UsageError
    from ..io.document import ensure_document_writable

    if out is None:
        return
    suffix = out.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise UsageError(f"--out {out}: model files are written as .toml (with a .json twin) or .json")
    ensure_document_writable(out, force)  # with the .json twin of a .toml


def _std_text(value: float, std: float | None, unit: str) -> str:
    return fmt_param(value, unit, std)


def _omega_bound_note(fit: dict, name: str) -> str:
    """``  (at the upper bound of its search)`` after a Stribeck velocity the fit left on a bound
    (``omega_at_bound``: the log does not resolve it), else empty."""
    bounds = fit.get("omega_bounds", {}).get(name.rsplit("_", 1)[-1])
    value = fit["friction"].get(name)
    if not (name.startswith("omega") and fit.get("omega_at_bound") and bounds and value):
        return ""
    lo, hi = bounds
    side = "lower" if value <= 1.001 * lo else "upper" if value >= 0.999 * hi else None
    return f"  (at the {side} bound of its search)" if side else ""


# ------------------------------------------------------------------------------------------ --json params
def ballscrew_params(result: dict) -> dict:
    """``params`` of ``identify ballscrew --json``: m1, m2, b1, b2, k, c and the fitted delay [s] as
    ``{"value", "unit", "std"}``."""
    params = quantities(result["params"], result["units"], result.get("std"))
    if result.get("delay_s") is not None:
        params["delay"] = quantity(result["delay_s"], "s", result.get("delay_std_s"))
    return params


def _law_params(directions: dict, units: dict) -> dict:
    """A law fitted per direction (``{"pos": {dc, ds, omega, viscous, std}, ...}``) as ``dc_pos, ds_pos, ...``
    (the coulomb-viscous law has no ``ds``, ``omega``: its directions' std name neither)."""
    return {f"{name}_{way}": quantity(d[name], units.get(name, "-"), d.get("std", {}).get(name))
            for way, d in directions.items() for name in ("dc", "ds", "omega", "viscous")
            if d.get(name) is not None and (name != "ds" or "ds" in d.get("std", {}))}


def joint_params(joint: dict) -> dict:
    """``params`` of the joint fit of mass and friction law (one direction): mass and the law of that direction."""
    return {"mass": quantity(joint["mass"], joint["units"]["mass"], joint.get("mass_std")),
            **_law_params(joint["law_fit"]["directions"], joint["law_fit"]["units"])}


def friction_params(result: dict) -> dict:
    """``params`` of ``identify friction --json``: the law per direction (``dc_pos, ds_pos, omega_pos, ...``) with
    standard deviations; with the Kalman method also mass and viscous friction (std from the joint fit, else null:
    given or from the rigid fit), Coulomb level and offset."""
    if result.get("method") == "steady-state":
        return _law_params(result["fit"]["directions"], result["fit"]["units"])
    fit = result["friction"]
    law, units, std = fit["friction"], fit["units"], fit.get("std", {})
    names = [k for k in law if k not in ("model", "units", "formula")]
    params = {k: quantity(law[k], law.get("units", {}).get(k, units.get(k, "-")), std.get(k)) for k in names}
    joint = result.get("joint_fit") or {}
    params["mass"] = quantity(result["mass"], result["units"]["mass"], joint.get("mass_std"))
    params["viscous"] = quantity(result["viscous"], result["units"]["viscous"], None)
    for name in ("coulomb", "offset"):
        params[name] = quantity(fit[name], units.get(name, "-"), None)
    return params


@app.command("rigid")
def rigid(
    log_files: list[Path] = typer.Argument(
        ..., metavar="LOG",
        help="Tracking log(s) (.csv, .mat, .mf4) with position and command; several logs are filtered one by one and "
             "fitted together.",
    ),
    position: str = typer.Option(
        "x", "--position", metavar="COLUMN",
        help="Measured position column [m or rad; mm, um, deg].",
    ),
    input_: str = typer.Option(
        "u", "--input", "-i", metavar="COLUMN",
        help="Command or force column (unit from the log or --unit).",
    ),
    asymmetric: bool = typer.Option(False, "--asymmetric", help="Viscous and Coulomb friction per direction."),
    lpf_hz: float = typer.Option(
        None, "--lpf-hz", metavar="HZ",
        help="Zero-phase Butterworth cut-off of the position [Hz] (default: from the data, where the velocity "
             "spectrum meets its noise floor; see docs/commands.md).",
    ),
    filter_order: int = typer.Option(
        4, "--filter-order", metavar="N",
        help="Butterworth order (applied forward and backward).",
    ),
    decimate: int = typer.Option(
        None, "--decimate", metavar="N",
        help="Parallel decimation factor (default round(fs / lpf-hz)).",
    ),
    velocity_threshold: float = typer.Option(
        None, "--velocity-threshold", metavar="SPEED", help="Drop samples slower than this [m/s or rad/s]."
    ),
    validate: Path = typer.Option(
        None, "--validate", metavar="LOG",
        help="Second log (same columns and options) to cross-check.",
    ),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    out: Path = typer.Option(
        None, "--out", "-o", metavar="FILE",
        help="Rigid-body model file (.toml with a .json twin).",
    ),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Fit inertia, friction and offset to logs (IDIM-LS).

    Inertia, viscous and Coulomb friction and offset by least squares on filtered derivatives (IDIM-LS)."""
    show_progress(quiet)
    from ..identify.rigid import fit_rigid, validate_rigid
    from ..io import save_model
    from .log_options import LogOptions

    _check_model_out(out, force)
    options = LogOptions.from_cli(map_, fs, time, scale, unit, skip_rows)
    settings = {"force": input_, "position": position, "cutoff_hz": lpf_hz, "filter_order": filter_order,
                "decimate": decimate, "velocity_threshold": velocity_threshold}
    fit = fit_rigid([options.read(p) for p in log_files], asymmetric=asymmetric, **settings)
    log_file = log_files[0] if len(log_files) == 1 else f"{len(log_files)} logs ({log_files[0]}, ...)"
    result = {"log": str(log_file), **({"logs": [str(p) for p in log_files]} if len(log_files) > 1 else {}),
              **fit.to_dict()}
    if validate is not None:
        result["validation"] = validate_rigid(options.read(validate), fit.model,
                                              **{**settings, "cutoff_hz": fit.cutoff_hz}).to_dict()
    if out is not None:
        record = {k: v for k, v in result.items() if k not in ("rigid_model", "validation")}
        result["files"] = [str(p) for p in save_model(out, fit.model, fit=record, force=force)]
    if as_json:
        result.pop("rigid_model", None)  # the same values as "params", keyed as in the model file
        emit({**result, "params": quantities(result["values"], result["units"], result["std"])})
        return
    units = result["units"]
    kind = {"rigid": "symmetric", "rigid-asymmetric": "asymmetric", "rigid-one-direction": "one-direction",
            "rigid-one-speed": "one-speed"}[result["model"]]
    typer.echo(f"Rigid-body model ({kind} friction, IDIM-LS) from {log_file}:")
    for name, value in result["values"].items():
        bound = result["on_bound"].get(name, {}).get("bound")
        typer.echo(f"  {name:12s} = {fmt_param(value, units[name], result['std'][name], lower=bound)}")
    typer.echo(f"  relative error {fmt(result['relative_error_pct'], '%')}, residual RMS "
               f"{fmt(result['residual_rms'], units['residual_rms'])}, condition number "
               f"{fmt(result['condition_number'])}, {result['n_samples']} samples after decimation by "
               f"{result['decimate']}, filter {fmt(result['cutoff_hz'], 'Hz')}")
    if result["cutoff_rule"] != "given":
        typer.echo(f"  filter cut-off chosen from the data: {result['cutoff_rule']}")
    if "validation" in result:
        v = result["validation"]
        typer.echo(f"  cross-check on {validate}: relative error {fmt(v['relative_error_pct'], '%')}, "
                   f"RMS {fmt(v['residual_rms'], v['units']['residual_rms'])}")
    for w in result.get("warnings", []):
        typer.echo(f"  warning: {cli_text(w)}")
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


def _friction_record(result: dict, log_file: Path | str) -> dict:
    """What goes in the ``[fit]`` table of a friction model file (no lists with missing values)."""
    if result.get("method") == "steady-state":
        fit = result["fit"]
        return {
            "log": str(log_file),
            "method": f"steady-state: mean command on constant-velocity plateaus, {result['law']} law per direction",
            "std": {f"{name}_{key}": s for key, d in fit["directions"].items() for name, s in d["std"].items()
                    if s is not None},
            "rms_error": fit["rms_error"],
            "relative_error_pct": fit["relative_error_pct"],
            "n_points": len(result["points"]),
            "points_velocity": [p["velocity"] for p in result["points"]],
            "points_force": [p["force"] for p in result["points"]],
            "omega_at_bound": any(d["omega_at_bound"] for d in fit["directions"].values()),
            "units": {"rms_error": fit["units"]["rms_error"], "relative_error_pct": "%",
                      "points_velocity": result["units"]["velocity"], "points_force": result["units"]["force"]},
        }
    fit = result["friction"]
    dist = result["disturbance"]
    law = result.get("law", "stribeck")
    joint = result.get("joint_fit")
    units = result["units"]
    record = {
        "log": str(log_file),
        "method": ("Kalman-filter equivalent disturbance, "
                   + ("Stribeck eq. 2.1" if law == "stribeck" else f"{law} law") + " least squares"
                   + ("; mass and viscous friction from the joint fit" if joint else "")),
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
        "units": {"mass": units["mass"], "viscous": units["viscous"],
                  "rms_error": fit["units"]["rms_error"], "relative_error_pct": "%",
                  "min_speed": fit["units"]["min_speed"], "observer_poles_hz": "Hz", "reversal_guard_s": "s"},
    }
    if joint:  # per-direction viscous coefficients and the mass's std of the joint fit
        record["viscous_pos"], record["viscous_neg"] = joint["viscous_pos"], joint["viscous_neg"]
        record["units"].update(viscous_pos=units["viscous"], viscous_neg=units["viscous"])
        if joint["mass_std"] is not None:
            record["mass_std"] = joint["mass_std"]
            record["units"]["mass_std"] = units["mass"]
    return record


def _friction_steady_state_checks(given: dict, steady_state: bool) -> None:
    """``--steady-state`` takes no Kalman/mass options, the plateau options need ``--steady-state``."""
    from ..errors import UsageError

    kalman = ("--model", "--mass", "--viscous", "--bandwidth-hz", "--method", "--per-direction-omega",
              "--reversal-guard", "--rigid-first")
    plateau = ("--plateau-acc-tol", "--plateau-vel-tol", "--plateau-min-duration")
    used = [name for name, value in given.items() if value is not None and value is not False]
    if steady_state and any(name in kalman for name in used):
        raise UsageError(f"{next(n for n in used if n in kalman)} is not used by --steady-state (the plateau "
                         "method needs no mass and no observer)")
    if not steady_state and any(name in plateau for name in used):
        raise UsageError(f"{next(n for n in used if n in plateau)} needs --steady-state")


def _friction_steady_state_text(result: dict, log_file: Path | str) -> None:
    """Print a steady-state friction result."""
    fit, units = result["fit"], result["units"]
    fu = fit["units"]
    typer.echo(f"Steady-state friction ({result['law']} law, {len(result['points'])} plateaus) from {log_file}:")
    for p in result["points"]:
        typer.echo(f"  v = {fmt(p['velocity'], units['velocity']):>14s}  F = {fmt(p['force'], units['force'])}  "
                   f"(scatter {fmt(p['force_std'])}, {fmt(p['duration_s'], 's')})")
    for key, d in fit["directions"].items():
        typer.echo(f"  {'v > 0' if key == 'pos' else 'v < 0'}: "
                   + ", ".join(f"{name} = {_std_text(d[name], d['std'].get(name), fu[name])}"
                               for name in ("dc", "ds", "omega", "viscous") if name in d["std"]))
    typer.echo(f"  fit RMS {fmt(fit['rms_error'], fu['rms_error'])} ({fmt(fit['relative_error_pct'], '%')})")
    for w in result.get("warnings", []):
        typer.echo(f"  warning: {cli_text(w)}")
    for p in result.get("files", []):
        typer.echo(f"wrote {p}")


def _friction_one_direction(joint, log_files: list[Path], log_file, as_json: bool, curve_out: Path | None = None,
                            force: bool = False) -> None:
    """Print the joint fit of data that move one way (a one-way friction run): mass, the law of that direction;
    with ``curve_out``, write its friction curve document first."""
    result = {"log": str(log_file), **({"logs": [str(p) for p in log_files]} if len(log_files) > 1 else {}),
              "method": "joint, one direction", "law": joint.law_fit.law, "joint_fit": joint.to_dict(),
              "warnings": list(joint.warnings)}
    files = _joint_curve_files(joint, curve_out, log_file, joint.warnings, force)
    if files:
        result["files"] = files
    if as_json:
        emit({**result, "params": joint_params(result["joint_fit"])})
        return
    jf = result["joint_fit"]
    fu = jf["law_fit"]["units"]
    typer.echo(f"Friction ({joint.law_fit.law} law, joint fit with the mass, one direction) from {log_file}:")
    typer.echo(f"  mass {_std_text(jf['mass'], jf['mass_std'], jf['units']['mass'])}")
    for key, d in jf["law_fit"]["directions"].items():
        typer.echo(f"  {'v > 0' if key == 'pos' else 'v < 0'}: "
                   + ", ".join(f"{name} = {_std_text(d[name], d['std'].get(name), fu[name])}"
                               for name in ("dc", "ds", "omega", "viscous") if name in d["std"]))
    typer.echo(f"  fit RMS {fmt(jf['law_fit']['rms_error'], fu['rms_error'])} "
               f"({fmt(jf['law_fit']['relative_error_pct'], '%')}), {jf['n_samples']} samples, filter "
               f"{fmt(jf['cutoff_hz'], 'Hz')}")
    for w in result["warnings"]:
        typer.echo(f"  warning: {cli_text(w)}")
    for p in files:
        typer.echo(f"wrote {p}")


CURVE_METHODS = {"steady-state": "steady-state: mean command on constant-velocity plateaus, law fitted per direction",
                 "joint": "joint fit of the mass and the law per direction: u = m a + law(v)"}
"""The ``method`` line of a friction curve document, per source of the fit."""


def _check_curve_out(curve_out: Path | None, out: Path | None, force: bool, joint: bool) -> None:
    """Fail before any work when ``--curve-out`` cannot be written or has no fit with points to hold."""
    from ..errors import UsageError
    from ..io.document import ensure_document_writable

    if curve_out is None:
        return
    suffix = curve_out.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise UsageError(f"--curve-out {curve_out}: friction curve documents are written as .toml (with a .json "
                         "twin) or .json")
    if not joint:
        raise UsageError("--curve-out needs --steady-state or the joint fit (not with --model, --mass or "
                         "--rigid-first: the Kalman disturbance fit keeps no law fit with points)")
    targets = {curve_out.resolve()} | ({curve_out.with_suffix(".json").resolve()} if suffix == ".toml" else set())
    if out is not None and targets & {out.resolve(), out.with_suffix(".json").resolve()}:
        raise UsageError(f"--curve-out {curve_out} and --out {out} name the same file")
    ensure_document_writable(curve_out, force)  # with the .json twin of a .toml


def _write_friction_curve(curve_out: Path, law_fit, points, *, method: str, points_what: str, log_file,
                          warnings, force: bool) -> list[str]:
    """Write the friction curve document (:mod:`feedtune.io.friction_curve_file`); the files written."""
    from ..io.friction_curve_file import friction_curve_document, write_friction_curve

    doc = friction_curve_document(law_fit, points, method=method, source=str(log_file), points_what=points_what,
                                  warnings=list(warnings))
    return [str(p) for p in write_friction_curve(curve_out, doc, force=force)]


def _joint_curve_files(joint, curve_out: Path | None, log_file, warnings, force: bool) -> list[str]:
    """The friction curve document of a joint fit (``F - m a`` binned by speed as its points), if asked."""
    if curve_out is None:
        return []
    return _write_friction_curve(curve_out, joint.law_fit, joint.points, method=CURVE_METHODS["joint"],
                                 points_what="friction F - m a of the joint fit's samples, mean per speed bin",
                                 log_file=log_file, warnings=warnings, force=force)


@app.command("friction")
def friction(
    log_files: list[Path] = typer.Argument(
        ..., metavar="LOG",
        help="Tracking log(s) (.csv, .mat, .mf4) moving both ways at several speeds; several logs are filtered one by "
             "one and fitted together.",
    ),
    model_file: Path = typer.Option(
        None, "--model", metavar="MODEL",
        help="Ballscrew or rigid model file giving mass and viscous friction (default: joint fit).",
    ),
    position: str = typer.Option(
        "x", "--position", metavar="COLUMN",
        help="Position column, e.g. x1 or x2 [rad] or x [m].",
    ),
    input_: str = typer.Option(
        "u", "--input", "-i", metavar="COLUMN",
        help="Command column (unit from the log or --unit).",
    ),
    mass: float = typer.Option(
        None, "--mass", metavar="MASS",
        help="Mass or inertia instead of --model [command/(position/s^2)].",
    ),
    viscous: float = typer.Option(
        None, "--viscous", metavar="COEFF",
        help="Viscous friction with --mass [command/(position/s)].",
    ),
    law: str = typer.Option(
        "stribeck", "--law", **choice(FRICTION_LAWS),
        help="Friction law: stribeck (eq. 2.1), hump, lugre or coulomb-viscous (sign(v) Fc + Fv v).",
    ),
    steady_state: bool = typer.Option(
        False, "--steady-state", help="Fit the law to the mean command on constant-velocity plateaus (no Kalman "
                                      "filter, no mass)."
    ),
    rigid_first: bool = typer.Option(
        False, "--rigid-first", help="Without --model/--mass: IDIM-LS rigid fit first instead of the joint fit."
    ),
    lpf_hz: float = typer.Option(
        None, "--lpf-hz", metavar="HZ",
        help="Position filter cut-off of the joint, rigid or plateau fit [Hz] (default: from the data).",
    ),
    bandwidth_hz: float = typer.Option(
        None, "--bandwidth-hz", metavar="HZ", help="Kalman observer bandwidth [Hz] (default min(0.05 fs, 50 Hz))."
    ),
    method: str = typer.Option(
        None, "--method", **choice(KALMAN_METHODS),
        help="Kalman filter: steady-state (fast, default) or filterpy (per-sample).",
    ),
    min_speed: float = typer.Option(
        None, "--min-speed", metavar="SPEED",
        help="Ignore slower samples or plateaus [m/s or rad/s] (default 2 % of the peak; plateaus 0.2 %).",
    ),
    per_direction_omega: bool = typer.Option(
        False, "--per-direction-omega", help="Separate Stribeck velocity per direction."
    ),
    reversal_guard_s: float = typer.Option(
        None, "--reversal-guard", metavar="S",
        help="Time left out after each reversal [s] (default: observer settling time).",
    ),
    plateau_acc_tol: float = typer.Option(
        None, "--plateau-acc-tol", metavar="ACC",
        help="--steady-state: largest |acceleration| on a plateau [m/s^2 or rad/s^2] (default 5 % of the log's 99th "
             "percentile).",
    ),
    plateau_vel_tol: float = typer.Option(
        None, "--plateau-vel-tol", metavar="FRACTION",
        help="--steady-state: relative velocity tolerance of a plateau (default 0.02).",
    ),
    plateau_min_duration: float = typer.Option(
        None, "--plateau-min-duration", metavar="S", help="--steady-state: shortest plateau [s] (default 0.1)."
    ),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    out: Path = typer.Option(
        None, "--out", "-o", metavar="FILE",
        help="Friction model file (.toml with a .json twin; needs both directions).",
    ),
    curve_out: Path = typer.Option(
        None, "--curve-out", metavar="FILE",
        help="Friction curve document (.toml with a .json twin, or .json) for the report: the law per direction with "
             "std, the measured points and the fitted curve; one direction is enough (--steady-state or the joint "
             "fit).",
    ),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Fit a friction law per direction of motion to logs.

    Friction per direction: Stribeck eq. 2.1 (or --law hump|lugre|coulomb-viscous) with viscous friction, fitted
    jointly with the mass (or from the Kalman-filter disturbance with --model/--mass), or with --steady-state from
    constant-velocity plateaus."""
    show_progress(quiet)
    from ..errors import DataError, UsageError
    from ..identify.friction import OneDirectionError, fit_joint_friction, identify_friction
    from ..identify.friction_curve import PlateauSettings, identify_friction_curve
    from ..io import save_model
    from ..models.friction import check_law
    from .log_options import read_log_with_options

    check_law(law)
    _friction_steady_state_checks({
        "--model": model_file, "--mass": mass, "--viscous": viscous, "--bandwidth-hz": bandwidth_hz,
        "--method": method, "--per-direction-omega": per_direction_omega, "--reversal-guard": reversal_guard_s,
        "--rigid-first": rigid_first, "--plateau-acc-tol": plateau_acc_tol, "--plateau-vel-tol": plateau_vel_tol,
        "--plateau-min-duration": plateau_min_duration}, steady_state)
    _check_model_out(out, force)
    _check_curve_out(curve_out, out, force, steady_state or (model_file is None and mass is None and not rigid_first))
    model = _friction_model_source(model_file)
    logs = [read_log_with_options(p, map_, fs, time, scale, unit, skip_rows) for p in log_files]
    if min_speed is not None and not min_speed >= 0 and position in logs[0]:  # before any fit
        raise UsageError(f"--min-speed must be >= 0 {logs[0].unit(position)}/s, got {min_speed:g}")
    log_file = log_files[0] if len(log_files) == 1 else f"{len(log_files)} logs ({log_files[0]}, ...)"
    if steady_state:
        given = {"acc_tol": plateau_acc_tol, "vel_tol": plateau_vel_tol, "min_duration": plateau_min_duration,
                 "min_speed": min_speed}
        ident = identify_friction_curve(logs, position=position, command=input_, law=law, cutoff_hz=lpf_hz,
                                        settings=PlateauSettings(**{k: v for k, v in given.items() if v is not None}))
        if out is not None and ident.friction is None:
            way = "v > 0" if "pos" in ident.fit.directions else "v < 0"
            raise DataError(f"--out {out}: only {way} has plateaus, and a friction model file needs both directions; "
                            "run without --out to see the one-direction fit, or add runs the other way")
    else:
        try:
            ident = identify_friction(logs, position=position, command=input_, model=model, mass=mass,
                                      viscous=viscous, bandwidth_hz=bandwidth_hz, method=method or "steady-state",
                                      min_speed=min_speed, per_direction_omega=per_direction_omega,
                                      reversal_guard_s=reversal_guard_s, law=law, joint=not rigid_first,
                                      cutoff_hz=lpf_hz)
        except OneDirectionError:
            if out is not None:
                raise DataError(f"--out {out}: the data move one way only, and a friction model file needs both "
                                "directions; run without --out to see the one-direction fit, or add runs the other "
                                "way") from None
            joint = fit_joint_friction(logs, position=position, command=input_, law=law, cutoff_hz=lpf_hz,
                                       min_speed=min_speed, one_direction=True)
            _friction_one_direction(joint, log_files, log_file, as_json, curve_out, force)
            return
    result = {"log": str(log_file), **({"logs": [str(p) for p in log_files]} if len(log_files) > 1 else {}),
              **ident.to_dict()}
    if out is not None:
        record = _friction_record(result, log_file)
        result["files"] = [str(p) for p in save_model(out, ident.friction, fit=record, force=force)]
    if curve_out is not None:
        if steady_state:
            files = _write_friction_curve(curve_out, ident.fit, [p.to_dict() for p in ident.plateaus],
                                          method=CURVE_METHODS["steady-state"],
                                          points_what="mean command on each constant-velocity plateau",
                                          log_file=log_file, warnings=ident.warnings, force=force)
        else:
            files = _joint_curve_files(ident.joint_fit, curve_out, log_file, ident.warnings, force)
        result["files"] = result.get("files", []) + files
    if as_json:
        emit({**result, "params": friction_params(result)})
        return
    if steady_state:
        _friction_steady_state_text(result, log_file)
        return
    fit = result["friction"]
    f, u, std = fit["friction"], fit["units"], fit["std"]
    viscous_in_law = "viscous_pos" in f
    name = ("Stribeck friction (eq. 2.1)" if result["law"] == "stribeck" else f"Friction ({result['law']} law)") + \
        (" with viscous friction" if viscous_in_law and result["law"] != "coulomb-viscous" else "")
    typer.echo(f"{name} from {log_file}:")
    for name in ("dc_pos", "ds_pos", "omega_pos", "viscous_pos", "dc_neg", "ds_neg", "omega_neg", "viscous_neg"):
        if name in f:
            typer.echo(f"  {name:11s} = {_std_text(f[name], std.get(name), u[name])}{_omega_bound_note(fit, name)}")
    typer.echo(f"  Coulomb {fmt(fit['coulomb'], u['coulomb'])}, offset {fmt(fit['offset'], u['offset'])}; "
               f"fit RMS {fmt(fit['rms_error'], u['rms_error'])} ({fmt(fit['relative_error_pct'], '%')}), "
               f"{fit['n_pos']} + {fit['n_neg']} samples")
    joint = result.get("joint_fit")
    if joint:
        typer.echo(f"  mass {_std_text(joint['mass'], joint['mass_std'], joint['units']['mass'])} (joint fit, filter "
                   f"{fmt(joint['cutoff_hz'], 'Hz')}, {joint['n_samples']} rows); observer poles "
                   f"{', '.join(fmt(p, 'Hz') for p in result['disturbance']['observer_poles_hz'])} (disturbance "
                   "record)")
    else:
        source = "IDIM-LS rigid fit" if result.get("rigid_fit") else "given"
        typer.echo(f"  mass {fmt(result['mass'], result['units']['mass'])}, viscous "
                   f"{fmt(result['viscous'], result['units']['viscous'])} ({source}); observer poles "
                   f"{', '.join(fmt(p, 'Hz') for p in result['disturbance']['observer_poles_hz'])}")
    for w in result.get("warnings", []):
        typer.echo(f"  warning: {cli_text(w)}")
    for p in result.get("files", []):
        typer.echo(f"wrote {p}")
