"""The ball-screw drive (thesis chapter 3): the two-mass twin, its experiments and its demo."""

from __future__ import annotations

from ..registry import MachineEntry


def _twin(overrides: dict, ideal: bool):
    from .twin import BallScrewTwin, TwinParams

    base = TwinParams.ideal() if ideal else TwinParams()
    return BallScrewTwin(base.with_overrides(overrides))


MACHINE = MachineEntry(
    name="ballscrew", title="ball-screw drive", plant="two_mass", make_twin=_twin,
    experiments="feedtune.machines.ballscrew.experiments", params="feedtune.machines.ballscrew.twin:TwinParams",
    demo="feedtune.workflows.ballscrew_demo:machine_demo", log_source="twin ",
    modules=("machines/ballscrew/", "workflows/ballscrew_demo.py", "workflows/comparison.py"))
