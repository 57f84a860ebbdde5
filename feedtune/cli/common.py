"""Helpers shared by the command modules: JSON output, option parsing, paths."""

from __future__ import annotations

import contextlib
import json
import math
from collections.abc import Iterator
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
    """Print one JSON object on stdout (commands print their ``--json`` result through
    :func:`feedtune.cli.envelope.emit`, which wraps it in the envelope of docs/json.md)."""
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
    """A number with its unit for summaries, rounded to ``digits`` significant digits (4: what a measured value
    means; designed gains are printed with 6): plain from 1e-4 up to 1e6 (``0.001936``, ``65080``, ``13``), with
    a power of ten outside (``2.285e-06``, ``1.079e+07``); ``-`` for None; no unit for ``""`` and ``"-"``
    (dimensionless)."""
    if x is None:
        return "-"
    text = _number(float(x), digits)
    return f"{text} {unit}" if unit and unit != "-" else text


def _number(x: float, digits: int) -> str:
    from ..display import plain_number

    return plain_number(x, digits)


def fmt_param(value, unit: str = "", std=None, lower=None, digits: int = 4) -> str:
    """A fitted parameter for summaries (:func:`feedtune.display.param_text`: values on their bound printed as the
    bound, ``(at its lower bound; std ...)``)."""
    from ..display import param_text

    return param_text(value, unit, std, lower, digits)


def fmt_hz(x) -> str:
    """A frequency [Hz] to the resolution that means something: ``2000``, ``260.1``, ``13.0``, ``0.5``."""
    if x is None:
        return "-"
    if x >= 1000:
        return f"{x:.0f}"
    return f"{x:.1f}" if x >= 1 else f"{x:.2g}"


def fmt_band(lo, hi) -> str:
    """A frequency band ``LO-HI Hz`` (:func:`fmt_hz`): ``13.0-260.1 Hz``."""
    return f"{fmt_hz(lo)}-{fmt_hz(hi)} Hz"


def fmt_length(x_m, digits: int = 4) -> str:
    """A length [m] in um, mm or m, whichever shows it without a power of ten: ``15.12 um``, ``99.95 mm``."""
    return _fmt_milli_micro(x_m, "m", digits)


def _fmt_milli_micro(x, unit: str, digits: int) -> str:
    """``x`` [unit] in u-unit, m-unit or unit, whichever shows it without a power of ten."""
    if x is None:
        return "-"
    size = abs(x)
    if size < 1e-3:
        return fmt(x * 1e6, f"u{unit}", digits)
    return fmt(x * 1e3, f"m{unit}", digits) if size < 1 else fmt(x, unit, digits)


def fmt_angle(x_rad, digits: int = 4) -> str:
    """An angle [rad] in urad, mrad or rad, whichever shows it without a power of ten: ``15.12 urad``."""
    return _fmt_milli_micro(x_rad, "rad", digits)


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


@contextlib.contextmanager
def option_names(**spellings: str) -> Iterator[None]:
    """Within the block, an error about a library parameter names the command's own option for it where that is not
    ``--`` plus the parameter's name (``simulate cut`` gives the trajectory's ``v_max`` as ``--speed``)::

        with option_names(v_max="--speed", distance="--cut-length"):
            tr = point_to_point(cut_start + cut_length, v_max=speed, ...)
    """
    from ..errors import FeedtuneError

    try:
        yield
    except FeedtuneError as exc:
        exc.options = {**(getattr(exc, "options", None) or {}), **spellings}
        raise
