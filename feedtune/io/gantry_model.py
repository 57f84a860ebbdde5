"""Gantry model documents (``kind = "gantry"`` of ``feedtune.model/1``): the writer and the reader."""

from __future__ import annotations

from collections.abc import Mapping

from ..errors import DataError
from ..models.gantry import MODEL_KIND, MODEL_SCHEMA, PARAM_NAMES, GantryModel, param_units


def gantry_model_to_doc(model: GantryModel) -> dict:
    """Model-file document ``{"schema", "kind": "gantry", "params": {name: {"value", "unit"}}}``."""
    units = param_units(model.input_unit)
    return {
        "schema": MODEL_SCHEMA,
        "kind": MODEL_KIND,
        "input_unit": model.input_unit,
        "params": {name: {"value": value, "unit": units[name]} for name, value in model.params().items()},
    }


def gantry_model_from_doc(doc: Mapping, where: str = "gantry model document") -> GantryModel:
    """Build a :class:`GantryModel` from a document written by :func:`gantry_model_to_doc`.

    Parameters
    ----------
    doc : mapping
        ``{"schema": "feedtune.model/1", "kind": "gantry", "input_unit": "V", "params": {...}}``; other
        top-level keys (e.g. ``fit``) are ignored.
    where : str
        Name of the source (file) used in error messages; the signature fits
        ``feedtune.io.model_file.register_model_kind``.

    Raises
    ------
    DataError
        Wrong schema or kind, a missing, unknown or non-numeric parameter, an invalid value, or a unit
        that differs from the one expected (no unit conversion is attempted).
    """
    if not isinstance(doc, Mapping):
        raise DataError(f"{where}: a gantry model must be a mapping with schema, kind and params")
    from .document import require_schema

    require_schema(doc, MODEL_SCHEMA.split("/")[0], where, int(MODEL_SCHEMA.split("/")[1].split(".")[0]),
                   written=MODEL_SCHEMA)
    if doc.get("kind") != MODEL_KIND:
        raise DataError(f"{where}: kind must be {MODEL_KIND!r}, got {doc.get('kind')!r}")
    params = doc.get("params")
    if not isinstance(params, Mapping):
        raise DataError(f"{where}: 'params' must be a mapping of name -> {{value, unit}}")
    input_unit = doc.get("input_unit", "V")
    if not isinstance(input_unit, str) or not input_unit:
        raise DataError(f"{where}: input_unit must be a unit string such as \"V\"")
    units = param_units(input_unit)
    unknown = sorted(set(params) - set(PARAM_NAMES))
    if unknown:
        raise DataError(f"{where}: unknown gantry parameter(s) {', '.join(unknown)}; "
                        f"expected {', '.join(PARAM_NAMES)}")
    values = {name: _doc_value(params, name, units[name], where) for name in PARAM_NAMES}
    try:
        return GantryModel(**values, input_unit=input_unit)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None


def _doc_value(params: Mapping, name: str, unit: str, where: str) -> float:
    if name not in params:
        raise DataError(f"{where}: params.{name} [{unit}] is missing")
    entry = params[name]
    value = entry.get("value") if isinstance(entry, Mapping) else entry
    if isinstance(entry, Mapping) and entry.get("unit") not in (None, unit):
        raise DataError(f"{where}: params.{name} has unit {entry.get('unit')!r}; expected {unit!r}")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DataError(f"{where}: params.{name} must be a number, got {value!r}")
    return float(value)
