"""The schema of gains documents (every ``kind``), validated before anything executes, analyses or exports one.

The structure (required tables and keys, types, ranges, sizes) is a JSON Schema (draft 2020-12) per kind,
checked with the ``jsonschema`` library: the schema is a language-neutral document that users can publish and check
their own files against (:func:`gains_schema` gives it), and its errors carry the path of the offending key. What a
JSON Schema cannot say is checked after it, on the sections a target executes: every number finite and within
float range (TOML allows ``nan``, ``inf`` and integers of any length), schedule positions strictly increasing, and
every second-order section stable (poles inside the unit circle; a controller's integrator pole at ``z = 1`` is
allowed where the law has one).

Resource bounds: :data:`MAX_FS_HZ`, :data:`MAX_DELAY_SAMPLES`, :data:`MAX_PREVIEW_SAMPLES`, :data:`MAX_SECTIONS`,
:data:`MAX_SCHEDULE_ROWS`, so that no document can make a runtime allocate without bound.

:func:`validate_gains` raises :class:`~feedtune.errors.DataError` with one line naming the file and key, the same
for ``export c``, ``analyze``, ``simulate`` and the runtimes (they all reach a gains document through
:func:`feedtune.machines.gains.gains_format_of`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import DataError
from .schema_common import check_finite, check_schema

MAX_FS_HZ = 1e7
"""Highest sample rate accepted [Hz]."""
MAX_DELAY_SAMPLES = 1000
"""Longest computational delay accepted [samples]."""
MAX_PREVIEW_SAMPLES = 100_000
"""Longest reference preview accepted [samples]."""
MAX_SECTIONS = 256
"""Most second-order sections in one cascade."""
MAX_SCHEDULE_ROWS = 10_000
"""Most rows of a gantry schedule table."""
POLE_MARGIN = 1e-9
"""A section's pole must lie inside ``|z| < 1 - POLE_MARGIN`` (an integrator: within it of ``z = 1``)."""
INTEGRATING_SOS = ("controller_sos",)
"""Cascades that hold the law's own integrator (the x axis' PI): one pole at ``z = 1`` is allowed there."""

_NUMBER = {"type": "number"}
_QUANTITY = {"type": "object", "required": ["value", "unit"],
             "properties": {"value": {"type": "number"}, "unit": {"type": "string"}}}
_SOS = {"type": "array", "minItems": 1, "maxItems": MAX_SECTIONS,
        "items": {"type": "array", "minItems": 6, "maxItems": 6, "items": _NUMBER}}
_SAMPLING = {
    "type": "object",
    "required": ["fs_hz", "delay_samples"],
    "properties": {
        "fs_hz": {"anyOf": [
            {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_FS_HZ},
            {"type": "object", "required": ["value"], "properties": {
                "value": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_FS_HZ},
                "unit": {"const": "Hz"}}},
        ]},
        "delay_samples": {"type": "integer", "minimum": 0, "maximum": MAX_DELAY_SAMPLES},
        "preview_samples": {"type": "integer", "minimum": 0, "maximum": MAX_PREVIEW_SAMPLES},
    },
}
_UNITS = {"type": "object", "additionalProperties": {"type": "string"}}
_GAINS = {"type": "object", "minProperties": 1,
          "additionalProperties": {"anyOf": [_QUANTITY, _NUMBER]}}
