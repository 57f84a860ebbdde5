"""The ball-screw drive (thesis chapter 3): two-mass twin, MC-PPC/P-PI runtime, experiments."""

from __future__ import annotations

from ..registry import MachineEntry


def _twin(overrides: dict, ideal: bool):
    from .twin import BallScrewTwin, TwinParams

    base = TwinParams.ideal() if ideal else TwinParams()
    return BallScrewTwin(base.with_overrides(overrides))


def _runtime(doc, where: str):
    from .runtime import GainsRuntime

    return GainsRuntime.from_document(dict(doc), where)


def _analysis(doc, where: str, frf):
    from .gains_analysis import analyze_document

    return analyze_document(doc, where, frf)


MACHINE = MachineEntry(name="ballscrew", title="ball-screw drive", gains_kinds=("ballscrew",), make_twin=_twin,
                       make_runtime=_runtime, make_analysis=_analysis)
