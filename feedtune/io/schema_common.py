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
        if abs(node) > MAX_ABS or abs(node) > 2**63:
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
