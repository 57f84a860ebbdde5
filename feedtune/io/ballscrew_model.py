"""Two-mass (ball-screw) model documents (``kind = "ballscrew"`` of ``feedtune.model/1``): the writer and the reader.

The model file of the plant structure ``two_mass`` (a ball screw, a rack and pinion, a belt axis; the kind keeps the
thesis' name)::

    schema = "feedtune.model/1"
    kind = "ballscrew"
    input_unit = "V"
    lead_m_per_rad = { value = 0.003183098861837907, unit = "m/rad" }
    real_pole_hz = 0.073...

    [params]
    m1 = { value = 0.001858, unit = "V/(rad/s^2)" }
    ...

    [[modes]]
    freq_hz = 130.5...
    zeta = 0.05...
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from ..errors import DataError
from ..models.ballscrew import PARAM_NAMES, BallScrewModel, param_units
from ..quantity import quantity, value_of


def ballscrew_to_doc(model: BallScrewModel) -> dict:
    """Document body of a :class:`BallScrewModel` (parameters, lead, modes, real pole)."""
    units = param_units(model.input_unit)
    lead = {"lead_m_per_rad": quantity(model.lead_m_per_rad, "m/rad")} if model.lead_given else {}
    return {
        "input_unit": model.input_unit,
        **lead,
        "real_pole_hz": model.real_pole_hz(),
        "params": {k: quantity(v, units[k]) for k, v in model.params().items()},
        "modes": [{"freq_hz": m.freq_hz, "zeta": m.zeta} for m in model.modes()],
    }


def ballscrew_from_doc(doc: Mapping[str, object], where: str) -> BallScrewModel:
    """Build a :class:`BallScrewModel` from a model document; errors name the file and the key."""
    input_unit = doc.get("input_unit", "V")
    if not isinstance(input_unit, str) or not input_unit:
        raise DataError(f"{where}: input_unit must be a unit string such as \"V\"")
    params = doc.get("params")
    if not isinstance(params, Mapping):
        raise DataError(f"{where}: missing [params] table with {', '.join(PARAM_NAMES)}")
    units = param_units(input_unit)
    values = {}
    for name in PARAM_NAMES:
        if name not in params:
            raise DataError(f"{where}: params.{name} is missing")
        v = value_of(params[name], units[name], f"{where}: params.{name}")
        if not math.isfinite(v) or v < 0 or (v == 0 and name in ("m1", "m2", "k")):
            need = "> 0" if name in ("m1", "m2", "k") else ">= 0"
            raise DataError(f"{where}: params.{name} = {v:g} must be finite and {need}")
        values[name] = v
    lead = value_of(doc.get("lead_m_per_rad", BallScrewModel.lead_m_per_rad), "m/rad",
                    f"{where}: lead_m_per_rad")
    if not (math.isfinite(lead) and lead > 0):
        raise DataError(f"{where}: lead_m_per_rad = {lead:g} must be > 0 m/rad")
    try:
        return BallScrewModel(**values, lead_m_per_rad=lead, input_unit=input_unit,
                              lead_given="lead_m_per_rad" in doc)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None
