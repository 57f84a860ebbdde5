"""The display names of the controller structures: one vocabulary for the command line, the report and the docs.

Gains files, twin logs and ``--json`` results name a controller by its structure (``mcppc``, ``ppi``, ``mimo``,
``pid``, ``loopshape``); people read it by its title in the registry of structures (:mod:`feedtune.structures`):
MC-PPC, P-PI, MIMO, PID and x-axis loop shaping (thesis chapters 3 and 4).
"""

from __future__ import annotations

from ..structures import controller_title, controllers

CONTROLLER_NAMES = {c.name: c.title for c in controllers()}
"""Display name of each controller structure (:attr:`feedtune.structures.ControllerStructure.title`)."""


def controller_name(kind: str | None) -> str:
    """``"mcppc"`` -> ``"MC-PPC"``; an unknown kind as given; empty or None -> ``"controller"``."""
    return controller_title(kind)
