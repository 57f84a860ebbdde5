"""``feedtune identify gantry`` and ``feedtune identify mass``: the T-gantry of thesis §4.3.

* ``gantry``: the constrained least-squares fit of eq. 4.5-4.15 at every table position and the
  position-dependent model of eq. 4.16 (``J0, d, m_x, c, k``, mass distribution) from 2x2 FRFs.
* ``mass``: total mass and mass distribution ``alpha1(x)`` from tracking logs at several table positions
  (and the table mass ``m_x`` from an x-axis log), written as a mass document that ``identify gantry
  --mass`` imposes as the constraint of eq. 4.13.

Registered in :mod:`feedtune.cli.main` on the ``identify`` group.
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, fmt, parse_float_pair
from .envelope import emit, quantities
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import QUANTITIES, choice
from .progress_display import QUIET_OPTION, show_progress

GANTRY_PARAMS = ("m", "J0", "d", "m_x", "c", "k", "alpha1_0", "dalpha1_dx")
"""The identified parameters of the gantry model (eq. 4.16) in ``identify gantry --json``'s ``params``."""


# ------------------------------------------------------------------------------------------ helpers
def _check_positions(files: list[Path], xs: list[float] | None, what: str) -> list[float]:
    from ..errors import UsageError

    xs = list(xs or [])
    if len(xs) != len(files):
        raise UsageError(f"give one --x per {what}: {len(files)} {what}(s) but {len(xs)} --x value(s)")
    return xs


def _gantry_frf(path: Path, quantity: str | None, frf_options=None):
    from ..errors import DataError
    from .frf_options import read_frf_with_options

    frf = read_frf_with_options(path, quantity, options=frf_options)
    if frf.output_unit.strip() != "m":
        raise DataError(f"{path}: gantry FRFs must declare the output unit m (e.g. '# output: y1 [m]'); "
                        f"found {frf.output_unit!r}")
    return frf


