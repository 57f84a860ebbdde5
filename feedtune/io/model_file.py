"""Model files: identified plant models as TOML documents (``schema = "feedtune.model/1"``) with a JSON twin.

A ball-screw model file::

    schema = "feedtune.model/1"
    kind = "ballscrew"
    input_unit = "V"
    lead_m_per_rad = { value = 0.003183098861837907, unit = "m/rad" }
    real_pole_hz = 0.073...

    [params]
    m1 = { value = 0.001858, unit = "V/(rad/s^2)" }
    ...

    [[modes]]
    freq_hz = 130.5...
    zeta = 0.05...

    [fit]
    ...free-form information about the identification, written as given

Loading dispatches on ``kind`` through a registry, so other model kinds plug in with
:func:`register_model_kind`; ``"gantry"``, ``"rigid"`` (:class:`~feedtune.models.rigid.RigidBodyModel`) and
``"friction"`` (:class:`~feedtune.models.friction.StribeckFriction`) are registered on first use.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..errors import DataError
from ..models.ballscrew import PARAM_NAMES, BallScrewModel, param_units
from ..models.friction import StribeckFriction
from ..models.gantry import GantryModel
from ..models.rigid import RigidBodyModel
from ..quantity import quantity, value_of
from .document import read_document, require_schema, write_document
from .friction_model import stribeck_from_doc, stribeck_to_doc
from .gantry_model import gantry_model_from_doc, gantry_model_to_doc
from .model_schema import validate_model
from .rigid_model import rigid_from_doc, rigid_to_doc
from .schema_common import check_finite

MODEL_SCHEMA = "feedtune.model"
MODEL_SCHEMA_MAJOR = 1

ModelLoader = Callable[[Mapping[str, object], str], object]
"""``loader(doc, where) -> model``: build a model from a document (``where`` = file name for messages)."""
ModelSaver = Callable[[object], dict]
"""``saver(model) -> dict``: the document body (everything but ``schema``, ``kind`` and ``fit``)."""

_REGISTRY: dict[str, tuple[ModelLoader, ModelSaver, type | None]] = {}


def register_model_kind(kind: str, loader: ModelLoader, saver: ModelSaver,
                        model_type: type | None = None) -> None:
    """Register how to load and save a model kind.

    Parameters
    ----------
    kind : str
        The document's ``kind`` value, e.g. ``"ballscrew"``, ``"gantry"``.
    loader : callable
        ``loader(doc, where) -> model``; raise :class:`DataError` naming ``where`` and the key on bad input.
    saver : callable
        ``saver(model) -> dict`` giving the document body (quantities with units).
    model_type : type, optional
        The model class :func:`save_model` recognises for this kind (default: none, loading only).
    """
    _REGISTRY[kind] = (loader, saver, model_type)


def model_kinds() -> list[str]:
    """The registered model kinds (including those registered on first use)."""
    return sorted(_REGISTRY)


# ------------------------------------------------------------------------------------------- ball screw
def ballscrew_to_doc(model: BallScrewModel) -> dict:
    """Document body of a :class:`BallScrewModel` (parameters, lead, modes, real pole)."""
    units = param_units(model.input_unit)
    lead = {"lead_m_per_rad": quantity(model.lead_m_per_rad, "m/rad")} if model.lead_given else {}
    return {
        "input_unit": model.input_unit,
        **lead,
        "real_pole_hz": model.real_pole_hz(),
        "params": {k: quantity(v, units[k]) for k, v in model.params().items()},
        "modes": [{"freq_hz": m.freq_hz, "zeta": m.zeta} for m in model.modes()],
    }


def ballscrew_from_doc(doc: Mapping[str, object], where: str) -> BallScrewModel:
    """Build a :class:`BallScrewModel` from a model document; errors name the file and the key."""
    input_unit = doc.get("input_unit", "V")
    if not isinstance(input_unit, str) or not input_unit:
        raise DataError(f"{where}: input_unit must be a unit string such as \"V\"")
    params = doc.get("params")
    if not isinstance(params, Mapping):
        raise DataError(f"{where}: missing [params] table with {', '.join(PARAM_NAMES)}")
    units = param_units(input_unit)
    values = {}
    for name in PARAM_NAMES:
        if name not in params:
            raise DataError(f"{where}: params.{name} is missing")
        v = value_of(params[name], units[name], f"{where}: params.{name}")
        if not math.isfinite(v) or v < 0 or (v == 0 and name in ("m1", "m2", "k")):
            need = "> 0" if name in ("m1", "m2", "k") else ">= 0"
            raise DataError(f"{where}: params.{name} = {v:g} must be finite and {need}")
        values[name] = v
    lead = value_of(doc.get("lead_m_per_rad", BallScrewModel.lead_m_per_rad), "m/rad",
                    f"{where}: lead_m_per_rad")
    if not (math.isfinite(lead) and lead > 0):
        raise DataError(f"{where}: lead_m_per_rad = {lead:g} must be > 0 m/rad")
    try:
        return BallScrewModel(**values, lead_m_per_rad=lead, input_unit=input_unit,
                              lead_given="lead_m_per_rad" in doc)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None


register_model_kind("ballscrew", ballscrew_from_doc, ballscrew_to_doc, BallScrewModel)

register_model_kind("gantry", gantry_model_from_doc, gantry_model_to_doc, GantryModel)
register_model_kind("friction", stribeck_from_doc, stribeck_to_doc, StribeckFriction)
register_model_kind("rigid", rigid_from_doc, rigid_to_doc, RigidBodyModel)


# ------------------------------------------------------------------------------------------- public API
def model_document(model: object, *, fit: Mapping[str, object] | None = None) -> dict:
    """The full document of a model: schema, kind, the kind's body, and ``fit`` as given."""
    for kind, (_, saver, model_type) in _REGISTRY.items():
        if model_type is not None and isinstance(model, model_type):
            body = {k: v for k, v in saver(model).items() if k not in ("schema", "kind", "fit")}
            doc = {"schema": f"{MODEL_SCHEMA}/{MODEL_SCHEMA_MAJOR}", "kind": kind, **body}
            if fit is not None:
                doc["fit"] = dict(fit)
            return doc
    raise DataError(f"cannot save a {type(model).__name__}: no model kind is registered for it "
                    f"(known kinds: {', '.join(model_kinds())})")


