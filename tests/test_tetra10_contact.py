"""Quadratic tetrahedra (tetra10, 6-node triangle contact facets) in node-to-node contact: the transformed
surface basis of fem/node_to_node.py (surface_transform) against a homogeneous solution (uniform pressure, exact
in the element space), Coulomb's gross slip T = sum mu_i N_i, and sensitivities against central differences.

The model: two 2 x 2 x 1 mm bodies stacked at z = 0, each made of two boxes split at x = 1 so that the contact
side carries zones A (x < 1) and B (x > 1); every curve transfinite, so both sides of the interface carry the same
triangles (coincident nodes), the volumes Delaunay-meshed by gmsh and raised to second order."""

import gmsh
import numpy as np
import pytest

from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh
from frictionid.fem.contact import SLIP, STICK
from frictionid.fem.node_to_node import TRI6_ALPHA, surface_transform
from frictionid.fem.problem import Problem
from frictionid.model import ContactInterface, Displacement, Material, Mesh, Model, Pressure, Stage, Support

from helpers import check_sensitivities

STEEL, ALUMINIUM = Material(210000.0, 0.3), Material(70000.0, 0.33)
MU = np.array([0.2, 0.35])


def _stack_mesh(divisions: int = 2):
    """The two bodies' tetra10 mesh with named faces (``divisions`` per mm on every curve)."""
    with gmsh_session("tet10_stack"):
        occ = gmsh.model.occ
        bodies = {}
        for name, z0 in (("lower", -1.0), ("upper", 0.0)):
            boxes = [(3, occ.addBox(x0, 0, z0, 1, 2, 1)) for x0 in (0.0, 1.0)]
            pieces, _ = occ.fragment(boxes[:1], boxes[1:])
            bodies[name] = [tag for dim, tag in pieces if dim == 3]
        occ.synchronize()
        for _, curve in gmsh.model.getEntities(1):
            box = np.reshape(gmsh.model.getBoundingBox(1, curve), (2, 3))
            gmsh.model.mesh.setTransfiniteCurve(curve, int(round(divisions * np.ptp(box, axis=0).max())) + 1)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface)

        def faces(volumes, axis, value, x_side=None):
            found = {abs(t) for _, t in gmsh.model.getBoundary([(3, v) for v in volumes], combined=False,
                                                               oriented=False)}
            out = []
            for face in sorted(found):
                box = np.reshape(gmsh.model.getBoundingBox(2, face), (2, 3))
                if np.allclose(box[:, axis], value, atol=1e-6) and (
                        x_side is None or (np.mean(box[:, 0]) < 1.0) == (x_side == "A")):
                    out.append(face)
            return out

        add = gmsh.model.addPhysicalGroup
        for name, volumes in bodies.items():
            add(3, volumes, name=name)
            add(2, faces(volumes, 0, 0.0), name=f"{name}_x0")
            add(2, faces(volumes, 1, 0.0), name=f"{name}_y0")
        add(2, faces(bodies["lower"], 2, -1.0), name="lower_bottom")
        add(2, faces(bodies["lower"], 2, 0.0), name="lower_top")
        add(2, faces(bodies["upper"], 2, 1.0), name="upper_top")
        add(2, faces(bodies["upper"], 2, 0.0, "A"), name="A")
        add(2, faces(bodies["upper"], 2, 0.0, "B"), name="B")
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh()


@pytest.fixture(scope="module")
def mesh():
    out = _stack_mesh()
    assert out.cell_type == "tetra10" and out.facet_type == "triangle6"
    return out


INTERFACE = (ContactInterface("stack", ("A", "B"), "lower_top", discretisation="node-to-node"),)


@pytest.fixture(scope="module")
def pressed(mesh):
    """10 MPa on the upper top, bodies of different stiffness, held by symmetry planes (x = 0, y = 0) and the
    lower bottom in z: uniaxial stress in both, exact in the element space; frictionless slip where their
    lateral expansions differ."""
    model = Model(mesh, "3d", {"lower": STEEL, "upper": ALUMINIUM},
                  supports=(Support("lower_bottom", (2,)), Support("lower_x0", (0,)), Support("upper_x0", (0,)),
                            Support("lower_y0", (1,)), Support("upper_y0", (1,))),
                  loads=(Pressure("upper_top", (10.0,)),), stages=(Stage("press", 1),), interfaces=INTERFACE)
    problem = Problem.build(model)
    return problem, problem.solve([0.0, 0.0])


