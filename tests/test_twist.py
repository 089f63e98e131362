"""Axisymmetry with twist ("axisymmetric_twist"): torsion against St-Venant, the axisymmetric kind without twist,
circumferential friction of a ring turned on a ring, sensitivities against central differences."""

import dataclasses

import numpy as np
import pytest
from helpers import check_sensitivities

from frictionid.builders import verification as bm
from frictionid.builders.torsion import effective_radius, shaft_model, turned_rings_model
from frictionid.errors import InputError
from frictionid.fem.assembly import stiffness
from frictionid.fem.contact import OPEN, SLIP, STICK
from frictionid.fem.problem import Problem
from frictionid.fem.space import Space
from frictionid.model import Model, Rotation, Support

E, NU = 200000.0, 0.3
G = E / (2 * (1 + NU))


def _polar_moment(radius, bore):
    return np.pi / 2 * (radius ** 4 - bore ** 4)


def _shear_stress(problem, u):
    """(tau_yt, r) at the quadrature points: tau_yt = 2 G e_yt = G du_t/dy."""
    space = problem.space
    field = space.basis.interpolate(u.ravel()[space.dof_of])
    return G * field.grad[2][1], space.basis.global_coordinates()[0]


@pytest.mark.parametrize("bore", [0.0, 3.0], ids=["solid", "hollow"])
def test_turned_shaft_is_exact_st_venant_torsion_on_quadratic_triangles(bore):
    """u_t = r phi y / L (St-Venant) lies in the P2 space: torque G J phi / L, tau = T r / J to round-off."""
    radius, length, twist = 5.0, 20.0, 1e-3
    problem = Problem.build(shaft_model(radius, length, bore=bore, twist=twist, size=1.0, order=2))
    solution = problem.solve([])
    torque = solution.reactions[-1][solution.reaction_labels.index("shaft_top.torque")]
    J = _polar_moment(radius, bore)
    assert torque == pytest.approx(G * J * twist / length, rel=1e-10)
    assert solution.reactions[-1][solution.reaction_labels.index("shaft_bottom.torque")] == pytest.approx(-torque,
                                                                                                         rel=1e-10)
    u, points = problem.displacement(solution), problem.model.mesh.points
    np.testing.assert_allclose(u[:, 2], points[:, 0] * twist * points[:, 1] / length, rtol=0, atol=1e-13)
    assert np.abs(u[:, :2]).max() < 1e-15                       # isotropy: torsion moves nothing in (r, y)
    tau, r = _shear_stress(problem, u)
    np.testing.assert_allclose(tau, torque * r / J, rtol=1e-9)


def test_linear_triangles_converge_to_st_venant_at_rate_two():
    """P1 cannot hold r y: the torque error falls as h^2 (measured 2.67 %, 0.667 %, 0.167 % at h = 1, 0.5, 0.25)."""
    J = _polar_moment(5.0, 0.0)
    errors = []
    for size in (1.0, 0.5):
        solution = Problem.build(shaft_model(size=size, order=1)).solve([])
        errors.append(solution.reactions[-1][solution.reaction_labels.index("shaft_top.torque")]
                      / (G * J * 1e-3 / 20.0) - 1)
    assert np.log2(errors[0] / errors[1]) == pytest.approx(2.0, abs=0.05)
    assert 0 < errors[1] < 0.007


def test_torque_on_a_hollow_shaft_gives_the_st_venant_twist_rate_away_from_its_ends():
    """A uniform circumferential traction totalling F on the top: T = F 2/3 (R^3 - r^3) / (R^2 - r^2); between
    y = 10 and 30 of a 40 mm shaft the twist rate is T / (G J) (measured to 1.4e-10) and tau = T r / J."""
    radius, bore, length, force = 5.0, 3.0, 40.0, 1000.0
    problem = Problem.build(shaft_model(radius, length, bore=bore, twist=None, force=force, size=0.5))
    solution = problem.solve([])
    torque, J = force * effective_radius(bore, radius), _polar_moment(radius, bore)
    assert solution.reactions[-1][solution.reaction_labels.index("shaft_bottom.torque")] == pytest.approx(
        -torque, rel=1e-10)
    u, points = problem.displacement(solution), problem.model.mesh.points
    angle = u[:, 2] / points[:, 0]
    at = [np.isclose(points[:, 1], y) for y in (10.0, 30.0)]
    assert all(np.ptp(angle[a]) < 1e-9 * np.abs(angle).max() for a in at)          # sections stay plane
    rate = (angle[at[1]].mean() - angle[at[0]].mean()) / 20.0
    assert rate == pytest.approx(torque / (G * J), rel=1e-8)
    tau, r = _shear_stress(problem, u)
    y = problem.space.basis.global_coordinates()[1]
    middle = (y > 10.0) & (y < 30.0)
    np.testing.assert_allclose(tau[middle], torque * r[middle] / J, rtol=1e-6)


