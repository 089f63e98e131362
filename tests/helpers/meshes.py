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


def stacked_rectangles_geo(x0: float, extra: str = "") -> str:
    """A gmsh .geo of two 4 x 2 mm rectangles from x = ``x0``, "lower" below y = 0 and "upper" above, with the
    curves bottom, lower_top, upper_bottom, upper_top and mesh size 0.5 mm (axisymmetric rings for x0 > 0);
    ``extra``: more .geo lines."""
    return (f'SetFactory("OpenCASCADE");\nRectangle(1) = {{{x0:g}, -2, 0, 4, 2}};\n'
            f'Rectangle(2) = {{{x0:g}, 0, 0, 4, 2}};\n'
            'Physical Surface("lower") = {1};\nPhysical Surface("upper") = {2};\nPhysical Curve("bottom") = {1};\n'
            'Physical Curve("lower_top") = {3};\nPhysical Curve("upper_bottom") = {5};\n'
            'Physical Curve("upper_top") = {7};\nMesh.MeshSizeMax = 0.5;\n' + extra)
