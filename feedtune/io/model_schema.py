"""The schema of model documents (``feedtune.model/1``: ballscrew, gantry, friction, rigid) and mass documents
(``feedtune.mass/1``), checked when they are read (:func:`validate_model`, :func:`validate_mass`): the parameters
present, numbers (bare or ``{value, unit}``) in their physical ranges — masses, inertias and stiffnesses > 0,
dampings >= 0, the Stribeck levels with the sign of their direction — so a file a fit or a hand edit got wrong is
refused with one line naming the key instead of reaching a design. JSON Schema draft 2020-12, as the gains schema
(:mod:`feedtune.io.gains_schema`); :func:`model_schema` gives each.
"""

from __future__ import annotations

from .schema_common import check_schema, quantity

_POSITIVE = quantity(exclusiveMinimum=0)
_NONNEGATIVE = quantity(minimum=0)
_NONPOSITIVE = quantity(maximum=0)
_ANY = quantity()
_UNIT = {"type": "string"}


def _params(required: dict, optional: dict | None = None) -> dict:
    return {"type": "object", "required": list(required), "properties": {**required, **(optional or {})}}


_FRICTION_PARAMS = {"dc_pos": _NONNEGATIVE, "ds_pos": _NONNEGATIVE, "dc_neg": _NONPOSITIVE, "ds_neg": _NONPOSITIVE,
                    "omega_pos": _POSITIVE, "omega_neg": _POSITIVE, "viscous_pos": _NONNEGATIVE,
                    "viscous_neg": _NONNEGATIVE}

MODEL_SCHEMAS = {
    "ballscrew": {"type": "object", "required": ["params"], "properties": {
        "input_unit": _UNIT, "lead_m_per_rad": _POSITIVE,
        "params": _params({"m1": _POSITIVE, "m2": _POSITIVE, "b1": _NONNEGATIVE, "b2": _NONNEGATIVE,
                           "k": _POSITIVE, "c": _NONNEGATIVE}),
    }},
    "gantry": {"type": "object", "required": ["params"], "properties": {
        "input_unit": _UNIT,
        "params": _params({"m": _POSITIVE, "L": _POSITIVE, "J0": _POSITIVE, "d": _ANY, "m_x": _POSITIVE,
                           "c": _NONNEGATIVE, "k": _POSITIVE, "alpha1_0": quantity(exclusiveMinimum=0,
                                                                                     exclusiveMaximum=1),
                           "dalpha1_dx": _ANY}),
    }},
    "friction": {"type": "object", "required": ["params"], "properties": {
        "command_unit": _UNIT, "velocity_unit": _UNIT,
        "params": {"type": "object", "properties": _FRICTION_PARAMS},
    },
        # the coulomb-viscous law has no static level and no characteristic velocity
        "if": {"required": ["model"], "properties": {"model": {"const": "coulomb-viscous"}}},
        "then": {"properties": {"params": {"required": ["dc_pos", "dc_neg", "viscous_pos"]}}},
        "else": {"properties": {"params": {"required": ["dc_pos", "ds_pos", "dc_neg", "ds_neg", "omega_pos"]}}},
    },
    "rigid": {"type": "object", "required": ["params"], "properties": {
        "command_unit": _UNIT, "position_unit": _UNIT,
        "params": _params({"mass": _POSITIVE}, {"viscous": _NONNEGATIVE, "viscous_neg": _NONNEGATIVE,
                                                "coulomb_pos": _NONNEGATIVE, "coulomb_neg": _NONNEGATIVE,
                                                "offset": _ANY}),
    }},
}
"""The JSON Schema of each model ``kind`` (the parts a loader reads; the ``fit`` record is information)."""

MASS_SCHEMA = {"type": "object", "required": ["m", "alpha1_0", "dalpha1_dx"], "properties": {
    "input_unit": _UNIT, "m": _POSITIVE, "alpha1_0": quantity(exclusiveMinimum=0, exclusiveMaximum=1),
    "dalpha1_dx": _ANY, "alpha1_rms_residual": _NONNEGATIVE, "m_x": _POSITIVE,
    "positions": {"type": "array", "maxItems": 10_000, "items": {"type": "object"}}}}
"""The JSON Schema of a gantry mass document."""


def model_schema(kind: str) -> dict:
    """The JSON Schema (draft 2020-12) of a model document of ``kind`` (``"mass"``: a mass document)."""
    body = MASS_SCHEMA if kind == "mass" else MODEL_SCHEMAS[kind]
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "title": f"feedtune {kind} document", **body}


def validate_model(doc, kind: str, where: str) -> None:
    """Check a model document of a known ``kind`` against its schema (DataError naming the key)."""
    if kind in MODEL_SCHEMAS:
        check_schema(doc, MODEL_SCHEMAS[kind], where)


def validate_mass(doc, where: str) -> None:
    """Check a mass document against :data:`MASS_SCHEMA` (DataError naming the key)."""
    check_schema(doc, MASS_SCHEMA, where)
