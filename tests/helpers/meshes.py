"""Contact test meshes made with gmsh: two bodies meshed apart (so that gmsh does not merge their touching faces),
then the upper one moved down into contact."""

from __future__ import annotations

import gmsh
import numpy as np

from frictionid.builders.gmsh_mesh import mesh_from_gmsh
from frictionid.model import Mesh


def generated(order: int = 1) -> Mesh:
    """The current gmsh model meshed in 3-D (complete second-order elements with ``order`` 2) as a Mesh; call it
    inside the gmsh session."""
    gmsh.model.mesh.generate(3)
    if order == 2:
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        gmsh.model.mesh.setOrder(2)
    return mesh_from_gmsh()


def lowered(mesh: Mesh, axis: int, apart: float) -> np.ndarray:
    """The mesh's points [mm] with those of region "upper" moved by -``apart`` along ``axis``."""
    points = np.array(mesh.points)
    points[np.unique(mesh.cells[mesh.regions["upper"]]), axis] -= apart
    return points
