"""Analysis of cascade gains documents (``kind = "cascade"``): what ``feedtune analyze`` prints and the report shows."""

from __future__ import annotations

from collections.abc import Mapping

from ..gains import GainsAnalysis, plain_gains


def analyze_document(doc: Mapping, where: str, frf=None) -> GainsAnalysis:
    """Both loops of a cascade gains document in every case (:func:`feedtune.analysis.cascade.analyze_cascade`).

    Parameters
    ----------
    doc : Mapping
        The gains document.
    where : str
        Its name in error messages.
    frf : Frf, optional
        Measured FRF of the axis: the motor side (speed or position per current setpoint) and, for a position loop
        on the load encoder, the load side.

    Returns
    -------
    GainsAnalysis
        The analysis and ``result``: ``kind``, ``controller``, ``gains`` (values in ``gain_units``), ``filters``
        (the drive's parameters), ``position_loop`` (rate [Hz], ratio, encoder), ``plant`` (the model and its
        current loop, or how it was estimated) and ``analysis`` (as ``feedtune analyze --json``, without the check).

    Raises
    ------
    DataError
        A document without a model analysed without an FRF, or one the analysis refuses.
    """
    from ...analysis.cascade import analyze_cascade
    from ...control.cascade import describe_filter
    from ...design.cascade import plant_from_frf
    from ...errors import DataError
    from ...io.cascade_gains import cascade_from_document

    law, plant, _ = cascade_from_document(doc, where)
    note = None
    if plant is None:
        if frf is None:
            raise DataError(f"{where}: the gains file holds no plant model ([model]); analyse it on the FRF it was "
                            "made for (--frf)")
        plant, note = plant_from_frf(frf, law.command_unit, law.position_unit)
    analysis = analyze_cascade(law, plant, frf)
    units = {k: v["unit"] for k, v in (doc.get("gains") or {}).items() if isinstance(v, Mapping) and "unit" in v}
    result = {"kind": "cascade", "controller": "cascade", "gains": plain_gains(doc.get("gains")), "gain_units": units,
              "filters": [describe_filter(f) + ("" if f.enabled else " (disabled)") for f in law.filters],
              "position_loop": {"fs_hz": law.fp, "ratio": law.position_ratio, "encoder": law.position_encoder,
                                "open": law.kv == 0},
              "plant": {**plant.to_dict(), **({"estimated": note} if note else {})},
              "analysis": analysis.to_dict()}
    return GainsAnalysis(analysis=analysis, result=result, law=law, model=plant)
