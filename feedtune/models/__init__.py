"""Physical models of feed drives: ball-screw 2-mass model and the T-gantry yaw model."""

from .ballscrew import THESIS_TABLE_3_1, BallScrewModel, Mode
from .friction import StribeckFriction
from .gantry import THESIS_GANTRY, GantryModel, GantryModelAtX
from .rigid import RigidBodyModel

__all__ = [
    "THESIS_GANTRY",
    "THESIS_TABLE_3_1",
    "BallScrewModel",
    "GantryModel",
    "GantryModelAtX",
    "Mode",
    "RigidBodyModel",
    "StribeckFriction",
]