_CONTINUOUS = {"type": "object", "properties": {
    "notches": {"type": "array", "maxItems": MAX_SECTIONS, "items": {"type": "object"}},
    "leads": {"type": "array", "maxItems": MAX_SECTIONS, "items": {"type": "object"}},
    "lpf_hz": {"type": ["number", "null"], "exclusiveMinimum": 0},
    "lpf_order": {"enum": [1, 2]},
    "lpf_zeta": {"type": "number", "exclusiveMinimum": 0},
}}
_SHA256 = {"type": "string", "pattern": "^[0-9a-f]{64}$"}
_CERTIFICATE = {
    "type": "object", "required": ["limits", "frfs", "worst"],
    "properties": {
        "format": {"type": "string"}, "made_by": {"type": "string"},
        "date": {"type": "string", "pattern": "^[0-9]{4}-[0-9]{2}-[0-9]{2}$"},
        "gains_sha256": _SHA256, "sections_sha256": {"type": "object", "additionalProperties": _SHA256},
        "ok": {"type": "boolean"}, "limits": {"type": "object"}, "worst": {"type": "object"},
        "frfs": {"type": "array", "minItems": 1, "maxItems": MAX_SECTIONS, "items": {
            "type": "object", "required": ["frf", "checked_case", "ok"],
            "properties": {"frf": {"type": "string"}, "sha256": _SHA256, "arrays_sha256": _SHA256,
                           "identity": {"enum": ["file", "arrays"]}, "checked_case": {"type": "string"},
                           "ok": {"type": "boolean"}, "items": {"type": "array"}}}},
    },
    "dependentRequired": {"gains_sha256": ["sections_sha256", "date"]},
}
"""The ``[certificate]`` (:mod:`feedtune.io.gains_certificate`): the certificate of :mod:`feedtune.machines.certificate`
with the digests of its FRFs and of the gains it certifies (schema 1.1; a 1.0 certificate has no digests)."""
_COMMON = {
    "schema": {"type": "string"},
    "controller": {"type": "string"},
    "sampling": _SAMPLING,
    "units": _UNITS,
    "gains": _GAINS,
    "model": {"type": "object"},
    "design": {"type": "object"},
    "certificate": _CERTIFICATE,
    "reference": {"type": "object", "patternProperties": {"_sos$": _SOS}},
}
_REQUIRED = ["kind", "sampling", "gains", "filters"]

SCHEMAS = {
    "ballscrew": {
        "type": "object", "required": [*_REQUIRED, "reference"],
        "properties": {**_COMMON, "kind": {"const": "ballscrew"},
                       "filters": {"type": "object", "required": ["filter_pack_sos"],
                                   "properties": {"filter_pack_sos": _SOS, "continuous": _CONTINUOUS}}},
    },
    "gantry": {
        "type": "object", "required": [*_REQUIRED, "reference", "schedule"],
        "properties": {
            **_COMMON, "kind": {"const": "gantry"}, "controller": {"enum": ["mimo", "pid"]},
            "filters": {"type": "object", "required": ["filter_pack_sos", "continuous"],
                        "properties": {"filter_pack_sos": _SOS, "lead_sos": _SOS, "continuous": _CONTINUOUS,
                                       "lead": {"type": "object"}}},
            "schedule": {"type": "object", "required": ["x"], "properties": {
                "units": _UNITS},
                "additionalProperties": {"type": "array", "minItems": 1, "maxItems": MAX_SCHEDULE_ROWS,
                                         "items": _NUMBER}},
        },
        "if": {"properties": {"controller": {"const": "mimo"}}},
        "then": {"properties": {"filters": {"required": ["lead_sos", "lead"]}}},
    },
    "axis": {
        "type": "object", "required": [*_REQUIRED, "feedforward", "reference"],
        "properties": {**_COMMON, "kind": {"const": "axis"},
                       "filters": {"type": "object", "required": ["controller_sos", "continuous"],
                                   "properties": {"controller_sos": _SOS, "continuous": _CONTINUOUS,
                                                  "lead_stages": {"type": "array", "maxItems": MAX_SECTIONS}}},
                       "feedforward": {"type": "object", "required": ["mass"],
                                       "properties": {"mass": {"anyOf": [_QUANTITY, _NUMBER]}}},
                       "prefilter": {"type": "object"}},
    },
    "cascade": {  # the drive cascade (io/cascade_gains.py, docs/cascade.md)
        "type": "object", "required": [*_REQUIRED, "position_loop"],
        "properties": {**_COMMON, "kind": {"const": "cascade"},
                       "filters": {"type": "object", "required": ["current_setpoint", "current_setpoint_sos"],
                                   "properties": {"current_setpoint_sos": _SOS, "current_setpoint": {
                                       "type": "array", "maxItems": MAX_SECTIONS, "items": {"type": "object"}}}},
                       "position_loop": {"type": "object", "required": ["ratio"],
                                         "properties": {"ratio": {"type": "integer", "minimum": 1,
                                                                  "maximum": MAX_DELAY_SAMPLES},
                                                        "encoder": {"enum": ["motor", "load"]}}}},
    },
}
"""The JSON Schema of each gains ``kind``."""

