"""Friction model documents (``kind = "friction"`` of ``feedtune.model/1``, Stribeck eq. 2.1)."""

from __future__ import annotations

from collections.abc import Mapping

from ..errors import DataError
from ..models.friction import LEVEL_NAMES, OMEGA_NAMES, VELOCITY_UNITS, StribeckFriction
from ..quantity import quantity, value_of


def stribeck_to_doc(model: StribeckFriction) -> dict:
    """Document body of a friction model file (registered as model kind ``"friction"``).

    Example file (``feedtune identify friction LOG --out friction.toml``)::

        schema = "feedtune.model/1"
        kind = "friction"
        model = "stribeck"
        command_unit = "V"
        velocity_unit = "rad/s"

        [params]
        dc_pos = { value = 0.1, unit = "V" }
        ds_pos = { value = 0.16, unit = "V" }
        dc_neg = { value = -0.09, unit = "V" }
        ds_neg = { value = -0.15, unit = "V" }
        omega_pos = { value = 0.8, unit = "rad/s" }
        omega_neg = { value = 0.6, unit = "rad/s" }   # optional: omitted = omega_pos (eq. 2.1)
    """
    return _stribeck_body(model)


def stribeck_from_doc(doc: Mapping[str, object], where: str = "friction model") -> StribeckFriction:
    """Build a :class:`StribeckFriction` from a friction model document (see :func:`stribeck_to_doc`)."""
    return _stribeck_from_body(doc, where)


def _stribeck_body(self: StribeckFriction) -> dict:
    """Body of a friction model file: units and ``[params]`` as quantities ."""
    params = {name: quantity(getattr(self, name), self.command_unit) for name in LEVEL_NAMES}
    params["omega_pos"] = quantity(self.omega_pos, self.velocity_unit)
    if self.omega_neg is not None:
        params["omega_neg"] = quantity(self.omega_neg, self.velocity_unit)
    return {"model": "stribeck", "command_unit": self.command_unit, "velocity_unit": self.velocity_unit,
            "params": params}


def _stribeck_from_body(doc: Mapping[str, object], where: str = "friction model") -> StribeckFriction:
    """Build the model from a document written by :func:`stribeck_to_doc` (errors name ``where`` and the key)."""
    model = doc.get("model", "stribeck")
    if model != "stribeck":
        raise DataError(f"{where}: model = {model!r}; only 'stribeck' (eq. 2.1) friction is known")
    command_unit = _unit_string(doc, "command_unit", where)
    velocity_unit = _unit_string(doc, "velocity_unit", where)
    if velocity_unit not in VELOCITY_UNITS:
        raise DataError(f"{where}: velocity_unit = {velocity_unit!r}; expected one of {', '.join(VELOCITY_UNITS)}")
    params = doc.get("params")
    if not isinstance(params, Mapping):
        raise DataError(f"{where}: missing [params] table with {', '.join(LEVEL_NAMES + OMEGA_NAMES)}")
    unknown = sorted(set(params) - set(LEVEL_NAMES + OMEGA_NAMES))
    if unknown:
        raise DataError(f"{where}: unknown friction parameter params.{unknown[0]}")
    values: dict[str, float | None] = {}
    for name in LEVEL_NAMES + OMEGA_NAMES:
        if name not in params:
            if name == "omega_neg":
                values[name] = None
                continue
            raise DataError(f"{where}: params.{name} is missing")
        unit = velocity_unit if name in OMEGA_NAMES else command_unit
        values[name] = value_of(params[name], unit, f"{where}: params.{name}")
    try:
        return StribeckFriction(**values, command_unit=command_unit, velocity_unit=velocity_unit)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None


def _unit_string(doc: Mapping[str, object], key: str, where: str) -> str:
    unit = doc.get(key)
    if not isinstance(unit, str) or not unit:
        raise DataError(f"{where}: {key} must be a unit string (e.g. \"V\", \"rad/s\"), got {unit!r}")
    return unit