def test_without_twist_it_is_the_axisymmetric_kind():
    """The (r, y) block of the stiffness is the axisymmetric one to round-off, and a contact load path with the
    circumferential displacement held nowhere but on the shaft gives the same contact forces and reactions."""
    model = bm.sleeve_model(size=1.0, n_push=3)
    twisted = dataclasses.replace(model, kind="axisymmetric_twist", supports=(Support("shaft_bottom", (1, 2)),))
    K2 = stiffness(Space.build(model.mesh, model.kind), model)
    K3 = stiffness(Space.build(model.mesh, twisted.kind), twisted)
    n = model.mesh.n_nodes
    in_plane = (3 * np.arange(n)[:, None] + np.arange(2)).ravel()
    assert abs(K3[in_plane][:, in_plane] - K2).max() <= 1e-13 * abs(K2).max()
    twist = 3 * np.arange(n) + 2
    assert abs(K3[twist][:, in_plane]).max() == 0.0                                 # isotropy: decoupled
    mu = np.array([0.12, 0.3])
    plain, turned = Problem.build(model).solve(mu), Problem.build(twisted).solve(mu)
    assert turned.reaction_labels == ("shaft_bottom.y", "shaft_bottom.torque", "sleeve_top.y")
    np.testing.assert_allclose(turned.lam[:, :, :2], plain.lam, rtol=0, atol=1e-11 * np.abs(plain.lam).max())
    assert np.abs(turned.lam[:, :, 2]).max() == 0.0
    np.testing.assert_allclose(turned.reactions[:, [0, 2]], plain.reactions, rtol=1e-11)
    np.testing.assert_array_equal(turned.state, plain.state)


@pytest.fixture(scope="module")
def turned():
    return {angle: Problem.build(turned_rings_model(angle=angle, size=0.5)) for angle in (8e-5, 2e-3)}


def test_ring_turned_on_a_ring_slips_at_mu_n_r_eff(turned):
    """One material under uniform axial stress: uniform contact pressure, no radial shear, and in gross slip
    T = mu N r_eff per zone (exact for the discrete problem too: r is interpolated exactly; measured 7e-13)."""
    problem = turned[2e-3]
    pressure, (inner, middle, outer) = 50.0, (6.0, 8.0, 10.0)
    for mu in (np.array([0.15, 0.15]), np.array([0.1, 0.2])):
        solution = problem.solve(mu)
        closed = solution.state[-1] != OPEN
        assert closed.all() and np.all(solution.state[-1] == SLIP)
        torque = solution.reactions[-1][solution.reaction_labels.index("upper_top.torque")]
        rings = [(inner, middle), (middle, outer)]
        expected = sum(m * pressure * np.pi * (b ** 2 - a ** 2) * effective_radius(a, b)
                       for m, (a, b) in zip(mu, rings))
        assert torque == pytest.approx(expected, rel=1e-9)
        if mu[0] == mu[1]:
            N = pressure * np.pi * (outer ** 2 - inner ** 2)
            assert torque == pytest.approx(mu[0] * N * effective_radius(inner, outer), rel=1e-9)
        lam = solution.lam[-1]
        np.testing.assert_allclose(np.abs(lam[:, 2]), problem.pairs.mu(mu) * lam[:, 0], rtol=1e-9)
        assert np.abs(lam[:, 1]).max() < 1e-9 * np.abs(lam[:, 2]).max()           # all the friction is around


def test_turned_ring_sensitivities_match_central_differences(turned):
    for angle, solution in ((angle, check_sensitivities(problem, np.array([0.1, 0.2])))
                            for angle, problem in turned.items()):
        states = np.bincount(solution.state[-1], minlength=3)
        assert states[SLIP] > 0 and (angle > 1e-3 or states[STICK] > 0)


def test_rotation_needs_the_twist_kind():
    model = shaft_model(size=2.0)
    with pytest.raises(InputError, match="Rotation on 'shaft_top' needs kind 'axisymmetric_twist'"):
        dataclasses.replace(model, kind="axisymmetric", supports=(Support("shaft_bottom", ("y",)),))
    with pytest.raises(InputError, match="component 't'"):
        Model(model.mesh, "axisymmetric", model.materials, supports=(Support("shaft_bottom", ("y", "t")),))
    twisted = Model(model.mesh, "axisymmetric_twist", model.materials, supports=(Support("shaft_bottom", ("y", "t")),),
                    loads=(Rotation("shaft_top", (0.01,)),))
    assert twisted.reaction_labels == ("shaft_bottom.y", "shaft_bottom.torque", "shaft_top.torque")


