"""Trajectories and simulation."""

from .trajectory import Trajectory, acceleration_mask, constant_velocity_mask, multi_segment, point_to_point

__all__ = ["Trajectory", "acceleration_mask", "constant_velocity_mask", "multi_segment", "point_to_point"]
