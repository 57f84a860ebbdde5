"""Analysis of a ball-screw gains document (``kind = "ballscrew"``): what ``feedtune analyze`` prints and the report
shows, computed in one place."""

from __future__ import annotations

from collections.abc import Mapping

from ..gains import GainsAnalysis, plain_gains


def analyze_document(doc: Mapping, where: str, frf=None) -> GainsAnalysis:
    """Every case of :func:`feedtune.analysis.ballscrew.analyze_ballscrew` for the law and model of a gains file.

    Parameters
    ----------
    doc : Mapping
        The gains document (``kind = "ballscrew"``).
    where : str
        Its name in error messages.
    frf : Frf, optional
        Measured ``x1/u``, ``x2/u`` FRF [m/V] for the measured and discrete cases.

    Returns
    -------
    GainsAnalysis
        The analysis and ``result``: ``kind``, ``controller``, ``gains`` (values in ``gain_units``), the
        closed-loop poles [rad/s] of the model loop and ``analysis`` (as ``feedtune analyze --json``, without the
        check).
    """
    from ...analysis.ballscrew import analyze_ballscrew, closed_loop_poles
    from ...control.ballscrew_law import all_gain_units
    from ...io.gains import law_from_document

    law, model, kind = law_from_document(doc, where)
    analysis = analyze_ballscrew(law, model, frf)
    gains = {**plain_gains(doc.get("gains")), **plain_gains(doc.get("ppi_gains"))}
    poles = closed_loop_poles(law, model)
    result = {"kind": kind, "controller": kind, "gains": gains, "gain_units": all_gain_units(model.input_unit),
              "command_unit": model.input_unit,
              "closed_loop_poles": [[float(p.real), float(p.imag)] for p in poles], "analysis": analysis.to_dict()}
    return GainsAnalysis(analysis=analysis, result=result, law=law, model=model)