def test_transformed_tributary_areas_are_positive_and_sum_to_each_facet(mesh):
    """Per 6-node facet of area A: corners 2 alpha A / 3, mid-side nodes (1 - 2 alpha) A / 3 (alpha = 1/5)."""
    facets = mesh.boundary("A")
    M, P = surface_transform(mesh, facets)
    np.testing.assert_allclose((P @ M.T).toarray(), np.eye(mesh.n_nodes), atol=1e-14)   # P = M^-T
    one = facets[:1]
    corners = mesh.points[one[0, :3]]
    area = 0.5 * np.linalg.norm(np.cross(corners[1] - corners[0], corners[2] - corners[0]))
    consistent = np.zeros(mesh.n_nodes)
    consistent[one[0, 3:]] = area / 3                          # int N_i over one flat 6-node triangle
    transformed = surface_transform(mesh, one)[0] @ consistent
    np.testing.assert_allclose(transformed[one[0, :3]], 2 * TRI6_ALPHA * area / 3, rtol=1e-12)
    np.testing.assert_allclose(transformed[one[0, 3:]], (1 - 2 * TRI6_ALPHA) * area / 3, rtol=1e-12)
    assert transformed.sum() == pytest.approx(area, rel=1e-12)
    assert np.array_equal(np.flatnonzero(transformed), np.sort(one[0]))


def test_uniform_pressure_is_reproduced_at_every_node(pressed):
    """Every contact node, corner or mid-side, carries 10 MPa; pressure x area sums to the applied 40 N; zone
    forces A = B = 20 N; areas 4 mm^2 (2 + 2), all positive. With these areas but the constraints on untransformed
    nodal values, measured: corners 0 MPa, mid-side nodes 16.7 MPa (the consistent A/3 over A/5)."""
    problem, solution = pressed
    pairs = problem.pairs
    corners = ~np.isin(pairs.nodes, problem.model.mesh.boundary("A")[:, 3:]) & \
        ~np.isin(pairs.nodes, problem.model.mesh.boundary("B")[:, 3:])
    assert 0 < corners.sum() < pairs.n_pairs
    assert np.all(pairs.weight > 0) and pairs.weight.sum() == pytest.approx(4.0, rel=1e-12)
    np.testing.assert_allclose((pairs.zone_share * pairs.weight[:, None]).sum(axis=0), [2.0, 2.0], rtol=1e-12)
    np.testing.assert_allclose(solution.pressure[-1], 10.0, rtol=1e-8)
    assert solution.pressure[-1] @ pairs.weight == pytest.approx(40.0, rel=1e-10)
    np.testing.assert_allclose(solution.zone_normal_force[-1], [20.0, 20.0], rtol=1e-8)
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert reactions["lower_bottom.z"] == pytest.approx(40.0, rel=1e-10)
    np.testing.assert_allclose(pairs.frames[:, 0], [[0.0, 0.0, 1.0]] * pairs.n_pairs, atol=1e-12)
    np.testing.assert_allclose(pairs.gap, 0.0, atol=1e-12)


def _pulled(mesh) -> Model:
    """Press 10 MPa, then the upper top driven in x (its y held) to 2e-4 mm (partial slip, measured: 55 of 81
    pairs sticking; all stick at 2e-5 mm, all slip at 1e-3 mm) and on to 0.05 mm (gross slip); lower bottom held."""
    return Model(mesh, "3d", {"lower": STEEL, "upper": ALUMINIUM},
                 supports=(Support("lower_bottom", (0, 1, 2)),),
                 loads=(Pressure("upper_top", (10.0, 10.0, 10.0)),
                        Displacement("upper_top", "x", (0.0, 2e-4, 0.05)),
                        Displacement("upper_top", "y", (0.0, 0.0, 0.0))),
                 stages=(Stage("press", 1), Stage("partial", 2), Stage("gross", 2)), interfaces=INTERFACE)


@pytest.fixture(scope="module")
def pulled(mesh):
    problem = Problem.build(_pulled(mesh))
    return problem, problem.solve(MU, sensitivities=True)


def test_gross_slip_tangential_force_is_sum_mu_n(pulled):
    """Coulomb at gross slip: sum |lam_T| = sum mu_i N_i (the pull's reaction as well, within the slip
    directions' small y part), every closed pair slipping on its cone, the press as applied."""
    problem, solution = pulled
    closed = solution.state[-1] != 0
    assert np.all(solution.state[-1][closed] == SLIP) and closed.sum() > 0.5 * problem.pairs.n_pairs
    normal = solution.zone_normal_force[-1]
    assert normal.sum() == pytest.approx(40.0, rel=1e-10)
    assert np.linalg.norm(solution.lam[-1, :, 1:], axis=1).sum() == pytest.approx(MU @ normal, rel=1e-8)
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert abs(reactions["upper_top.x"]) == pytest.approx(MU @ normal, rel=2e-3)
    np.testing.assert_allclose(np.linalg.norm(solution.lam[-1, closed, 1:], axis=1),
                               problem.pairs.mu(MU)[closed] * solution.lam[-1, closed, 0], rtol=1e-8)


