"""The display names of the controller structures: one vocabulary for the command line, the report and the docs.

Gains files, twin logs and ``--json`` results name a controller by its kind (``mcppc``, ``ppi``, ``mimo``, ``pid``,
``loopshape``); people read it as MC-PPC, P-PI, MIMO, PID and x-axis loop shaping (thesis chapters 3 and 4).
"""

from __future__ import annotations

CONTROLLER_NAMES = {
    "mcppc": "MC-PPC",
    "ppi": "P-PI",
    "mimo": "MIMO",
    "pid": "PID",
    "loopshape": "x-axis loop shaping",
}
"""Display name of each controller kind: mode-compensating pole placement (ball screw), the P-PI cascade (ball screw),
the gantry's MIMO law, the gantry's independent PIDs and the loop-shaped x axis."""


def controller_name(kind: str | None) -> str:
    """``"mcppc"`` -> ``"MC-PPC"``; an unknown kind as given; empty or None -> ``"controller"``."""
    if not kind:
        return "controller"
    key = str(kind).strip()
    return CONTROLLER_NAMES.get(key.lower(), key)
