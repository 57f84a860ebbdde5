"""Checking a ball-screw design against the limits policy before it is exported.

A design passes when it is stable (Nyquist) in every analysis case and meets every limit of the
:class:`~feedtune.analysis.limits.Limits` in the checked case: ``discrete`` (the measured FRF with the controller as
the target runs it) when an FRF is given, else ``ideal_discrete``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frf import Frf
from .ballscrew import BallScrewAnalysis, analyze_ballscrew, closed_loop_poles
from .limits import DEFAULT_LIMITS, LimitCheck, Limits, check_analysis


@dataclass(frozen=True)
class DesignCheck:
    """Analysis of a design and whether it meets the limits.

    Attributes
    ----------
    analysis : BallScrewAnalysis
    closed_loop_poles : ndarray
        Roots of ``1 + L`` of the continuous loop with the filter pack [rad/s].
    limit_check : LimitCheck
        Every limit in the checked case and stability in every case.
    worst_case : str
        The case the limits were checked in (``discrete`` with an FRF, else ``ideal_discrete``).
    """

    analysis: BallScrewAnalysis
    closed_loop_poles: np.ndarray
    limit_check: LimitCheck
    worst_case: str

    @property
    def ok(self) -> bool:
        """Stable in every case and within every limit in the checked case."""
        return self.limit_check.ok

    @property
    def violations(self) -> list[str]:
        """One line per violated limit."""
        return self.limit_check.violations

    def to_dict(self) -> dict:
        """``{"ok", "checked_case", "violations", "limits", "items", "active"}``."""
        return {"checked_case": self.worst_case, **self.limit_check.to_dict()}


def resolve_limits(limits: Limits | None = None, *, ms_max: float | None = None,
                   pm_min_deg: float | None = None) -> Limits:
    """``limits`` (default :data:`~feedtune.analysis.limits.DEFAULT_LIMITS`) with the given values overriding it."""
    return (limits or DEFAULT_LIMITS).override(ms_max=ms_max, pm_min_deg=pm_min_deg)


def check_design(design, *, frf: Frf | None = None, limits: Limits | None = None, ms_max: float | None = None,
                 pm_min_deg: float | None = None, cases: dict | None = None) -> DesignCheck:
    """Analyse ``design`` (MC-PPC or P-PI) in every case and compare it with the limits.

    Parameters
    ----------
    design : McppcDesign or PpiDesign
    frf : Frf, optional
        Measured FRF for the measured and discrete cases.
    limits : Limits, optional
        The limits policy (default: the ``textbook`` profile).
    ms_max, pm_min_deg : float, optional
        Overrides of the policy's peak sensitivity [-] and phase margin [deg].
    cases : dict, optional
        The plant cases of ``design.model`` and ``frf`` at the design's rate and delay, made already
        (:func:`~feedtune.analysis.ballscrew.plant_cases`: a tuner checking many designs on one FRF makes them once).
    """
    pol = resolve_limits(limits, ms_max=ms_max, pm_min_deg=pm_min_deg)
    law = design.law()
    analysis = analyze_ballscrew(law, design.model, frf, cases=cases)
    check, worst = check_analysis(analysis, pol)
    return DesignCheck(analysis, closed_loop_poles(law, design.model), check, worst)
