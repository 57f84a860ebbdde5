"""``feedtune identify resonances``: resonances, a notch and input shapers from a magnitude-only vibration spectrum.

Reads a Klipper ``resonances_*.csv`` / ``calibration_data_*.csv`` (:func:`feedtune.io.psd_csv.read_psd_csv`), picks the
resonances of one PSD (:func:`feedtune.identify.resonances.find_resonances`), proposes a notch for the largest
(:func:`feedtune.design.input_shaper.resonance_notch`) and fits the input shapers as Klipper does
(:func:`feedtune.design.input_shaper.fit_shapers`), beside the shaper columns the file carries.
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import JSON_OPTION, fmt
from .help_text import choice
from .progress_display import QUIET_OPTION, show_progress

SHAPER_TYPES = ("zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei")
"""``--shaper``: :data:`feedtune.control.shapers.SHAPER_TYPES`."""
PSD_COLUMNS = ("xyz", "x", "y", "z")
"""``--column``: the PSDs of a Klipper file."""


def _length_scale(unit: str) -> tuple[float, str]:
    """Factor from m and the name of the length unit the spectrum's data are in (mm for Klipper)."""
    return (1e3, "mm") if "mm" in unit else (1.0, "m")


def resonances_result(spectrum, found, fits, recommended, notch) -> dict:
    """The ``--json`` object: spectrum, resonances, notch, shapers (with the file's columns), recommendation."""
    from ..io.psd_csv import shaper_column

    columns = {}
    for name, values in spectrum.shaper_columns.items():
        kind, freq = shaper_column(name)
        columns[kind] = {"column": name, "freq_hz": freq, "values": values}
    shapers = []
    for fit in fits:
        item = fit.to_dict()
        col = columns.get(fit.kind)
        if col is not None:
            n = min(fit.values.size, col["values"].size)
            item["file"] = {"column": col["column"], "freq_hz": col["freq_hz"],
                            "freq_ratio": fit.freq_hz / col["freq_hz"],
                            "max_vibration_difference": float(abs(fit.values[:n] - col["values"][:n]).max())}
        shapers.append(item)
    f = spectrum.freq_hz
    return {"spectrum": {"source": spectrum.source, "lines": int(f.size), "band_hz": [float(f[0]), float(f[-1])],
                         "unit": spectrum.unit, "normalized": spectrum.normalized,
                         "columns": list(spectrum.psd), "shaper_columns": list(spectrum.shaper_columns)},
            **found.to_dict(), "notch": None if notch is None else {"freq_hz": notch.freq_hz, "zeta_z": notch.zeta_z,
                                                                     "zeta_p": notch.zeta_p},
            "shapers": shapers, "recommended": None if recommended is None else recommended.kind,
            "units": {**found.to_dict()["units"], "smoothing_m": "m", "max_accel": "m/s^2", "score": "m",
                      "vibrations": "-", "band_hz": "Hz", "zeta_z": "-", "zeta_p": "-"}}


