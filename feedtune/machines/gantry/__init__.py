"""The linear-motor T-gantry (thesis chapter 4): twin, MIMO/PID and x-axis runtimes, experiments."""

from __future__ import annotations

from ..registry import MachineEntry


def _twin(overrides: dict, ideal: bool):
    from .twin import GantryTwin, GantryTwinParams

    base = GantryTwinParams.ideal() if ideal else GantryTwinParams()
    return GantryTwin(base.with_overrides(overrides))


def _runtime(doc, where: str):
    from .runtime import AxisRuntime, GantryRuntime

    cls = AxisRuntime if doc.get("kind") == "axis" else GantryRuntime
    return cls.from_document(dict(doc), where)


def _analysis(doc, where: str, frf):
    from .gains_analysis import analyze_document

    return analyze_document(doc, where, frf)


MACHINE = MachineEntry(name="gantry", title="linear-motor T-gantry", gains_kinds=("gantry", "axis"),
                       make_twin=_twin, make_runtime=_runtime, make_analysis=_analysis)
