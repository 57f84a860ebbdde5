"""Helpers shared by the command modules: JSON output, option parsing, paths."""

from __future__ import annotations

import json
import math
from pathlib import Path

import typer

JSON_OPTION = typer.Option(False, "--json", help="Print one JSON object to stdout instead of a summary.")
FORCE_OPTION = typer.Option(False, "--force", help="Overwrite existing output files.")


def jsonable(obj):
    """Convert numpy scalars/arrays, tuples and non-finite floats to JSON-ready values."""
    import numpy as np

    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, complex):
        return [obj.real, obj.imag]
    if isinstance(obj, Path):
        return str(obj)
    return obj


def print_json(obj) -> None:
    """Print one JSON object on stdout."""
    typer.echo(json.dumps(jsonable(obj), indent=2, allow_nan=False))


def parse_float_pair(values, name: str) -> tuple[float, float] | None:
    """Validate a ``LO HI`` option [Hz]."""
    from ..errors import UsageError

    if not values:
        return None
    lo, hi = (float(v) for v in values)
    if not (0 <= lo < hi):
        raise UsageError(f"{name} expects LO HI with 0 <= LO < HI, got {lo:g} {hi:g}")
    return lo, hi


def fmt(x, unit: str = "", digits: int = 4) -> str:
    """Format a number with its unit for summaries; '-' for None."""
    if x is None:
        return "-"
    return f"{x:.{digits}g}{(' ' + unit) if unit else ''}"


def check_distinct_outputs(*named) -> None:
    """Refuse (UsageError) two output options naming the same file: ``named`` holds ``(option, path)`` pairs."""
    from pathlib import Path

    from ..errors import UsageError

    seen: dict = {}
    for option, path in named:
        if path is None:
            continue
        key = Path(path).resolve()
        if key in seen:
            raise UsageError(f"{option} {path} is also the file of {seen[key]}; give the outputs different names")
        seen[key] = option
