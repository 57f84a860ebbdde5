"""Checks and ``--param NAME=VALUE`` overrides shared by every twin's parameters."""

from __future__ import annotations

import math

from ..errors import UsageError


def finite_param(v, name: str) -> float:
    """``v`` as a float; UsageError naming the twin parameter when it is not a finite number."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise UsageError(f"twin parameter {name} must be a finite number, got {v!r}")
    return float(v)


def positive_param(v, name: str, unit: str = "") -> float:
    """``v`` as a float > 0; UsageError naming the twin parameter and its unit otherwise."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise UsageError(f"twin parameter {name} must be a finite number > 0 {unit}".rstrip() + f", got {v!r}")
    return float(v)


def non_negative_param(v, name: str) -> float:
    """``v`` as a float >= 0; UsageError naming the twin parameter otherwise."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
        raise UsageError(f"twin parameter {name} must be a finite number >= 0, got {v!r}")
    return float(v)


def parse_override_value(raw, key: str):
    """A ``--param NAME=VALUE`` value: a number (int when integral text), or None for none/off/null.

    Raises
    ------
    UsageError
        Neither a number nor none/off/null (names the parameter).
    """
    if raw is None or (isinstance(raw, (int, float)) and not isinstance(raw, bool)):
        return raw
    text = str(raw).strip()
    if text.lower() in ("none", "off", "null"):
        return None
    try:
        return int(text) if text.lstrip("+-").isdigit() else float(text)
    except ValueError:
        raise UsageError(f"twin parameter {key}: expected a number or 'none', got {raw!r}") from None


def positive_setting(v, name: str, unit: str) -> float:
    """An experiment setting ``v`` as a float > 0; UsageError naming the setting and its unit otherwise."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise UsageError(f"{name} must be a finite number > 0 {unit}, got {v!r}")
    return float(v)
