"""Physical models of feed drives: ball-screw 2-mass model, gantry yaw model, rigid body, friction."""

from .ballscrew import THESIS_TABLE_3_1, BallScrewModel, Mode

__all__ = ["THESIS_TABLE_3_1", "BallScrewModel", "Mode"]
