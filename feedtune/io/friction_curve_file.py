"""The friction curve document (``schema = "feedtune.friction_curve/1"``, ``kind = "friction_curve"``).

Written by ``feedtune identify friction LOG --curve-out FILE`` and read by ``feedtune report``. Unlike a friction
*model* file (:mod:`feedtune.io.friction_model`, both directions, used by a feedforward) it holds what a friction
run measured, one direction or both: the law fitted per direction with standard deviations, the measured points
(plateau means of ``--steady-state``, or the friction ``F - m a`` of the joint fit binned by speed), the fitted
curve, the mass of a joint fit, the warnings and the source log. Example (TOML; the ``.json`` twin holds the
same)::

    schema = "feedtune.friction_curve/1"
    kind = "friction_curve"
    law = "hump"
    method = "joint fit with the mass, one direction"
    source = "rack.csv"
    command_unit = "N"
    velocity_unit = "m/s"
    directions = ["pos"]
    warnings = ["the data move one way only ..."]
    mass = { value = 25.17, unit = "N/(m/s^2)" }
    mass_std = { value = 0.398, unit = "N/(m/s^2)" }
    rms_error = { value = 13.2, unit = "N" }
    relative_error_pct = { value = 16.1, unit = "%" }

    [params.pos]
    dc = { value = 25.6, unit = "N" }
    ds = { value = 13.6, unit = "N" }
    omega = { value = 0.0574, unit = "m/s" }
    viscous = { value = 27.0, unit = "N/(m/s)" }

    [std.pos]               # a parameter the data do not resolve has no std entry
    dc = { value = 6.79, unit = "N" }
    ...

    [points]                # measured friction, signed; one entry per point
    what = "F - m a of the joint fit's samples, mean per speed bin"
    velocity_unit = "m/s"
    force_unit = "N"
    direction = ["pos", ...]
    velocity = [...]
    force = [...]
    force_std = [...]
    n = [...]

    [curve.pos]             # the fitted law on log-spaced speeds
    velocity = [...]
    force = [...]

Levels are signed as their direction (``v < 0``: negative), as in :class:`~feedtune.models.friction.FrictionLaw`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from ..errors import DataError
from ..models.friction import LAWS
from ..quantity import quantity, value_of
from .document import read_document, require_schema, write_document

FRICTION_CURVE_SCHEMA = "feedtune.friction_curve"
FRICTION_CURVE_KIND = "friction_curve"
PARAMETERS = ("dc", "ds", "omega", "viscous")
"""Per-direction parameters of a law: levels ``dc``, ``ds`` [command unit], ``omega`` (``vs``) [velocity unit],
``viscous`` (``Fv``) [command unit/(velocity unit)]."""
POINT_COLUMNS = ("direction", "velocity", "force", "force_std", "n")


def parameter_units(command_unit: str, velocity_unit: str) -> dict[str, str]:
    """Unit of each of :data:`PARAMETERS`."""
    return {"dc": command_unit, "ds": command_unit, "omega": velocity_unit,
            "viscous": f"{command_unit}/({velocity_unit})"}


def friction_curve_document(law_fit, points: Sequence[Mapping], *, method: str, source: str,
                            points_what: str, warnings: Sequence[str] = ()) -> dict:
    """The friction curve document of a law fit (module docstring).

    Parameters
    ----------
    law_fit : FrictionLawFit
        From :func:`~feedtune.identify.friction_curve.fit_friction_law` (a steady-state fit or the ``law_fit`` of a
        joint fit); its ``mass`` is written when fitted.
    points : sequence of mapping
        Measured points with ``direction``, ``velocity`` [velocity unit], ``force``, ``force_std`` [command unit]
        and ``n``.
    method : str
        How the law was fitted (one line).
    source : str
        The log(s) it was fitted to.
    points_what : str
        What the points are (one line).
    warnings : sequence of str
        The identification's warnings.

    Returns
    -------
    dict
        The document (numbers as ``{value, unit}`` quantities, arrays in the document's units).
    """
    c, v = law_fit.command_unit, law_fit.velocity_unit
    units = parameter_units(c, v)
    params, std = {}, {}
    for key, d in law_fit.directions.items():
        params[key] = {name: quantity(float(getattr(d, name)), units[name]) for name in PARAMETERS}
        std[key] = {name: quantity(float(s), units[name]) for name, s in d.std.items()
                    if name in units and s is not None and math.isfinite(s)}
    doc: dict = {
        "schema": f"{FRICTION_CURVE_SCHEMA}/1",
        "kind": FRICTION_CURVE_KIND,
        "law": law_fit.law,
        "method": method,
        "source": source,
        "command_unit": c,
        "velocity_unit": v,
        "directions": list(law_fit.directions),
        "warnings": [str(w) for w in warnings],
        "rms_error": quantity(float(law_fit.rms_error), c),
        "relative_error_pct": quantity(float(law_fit.relative_error_pct), "%"),
    }
    if law_fit.mass is not None:
        doc["mass"] = quantity(float(law_fit.mass), f"{c}/({v}^2)")
        if law_fit.mass_std is not None and math.isfinite(law_fit.mass_std):
            doc["mass_std"] = quantity(float(law_fit.mass_std), f"{c}/({v}^2)")
    doc["params"] = params
    doc["std"] = std
    doc["points"] = {"what": points_what, "velocity_unit": v, "force_unit": c,
                     **{col: [p[col] for p in points] for col in POINT_COLUMNS}}
    doc["curve"] = law_fit.curve()
    return doc


def write_friction_curve(path: str | os.PathLike[str], doc: Mapping, *, force: bool = False) -> list[Path]:
    """Write a friction curve document atomically (``.toml`` with its ``.json`` twin, or ``.json``).

    Parameters
    ----------
    path : path-like
        Destination.
    doc : mapping
        From :func:`friction_curve_document`.
    force : bool
        Replace existing files (refused otherwise, before anything is written).

    Returns
    -------
    list of Path
        The files written.
    """
    return write_document(path, doc, force=force)


def _floats(values, where: str) -> list[float]:
    if not isinstance(values, list) or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                               for x in values):
        raise DataError(f"{where} must be a list of numbers")
    return [float(x) for x in values]


def check_friction_curve(doc: Mapping, where: str) -> dict:
    """Validate a friction curve document (module docstring) and return it.

    Parameters
    ----------
    doc : mapping
        The document read.
    where : str
        File name for messages.

    Returns
    -------
    dict
        The document.

    Raises
    ------
    DataError
        Another schema or kind, an unknown law, a missing entry, a unit other than the document's, or lists of
        different lengths (named).
    """
    require_schema(doc, FRICTION_CURVE_SCHEMA, where)
    if doc.get("kind") != FRICTION_CURVE_KIND:
        raise DataError(f"{where}: kind must be {FRICTION_CURVE_KIND!r}, got {doc.get('kind')!r}")
    if doc.get("law") not in LAWS:
        raise DataError(f"{where}: law = {doc.get('law')!r}; known friction laws: {', '.join(LAWS)}")
    c, v = doc.get("command_unit"), doc.get("velocity_unit")
    if not (isinstance(c, str) and c and isinstance(v, str) and v):
        raise DataError(f"{where}: command_unit and velocity_unit must be unit strings")
    units = parameter_units(c, v)
    params = doc.get("params")
    if not isinstance(params, Mapping) or not params or not set(params) <= {"pos", "neg"}:
        raise DataError(f"{where}: [params] must hold a table per direction, pos and/or neg")
    for key, table in params.items():
        if not isinstance(table, Mapping):
            raise DataError(f"{where}: params.{key} must be a table")
        for name in PARAMETERS:
            if name not in table:
                raise DataError(f"{where}: params.{key}.{name} is missing")
            value_of(table[name], units[name], f"{where}: params.{key}.{name}")
    for key, table in (doc.get("std") or {}).items():
        for name, q in (table or {}).items():
            if name in units:
                value_of(q, units[name], f"{where}: std.{key}.{name}", finite=False)
    if "mass" in doc:
        value_of(doc["mass"], f"{c}/({v}^2)", f"{where}: mass")
    points = doc.get("points")
    if not isinstance(points, Mapping):
        raise DataError(f"{where}: [points] table is missing")
    size = None
    for col in ("velocity", "force", "force_std", "n"):
        values = _floats(points.get(col), f"{where}: points.{col}")
        if size is not None and len(values) != size:
            raise DataError(f"{where}: points.{col} has {len(values)} entries, points.velocity {size}")
        size = len(values)
    curve = doc.get("curve")
    if not isinstance(curve, Mapping) or not curve:
        raise DataError(f"{where}: [curve] table is missing")
    for key, c_table in curve.items():
        if not isinstance(c_table, Mapping):
            raise DataError(f"{where}: curve.{key} must be a table")
        vel = _floats(c_table.get("velocity"), f"{where}: curve.{key}.velocity")
        frc = _floats(c_table.get("force"), f"{where}: curve.{key}.force")
        if len(vel) != len(frc):
            raise DataError(f"{where}: curve.{key}: velocity and force have different lengths")
    return dict(doc)


def read_friction_curve(path: str | os.PathLike[str]) -> dict:
    """Read and validate a friction curve document (:func:`check_friction_curve`)."""
    return check_friction_curve(read_document(path), str(path))
