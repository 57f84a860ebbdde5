"""What every document check shares: every number finite and in range, and a key's path for messages."""

from __future__ import annotations

import math
from collections.abc import Mapping

from ..errors import DataError

MAX_ABS = 1e300
"""Largest magnitude of a number [-] (keeps products finite)."""


def key_path(parts) -> str:
    """``a.b[0].c`` from the parts of a key path."""
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def check_finite(node, parts: list, where: str) -> None:
    """Every number of ``node`` finite and within :data:`MAX_ABS` (DataError naming the key)."""
    if isinstance(node, bool) or node is None or isinstance(node, str):
        return
    if isinstance(node, int):
        if abs(node) > 2**63:  # beyond int64 (and far beyond what any count or gain here needs)
            raise DataError(f"{where}: {key_path(parts)}: integer with {len(str(abs(node)))} digits is out of range")
        return
    if isinstance(node, float):
        if not math.isfinite(node) or abs(node) > MAX_ABS:
            raise DataError(f"{where}: {key_path(parts)}: value must be a finite number, got {node!r}")
        return
    if isinstance(node, Mapping):
        for k, v in node.items():
            check_finite(v, [*parts, k], where)
    elif isinstance(node, (list, tuple)):
        for i, v in enumerate(node):
            check_finite(v, [*parts, i], where)


def check_schema(doc, schema: dict, where: str) -> None:
    """Validate ``doc`` against a JSON Schema (draft 2020-12, ``jsonschema``); DataError with one line naming the
    key and what was expected (the most relevant error: ``jsonschema.exceptions.best_match``)."""
    import jsonschema

    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(doc))
    if error is None:
        return
    parts = list(error.absolute_path)
    if parts and parts[-1] == "value":  # a quantity {value, unit}: name the quantity
        parts = parts[:-1]
    if error.validator == "required":
        missing = error.message.split("'")[1] if "'" in error.message else "?"
        raise DataError(f"{where}: {key_path([*parts, missing])} is missing")
    raise DataError(f"{where}: {key_path(parts) or 'document'}: {_message(error)}")


def quantity(**bounds) -> dict:
    """Schema of a number with ``bounds`` (``minimum``, ``exclusiveMinimum``...), bare or as ``{value, unit}``."""
    number = {"type": "number", **bounds}
    return {"anyOf": [number, {"type": "object", "required": ["value"],
                               "properties": {"value": number, "unit": {"type": "string"}}}]}


TYPE_WORDS = {"object": "a table", "array": "a list", "integer": "an integer", "number": "a number",
              "string": "a string", "null": "nothing", "boolean": "true or false"}


def _message(error) -> str:
    """A short message for a jsonschema error (what was expected)."""
    v = error.validator
    if v == "type":
        names = error.validator_value if isinstance(error.validator_value, list) else [error.validator_value]
        return f"expected {' or '.join(TYPE_WORDS.get(n, n) for n in names)}, got {error.instance!r}"[:160]
    if v == "enum":
        return f"expected one of {', '.join(map(repr, error.validator_value))}, got {error.instance!r}"[:160]
    if v == "const":
        return f"expected {error.validator_value!r}, got {error.instance!r}"[:160]
    if v in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
        word = {"minimum": ">=", "maximum": "<=", "exclusiveMinimum": ">", "exclusiveMaximum": "<"}[v]
        return f"must be {word} {error.validator_value:g}, got {error.instance!r}"
    if v in ("minItems", "maxItems", "minProperties"):
        n = error.validator_value
        what = ("key" if n == 1 else "keys") if v == "minProperties" else ("entry" if n == 1 else "entries")
        return f"expected {'at least' if v.startswith('min') else 'at most'} {n} {what}, got {len(error.instance)}"
    return error.message[:160]