def test_tetra10_sensitivities_match_central_differences(pulled):
    """d reactions / d mu at every increment, partial slip (end of stage 2) and gross slip (stage 3), by the
    3-D and axisymmetric tests' helper (rtol 1e-6, h = 1e-6)."""
    problem, _ = pulled
    solution = check_sensitivities(problem, MU)
    partial = np.bincount(solution.state[solution.stage_end(1)], minlength=3)
    assert partial[SLIP] > 0 and partial[STICK] > 0                       # the regimes the test claims
    assert np.all(solution.state[-1][solution.state[-1] != 0] == SLIP)


def _interference(mesh, upper: Material) -> Problem:
    """The upper body moved down by 1 um into the lower one (the meshes overlap: gaps -1 um at corners and
    mid-side nodes alike), both held at their far faces in z and on the symmetry planes x = 0, y = 0."""
    delta = 1e-3
    nodes = np.unique(mesh.cells[mesh.regions["upper"]])
    points = np.array(mesh.points)
    points[nodes, 2] -= delta
    moved = Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), dict(mesh.boundaries))
    model = Model(moved, "3d", {"lower": STEEL, "upper": upper},
                  supports=(Support("lower_bottom", (2,)), Support("upper_top", (2,)), Support("lower_x0", (0,)),
                            Support("upper_x0", (0,)), Support("lower_y0", (1,)), Support("upper_y0", (1,))),
                  stages=(Stage("fit", 1),), interfaces=INTERFACE)
    problem = Problem.build(model)
    np.testing.assert_allclose(problem.pairs.gap, -delta, rtol=1e-9)
    return problem


def _on_symmetry_planes(problem) -> np.ndarray:
    """(n_pairs, 2) pairs on x = 0, y = 0: the tangential directions t1 = x, t2 = y that both supports hold."""
    np.testing.assert_allclose(problem.pairs.frames[:, 1:, :2], [np.eye(2)] * problem.pairs.n_pairs, atol=1e-12)
    return np.abs(problem.pairs.position[:, :2]) < 1e-12


@pytest.mark.parametrize("upper, mu", [(ALUMINIUM, 0.0), (STEEL, 0.3)], ids=["frictionless", "friction"])
def test_a_uniform_interference_gives_the_uniaxial_pressure(mesh, upper, mu):
    """Uniaxial stress in series, p = delta / (h_upper / E_upper + h_lower / E_lower) at every node (exact in the
    space): 52.5 MPa frictionless with aluminium on steel. With friction, both bodies of steel: they expand alike
    laterally, so friction has nothing to resist and the answer is the frictionless one (105 MPa), every pair
    stuck with no tangential force. The 17 of 81 pairs on the symmetry planes, whose tangential motion the
    supports hold (in x, y or both), take part in the stick system with no friction force in those directions
    (without that the stick system is singular and the solver stops)."""
    problem = _interference(mesh, upper)
    solution = problem.solve([mu, mu])
    expected = 1e-3 / (1.0 / upper.E + 1.0 / STEEL.E)
    np.testing.assert_allclose(solution.pressure[-1], expected, rtol=1e-8)
    assert solution.pressure[-1] @ problem.pairs.weight == pytest.approx(4.0 * expected, rel=1e-10)
    assert np.any(_on_symmetry_planes(problem), axis=1).sum() == 17
    if mu:
        assert np.all(solution.state[-1] == STICK)
        assert np.abs(solution.lam[-1, :, 1:]).max() <= 1e-10 * solution.lam[-1, :, 0].max()
        frictionless = problem.solve([0.0, 0.0])
        np.testing.assert_allclose(solution.pressure[-1], frictionless.pressure[-1], rtol=1e-10)


def test_an_interference_of_unlike_bodies_with_friction_and_its_sensitivities(mesh):
    """Aluminium on steel with friction: the lateral mismatch of their expansions is resisted by friction, the
    pairs stick but for a far corner. No friction force where the supports hold the tangential motion, Coulomb's
    cone elsewhere, the contact force balancing the supports, and d reactions / d mu against central differences
    (the held pairs treated alike in the sensitivities)."""
    problem = _interference(mesh, ALUMINIUM)
    solution = check_sensitivities(problem, MU)
    lam = solution.lam[-1]
    assert np.bincount(solution.state[-1], minlength=3)[STICK] > 0.9 * problem.pairs.n_pairs
    assert np.abs(lam[:, 1:][_on_symmetry_planes(problem)]).max() <= 1e-12 * lam[:, 0].max()
    assert np.all(np.linalg.norm(lam[:, 1:], axis=1) <= problem.pairs.mu(MU) * lam[:, 0] * (1 + 1e-10))
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert reactions["lower_bottom.z"] == pytest.approx(lam[:, 0].sum(), rel=1e-10)
    assert np.abs(solution.d_reactions[-1]).max() > 1e-3 * lam[:, 0].sum()      # friction matters here


