"""The ``Machine`` protocol and the registry of the machines feedtune simulates.

A machine is one sub-package of :mod:`feedtune.machines`: its twin (physics and the compiled closed loop), its
experiments and its demo. It names the plant structure of its twin (:mod:`feedtune.structures`); the gains documents
its twin runs are executed by the runtimes the registry of structures names (:mod:`feedtune.machines.gains`), as on
a real target. The registry maps a machine name (``feedtune simulate --machine NAME``, ``feedtune demo NAME``) to it.
Adding a machine is one sub-package and one line in :func:`_machines` (see ``docs/architecture.md``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from ..errors import UsageError


class Machine(Protocol):
    """One simulated machine."""

    name: str
    title: str
    plant: str
    experiments: str
    demo: str | None

    def twin(self, overrides: Mapping[str, object] | None = None, *, ideal: bool = False) -> Any:
        """The digital twin with parameter overrides (``NAME -> value``); ``ideal`` drops unmodelled effects."""


@dataclass(frozen=True)
class MachineEntry:
    """A :class:`Machine` (built by the machine's package).

    Attributes
    ----------
    name : str
        ``feedtune simulate --machine NAME``, ``feedtune demo NAME``.
    title : str
        What it is, for messages.
    plant : str
        The plant structure of its twin (``two_mass``, ``gantry``).
    axes : tuple of str
        The plant structures of its twin's further axes, run by their own gains documents (the gantry's x axis:
        ``rigid``).
    make_twin : callable
        ``make_twin(overrides, ideal) -> twin`` (imports the twin lazily).
    experiments : str
        The module of its experiments (``feedtune simulate``'s commands for its plant structure call them).
    demo : str, optional
        ``package.module:function`` of its demo pipeline (``feedtune demo NAME``), or None.
    params : str
        ``package.module:Class`` of its twin's parameters (their defaults: the twin's).
    log_source : str
        How the ``source`` of the logs its twin writes begins (the report's saturation level of a twin run).
    modules : tuple of str
        Its modules (paths under ``feedtune/``): they may name its kinds.
    """

    name: str
    title: str
    plant: str
    make_twin: Callable[..., Any]
    experiments: str
    params: str
    axes: tuple[str, ...] = ()
    demo: str | None = None
    log_source: str = ""
    modules: tuple[str, ...] = ()

    def twin(self, overrides: Mapping[str, object] | None = None, *, ideal: bool = False) -> Any:
        return self.make_twin(dict(overrides or {}), ideal)


def _machines() -> dict[str, MachineEntry]:
    from .ballscrew import MACHINE as BALLSCREW
    from .gantry import MACHINE as GANTRY

    return {m.name: m for m in (BALLSCREW, GANTRY)}


def machines() -> tuple[MachineEntry, ...]:
    """Every registered machine."""
    return tuple(_machines().values())


def machine_names() -> tuple[str, ...]:
    """The registered machine names, e.g. ``('ballscrew', 'gantry')``."""
    return tuple(_machines())


def machines_of(plant: str) -> tuple[str, ...]:
    """The names of the machines whose twin has the plant structure ``plant``."""
    return tuple(m.name for m in _machines().values() if m.plant == plant)


def get_machine(name: str) -> MachineEntry:
    """The machine called ``name``; UsageError listing the known ones otherwise."""
    machines = _machines()
    if name not in machines:
        raise UsageError(f"unknown machine {name!r}; known machines: {', '.join(machines)}")
    return machines[name]
