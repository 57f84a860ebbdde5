"""Analysis of gantry (``kind = "gantry"``) and x-axis (``kind = "axis"``) gains documents: what
``feedtune analyze`` prints and the report shows, computed in one place."""

from __future__ import annotations

from collections.abc import Mapping

from ..gains import GainsAnalysis, plain_gains


def _gain_units(doc: Mapping) -> dict:
    return {k: v["unit"] for k, v in (doc.get("gains") or {}).items() if isinstance(v, Mapping) and "unit" in v}


def analyze_gantry_document(doc: Mapping, where: str, frf=None) -> GainsAnalysis:
    """Every case of the gantry MIMO/PID analysis of a gains file (``kind = "gantry"``).

    Parameters
    ----------
    doc : Mapping
        The gains document.
    where : str
        Its name in error messages.
    frf : Frf, optional
        Measured 2x2 FRF ``y1/u1, y1/u2, y2/u1, y2/u2`` [m/V]. An FRF that records its table position
        (:attr:`~feedtune.frf.Frf.position_m`) is analysed there: the model and the scheduled law at that position;
        otherwise at the design position.

    Returns
    -------
    GainsAnalysis
        The analysis and ``result``: ``kind``, ``controller``, ``x_m`` (the position analysed [m]), ``design_x_m``
        (the design position [m]), ``gains`` (values in ``gain_units``) and ``analysis`` (as ``feedtune analyze
        --json``, without the check).
    """
    from ...analysis.gantry import analyze_gantry
    from ...io.gantry_gains import GANTRY_KIND, check_header, design_position, gantry_law_from_document

    kind = check_header(doc, where, (GANTRY_KIND,))
    gains = plain_gains(doc.get("gains"))
    design_x = design_position(doc, where)
    law, model, x, reference = gantry_law_from_document(doc, where, None if frf is None else frf.position_m)
    analysis = analyze_gantry(law, model, x=x, frf=frf, reference=reference)
    return GainsAnalysis(analysis=analysis, law=law, model=model, result={
        "kind": kind, "controller": law.controller, "x_m": x, "design_x_m": design_x, "gains": gains,
        "gain_units": _gain_units(doc),
        "analysis": analysis.to_dict()})


def analyze_axis_document(doc: Mapping, where: str, frf=None) -> GainsAnalysis:
    """Every case of the loop-shaped axis' analysis of a gains file (``kind = "axis"``).

    Parameters
    ----------
    doc : Mapping
        The gains document.
    where : str
        Its name in error messages.
    frf : Frf, optional
        Measured SISO FRF of the axis [position unit / command unit].

    Returns
    -------
    GainsAnalysis
        The analysis and ``result``: ``kind``, ``controller``, ``gains`` (values in ``gain_units``),
        ``lead_stages`` and ``analysis`` (as ``feedtune analyze --json``, without the check).
    """
    from ...analysis.gantry import analyze_axis
    from ...io.gantry_gains import AXIS_KIND, axis_law_from_document, check_header

    kind = check_header(doc, where, (AXIS_KIND,))
    gains = plain_gains(doc.get("gains"))
    law = axis_law_from_document(doc, where)
    analysis = analyze_axis(law, frf)
    return GainsAnalysis(analysis=analysis, law=law, model=None, result={
        "kind": kind, "controller": "loopshape", "gains": gains, "gain_units": _gain_units(doc),
        "lead_stages": [s.to_dict() for s in law.lead_stages], "analysis": analysis.to_dict()})