def _split(mesh, body: str, interface: str, copy: str):
    """The cells of region ``body`` get their own copies of the nodes of boundary ``interface`` (gmsh meshed the
    bodies together); the boundary's facets with the copies are named ``copy``."""
    nodes = mesh.boundary_nodes(interface)
    to = np.arange(mesh.n_nodes)
    to[nodes] = np.arange(mesh.n_nodes, mesh.n_nodes + len(nodes))
    cells = np.array(mesh.cells)
    cells[mesh.regions[body]] = to[cells[mesh.regions[body]]]
    return Mesh(np.vstack([mesh.points, mesh.points[nodes]]), mesh.cell_type, cells, dict(mesh.regions),
                {**mesh.boundaries, copy: to[mesh.boundary(interface)]})


def _shrink_fit_quarter(a: float, b: float, length: float, delta: float, size: float) -> Model:
    """A quarter of a solid shaft (radius a + delta) in a hub (a to b), both ``length`` long, tetra10 of gmsh's
    ``size``; the shaft scaled radially after meshing, so the curved interface overlaps by delta. Held in z at
    the bottom (z = 0) and on the symmetry planes x = 0, y = 0."""
    with gmsh_session("shrink_fit"):
        occ = gmsh.model.occ
        occ.fragment([(3, occ.addCylinder(0, 0, 0, 0, 0, length, b, angle=np.pi / 2))],
                     [(3, occ.addCylinder(0, 0, 0, 0, 0, length, a, angle=np.pi / 2))])
        occ.synchronize()
        volumes = {("shaft" if np.hypot(*occ.getCenterOfMass(3, v)[:2]) < a else "hub"): v
                   for _, v in gmsh.model.getEntities(3)}
        faces = {name: {abs(f) for _, f in gmsh.model.getBoundary([(3, v)], oriented=False)}
                 for name, v in volumes.items()}

        def flat(face, axis):
            box = np.reshape(gmsh.model.getBoundingBox(2, face), (2, 3))[:, axis]
            return abs(box[0]) < 1e-6 and abs(box[1]) < 1e-6

        for name, v in volumes.items():
            gmsh.model.addPhysicalGroup(3, [v], name=name)
            for axis, side in enumerate(("x0", "y0", "bottom")):
                gmsh.model.addPhysicalGroup(2, [f for f in faces[name] if flat(f, axis)], name=f"{name}_{side}")
        gmsh.model.addPhysicalGroup(2, sorted(faces["shaft"] & faces["hub"]), name="shaft_surface")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        gmsh.model.mesh.setOrder(2)
        mesh = _split(mesh_from_gmsh(), "hub", "shaft_surface", "bore")
    points = np.array(mesh.points)
    shaft = np.unique(mesh.cells[mesh.regions["shaft"]])
    points[shaft, :2] *= (a + delta) / a
    mesh = Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), dict(mesh.boundaries))
    return Model(mesh, "3d", {"shaft": STEEL, "hub": STEEL},
                 supports=tuple(Support(f"{body}_{side}", (axis,)) for body in ("shaft", "hub")
                                for axis, side in enumerate(("x0", "y0", "bottom"))),
                 stages=(Stage("fit", 1),),
                 interfaces=(ContactInterface("fit", ("shaft_surface",), "bore", discretisation="node-to-node"),))


def test_a_shrink_fit_on_a_curved_interface_carries_the_lame_force():
    """Curved 6-node facets: one material, equal lengths, free top: plane-stress Lame is the exact solution,
    p = E delta (b^2 - a^2) / (2 a b^2) = 78.75 MPa on a = 5, b = 10, delta = 5 um (the axisymmetric solver gives
    it to 5e-6). The quarter model's normal force x 4 against p 2 pi a L, measured -0.60 / -0.40 / -0.16 % at
    gmsh sizes 2 / 1 / 0.6 mm (1,705 / 3,474 / 13,584 nodes). Nodal pressures scatter on the unstructured mesh
    (68-79 MPa inside the contact at 1 mm, up to 116 MPa on its edges; linear tetrahedra of as many nodes 58-87
    and 133)."""
    a, b, length, delta = 5.0, 10.0, 4.0, 0.005
    problem = Problem.build(_shrink_fit_quarter(a, b, length, delta, size=2.0))
    solution = problem.solve([0.0])
    lame = STEEL.E * delta * (b ** 2 - a ** 2) / (2 * a * b ** 2)
    assert 4 * solution.zone_normal_force[-1].sum() == pytest.approx(lame * 2 * np.pi * a * length, rel=0.01)
    assert np.all(solution.state[-1] != 0)
    assert 4 * problem.pairs.weight.sum() == pytest.approx(2 * np.pi * (a + delta) * length, rel=1e-3)
