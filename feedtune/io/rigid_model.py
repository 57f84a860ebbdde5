"""Rigid-body model documents (``kind = "rigid"`` of ``feedtune.model/1``)."""

from __future__ import annotations

from collections.abc import Mapping

from ..errors import DataError
from ..models.rigid import OPTIONAL_PARAMS, PARAM_NAMES, POSITION_UNITS, RigidBodyModel
from ..quantity import value_of


def rigid_to_doc(model: RigidBodyModel) -> dict:
    """Document body of a rigid-body model file (registered as model kind ``"rigid"``).

    Example file (``feedtune identify rigid LOG --out rigid.toml``)::

        schema = "feedtune.model/1"
        kind = "rigid"
        command_unit = "N"
        position_unit = "m"

        [params]
        mass = { value = 95.1, unit = "N/(m/s^2)" }
        viscous = { value = 203.5, unit = "N/(m/s)" }
        coulomb_pos = { value = 20.39, unit = "N" }
        coulomb_neg = { value = 20.39, unit = "N" }     # optional: omitted = coulomb_pos
        offset = { value = -3.16, unit = "N" }
        viscous_neg = { value = 203.5, unit = "N/(m/s)" }  # optional: omitted = viscous
    """
    return _rigid_body(model)


def rigid_from_doc(doc: Mapping[str, object], where: str = "rigid-body model") -> RigidBodyModel:
    """Build a :class:`RigidBodyModel` from a rigid-body model document (see :func:`rigid_to_doc`)."""
    return _rigid_from_body(doc, where)


def _rigid_body(self: RigidBodyModel) -> dict:
    """Body of a rigid-body model file: units and ``[params]`` as quantities ."""
    units = self.units
    params = {}
    for name in PARAM_NAMES:
        value = getattr(self, name)
        if value is not None:
            params[name] = {"value": float(value), "unit": units[name]}
    return {"command_unit": self.command_unit, "position_unit": self.position_unit, "params": params}


def _rigid_from_body(doc: Mapping[str, object], where: str = "rigid-body model") -> RigidBodyModel:
    """Build the model from a document written by :func:`rigid_to_doc` (errors name ``where`` and the key)."""
    command_unit = doc.get("command_unit")
    position_unit = doc.get("position_unit")
    for key, unit in (("command_unit", command_unit), ("position_unit", position_unit)):
        if not isinstance(unit, str) or not unit:
            raise DataError(f"{where}: {key} must be a unit string, got {unit!r}")
    if position_unit not in POSITION_UNITS:
        raise DataError(f"{where}: position_unit = {position_unit!r}; expected one of {', '.join(POSITION_UNITS)}")
    params = doc.get("params")
    if not isinstance(params, Mapping):
        raise DataError(f"{where}: missing [params] table with {', '.join(PARAM_NAMES)}")
    unknown = sorted(set(params) - set(PARAM_NAMES))
    if unknown:
        raise DataError(f"{where}: unknown rigid-body parameter params.{unknown[0]}")
    probe = RigidBodyModel(mass=1.0, command_unit=command_unit, position_unit=position_unit)
    values: dict[str, float | None] = {}
    for name in PARAM_NAMES:
        if name not in params:
            if name in OPTIONAL_PARAMS:
                values[name] = None
                continue
            raise DataError(f"{where}: params.{name} is missing")
        values[name] = value_of(params[name], probe.units[name], f"{where}: params.{name}")
    try:
        return RigidBodyModel(**values, command_unit=command_unit, position_unit=position_unit)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None
