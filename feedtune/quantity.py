"""Quantities: numbers with their unit, ``{"value": v, "unit": "..."}``, as every document writes them."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .errors import DataError

_NONFINITE_STRINGS = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}


# ----------------------------------------------------------------------------------------------- helpers
def quantity(value: float, unit: str) -> dict[str, object]:
    """A number with its unit: ``{"value": float(value), "unit": unit}``.

    Examples
    --------
    >>> quantity(0.5, "m")
    {'value': 0.5, 'unit': 'm'}
    """
    return {"value": float(value), "unit": str(unit)}


def is_quantity(entry: object) -> bool:
    """True for a dict with exactly the keys ``value`` (a number) and ``unit`` (a string)."""
    return (isinstance(entry, Mapping) and set(entry) == {"value", "unit"} and isinstance(entry["unit"], str)
            and isinstance(entry["value"], (int, float, np.integer, np.floating))
            and not isinstance(entry["value"], bool))


def value_of(entry: object, unit: str | None = None, where: str = "", *, finite: bool = True) -> float:
    """The number of a bare number or a quantity dict, checking its unit and that it is finite.

    Parameters
    ----------
    entry : float or dict
        ``0.5`` or ``{"value": 0.5, "unit": "m"}``.
    unit : str, optional
        Expected unit; a quantity with another unit is a :class:`DataError` (bare numbers are accepted).
    where : str
        Location for messages, e.g. ``"model.toml: params.m1"``.
    finite : bool
        Refuse NaN and infinite values (a :class:`DataError` naming ``where``); False for entries that may be
        unknown (a standard deviation written as ``nan``).

    Raises
    ------
    DataError
        Not a number, a unit other than ``unit``, an integer beyond the range of a float, or (with ``finite``) NaN or
        an infinite value.
    """
    label = where or "value"
    if isinstance(entry, Mapping):
        if "value" not in entry:
            raise DataError(f"{label}: expected a number or {{ value = ..., unit = ... }}, got keys "
                            f"{', '.join(map(str, entry)) or 'none'}")
        got = entry.get("unit")
        if unit is not None and got is not None and str(got) != unit:
            raise DataError(f"{label}: unit {got!r} where {unit!r} is expected")
        entry = entry["value"]
    if isinstance(entry, str) and entry in _NONFINITE_STRINGS:
        entry = _NONFINITE_STRINGS[entry]
    if isinstance(entry, bool) or not isinstance(entry, (int, float, np.integer, np.floating)):
        raise DataError(f"{label}: expected a number, got {str(entry)[:40]!r}")
    try:
        v = float(entry)
    except OverflowError:
        raise DataError(f"{label}: integer with {len(str(abs(int(entry))))} digits, beyond the range of a float") \
            from None
    if finite and not math.isfinite(v):
        raise DataError(f"{label}: expected a finite number, got {v!r}")
    return v
