"""Model files: identified plant models as TOML documents (``schema = "feedtune.model/1"``) with a JSON twin.

A model file names its ``kind``; the body is the kind's (a ball screw's: :mod:`feedtune.io.ballscrew_model`)::

    schema = "feedtune.model/1"
    kind = "ballscrew"
    input_unit = "V"
    ...

    [fit]
    ...free-form information about the identification, written as given

Loading dispatches on ``kind`` through a registry: the model kind of every plant structure (``ballscrew``,
``gantry``, ``rigid``: :mod:`feedtune.structures` names its model class and codec) is registered on first use, and
``"friction"`` (:class:`~feedtune.models.friction.StribeckFriction`) here; other kinds plug in with
:func:`register_model_kind`.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from ..errors import DataError
from ..models.friction import MODEL_KIND as MODEL_KIND_FRICTION
from ..models.friction import StribeckFriction
from ..structures import plants, require_plant, resolve
from .document import read_document, require_schema, write_document
from .friction_model import stribeck_from_doc, stribeck_to_doc
from .model_schema import validate_model
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
    return sorted(_registry())


register_model_kind(MODEL_KIND_FRICTION, stribeck_from_doc, stribeck_to_doc, StribeckFriction)


def _registry() -> dict[str, tuple[ModelLoader, ModelSaver, type | None]]:
    """The registered kinds, with the model kind of every plant structure (:mod:`feedtune.structures`: its model class
    and codec) registered on first use."""
    for p in plants():
        if p.model_kind not in _REGISTRY:
            _REGISTRY[p.model_kind] = (resolve(p.reader), resolve(p.writer), resolve(p.model))
    return _REGISTRY


# ------------------------------------------------------------------------------------------- public API
def model_document(model: object, *, fit: Mapping[str, object] | None = None) -> dict:
    """The full document of a model: schema, kind, the kind's body, and ``fit`` as given."""
    for kind, (_, saver, model_type) in _registry().items():
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


def load_model(path: str | os.PathLike[str], *, plants: Iterable[str] | None = None) -> Any:
    """Read a model file and build the model its ``kind`` names (``"ballscrew"`` -> :class:`BallScrewModel`).

    Parameters
    ----------
    path : path-like
        ``.toml`` or ``.json`` model file.
    plants : iterable of str, optional
        The plant structures the caller needs (``("two_mass",)``): a model of another one is refused, naming what
        is needed (:func:`feedtune.structures.require_plant`).

    Raises
    ------
    DataError
        Missing file, syntax error, wrong schema or kind, missing or invalid parameter, a model of another plant
        structure than ``plants``.
    """
    where = str(path)
    doc = read_document(path)
    require_schema(doc, MODEL_SCHEMA, where, MODEL_SCHEMA_MAJOR)
    kind = doc.get("kind")
    registry = _registry()
    if not isinstance(kind, str) or kind not in registry:
        known = ", ".join(model_kinds())
        raise DataError(f"{where}: kind = {kind!r} is not a known model kind; known: {known}")
    for key, value in doc.items():  # every number the loaders read: finite and within float range
        if key not in ("fit", "design"):
            check_finite(value, [key], where)
    model = registry[kind][0](doc, where)  # the loader's own checks first (their messages name the rule)
    validate_model(doc, kind, where)  # then the schema's ranges, which no loader may relax
    if plants is not None:
        require_plant(model, plants, where)
    return model