CHECKED_SECTIONS = ("sampling", "gains", "filters", "reference", "schedule", "feedforward", "prefilter", "model",
                    "position_loop")
"""Sections whose numbers a target or the analysis uses (checked finite and in range)."""


def gains_schema(kind: str) -> dict:
    """The JSON Schema (draft 2020-12) of a gains document of ``kind``."""
    return {"$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": f"feedtune gains document, kind {kind}", **SCHEMAS[kind]}


def _stable_sections(name: str, sos, where: str) -> None:
    """Every section of a cascade has ``a0 != 0`` and its poles inside the unit circle (DataError naming it)."""
    for i, s in enumerate(sos):
        a = np.asarray(s[3:], float)
        if a[0] == 0:
            raise DataError(f"{where}: {name}[{i}]: a0 = 0 (a section needs a0 != 0)")
        poles = np.roots(a / a[0]) if np.any(a[1:]) else np.array([])
        for p in poles:
            if name.endswith(INTEGRATING_SOS) and abs(p - 1.0) <= POLE_MARGIN:
                continue
            if abs(p) >= 1.0 - POLE_MARGIN:
                raise DataError(f"{where}: {name}[{i}]: section is unstable (pole at |z| = {abs(p):.6g}; a filter "
                                "section must have its poles inside the unit circle)")


VALID_MEMORY = 64
"""Fingerprints of the documents found valid last, kept so that one document checked again (the report analyses a
gains file on several FRFs; each analysis reads it) is not walked again."""
_valid: dict[bytes, str] = {}


def _fingerprint(doc: Mapping) -> bytes | None:
    """A digest of the document's pickle (types, order and every value included: a list and a tuple, 1 and 1.0
    differ), None when it does not pickle."""
    import hashlib
    import pickle

    try:
        return hashlib.blake2b(pickle.dumps(doc, protocol=pickle.HIGHEST_PROTOCOL), digest_size=20).digest()
    except Exception:  # anything that does not pickle is simply not remembered
        return None


def validate_gains(doc, where: str) -> str:
    """Validate a gains document (module docstring); returns its ``kind``.

    A document with the same content as one of the last :data:`VALID_MEMORY` found valid is not checked again
    (validation depends on the content only; invalid documents are always checked, so each error names its
    ``where``).

    Raises
    ------
    DataError
        One line: the file, the key and what was expected.
    """
    key = _fingerprint(doc) if isinstance(doc, Mapping) else None
    if key is not None and key in _valid:
        return _valid[key]
    kind = _validate_gains(doc, where)
    if key is not None:
        if len(_valid) >= VALID_MEMORY:
            _valid.pop(next(iter(_valid)))
        _valid[key] = kind
    return kind


def _validate_gains(doc, where: str) -> str:
    if not isinstance(doc, Mapping):
        raise DataError(f"{where}: a gains document must be a table of sections, got {type(doc).__name__}")
    kind = doc.get("kind")
    if not isinstance(kind, str) or kind not in SCHEMAS:
        raise DataError(f"{where}: kind must be one of {', '.join(repr(k) for k in SCHEMAS)}, got {kind!r}")
    for section in CHECKED_SECTIONS:
        if section in doc:
            check_finite(doc[section], [section], where)
    check_schema(doc, SCHEMAS[kind], where)
    for section in ("filters", "reference"):
        for name, sos in (doc.get(section) or {}).items():
            if name.endswith("_sos"):
                _stable_sections(f"{section}.{name}", sos, where)
    sched = doc.get("schedule")
    if isinstance(sched, Mapping):
        x = np.asarray(sched["x"], float)
        if np.any(np.diff(x) <= 0):
            raise DataError(f"{where}: schedule.x: positions must be strictly increasing [m]")
        for name, col in sched.items():
            if name != "units" and len(col) != x.size:
                raise DataError(f"{where}: schedule.{name}: {len(col)} rows, schedule.x has {x.size}")
    return kind