def _print(result: dict) -> None:
    import math

    sp = result["spectrum"]
    scale, length = _length_scale(sp["unit"])
    lo, hi = sp["band_hz"]
    norm = " (normalised by Klipper: divided by f + 0.1 Hz, zero below 5 Hz)" if sp["normalized"] else ""
    typer.echo(f"spectrum {sp['source']}: PSDs {', '.join(sp['columns'])} in {sp['unit'] or '-'}, {sp['lines']} "
               f"lines, {lo:g}-{hi:g} Hz{norm}")
    typer.echo(f"resonances of psd_{result['column']} (fitted peak; half-power damping beside):")
    for r in result["resonances"]:
        f1, f2 = r["half_power_band_hz"]
        typer.echo(f"  {r['freq_hz']:.1f} Hz, damping {100 * r['damping']:.2f} %  (half-power {f1:.1f}-{f2:.1f} Hz: "
                   f"{100 * r['half_power_damping']:.2f} %; highest bin {r['bin_freq_hz']:g} Hz, peak "
                   f"{fmt(r['peak_psd'])})")
    notch = result["notch"]
    if notch:
        depth = 20 * math.log10(notch["zeta_z"] / notch["zeta_p"]) if notch["zeta_z"] > 0 else -math.inf
        typer.echo(f"  notch for the largest (zeros on the resonance): --notch {notch['freq_hz']:.4g},"
                   f"{notch['zeta_z']:.3g},{notch['zeta_p']:g}  ({depth:.0f} dB at {notch['freq_hz']:.1f} Hz)")
    if not result["shapers"]:
        return
    typer.echo("input shapers, fitted as Klipper fits them (vibration left at damping 0.075-0.15, smoothing at "
               f"{5000 if length == 'mm' else 5} {length}/s^2):")
    header = f"  {'type':9s} {'freq':>9s} {'vibrations':>11s} {'smoothing':>12s} {'max accel':>16s}   file"
    typer.echo(header)
    for s in result["shapers"]:
        acc = s["max_accel"] * scale
        acc_text = f"{round(acc / 100) * 100:.0f} {length}/s^2" if length == "mm" else f"{fmt(acc)} {length}/s^2"
        file = s.get("file")
        col = (f"{file['column']} ({round(100 * (file['freq_ratio'] - 1), 1) + 0.0:+.1f} %)" if file else "-")
        typer.echo(f"  {s['kind']:9s} {s['freq_hz']:6.1f} Hz {100 * s['vibrations']:9.1f} % "
                   f"{s['smoothing_m'] * scale:9.3g} {length} {acc_text:>16s}   {col}")
    typer.echo(f"  recommended: {result['recommended']} (Klipper's rule: a lower score by 20 %, or by 5 % with 10 % "
               "less smoothing)")


def resonances(
    spectrum_file: Path = typer.Argument(
        ..., metavar="FILE",
        help="Klipper resonances_*.csv or calibration_data_*.csv (freq,psd_x,psd_y,psd_z,psd_xyz).",
    ),
    column: str = typer.Option(
        "xyz", "--column", **choice(PSD_COLUMNS),
        help="PSD to pick resonances in and fit shapers to: xyz (the sum, as Klipper), x, y or z.",
    ),
    shaper: list[str] = typer.Option(
        None, "--shaper", **choice(SHAPER_TYPES, "TYPE"),
        help="Shaper types to fit (repeatable): zv, mzv, zvd, ei, 2hump_ei, 3hump_ei (default Klipper's five: all "
             "but zvd).",
    ),
    max_smoothing: float = typer.Option(
        None, "--max-smoothing", metavar="MM",
        help="Largest smoothing accepted [mm, the spectrum's length unit] (Klipper's max_smoothing).",
    ),
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Resonances, a notch and input shapers from a vibration PSD.

    Pick the resonances of a magnitude-only vibration spectrum (frequency and damping of each peak, fitted and by
    half power), propose a notch for the largest and fit the input shapers ZV, MZV, EI, 2HUMP_EI and 3HUMP_EI as
    Klipper does, beside the shaper columns a calibration file carries."""
    show_progress(quiet)
    from ..design.input_shaper import AUTOTUNE_TYPES, fit_shapers, normalize_psd, recommended_shaper, resonance_notch
    from ..errors import UsageError
    from ..identify.resonances import find_resonances
    from ..io.psd_csv import read_psd_csv
    from .envelope import emit

    if column not in PSD_COLUMNS:
        raise UsageError(f"--column expects one of {', '.join(PSD_COLUMNS)}, got {column!r}")
    kinds = tuple(shaper) if shaper else AUTOTUNE_TYPES
    bad = [k for k in kinds if k not in SHAPER_TYPES]
    if bad:
        raise UsageError(f"--shaper {bad[0]}: expected one of {', '.join(SHAPER_TYPES)}")
    if max_smoothing is not None and not max_smoothing > 0:
        raise UsageError(f"--max-smoothing expects a length > 0, got {max_smoothing:g}")
    spectrum = read_psd_csv(spectrum_file)
    found = find_resonances(spectrum, column)
    top = found.resonances[0]
    notch = resonance_notch(top.freq_hz, top.damping) if top.damping < 0.7 else None
    psd = spectrum.get(column)
    psd = psd if spectrum.normalized else normalize_psd(spectrum.freq_hz, psd)
    scale, _ = _length_scale(spectrum.unit)
    fits = fit_shapers(spectrum.freq_hz, psd, kinds,
                       max_smoothing=None if max_smoothing is None else max_smoothing / scale)
    result = resonances_result(spectrum, found, fits, recommended_shaper(fits), notch)
    if as_json:
        emit(result)
    else:
        _print(result)