@pytest.mark.parametrize("angle", [2e-3, -2e-3], ids=["down", "up"])
def test_a_helical_face_turns_like_a_square_thread_screw(angle):
    """Lead L on the face (a square thread): frictionless, turning by phi screws the upper ring by -L phi / (2 pi)
    along the axis and the torque is -F L / (2 pi) exactly (virtual work; measured 3e-12); with friction the torque
    is the square-thread screw's, int p r (s mu - tan l) / (1 + s mu tan l) dA with tan l = L / (2 pi r) and
    s the turning sense (measured 2e-5, 4e-5: the pressure is uniform up to the friction's small effect)."""
    lead, pressure, inner, outer = 2.0, 50.0, 6.0, 10.0
    problem = Problem.build(turned_rings_model(inner, outer, angle=angle, lead=lead))
    force = pressure * np.pi * (outer ** 2 - inner ** 2)
    top = problem.model.mesh.boundary_nodes("upper_top")
    r = np.linspace(inner, outer, 20001)
    for mu in (0.0, 0.15):
        solution = problem.solve([mu, mu])
        assert np.all(solution.state[-1] == SLIP)
        torque = solution.reactions[-1][solution.reaction_labels.index("upper_top.torque")]
        tan, sense = lead / (2 * np.pi * r), np.sign(angle)
        expected = np.trapezoid(pressure * 2 * np.pi * r ** 2 * (sense * mu - tan) / (1 + sense * mu * tan), r)
        assert torque == pytest.approx(expected, rel=1e-4 if mu else 1e-9)
        if mu == 0:
            assert expected == pytest.approx(-force * lead / (2 * np.pi), rel=1e-12)
            moved = problem.displacement(solution)[top, 1] - problem.displacement(solution, 0)[top, 1]
            np.testing.assert_allclose(moved, -lead * angle / (2 * np.pi), rtol=1e-9)


def test_a_lead_needs_the_twist_kind():
    model = turned_rings_model(size=2.0, lead=2.0)
    with pytest.raises(InputError, match="interface 'face' has a lead"):
        dataclasses.replace(model, kind="axisymmetric", supports=(), loads=())


def test_calculix_refuses_the_twist_kind_by_name():
    from frictionid.backends.calculix.elements import element_type
    with pytest.raises(InputError, match="cannot write a model of kind 'axisymmetric_twist'"):
        element_type("axisymmetric_twist", "triangle6")


def test_points_observe_the_circumferential_displacement_and_the_twist_shears():
    """On the x-y plane u_t is uz, e_yt is eyz and e_rt is exz: exact on P2 for u_t = r^2 (e_rt = r / 2, not
    du_t/dr / 2 = r) and for the St-Venant field u_t = r phi y / L (eyz = r phi / (2 L), exz = 0)."""
    from frictionid.fem.points import point_operator
    model = shaft_model(bore=2.0, size=1.0)
    problem = Problem.build(model, points=[[2.5, 5.0], [4.2, 13.7]], quantities=("uz", "eyz", "exz", "ezz"))
    points = np.array([[2.5, 5.0], [4.2, 13.7], [3.3, 0.4]])
    H = point_operator(problem.space, points, ["ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz"])
    nodes = model.mesh.points
    u = np.zeros((model.mesh.n_nodes, 3))
    u[:, 2] = nodes[:, 0] ** 2
    values = (H @ u.ravel()).reshape(len(points), 9)
    np.testing.assert_allclose(values[:, 2], points[:, 0] ** 2, rtol=1e-12)
    np.testing.assert_allclose(values[:, 8], points[:, 0] / 2, rtol=1e-12)
    np.testing.assert_allclose(values[:, [0, 1, 3, 4, 5, 6, 7]], 0.0, atol=1e-12)
    solution = problem.solve([])
    observed = solution.observations[-1].reshape(2, 4)
    r, y = points[:2, 0], points[:2, 1]
    np.testing.assert_allclose(observed[:, 0], r * 1e-3 * y / 20.0, rtol=1e-10)
    np.testing.assert_allclose(observed[:, 1], r * 1e-3 / 40.0, rtol=1e-10)
    np.testing.assert_allclose(observed[:, 2:], 0.0, atol=1e-14)


