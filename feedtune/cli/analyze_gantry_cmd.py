"""Analysis of gantry (``kind = "gantry"``) and x-axis (``kind = "axis"``) gains documents.

``feedtune analyze GAINS`` calls :func:`analyze_gantry_document` for these kinds; the design commands of
:mod:`feedtune.cli.design_gantry_cmd` print the same summary.
"""

from __future__ import annotations

from pathlib import Path


def analyze_gantry_document(doc: dict, path, frf_path, quantity, as_json: bool, limits=None,
                            strict: bool = False) -> None:
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
    limits : Limits, optional
        The policy to check (default: textbook).
    strict : bool
        Raise DesignError when the check fails.
    """
    from .limits_options import finish_analysis

    result, analysis = gantry_document_result(doc, str(path), frf_path, quantity)
    finish_analysis(result, analysis, limits, as_json, strict)


def gantry_document_result(doc: dict, where: str, frf_path=None, quantity=None) -> tuple[dict, object]:
    """``{"kind", "controller", "gains", "analysis"}`` of a gantry or axis gains document, and the analysis."""
    from ..io.gantry_gains import AXIS_KIND, GANTRY_KIND, check_header
    from .frf_options import read_optional_frf

    kind = check_header(doc, where, (GANTRY_KIND, AXIS_KIND))
    frf = read_optional_frf(Path(frf_path) if frf_path is not None else None, quantity)
    gains = {k: (v["value"] if isinstance(v, dict) else v) for k, v in doc.get("gains", {}).items()}
    if kind == AXIS_KIND:
        from ..analysis.gantry import analyze_axis
        from ..io.gantry_gains import axis_law_from_document

        design = axis_law_from_document(doc, where)
        full = analyze_axis(design, frf)
        return {"kind": kind, "controller": "loopshape", "gains": gains, "gain_units": _units(doc),
                "lead_stages": [s.to_dict() for s in design.lead_stages], "analysis": full.to_dict()}, full
    from ..analysis.gantry import analyze_gantry
    from ..io.gantry_gains import gantry_law_from_document

    law, model, x, reference = gantry_law_from_document(doc, where)
    full = analyze_gantry(law, model, x=x, frf=frf, reference=reference)
    return {"kind": kind, "controller": law.controller, "x_m": x, "gains": gains, "gain_units": _units(doc),
            "analysis": full.to_dict()}, full


def _units(doc: dict) -> dict:
    return {k: v["unit"] for k, v in doc.get("gains", {}).items() if isinstance(v, dict) and "unit" in v}
