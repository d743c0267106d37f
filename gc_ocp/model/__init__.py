"""Body model: de Leva anthropometry, URDF generation and the Pinocchio wrapper."""

from gc_ocp.model.anthropometry import Anthropometry, anthropometry
from gc_ocp.model.body import BodyModel
from gc_ocp.model.urdf import generate_urdf, write_seed_urdf, write_urdf

__all__ = [
    "Anthropometry",
    "BodyModel",
    "anthropometry",
    "generate_urdf",
    "write_seed_urdf",
    "write_urdf",
]
