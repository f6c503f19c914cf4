"""7-DOF full car: validated parameters and its M, C, K, D0(s), stroke and road-input matrices."""

from hisopt.vehicle.full_car import (
    at_frequencies,
    body_to_corners,
    damping_matrix,
    dynamic_stiffness_matrix,
    mass_matrix,
    road_damping_input,
    road_stiffness_input,
    stiffness_matrix,
    stroke_matrix,
)
from hisopt.vehicle.parameters import VehicleParams

__all__ = [
    "VehicleParams",
    "at_frequencies",
    "body_to_corners",
    "damping_matrix",
    "dynamic_stiffness_matrix",
    "mass_matrix",
    "road_damping_input",
    "road_stiffness_input",
    "stiffness_matrix",
    "stroke_matrix",
]
