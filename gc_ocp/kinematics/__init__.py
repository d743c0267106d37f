"""Kinematics: marker filtering, scaling/registration, IK and sole-point kinematics."""

from gc_ocp.kinematics.filtering import lowpass
from gc_ocp.kinematics.ik import IKResult, MarkerModel, solve_ik
from gc_ocp.kinematics.pipeline import compute_kinematics, foot_kinematics
from gc_ocp.kinematics.scaling import estimate_height, register_markers

__all__ = [
    "IKResult",
    "MarkerModel",
    "compute_kinematics",
    "estimate_height",
    "foot_kinematics",
    "lowpass",
    "register_markers",
    "solve_ik",
]
