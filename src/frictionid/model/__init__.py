"""Solver-independent description of a contact model: mesh, materials, supports, load path, friction zones."""

from .mesh import Mesh
from .model import (
    ContactInterface,
    Displacement,
    Material,
    Model,
    Pressure,
    Rotation,
    Stage,
    SurfaceForce,
    Support,
)

__all__ = [
    "ContactInterface",
    "Displacement",
    "Material",
    "Mesh",
    "Model",
    "Pressure",
    "Rotation",
    "Stage",
    "SurfaceForce",
    "Support",
]