def save_model(path: str | os.PathLike[str], model: object, *, fit: Mapping[str, object] | None = None,
               force: bool = False) -> list[Path]:
    """Write a model file (``x.toml`` + JSON twin ``x.json``, or ``x.json`` alone).

    Parameters
    ----------
    path : path-like
        ``.toml`` or ``.json`` destination.
    model : BallScrewModel or another registered model type
        The model.
    fit : dict, optional
        Free-form information about the identification (band, errors...), written as given.
    force : bool
        Replace existing files.

    Returns
    -------
    list of Path
        The files written.
    """
    return write_document(path, model_document(model, fit=fit), force=force)


def load_model(path: str | os.PathLike[str]) -> Any:
    """Read a model file and build the model its ``kind`` names (``"ballscrew"`` -> :class:`BallScrewModel`).

    Parameters
    ----------
    path : path-like
        ``.toml`` or ``.json`` model file.

    Raises
    ------
    DataError
        Missing file, syntax error, wrong schema or kind, missing or invalid parameter.
    """
    where = str(path)
    doc = read_document(path)
    require_schema(doc, MODEL_SCHEMA, where, MODEL_SCHEMA_MAJOR)
    kind = doc.get("kind")
    if not isinstance(kind, str) or kind not in _REGISTRY:
        known = ", ".join(model_kinds())
        raise DataError(f"{where}: kind = {kind!r} is not a known model kind; known: {known}")
    for key, value in doc.items():  # every number the loaders read: finite and within float range
        if key not in ("fit", "design"):
            check_finite(value, [key], where)
    model = _REGISTRY[kind][0](doc, where)  # the loader's own checks first (their messages name the rule)
    validate_model(doc, kind, where)  # then the schema's ranges, which no loader may relax
    return model
