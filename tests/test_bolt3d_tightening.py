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


def test_a_3d_rotation_is_refused_by_the_calculix_deck():
    """The deck has no rotation of a face in 3-D: an input error naming the boundary, not a deck without it."""
    from frictionid.backends.calculix.deck import ContactSettings, write_deck
    from frictionid.errors import InputError
    from frictionid.fem.assembly import load_channels
    from frictionid.fem.space import Space
    model = Model(mesh=_tube(5.0, 3.0, 10.0, 2.5), kind="3d", materials={"tube": Material(200000.0, 0.3)},
                  supports=(Support("bottom"),), loads=(Rotation("top", (1e-3,)),), stages=(Stage("turn"),),
                  interfaces=())
    channels = load_channels(Space.build(model.mesh, model.kind, model.element), model)
    with pytest.raises(InputError, match="rotation prescribed on 'top'"):
        write_deck(model, np.zeros(0), ContactSettings(normal_stiffness=1e6, stick_slope=2e6), channels.forces,
                   channels.amplitudes)


def test_a_3d_lead_needs_node_to_node_pairs():
    """The helicoid's normals are set on node-to-node pairs only: a 3-D mortar interface with a lead is refused."""
    import dataclasses
    from frictionid.builders.block import block_model
    from frictionid.errors import InputError
    model = block_model(mesh_size=2.0, n_pull=1)
    interface = dataclasses.replace(model.interfaces[0], discretisation="mortar", lead=1.0)
    model = dataclasses.replace(model, interfaces=(interface,) + model.interfaces[1:])
    with pytest.raises(InputError, match="a lead .* needs node-to-node pairs in 3-D"):
        Problem.build(model)


#: the smallest 3-D tightening model measured: M8, threads engaged over two pitches, no window, one element across
#: a flank (flank_size = P); 49,364 nodes, 1,022 pairs; build 67 s and condensation 54 s CPU, the module's slow
#: tests 164 s CPU together (a shorter bolt, length 32, meshed to more nodes: 54,267)
SMALL = dict(size="M8", model="3d", load="tightening", engaged_length=2.5, thread_length=13.05, n_axial=2,
             flank_size=1.25, contact_size=2.5, mesh_size=4.0, root_size=0.25, root_refinement="engaged",
             cutout=False, angles=(0.05, 0.1), n_increments=1)


@pytest.fixture(scope="module")
def tightening():
    from frictionid.builders.bolt import bolt_model
    return Problem.build(bolt_model(**SMALL), factorisation="mumps")


@pytest.mark.slow
@pytest.mark.parametrize("mu", [0.1, 0.2])
def test_3d_torque_tension_relation_is_vdi_2230s(tightening, mu):
    """Uniform mu: the nut's flats turned 0.05 and 0.1 deg (its slide on the flanks, at most 7 um, stays under the
    local element length, the solver's small-sliding check; the relation does not depend on the angle: every
    response is proportional to it) against the held head; the helix of the mesh makes the preload.
    Torque and clamp force grow in proportion; the wrench torque is the moment of the thread's and the bearing's
    contact forces, all but a few thread pairs and every nut bearing pair slip; and it is VDI 2230's
    F (r_G tan(phi + rho') + mu r_K) at the model's effective radii (sum lam_N r / sum lam_N of thread and nut
    bearing, at the pairs' acting positions) within 2 %: measured -0.003 % (mu 0.1) and -0.02 % (mu 0.2), r_G
    3.678, r_K 5.822 mm. Without the lead on the thread's pairs (their normals the facets') the turned nut loads the
    10 % of the pairs whose normals are steepest and the torque was 14 % (mu 0.1) above VDI's (straight-sided
    tets)."""
    from frictionid.builders.bolt import bolt_layout
    from frictionid.fem.contact import SLIP
    from frictionid.report.bolt import torque_split, vdi_torque
    problem = tightening
    solution = problem.solve({zone: mu for zone in problem.model.zone_names})
    first, last = (dict(zip(solution.reaction_labels, solution.reactions[i])) for i in (0, -1))
    torque, force = last["nut_outer.torque"], last["plate1_rim.y"]
    assert force > 10.0 and torque > 0                     # 0.1 deg: about 48 N, 58 N mm (mu 0.1)
    assert torque / force == pytest.approx(first["nut_outer.torque"] / first["plate1_rim.y"], rel=1e-6)
    split = torque_split(solution)
    assert split.thread - split.bearing == pytest.approx(torque, rel=1e-8)
    assert split.axial == pytest.approx(force, rel=1e-8)
    state, interface = solution.state[-1], solution.pairs.interface
    assert np.all(state[interface == 2] == SLIP) and np.mean(state[interface == 0] == SLIP) > 0.95
    pitch = bolt_layout("M8").size.P
    expected = vdi_torque(force, pitch, split.r_thread, split.r_bearing, mu, mu)
    assert torque == pytest.approx(expected, rel=0.02)


@pytest.mark.slow
def test_3d_tightening_turns_the_nut_flats_and_holds_the_head_flats(tightening):
    """"nut_outer" and "head_side" are the six flats of nut and head; at the end the nut's flats have turned rigidly
    by 0.1 deg (u_x = -z a, u_z = x a), the head's have not moved in x and z, and the nut has moved towards the head
    (u_y < 0: it presses plate 1, held at its rim)."""
    from frictionid.builders.bolt import bolt_layout
    from frictionid.builders.bolt3d_geometry import direction
    model, s = tightening.model, bolt_layout("M8").size
    normals = direction(np.pi / 2 + np.radians(60.0 * np.arange(6)))
    for name, width in (("nut_outer", s.nut_s), ("head_side", s.head_s)):
        points = model.mesh.points[model.mesh.boundary_nodes(name)]
        on = np.abs(points @ normals.T - width / 2) < 1e-9
        assert np.all(on.any(axis=1)) and np.all(on.any(axis=0))          # every node on a flat, every flat there
    solution = tightening.solve(np.full(model.n_zones, 0.15))
    u = tightening.displacement(solution)
    nut, head = (model.mesh.boundary_nodes(name) for name in ("nut_outer", "head_side"))
    a, x = np.radians(0.1), model.mesh.points[nut]
    np.testing.assert_allclose(u[nut][:, [0, 2]], a * np.column_stack([-x[:, 2], x[:, 0]]), atol=1e-12)
    np.testing.assert_allclose(u[head][:, [0, 2]], 0.0, atol=1e-15)
    assert np.all(u[nut, 1] < 0)
