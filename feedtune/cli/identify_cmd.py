"""``feedtune identify``: models from measurements."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, fmt, parse_float_pair, print_json

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
    from .frf_options import mat_channels

    b = parse_float_pair(band, "--band")
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
