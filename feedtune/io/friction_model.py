"""Friction model documents (``kind = "friction"`` of ``feedtune.model/1``): Stribeck eq. 2.1 and the friction laws.

``model`` names the law: ``"stribeck"`` without viscous parameters is eq. 2.1 and loads as a
:class:`~feedtune.models.friction.StribeckFriction` (the original format); ``"stribeck"`` with ``viscous_pos``,
``"hump"``, ``"lugre"`` and ``"coulomb-viscous"`` (``dc_pos, dc_neg, viscous_pos[, viscous_neg]`` only: no static level,
no characteristic velocity) load as a :class:`~feedtune.models.friction.FrictionLaw`. A level whose sign is opposite
to its direction (checked by the model schema, :mod:`feedtune.io.model_schema`), or a negative viscous coefficient
(checked here), is refused with one line naming the file and the key.
"""

from __future__ import annotations

from collections.abc import Mapping

from ..errors import DataError
from ..models.friction import (
    COULOMB_VISCOUS,
    LAWS,
    LEVEL_NAMES,
    OMEGA_NAMES,
    VELOCITY_UNITS,
    VISCOUS_NAMES,
    FrictionLaw,
    StribeckFriction,
)
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

    A :class:`FrictionLaw` (``model`` = its law) adds the viscous coefficients::

        model = "hump"
        ...
        viscous_pos = { value = 40.0, unit = "N/(m/s)" }
        viscous_neg = { value = 50.0, unit = "N/(m/s)" }   # optional: omitted = viscous_pos

    The ``coulomb-viscous`` law (``F = sign(v) Fc + Fv v``) has no static level and no characteristic velocity::

        model = "coulomb-viscous"
        command_unit = "N"
        velocity_unit = "m/s"

        [params]
        dc_pos = { value = 20.4, unit = "N" }
        dc_neg = { value = -20.1, unit = "N" }
        viscous_pos = { value = 203.0, unit = "N/(m/s)" }
        viscous_neg = { value = 205.0, unit = "N/(m/s)" }   # optional: omitted = viscous_pos
    """
    if isinstance(model, FrictionLaw):
        return _law_body(model)
    return _stribeck_body(model)


def stribeck_from_doc(doc: Mapping[str, object], where: str = "friction model") -> StribeckFriction:
    """Build a :class:`StribeckFriction` or a :class:`FrictionLaw` from a friction model document (see
    :func:`stribeck_to_doc`); DataError naming the file and the key on a missing, unknown or wrong-signed value."""
    model = _stribeck_from_body(doc, where)
    # the levels' signs are the schema's (feedtune.io.model_schema, checked after this loader); the viscous
    # coefficients of a friction law are not in it
    for name in VISCOUS_NAMES:
        value = getattr(model, name, None)
        if value is not None and value < 0:
            raise DataError(f"{where}: params.{name}: must be >= 0, got {value!r} (viscous friction opposes the "
                            "motion)")
    return model


def _law_body(self: FrictionLaw) -> dict:
    """Body of a friction law file: eq. 2.1's layout with ``model`` = the law and the viscous coefficients."""
    body = _stribeck_body(self)
    body["model"] = self.law
    if not self.has_static_level:
        for name in ("ds_pos", "ds_neg", "omega_pos", "omega_neg"):
            body["params"].pop(name, None)
    unit = f"{self.command_unit}/({self.velocity_unit})"
    body["params"]["viscous_pos"] = quantity(self.viscous_pos, unit)
    if self.viscous_neg is not None:
        body["params"]["viscous_neg"] = quantity(self.viscous_neg, unit)
    return body


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
    if model not in LAWS:
        raise DataError(f"{where}: model = {model!r}; known friction laws: {', '.join(LAWS)}")
    command_unit = _unit_string(doc, "command_unit", where)
    velocity_unit = _unit_string(doc, "velocity_unit", where)
    if velocity_unit not in VELOCITY_UNITS:
        raise DataError(f"{where}: velocity_unit = {velocity_unit!r}; expected one of {', '.join(VELOCITY_UNITS)}")
    params = doc.get("params")
    if not isinstance(params, Mapping):
        raise DataError(f"{where}: missing [params] table with {', '.join(LEVEL_NAMES + OMEGA_NAMES)}")
    unknown = sorted(set(params) - set(LEVEL_NAMES + OMEGA_NAMES + VISCOUS_NAMES))
    if unknown:
        raise DataError(f"{where}: unknown friction parameter params.{unknown[0]}")
    law = model != "stribeck" or any(name in params for name in VISCOUS_NAMES)
    optional = ("omega_neg", "viscous_neg")
    names = LEVEL_NAMES + OMEGA_NAMES + (VISCOUS_NAMES if law else ())
    if model == COULOMB_VISCOUS:
        extra = sorted(set(params) & {"ds_pos", "ds_neg", *OMEGA_NAMES})
        if extra:
            raise DataError(f"{where}: params.{extra[0]}: a {COULOMB_VISCOUS} law has no static level and no "
                            "characteristic velocity (params: dc_pos, dc_neg, viscous_pos, viscous_neg)")
        names = ("dc_pos", "dc_neg", *VISCOUS_NAMES)
    values: dict[str, float | None] = {}
    for name in names:
        if name not in params:
            if name in optional:
                values[name] = None
                continue
            raise DataError(f"{where}: params.{name} is missing")
        unit = (velocity_unit if name in OMEGA_NAMES else
                f"{command_unit}/({velocity_unit})" if name in VISCOUS_NAMES else command_unit)
        values[name] = value_of(params[name], unit, f"{where}: params.{name}")
    try:
        if model == COULOMB_VISCOUS:
            return FrictionLaw.coulomb_viscous(values["dc_pos"], values["dc_neg"], values["viscous_pos"],
                                               values["viscous_neg"], command_unit=command_unit,
                                               velocity_unit=velocity_unit)
        if law:
            return FrictionLaw(**values, command_unit=command_unit, velocity_unit=velocity_unit, law=model)
        return StribeckFriction(**values, command_unit=command_unit, velocity_unit=velocity_unit)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None


def _unit_string(doc: Mapping[str, object], key: str, where: str) -> str:
    unit = doc.get(key)
    if not isinstance(unit, str) or not unit:
        raise DataError(f"{where}: {key} must be a unit string (e.g. \"V\", \"rad/s\"), got {unit!r}")
    return unit
