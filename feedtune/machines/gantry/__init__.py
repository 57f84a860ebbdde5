"""The linear-motor T-gantry (thesis chapter 4): the twin with its x axis, its experiments and its demo."""

from __future__ import annotations

from ..registry import MachineEntry


def _twin(overrides: dict, ideal: bool):
    from .twin import GantryTwin, GantryTwinParams

    base = GantryTwinParams.ideal() if ideal else GantryTwinParams()
    return GantryTwin(base.with_overrides(overrides))


MACHINE = MachineEntry(
    name="gantry", title="linear-motor T-gantry", plant="gantry", make_twin=_twin,
    experiments="feedtune.machines.gantry.experiments", params="feedtune.machines.gantry.twin:GantryTwinParams",
    axes=("rigid",),
    demo="feedtune.workflows.gantry_demo:machine_demo", log_source="gantry twin ",
    modules=("machines/gantry/", "workflows/gantry_demo.py", "cli/simulate_gantry_cmd.py"))
