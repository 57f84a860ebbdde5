"""The gains documents a target executes: the runtime of a document and its analysis, chosen by its ``kind``.

A gains document's ``kind`` names its gains format in the registry of structures (:mod:`feedtune.structures`),
which names the runtime that executes it per sample and the analysis ``feedtune analyze`` prints and the report
shows; every command dispatches here, in one place, whichever machine (or real target) runs the document.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from ..structures import GainsFormat, gains_format, resolve


class Runtime(Protocol):
    """What every runtime offers: a control law executed one sample at a time at the target's rate."""

    fs: float
    preview_samples: int

    def reset(self) -> None:
        """Zero every state."""

    def check_target(self, fs: float) -> None:
        """DataError when the gains were designed for another sample rate than ``fs`` [Hz]."""


@dataclass(frozen=True)
class GainsAnalysis:
    """The analysis of a gains document and its ``feedtune analyze --json`` dictionary (without the check).

    Attributes
    ----------
    analysis : object
        The library analysis (ball screw: ``BallScrewAnalysis``; gantry/axis: ``GantryAnalysis``/``AxisAnalysis``).
    result : dict
        ``kind``, ``controller``, ``gains`` with ``gain_units``, machine-specific keys and ``analysis``.
    law, model : object
        The control law and the plant model read from the document (``model`` is None for an axis).
    """

    analysis: Any
    result: dict
    law: Any
    model: Any


def plain_gains(section: Mapping | None) -> dict:
    """``{name: value}`` of a gains-file section whose entries are numbers or ``{value, unit}`` tables."""
    return {k: (v["value"] if isinstance(v, Mapping) else v) for k, v in (section or {}).items()}


def gains_format_of(doc: Mapping, where: str) -> GainsFormat:
    """The gains format of a document, by its ``kind``, once the document is valid
    (:func:`feedtune.io.gains_schema.validate_gains`: one-line DataError naming the file and key)."""
    from ..io.gains import SCHEMA
    from ..io.gains_schema import validate_gains

    if isinstance(doc, Mapping):  # a model or another document is named as such, before its kind is looked at
        from ..io.document import require_schema

        require_schema(doc, "feedtune.gains", where, written=SCHEMA)
    kind = doc.get("kind") if isinstance(doc, Mapping) else None
    entry = gains_format(kind, where)
    validate_gains(doc, where)
    return entry


def load_runtime(path_or_doc, where: str | None = None) -> Runtime:
    """The runtime of a gains file or document, chosen by its ``kind`` through the registry.

    Parameters
    ----------
    path_or_doc : path-like or dict
        A ``.toml``/``.json`` gains file, or the document read from one.
    where : str, optional
        Name used in error messages (default: the path, or ``"gains document"``).

    Raises
    ------
    DataError
        Unreadable file, or a ``kind`` no gains format has.
    """
    if isinstance(path_or_doc, Mapping):
        doc, name = path_or_doc, where or "gains document"
    else:
        from ..io import read_document

        doc, name = read_document(os.fspath(path_or_doc)), where or str(path_or_doc)
    return resolve(gains_format_of(doc, name).runtime).from_document(dict(doc), name)


def analyze_gains(doc: Mapping, where: str, frf=None) -> GainsAnalysis:
    """The analysis of a gains document by its gains format (what ``feedtune analyze GAINS`` prints).

    Parameters
    ----------
    doc : Mapping
        The gains document.
    where : str
        Its name in error messages.
    frf : Frf, optional
        Measured FRF of the machine, for the measured and discrete cases.

    Raises
    ------
    DataError
        A ``kind`` no gains format has, or a document its analysis refuses.
    """
    return resolve(gains_format_of(doc, where).analysis)(doc, where, frf)
