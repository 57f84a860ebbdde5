"""From data to models: FRF fits (ball screw, gantry), FRF estimation from logs, rigid-body least squares,
Kalman-filter disturbance estimation and Stribeck friction, mass distribution."""

from ..models.gantry_mass import MassFit
from .ballscrew import BallScrewFit, fit_ballscrew
from .frf_estimate import detect_period, estimate_frf, excited_lines
from .friction import FrictionIdentification, StribeckFit, fit_stribeck, identify_friction
from .gantry import GantryFit, GantryFitAtX, fit_gantry, fit_gantry_frf
from .kalman import DisturbanceEstimate, estimate_disturbance
from .mass import fit_axis_mass, fit_mass_distribution
from .rigid import RigidFit, RigidValidation, fit_rigid, validate_rigid

__all__ = [
    "BallScrewFit",
    "DisturbanceEstimate",
    "FrictionIdentification",
    "GantryFit",
    "GantryFitAtX",
    "MassFit",
    "RigidFit",
    "RigidValidation",
    "StribeckFit",
    "detect_period",
    "estimate_disturbance",
    "estimate_frf",
    "excited_lines",
    "fit_axis_mass",
    "fit_ballscrew",
    "fit_gantry",
    "fit_gantry_frf",
    "fit_mass_distribution",
    "fit_rigid",
    "fit_stribeck",
    "identify_friction",
    "validate_rigid",
]
