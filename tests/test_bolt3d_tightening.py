"""Tightening in 3-D: a :class:`~frictionid.model.Rotation` of a boundary about the y axis of a 3-D model (checked
on a tube in torsion), and the 3-D bolt's tightening test, the nut turned against the held head on the helix of
the mesh."""

import gmsh
import numpy as np
import pytest

from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh
from frictionid.fem.problem import Problem
from frictionid.model import Material, Model, Rotation, Stage, Support


def _tube(outer: float, inner: float, length: float, size: float):
    """Quadratic tetrahedra of a tube along y, faces "bottom" (y = 0) and "top" (y = length)."""
    with gmsh_session():
        occ = gmsh.model.occ
        tube, _ = occ.cut([(3, occ.addCylinder(0, 0, 0, 0, length, 0, outer))],
                          [(3, occ.addCylinder(0, 0, 0, 0, length, 0, inner))])
        occ.synchronize()
        faces = gmsh.model.getBoundary(tube, oriented=False)
        for name, y in (("bottom", 0.0), ("top", length)):
            gmsh.model.addPhysicalGroup(2, [t for _, t in faces if abs(occ.getCenterOfMass(2, t)[1] - y) < 1e-9],
                                        name=name)
        gmsh.model.addPhysicalGroup(3, [tube[0][1]], name="tube")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh("tube")


def test_rotation_in_3d_twists_a_tube_by_saint_venant():
    """Bottom held, top turned by 1 mrad (u_x = -z a, u_z = x a, u_y free): the torque "top.torque" is Saint-Venant's
    G J a / L of the circular tube, J = pi (R^4 - r^4) / 2, within 1e-4 (measured 6e-6: the exact field is
    quadratic, the error is the polygonal section's); the turned face's displacements are the rigid rotation."""
    R, r, L, E, nu, a = 5.0, 3.0, 10.0, 200000.0, 0.3, 1e-3
    mesh = _tube(R, r, L, 1.0)
    model = Model(mesh=mesh, kind="3d", materials={"tube": Material(E, nu)}, supports=(Support("bottom"),),
                  loads=(Rotation("top", (a,)),), stages=(Stage("turn"),), interfaces=())
    problem = Problem.build(model)
    solution = problem.solve(np.zeros(0))
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert set(reactions) == {"bottom.x", "bottom.y", "bottom.z", "top.torque"}
    torque = E / (2 * (1 + nu)) * np.pi * (R ** 4 - r ** 4) / 2 * a / L
    assert reactions["top.torque"] == pytest.approx(torque, rel=1e-4)
    top = mesh.boundary_nodes("top")
    u, x = problem.displacement(solution).reshape(-1, 3)[top], mesh.points[top]
    np.testing.assert_allclose(u[:, [0, 2]], a * np.column_stack([-x[:, 2], x[:, 0]]), atol=1e-12)
