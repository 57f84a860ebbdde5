"""Analysis of gantry (``kind = "gantry"``) and x-axis (``kind = "axis"``) gains documents.

``feedtune analyze GAINS`` calls :func:`analyze_gantry_document` for these kinds; the design commands of
:mod:`feedtune.cli.design_gantry_cmd` print the same summary.
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import fmt, print_json


def analyze_gantry_document(doc: dict, path, frf_path, quantity, as_json: bool) -> None:
    """Analyse a gantry or axis gains document in every case and print the summary (or the ``--json`` dict).

    Parameters
    ----------
    doc : dict
        The gains document (read by :func:`feedtune.io.read_document`).
    path : path-like
        Its file name (for messages).
    frf_path : path-like or None
        Measured FRF: 2x2 ``y1/u1, y1/u2, y2/u1, y2/u2`` [m/V] for a gantry, SISO for an axis.
    quantity : str or None
        Quantity of the FRF file when its metadata do not say.
    as_json : bool
        Print one JSON object instead of the summary.
    """
    result = gantry_document_result(doc, str(path), frf_path, quantity)
    if as_json:
        print_json(result)
    else:
        print_summary(result)


def gantry_document_result(doc: dict, where: str, frf_path=None, quantity=None) -> dict:
    """``{"kind", "controller", "gains", "analysis"}`` of a gantry or axis gains document."""
    from ..design.gantry_gains import AXIS_KIND, GANTRY_KIND, check_header
    from .frf_options import read_optional_frf

    kind = check_header(doc, where, (GANTRY_KIND, AXIS_KIND))
    frf = read_optional_frf(Path(frf_path) if frf_path is not None else None, quantity)
    gains = {k: (v["value"] if isinstance(v, dict) else v) for k, v in doc.get("gains", {}).items()}
    if kind == AXIS_KIND:
        from ..analysis.gantry import analyze_axis
        from ..design.gantry_gains import axis_design_from_document

        design = axis_design_from_document(doc, where)
        analysis = analyze_axis(design, frf).to_dict()
        return {"kind": kind, "controller": "loopshape", "gains": gains, "gain_units": _units(doc),
                "lead_stages": [s.to_dict() for s in design.lead_stages], "analysis": analysis}
    from ..analysis.gantry import analyze_gantry
    from ..design.gantry_gains import gantry_law_from_document

    law, model, x, reference = gantry_law_from_document(doc, where)
    analysis = analyze_gantry(law, model, x=x, frf=frf, reference=reference).to_dict()
    return {"kind": kind, "controller": law.controller, "x_m": x, "gains": gains, "gain_units": _units(doc),
            "analysis": analysis}


def _units(doc: dict) -> dict:
    return {k: v["unit"] for k, v in doc.get("gains", {}).items() if isinstance(v, dict) and "unit" in v}


def _band(b) -> str:
    return f"{b[0]:.3g}-{b[1]:.4g}" if b else "-"


def print_summary(result: dict) -> None:
    """Human-readable summary: gains with units and one line per analysis case."""
    units = result.get("gain_units", {})
    label = f"{result['kind']} ({result['controller']})"
    typer.echo(f"{label} gains:")
    for k, v in result["gains"].items():
        typer.echo(f"  {k:5s} = {fmt(v, units.get(k, ''), 6)}")
    for stage in result.get("lead_stages", []):
        typer.echo(f"  lead stage {stage['phase_deg']:.1f} deg at {stage['center_hz']:.4g} Hz "
                   f"(zero {stage['zero_hz']:.4g} Hz, pole {stage['pole_hz']:.4g} Hz, gamma {stage['gamma']:.3g})")
    gantry = result["kind"] == "gantry"
    head = "CoM crossover [Hz]" if gantry else "crossovers [Hz]"
    extra = f" {'damping band [Hz]':>18s}" if gantry else ""
    typer.echo(f"{'case':15s} {head:22s} {'PM [deg]':>9s} {'GM [dB]':>8s} {'Ms':>6s} {'Ms at [Hz]':>10s} "
               f"{'|S|<1 [Hz]':>14s}{extra} stable")
    for name, a in result["analysis"].items():
        if a is None:
            typer.echo(f"{name:15s} (needs --frf)")
            continue
        xo = ", ".join(f"{x:.1f}" for x in a["crossovers_hz"][:3]) or "-"
        damp = f" {_band(a.get('damping_band_hz')):>18s}" if gantry else ""
        typer.echo(f"{name:15s} {xo:22s} {fmt(a['phase_margin_deg'], '', 3):>9s} {fmt(a['gain_margin_db'], '', 3):>8s} "
                   f"{a['ms']:6.3f} {a['ms_freq_hz']:10.1f} {_band(a['rejection_band_hz']):>14s}{damp} "
                   f"{'yes' if a['stable'] else 'NO'}")
    if gantry:
        typer.echo("Ms = max sigma_max(S); stability by the MIMO Nyquist criterion on det(I + L); "
                   "crossover and margins of the CoM loop alpha^T L [1 1]^T")
