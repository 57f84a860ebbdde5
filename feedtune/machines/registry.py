"""The ``Machine`` protocol and the registry of the machines feedtune simulates and deploys to.

A machine is one sub-package of :mod:`feedtune.machines`: its twin (physics and the compiled closed loop), its
runtime (the control law executed sample by sample from a gains file), its experiments and its demo settings. The
registry maps a machine name (``feedtune simulate MACHINE``) and a gains file's ``kind`` to it, so that commands
dispatch in one place. Adding a machine is one sub-package and one line in :data:`MACHINES` (see
``docs/architecture.md``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from ..errors import DataError, UsageError


class Runtime(Protocol):
    """What every runtime offers: a control law executed one sample at a time at the target's rate."""

    fs: float
    preview_samples: int

    def reset(self) -> None:
        """Zero every state."""

    def check_target(self, fs: float) -> None:
        """DataError when the gains were designed for another sample rate than ``fs`` [Hz]."""


class Machine(Protocol):
    """One simulated and deployable machine."""

    name: str
    title: str
    gains_kinds: tuple[str, ...]

    def twin(self, overrides: Mapping[str, object] | None = None, *, ideal: bool = False) -> Any:
        """The digital twin with parameter overrides (``NAME -> value``); ``ideal`` drops unmodelled effects."""

    def runtime(self, doc: Mapping, where: str) -> Runtime:
        """The runtime executing a gains document of one of :attr:`gains_kinds`."""

    def analyze(self, doc: Mapping, where: str, frf=None) -> GainsAnalysis:
        """Every analysis case of a gains document of one of :attr:`gains_kinds`, with a measured FRF or not."""


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


@dataclass(frozen=True)
class MachineEntry:
    """A :class:`Machine` built from two factories (imported lazily by the machine's package)."""

    name: str
    title: str
    gains_kinds: tuple[str, ...]
    make_twin: Callable[..., Any]
    make_runtime: Callable[[Mapping, str], Runtime]
    make_analysis: Callable[[Mapping, str, Any], GainsAnalysis]

    def twin(self, overrides: Mapping[str, object] | None = None, *, ideal: bool = False) -> Any:
        return self.make_twin(dict(overrides or {}), ideal)

    def runtime(self, doc: Mapping, where: str) -> Runtime:
        return self.make_runtime(doc, where)

    def analyze(self, doc: Mapping, where: str, frf=None) -> GainsAnalysis:
        return self.make_analysis(doc, where, frf)


def _machines() -> dict[str, Machine]:
    from .ballscrew import MACHINE as BALLSCREW
    from .gantry import MACHINE as GANTRY

    return {m.name: m for m in (BALLSCREW, GANTRY)}


def machine_names() -> tuple[str, ...]:
    """The registered machine names, e.g. ``('ballscrew', 'gantry')``."""
    return tuple(_machines())


def get_machine(name: str) -> Machine:
    """The machine called ``name``; UsageError listing the known ones otherwise."""
    machines = _machines()
    if name not in machines:
        raise UsageError(f"unknown machine {name!r}; known machines: {', '.join(machines)}")
    return machines[name]


def gains_kinds() -> dict[str, Machine]:
    """Every gains-file ``kind`` and the machine that executes it."""
    return {k: m for m in _machines().values() for k in m.gains_kinds}


def machine_of_gains(doc: Mapping, where: str) -> Machine:
    """The machine that executes a gains document, by its ``kind``, once the document is valid
    (:func:`feedtune.io.gains_schema.validate_gains`: one-line DataError naming the file and key)."""
    from ..io.gains import SCHEMA
    from ..io.gains_schema import validate_gains

    if isinstance(doc, Mapping):  # a model or another document is named as such, before its kind is looked at
        from ..io.document import require_schema

        require_schema(doc, "feedtune.gains", where, written=SCHEMA)
    kinds = gains_kinds()
    kind = doc.get("kind") if isinstance(doc, Mapping) else None
    if not isinstance(kind, str) or kind not in kinds:
        known = ", ".join(repr(k) for k in kinds)
        raise DataError(f"{where}: gains file kind {kind!r} unknown; expected one of {known}")
    validate_gains(doc, where)
    return kinds[kind]


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
        Unreadable file, or a ``kind`` no registered machine executes.
    """
    if isinstance(path_or_doc, Mapping):
        doc, name = path_or_doc, where or "gains document"
    else:
        from ..io import read_document

        doc, name = read_document(os.fspath(path_or_doc)), where or str(path_or_doc)
    return machine_of_gains(doc, name).runtime(doc, name)


def analyze_gains(doc: Mapping, where: str, frf=None) -> GainsAnalysis:
    """The analysis of a gains document by the machine of its ``kind`` (what ``feedtune analyze GAINS`` prints).

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
        A ``kind`` no registered machine executes, or a document its machine refuses.
    """
    return machine_of_gains(doc, where).analyze(doc, where, frf)
