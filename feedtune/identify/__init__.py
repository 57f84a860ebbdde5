"""From data to models: FRF fits (ball screw, gantry), FRF estimation from logs, mass distribution.

Rigid-body and friction identification live in :mod:`feedtune.identify.rigid` and
:mod:`feedtune.identify.friction`.
"""

from .ballscrew import BallScrewFit, fit_ballscrew
from .frf_estimate import detect_period, estimate_frf, excited_lines
from .gantry import GantryFit, GantryFitAtX, fit_gantry, fit_gantry_frf
from .mass import MassFit, fit_axis_mass, fit_mass_distribution

__all__ = [
    "BallScrewFit",
    "GantryFit",
    "GantryFitAtX",
    "MassFit",
    "detect_period",
    "estimate_frf",
    "excited_lines",
    "fit_axis_mass",
    "fit_ballscrew",
    "fit_gantry",
    "fit_gantry_frf",
    "fit_mass_distribution",
]