# ------------------------------------------------------------------------------------------ commands
def gantry(
    frf_files: list[Path] = typer.Argument(
        ..., metavar="FRF",
        help="2x2 FRF files (y1/u1, y1/u2, y2/u1, y2/u2; output unit m), one per table position.",
    ),
    x: list[float] = typer.Option(
        None, "--x", metavar="M",
        help="Table position [m] of each FRF file, in the same order (repeatable; at least 3 distinct).",
    ),
    span: float = typer.Option(
        ..., "--span", metavar="M",
        help="Span L between the two actuators/encoders [m] (1.484 in the thesis). Required: the FRFs determine only "
             "M, C, K in encoder coordinates, not the geometry.",
    ),
    band: tuple[float, float] = typer.Option(
        None, "--band", metavar="LO HI",
        help="Fit band LO HI [Hz] around the yaw mode (default: detected, 0.6-1.6 f_yaw).",
    ),
    bounds: bool = typer.Option(False, "--bounds", help="Solve with physical bounds (c, k >= 0, M >= 0; cvxpy)."),
    mass_file: Path = typer.Option(
        None, "--mass", metavar="FILE",
        help="Mass document from feedtune identify mass: imposes the side masses (eq. 4.13) and its m_x.",
    ),
    m_x: float = typer.Option(None, "--m-x", metavar="MASS", help="Table mass [V/(m/s^2)]: fit only J0 and d of J(x)."),
    quantity: str = typer.Option(
        None, "--quantity", **choice(QUANTITIES, "QUANTITY"),
        help="position, velocity or acceleration (overrides the files).",
    ),
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    out: Path = typer.Option(
        None, "--out", "-o", metavar="FILE",
        help="Model file to write (.toml with a .json twin).",
    ),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Fit the gantry yaw model to 2x2 FRFs at several positions.

    Fit the gantry yaw model (eq. 4.1-4.16: m, J0, d, m_x, c, k, alpha1(x)) to 2x2 FRFs at several x."""
    show_progress(quiet)
    from ..identify.gantry import fit_gantry
    from ..io import save_model
    from .frf_options import FrfReadOptions

    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    xs = _check_positions(frf_files, x, "FRF file")
    b = parse_float_pair(band, "--band")
    from ..io.mass_file import read_mass_document

    mass_fit, mass_mx = read_mass_document(mass_file) if mass_file is not None else (None, None)
    frfs = [_gantry_frf(p, quantity, frf_options) for p in frf_files]
    fit = fit_gantry(frfs, xs, L=span, band_hz=b, mass_distribution=mass_fit, bounds=bounds,
                     m_x=m_x if m_x is not None else mass_mx)
    result = fit.to_dict()
    if out is not None:
        written = save_model(out, fit.model, fit=result, force=force)
        result["files"] = [str(p) for p in written]
    if as_json:
        model = result["model"]  # the fit gives no standard deviations; the span L is given (--span)
        emit({**result, "params": quantities(model, model["units"], names=GANTRY_PARAMS)})
        return
    model = result["model"]
    units = model["units"]
    typer.echo(f"Gantry model (eq. 4.16) from {len(frfs)} FRFs at x = {', '.join(f'{v:g}' for v in xs)} m:")
    for name in ("m", "J0", "d", "m_x", "c", "k", "alpha1_0", "dalpha1_dx"):
        typer.echo(f"  {name:10s} = {fmt(model[name], units[name])}")
    for row in result["yaw_modes"]:
        typer.echo(f"  x = {row['x']:+.3f} m: yaw mode {row['fit_freq_hz']:.2f} Hz, damping "
                   f"{100 * row['fit_zeta']:.2f} % (model {row['model_freq_hz']:.2f} Hz)")
    typer.echo(f"  J(x) residual {fmt(100 * result['inertia_rms_residual'], '%')}, k spread "
               f"{fmt(100 * result['k_spread'], '%')}")
    for f in result["fits"]:
        worst = max(f["fit_error"].values())
        typer.echo(f"  fit at x = {f['x']:+.3f} m: band {f['band_hz'][0]:.1f}-{f['band_hz'][1]:.1f} Hz, "
                   f"worst channel error {fmt(100 * worst, '%')}")
    for p in result.get("files", []):
        typer.echo(f"wrote {p}")


def mass(
    logs: list[Path] = typer.Argument(
        ..., metavar="LOG",
        help="Tracking logs of the gantry (u1, u2 [V] and the commanded acceleration), one per table position.",
    ),
    x: list[float] = typer.Option(None, "--x", metavar="M", help="Table position [m] of each log, in the same order "
                                                    "(repeatable; at least 2 distinct)."),
    axis_log: Path = typer.Option(
        None, "--axis-log", metavar="LOG",
        help="Tracking log of the x axis (ux, a_ref) for m_x.",
    ),
    u1: str = typer.Option("u1", "--u1", metavar="COLUMN", help="Left command signal [V]."),
    u2: str = typer.Option("u2", "--u2", metavar="COLUMN", help="Right command signal [V]."),
    acc_ref: str = typer.Option(
        "ay_ref", "--acc-ref", metavar="COLUMN",
        help="Commanded y acceleration signal [m/s^2].",
    ),
    axis_u: str = typer.Option("ux", "--axis-u", metavar="COLUMN", help="x-axis command signal in --axis-log [V]."),
    axis_acc_ref: str = typer.Option(
        "a_ref", "--axis-acc-ref", metavar="COLUMN",
        help="Commanded x acceleration in --axis-log.",
    ),
    out: Path = typer.Option(
        None, "--out", "-o", metavar="FILE",
        help="Mass document to write (.toml with a .json twin).",
    ),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Fit the gantry's mass distribution to tracking logs.

    Total mass and distribution alpha1(x) (thesis Fig. 4.5) from tracking logs; m_x from an x-axis log."""
    show_progress(quiet)
    from ..identify.mass import fit_axis_mass, fit_mass_distribution
    from ..io import read_log, write_document
    from ..io.mass_file import mass_document

    xs = _check_positions(logs, x, "log")
    fit = fit_mass_distribution([read_log(p) for p in logs], xs, u1=u1, u2=u2, acc_ref=acc_ref)
    m_x = fit_axis_mass(read_log(axis_log), u=axis_u, acc_ref=axis_acc_ref) if axis_log is not None else None
    doc = mass_document(fit, m_x)
    result = {**fit.to_dict(), "m_x": m_x}
    result["units"] = {**result["units"], "m_x": "V/(m/s^2)"}
    if out is not None:
        result["files"] = [str(p) for p in write_document(out, doc, force=force)]
    if as_json:
        names = ["m", "alpha1_0", "dalpha1_dx"] + ([] if m_x is None else ["m_x"])
        emit({**result, "params": quantities(result, result["units"], names=names)})
        return
    typer.echo(f"Gantry mass from {len(logs)} logs: m = {fmt(fit.m, 'V/(m/s^2)')}, alpha1(x) = "
               f"{fit.alpha1_0:.4f} {fit.dalpha1_dx:+.4f} x [x in m] (rms residual {fit.alpha1_rms_residual:.2g})")
    for p in fit.positions:
        typer.echo(f"  x = {p.x:+.3f} m: m1 = {fmt(p.m1, 'V/(m/s^2)')}, m2 = {fmt(p.m2, 'V/(m/s^2)')}, "
                   f"alpha1 = {p.alpha1:.4f}")
    if m_x is not None:
        typer.echo(f"  table: m_x = {fmt(m_x, 'V/(m/s^2)')}")
    for p in result.get("files", []):
        typer.echo(f"wrote {p}")
