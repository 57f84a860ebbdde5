"""Checking a ball-screw design against stability and margin limits before it is exported."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..analysis.ballscrew import BallScrewAnalysis, analyze_ballscrew, closed_loop_poles
from ..frf import Frf


@dataclass(frozen=True)
class DesignCheck:
    """Analysis of a design and whether it meets the limits.

    Attributes
    ----------
    analysis : BallScrewAnalysis
    closed_loop_poles : ndarray
        Roots of ``1 + L`` of the continuous loop with the filter pack [rad/s].
    ok : bool
        Stable in every analysed case and within the limits in the worst case.
    worst_case : str
        The case the limits were checked in (``discrete`` with an FRF, else ``ideal_discrete``).
    violations : list of str
    """

    analysis: BallScrewAnalysis
    closed_loop_poles: np.ndarray
    ok: bool
    worst_case: str
    violations: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """``{"ok", "checked_case", "violations"}``."""
        return {"ok": self.ok, "checked_case": self.worst_case, "violations": list(self.violations)}


def check_design(
    design, *, frf: Frf | None = None, ms_max: float | None = None, pm_min_deg: float | None = None
) -> DesignCheck:
    """Analyse ``design`` (MC-PPC or P-PI) and compare with the limits.

    Parameters
    ----------
    design : McppcDesign or PpiDesign
    frf : Frf, optional
        Measured FRF for the measured and discrete cases.
    ms_max : float, optional
        Largest acceptable peak sensitivity [-].
    pm_min_deg : float, optional
        Smallest acceptable |phase margin| at any crossover [deg].
    """
    law = design.law()
    analysis = analyze_ballscrew(law, design.model, frf)
    violations = []
    for name, case in analysis.cases.items():
        if case is not None and not case.metrics.stable:
            violations.append(
                f"closed loop is unstable in the {name} case "
                f"({case.metrics.nyquist_encirclements} clockwise encirclements of -1)"
            )
    worst = "discrete" if frf is not None else "ideal_discrete"
    m = analysis.cases[worst].metrics
    if ms_max is not None and m.ms > ms_max:
        violations.append(
            f"peak sensitivity Ms = {m.ms:.3g} at {m.ms_freq_hz:.4g} Hz exceeds --ms-max {ms_max:g} ({worst} case)"
        )
    if pm_min_deg is not None and m.phase_margin_deg is not None and abs(m.phase_margin_deg) < pm_min_deg:
        violations.append(
            f"phase margin {m.phase_margin_deg:.3g} deg is below --pm-min {pm_min_deg:g} deg ({worst} case)"
        )
    poles = closed_loop_poles(law, design.model)
    return DesignCheck(analysis, poles, not violations, worst, violations)