def test_a_user_mesh_refuses_the_twist_kind_by_name():
    from pathlib import Path

    from frictionid.builders.mesh import mesh_model
    geo = Path(__file__).parents[1] / "examples" / "hub" / "hub.geo"
    with pytest.raises(InputError, match="kind = 'axisymmetric_twist': not available for a user's mesh yet"):
        mesh_model(geo, kind="axisymmetric_twist")


def test_lifting_keeps_segment_weights_of_mortar_like_pairs():
    """Pairs coupled to two target nodes with weights 0.3 / 0.7 (as mortar's): the lifted in-plane rows are the
    section's rows on three components per node, the circumferential row couples u_t with the same weights."""
    from frictionid.fem.pairs import ContactPairs, relative_operator, tangent_frames
    from frictionid.fem.twist import with_circumferential_tangent
    normals = np.array([[0.6, 0.8], [0.0, 1.0]])
    frames = tangent_frames(normals)
    contact, targets, weights = np.array([0, 1]), np.array([[2, 3], [3, 4]]), np.array([[0.3, 0.7], [0.7, 0.3]])
    B = relative_operator(frames, contact, targets, weights, 2 * 5)
    pairs = ContactPairs(contact, np.array([[1.0, 0.0], [2.0, 0.0]]), frames, np.ones(2), np.ones((2, 1)),
                         np.zeros(2), B, np.zeros(2, int))
    lifted = with_circumferential_tangent(pairs, 5)
    u = np.random.default_rng(3).normal(size=(5, 3))
    w = (lifted.B @ u.ravel()).reshape(2, 3)
    np.testing.assert_allclose(w[:, :2], (B @ u[:, :2].ravel()).reshape(2, 2), rtol=1e-13)
    expected = u[contact, 2] - np.sum(weights * u[targets, 2], axis=1)
    np.testing.assert_allclose(w[:, 2], expected, rtol=1e-13)
    np.testing.assert_allclose(lifted.frames[:, 2], [[0.0, 0.0, 1.0]] * 2, atol=1e-15)


def test_measured_points_of_a_twist_model_must_lie_on_the_x_y_plane():
    from types import SimpleNamespace

    from frictionid.inverse.observations import _coordinates
    model = shaft_model(size=2.0)
    on_plane = SimpleNamespace(coordinates=np.array([[2.0, 5.0, 0.0], [4.0, 9.0, 0.0]]), source="m.csv")
    np.testing.assert_array_equal(_coordinates(on_plane, model)[1], [[2.0, 5.0], [4.0, 9.0]])
    for bad in ([2.0, 5.0, 0.5], [-2.0, 5.0, 0.0]):
        off = SimpleNamespace(coordinates=np.array([[4.0, 9.0, 0.0], bad]), source="m.csv")
        with pytest.raises(InputError, match="m.csv: an axisymmetric model with twist needs points on the x-y plane"):
            _coordinates(off, model)


def test_a_ring_turned_on_a_cone_slips_on_the_coulomb_disc():
    """cone_deg = 30 (a flank without its helix): the face is y = (r - 6) tan 30, held bottom and pressed top flat;
    turned into gross slip each closed pair's friction is mu times its normal force, the clamp force is the pairs'
    axial resultant, and the torque is that of their circumferential friction forces."""
    with pytest.raises(InputError, match="cone_deg"):
        turned_rings_model(cone_deg=75.0)
    model = turned_rings_model(size=1.0, order=1, cone_deg=30.0)
    problem = Problem.build(model)
    face = model.mesh.boundary_nodes("inside")
    points = model.mesh.points
    np.testing.assert_allclose(points[face, 1], (points[face, 0] - 6.0) * np.tan(np.radians(30.0)), atol=1e-12)
    assert np.ptp(points[model.mesh.boundary_nodes("upper_top"), 1]) == 0.0
    mu = np.array([0.1, 0.2])
    solution = problem.solve(mu)
    lam, closed = solution.lam[-1], solution.state[-1] != OPEN
    assert np.all(solution.state[-1][closed] == SLIP) and closed.sum() > 0.8 * len(closed)
    friction = np.linalg.norm(lam[:, 1:], axis=1)
    np.testing.assert_allclose(friction[closed], problem.pairs.mu(mu)[closed] * lam[closed, 0], rtol=1e-8)
    frames = problem.pairs.frames
    axial = np.einsum("pk,pk->", lam, frames[:, :, 1])                 # y components of n, t1, t
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert abs(axial) == pytest.approx(reactions["lower_bottom.y"], rel=1e-8)
    torque = np.sum(lam[:, 2] * problem.pairs.position[:, 0])
    assert abs(torque) == pytest.approx(reactions["upper_top.torque"], rel=1e-8)
