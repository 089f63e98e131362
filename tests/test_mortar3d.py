"""3-D dual mortar (fem/mortar3d.py) on separately meshed bodies (tests/stacks3d.py): exact coupling of linear
fields, the matching limit, the contact patch test, Coulomb's gross slip and sensitivities against central
differences, for linear and quadratic hexahedra and tetrahedra."""

import numpy as np
import pytest

from frictionid.builders.registry import build_model
from frictionid.errors import InputError
from frictionid.fem.contact import SLIP, STICK
from frictionid.fem.interface import contact_pairs
from frictionid.fem.mortar3d import mortar_pairs_3d
from frictionid.fem.node_to_node import node_to_node_pairs
from frictionid.fem.problem import Problem
from frictionid.fem.space import Space
from frictionid.model import ContactInterface, Displacement, Material, Mesh, Model, Pressure, Stage, Support

from element_models import BLOCK_3D, ZONES_3D
from hertz3d import THICKNESS, hertz_model, hertz_reference, sphere_model, sphere_reference
from stacks3d import stack, write_nonmatching_block
from test_calculix_deck import deck_of
from helpers import check_sensitivities
from test_verification import ellipse_fit
from frictionid.options import ModelSpec

STEEL, ALUMINIUM = Material(210000.0, 0.3), Material(70000.0, 0.33)
MU = np.array([0.2, 0.35])

#: (cell type, upper pattern, lower pattern, hexes, order): sides of different sizes, and one side unstructured
NON_MATCHING = {
    "hexahedron-sizes": ("grid 4", "grid 3", True, 1),
    "hexahedron-free": ("grid 4", "free 0.45", True, 1),
    "hexahedron27-sizes": ("grid 2", "grid 3", True, 2),
    "hexahedron27-free": ("grid 2", "free 0.7", True, 2),
    "tetra-free": ("free 0.45", "free 0.6", False, 1),
    "tetra10-free": ("free 0.6", "free 0.4", False, 2),
}
_meshes = {}


def _mesh(case):
    if case not in _meshes:
        _meshes[case] = stack(*NON_MATCHING[case])
    return _meshes[case]


def _interface(discretisation="mortar"):
    return (ContactInterface("stack", ("A", "B"), "target", discretisation),)


def _linear_field(points):
    gradient = np.array([[0.3, -1.1, 0.2], [0.7, 0.45, -0.3], [0.1, 0.2, 0.5]])
    return (np.array([0.2, -0.5, 0.1]) + points @ gradient.T).ravel()


@pytest.mark.parametrize("case", list(NON_MATCHING))
def test_linear_fields_are_coupled_exactly(case):
    """A linear displacement field of both bodies gives no relative displacement (rows of B annihilate it, to
    round-off); the weights tile the 2 x 2 mm interface, each positive; flat coincident faces have no gap."""
    mesh = _mesh(case)
    model = Model(mesh, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface())
    pairs = mortar_pairs_3d(Space.build(mesh, "3d"), model, 0)
    assert np.array_equal(pairs.nodes, np.unique(np.vstack([mesh.boundary("A"), mesh.boundary("B")])))
    assert pairs.B.getnnz(axis=1).max() > 3 * 3                            # coupled to several target nodes
    # round-off: up to 3.4e-12 with a quadratic facet pair's 16 pieces
    np.testing.assert_allclose(pairs.B @ _linear_field(mesh.points), 0.0, atol=1e-11)
    assert np.all(pairs.weight > 0) and pairs.weight.sum() == pytest.approx(4.0, rel=1e-12)
    np.testing.assert_allclose(pairs.zone_share.sum(axis=1), 1.0, rtol=1e-12)
    area = {z: np.sum(pairs.zone_share[:, i] * pairs.weight) for i, z in enumerate("AB")}
    assert area["A"] + area["B"] == pytest.approx(4.0, rel=1e-12) and min(area.values()) > 1.5
    np.testing.assert_allclose(pairs.gap, 0.0, atol=1e-12)
    np.testing.assert_allclose(pairs.frames[:, 0], [[0.0, 0.0, 1.0]] * pairs.n_pairs, atol=1e-12)


@pytest.mark.parametrize("pattern, hexes, order", [("grid 3", True, 1), ("grid 2", True, 2)])
def test_matching_meshes_give_node_to_node_coupling(pattern, hexes, order):
    """Where the two sides' facets coincide the dual mortar coupling is node-to-node (D diagonal, M = D)."""
    mesh = stack(pattern, pattern, hexes, order)
    model = Model(mesh, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface())
    space = Space.build(mesh, "3d")
    mortar, matching = mortar_pairs_3d(space, model, 0), node_to_node_pairs(space, model, 0)
    assert np.array_equal(mortar.nodes, matching.nodes)
    assert abs(mortar.B - matching.B).max() < 1e-12
    np.testing.assert_allclose(mortar.weight, matching.weight, rtol=1e-12)
    np.testing.assert_allclose(mortar.zone_share, matching.zone_share, atol=1e-12)


@pytest.mark.parametrize("hexes, order", [(True, 1), (False, 2)])
def test_auto_picks_node_to_node_where_meshes_match_and_mortar_where_not(hexes, order):
    matching = stack("grid 2", "grid 2", hexes, order)
    different = stack("grid 2", "grid 3", hexes, order)
    for mesh, expected in ((matching, node_to_node_pairs), (different, mortar_pairs_3d)):
        model = Model(mesh, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface("auto"))
        space = Space.build(mesh, "3d")
        pairs = contact_pairs(space, model)
        assert abs(pairs.B - expected(space, model, 0).B).max() == 0.0
    model = Model(different, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface("node-to-node"))
    with pytest.raises(InputError, match="do not match"):
        contact_pairs(Space.build(different, "3d"), model)


@pytest.mark.parametrize("coefficients", [("X", "Y"), ("Y", "X"), ("X", "X")])
def test_zones_take_their_coefficients_by_name(coefficients):
    """Zones whose coefficient is not named after them (``[friction] merge`` across interfaces, a user's own
    names): the coupling is the zones' own, and each pair's zone share goes to its zone's coefficient, summed
    where two zones share one (as in 2-D and node to node)."""
    mesh = _mesh("tetra10-free")
    space = Space.build(mesh, "3d")
    own = mortar_pairs_3d(space, Model(mesh, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface()), 0)
    interface = ContactInterface("stack", ("A", "B"), "target", "mortar", coefficients=coefficients)
    model = Model(mesh, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=(interface,))
    pairs = mortar_pairs_3d(space, model, 0)
    assert abs(pairs.B - own.B).max() == 0.0 and np.array_equal(pairs.weight, own.weight)
    expected = np.zeros((own.n_pairs, model.n_zones))
    for k, name in enumerate(coefficients):
        expected[:, model.zone_names.index(name)] += own.zone_share[:, k]
    assert 0 < own.zone_share[:, 0].sum() < own.n_pairs          # both zones have pairs
    np.testing.assert_allclose(pairs.zone_share, expected, atol=1e-15)


def test_an_interface_whose_sides_do_not_face_is_refused():
    """Bad input: the upper body moved 3 mm sideways (its zones face nothing) and the target swapped for a
    boundary of the same body facing away: each refused by name."""
    mesh = _mesh("tetra-free")
    points = np.array(mesh.points)
    points[np.unique(mesh.cells[mesh.regions["upper"]]), 0] += 3.0
    moved = Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), dict(mesh.boundaries))
    away = ContactInterface("stack", ("A", "B"), "lower_bottom", "mortar")
    for case, interfaces in ((moved, _interface()), (mesh, (away,))):
        model = Model(case, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=interfaces)
        with pytest.raises(InputError, match="interface 'stack': no contact facet of zones \\['A', 'B'\\] faces"):
            mortar_pairs_3d(Space.build(case, "3d"), model, 0)


def _pressed(mesh) -> Model:
    """10 MPa on the upper top, bodies of different stiffness, held by symmetry planes (x = 0, y = 0) and the
    lower bottom in z: uniaxial stress in both, exact in the element space; frictionless slip where their
    lateral expansions differ."""
    return Model(mesh, "3d", {"lower": STEEL, "upper": ALUMINIUM},
                 supports=(Support("lower_bottom", (2,)), Support("lower_x0", (0,)), Support("upper_x0", (0,)),
                           Support("lower_y0", (1,)), Support("upper_y0", (1,))),
                 loads=(Pressure("upper_top", (10.0,)),), stages=(Stage("press", 1),), interfaces=_interface("auto"))


@pytest.mark.parametrize("case", list(NON_MATCHING))
def test_contact_patch_test_gives_the_uniform_pressure(case):
    """Contact patch test (Taylor & Papadopoulos 1991) on non-matching meshes: 10 MPa at every contact node to
    1e-8. Measured: 1e-12 relative where the cells' maps are affine (tetrahedra, the rectangular grids); on the
    unstructured quadrilaterals the integrand is not polynomial (their maps are bilinear), 2e-11 (linear) and
    6e-9 (quadratic)."""
    problem = Problem.build(_pressed(_mesh(case)))
    solution = problem.solve([0.0, 0.0])
    assert problem.pairs.B.getnnz(axis=1).max() > 6 * 3                  # "auto" took mortar
    np.testing.assert_allclose(solution.pressure[-1], 10.0, rtol=1e-8)
    assert solution.zone_normal_force[-1].sum() == pytest.approx(40.0, rel=1e-10)
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert reactions["lower_bottom.z"] == pytest.approx(40.0, rel=1e-10)


def _pulled(mesh) -> Model:
    """Press 10 MPa, then the upper top driven in x (its y held) to 2e-5 mm (stick), 2e-4 mm (partial slip) and
    0.05 mm (gross slip); lower bottom held."""
    return Model(mesh, "3d", {"lower": STEEL, "upper": ALUMINIUM},
                 supports=(Support("lower_bottom", (0, 1, 2)),),
                 loads=(Pressure("upper_top", (10.0,) * 4),
                        Displacement("upper_top", "x", (0.0, 2e-5, 2e-4, 0.05)),
                        Displacement("upper_top", "y", (0.0,) * 4)),
                 stages=(Stage("press", 1), Stage("stick", 1), Stage("partial", 2), Stage("gross", 2)),
                 interfaces=_interface())


@pytest.mark.parametrize("case", ["hexahedron-free", "tetra10-free"])
def test_gross_slip_and_sensitivities(case):
    """Coulomb at gross slip: sum |lam_T| = sum mu_i N_i to 1e-8, every closed pair on its cone, the pull's
    reaction within 0.5 % (the slip directions' small y part); d reactions / d mu against central differences
    (rtol 1e-6, h = 1e-6) at every increment: all stuck, partial slip, gross slip."""
    problem = Problem.build(_pulled(_mesh(case)))
    solution = check_sensitivities(problem, MU)
    states = [np.bincount(solution.state[solution.stage_end(k)], minlength=3) for k in (1, 2)]
    assert states[0][STICK] > 0 and states[0][SLIP] == 0
    assert states[1][STICK] > 0 and states[1][SLIP] > 0
    closed = solution.state[-1] != 0
    assert np.all(solution.state[-1][closed] == SLIP) and closed.sum() > 0.5 * problem.pairs.n_pairs
    normal = solution.zone_normal_force[-1]
    assert normal.sum() == pytest.approx(40.0, rel=1e-10)
    assert np.linalg.norm(solution.lam[-1, :, 1:], axis=1).sum() == pytest.approx(MU @ normal, rel=1e-8)
    np.testing.assert_allclose(np.linalg.norm(solution.lam[-1, closed, 1:], axis=1),
                               problem.pairs.mu(MU)[closed] * solution.lam[-1, closed, 0], rtol=1e-8)
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert abs(reactions["upper_top.x"]) == pytest.approx(MU @ normal, rel=5e-3)


def test_a_users_separately_meshed_block_builds_and_slips_by_coulomb(tmp_path):
    """builder = "mesh" with a user's .msh whose block and plate are meshed separately (reference test 1, 4 and
    3 divisions per half side of the footprint): accepted, "auto" takes mortar, and at the end of the 0.2 mm pull
    (gross slip) the pull's reaction is sum mu_i N_i (to 0.5 %: the slip directions' small x part) with the press's
    2000 N carried by the zones (to 1e-8). CalculiX on the same mesh: tests/test_mortar3d_calculix.py."""
    write_nonmatching_block(tmp_path / "block.msh")
    model = build_model(ModelSpec.from_table({"builder": "mesh", "file": str(tmp_path / "block.msh"), **BLOCK_3D}))
    problem = Problem.build(model)
    assert problem.pairs.n_pairs == 9 ** 2 and problem.pairs.B.getnnz(axis=1).max() > 6 * 3
    mu = np.array([ZONES_3D[z] for z in model.zone_names])
    solution = problem.solve(mu)
    normal = solution.zone_normal_force[-1]
    assert normal.sum() == pytest.approx(2000.0, rel=1e-8)
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert abs(reactions["block_top.y"]) == pytest.approx(mu @ normal, rel=5e-3)
    assert np.linalg.norm(solution.lam[-1, :, 1:], axis=1).sum() == pytest.approx(mu @ normal, rel=1e-8)
    # the CalculiX deck of the same model (`frictionid crosscheck`, backend "calculix"): one surface-to-surface
    # pair per zone, block zone on plate top
    deck, _ = deck_of(model, mu)
    pairs = [line for line in deck.splitlines() if line.startswith("*CONTACT PAIR")]
    assert pairs == [f"*CONTACT PAIR, INTERACTION=I{k + 1}, TYPE=SURFACE TO SURFACE" for k in range(4)]


def _hertz_line(h):
    """(a, p0) fitted and Hertz's (a, p0) of the cylinder on the flat (tests/hertz3d.py), and the problem."""
    problem = Problem.build(hertz_model(h))
    solution = problem.solve([0.0])
    force = 2 * abs(dict(zip(solution.reaction_labels, solution.reactions[-1]))["top.y"]) / THICKNESS
    return ellipse_fit(problem.pairs.position[:, 0], solution.pressure[-1]), hertz_reference(force), problem


def _hertz_point(h):
    """The same for the sphere on the flat (a quarter model: 4 times the reaction)."""
    problem = Problem.build(sphere_model(h))
    solution = problem.solve([0.0])
    force = 4 * abs(dict(zip(solution.reaction_labels, solution.reactions[-1]))["top.z"])
    radius = np.linalg.norm(problem.pairs.position[:, :2], axis=1)
    return ellipse_fit(radius, solution.pressure[-1]), sphere_reference(force), problem


@pytest.mark.slow
@pytest.mark.parametrize("case, sizes", [(_hertz_line, (0.2, 0.1)), (_hertz_point, (0.2, 0.1))],
                         ids=["cylinder", "sphere"])
def test_hertz_contact_on_separately_meshed_bodies(case, sizes):
    """Hertz contact (tests/hertz3d.py; quadratic elements, the two bodies' meshes different): a cylinder on a
    flat in a 3-D slab (hexahedra, meshes different in-plane and through the thickness) and a sphere on a flat
    (tetrahedra): contact half-width / radius and peak pressure within 2 % of Hertz's at the finer mesh.
    Measured (docs/solver.md, at h = 0.2 / 0.1 mm): cylinder a -0.09 / -0.64 %, p0 +1.05 / +1.05 %; sphere
    a +0.64 / -0.51 %, p0 -0.99 / -0.02 %."""
    for h in sizes:
        (a, p0), (a_hertz, p0_hertz), problem = case(h)
        assert problem.pairs.B.getnnz(axis=1).max() > 9 * 3                # mortar coupling
        assert a_hertz > 2 * h                                             # the contact spans elements
    assert a == pytest.approx(a_hertz, rel=0.02)
    assert p0 == pytest.approx(p0_hertz, rel=0.02)



def test_clipping_a_vertex_inside_only_by_the_tolerance_keeps_the_crossing_on_its_edge():
    """A subject vertex within the tolerance outside a window edge counts as inside; when the next vertex lies
    farther outside, the crossing is that vertex, not a point extrapolated off the segment (a block's facet slid
    over the plate facet under it, edges nearly coincident, once got 2.11 mm^2 of a 1.57 mm^2 facet)."""
    from frictionid.fem.clipping import clip, signed_areas
    tol = 1e-10
    window = np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])
    subject = np.array([[[0.2, -0.5 * tol], [0.8, -2.0 * tol], [0.8, 0.9], [0.2, 0.9]]])
    piece, count = clip(subject, window, tol=tol)
    piece = piece[0, :count[0]]
    assert np.all((piece[:, 0] >= 0.2 - 1e-12) & (piece[:, 0] <= 0.8 + 1e-12))
    np.testing.assert_allclose(signed_areas(piece[None])[0], 0.6 * 0.9, atol=1e-9)


def test_batched_clipping_equals_clipping_one_polygon_at_a_time():
    """2000 random convex triangles and quadrilaterals (a third of them sharing the window's vertices, so edges
    coincide) clipped at once: the same vertices, in the same order, as the scalar Sutherland-Hodgman."""
    from mortar3d_facets import clip as clip_one
    from frictionid.fem.clipping import clip, counter_clockwise
    rng = np.random.default_rng(3)

    def polygon(n, centre):
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        return centre + np.column_stack([np.cos(angles), np.sin(angles)])

    subjects, windows = [], []
    for _ in range(2000):
        n, k = rng.choice([3, 4], size=2)
        window = polygon(k, np.zeros(2))
        subject = window[:n] if (n <= k and rng.random() < 0.33) else polygon(n, 0.7 * rng.normal(size=2))
        subjects.append(counter_clockwise(subject[None])[0])
        windows.append(window)
    n_empty = 0
    for n, k in ((3, 3), (3, 4), (4, 3), (4, 4)):
        chosen = [i for i in range(len(subjects)) if (len(subjects[i]), len(windows[i])) == (n, k)]
        pieces, counts = clip(np.array([subjects[i] for i in chosen]), np.array([windows[i] for i in chosen]),
                              tol=1e-10)
        for i, piece, count in zip(chosen, pieces, counts):
            expected = clip_one(subjects[i], windows[i], tol=1e-10)
            n_empty += len(expected) == 0
            assert count == len(expected)
            np.testing.assert_allclose(piece[:count], expected, rtol=0, atol=1e-15)
    assert 0 < n_empty < 1000


def _bent(mesh, amplitude):
    """The mesh moved by a smooth non-affine field (a bent, sheared, wavy interface) of the given amplitude [mm]."""
    x, y, z = mesh.points.T
    shift = amplitude * np.column_stack([np.sin(3 * y + 1) + 0.5 * z, np.cos(2 * x) * (1 + z),
                                         np.sin(2 * x + y) + 0.3 * x * y])
    return Mesh(mesh.points + shift, mesh.cell_type, mesh.cells, dict(mesh.regions), dict(mesh.boundaries))


def _slid(mesh, offset):
    """The upper body moved by offset (3,) [mm] and turned by 10 degrees about z: its contact side overhangs the
    target's edges, partly uncovered."""
    points = np.array(mesh.points)
    upper = np.unique(mesh.cells[mesh.regions["upper"]])
    c, s = np.cos(np.radians(10)), np.sin(np.radians(10))
    centre = np.array([1.0, 1.0, 0.0])
    points[upper] = (points[upper] - centre) @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) + centre + offset
    return Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), dict(mesh.boundaries))


def _tilted(mesh, slope):
    """The upper body turned about the x axis (y = z = 0): its bottom rises as slope * y [mm]."""
    points = np.array(mesh.points)
    upper = np.unique(mesh.cells[mesh.regions["upper"]])
    points[upper, 2] += slope * points[upper, 1]
    return Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), dict(mesh.boundaries))


@pytest.mark.parametrize("change", ["none", "bent", "slid", "tilted"])
@pytest.mark.parametrize("case", list(NON_MATCHING))
def test_vectorised_coupling_equals_the_facet_by_facet_integration(case, change):
    """All candidate facet pairs integrated at once give the facet-by-facet loop's (tests/mortar3d_facets.py)
    mortar matrix, gap integrals and zone weights to 1e-13 of their largest: every facet type, non-matching,
    bent (curved, non-parallel facets with gaps of both signs), slid and turned (partly covered nodes), and tilted
    (the gap growing to 0.02 mm across the interface) with a search distance of 0.01 mm, which drops the facet
    pairs with gaps beyond it."""
    from mortar3d_facets import integrate
    from frictionid.fem import mortar3d

    mesh = {"none": _mesh(case), "bent": _bent(_mesh(case), 0.01), "tilted": _tilted(_mesh(case), 0.01),
            "slid": _slid(_mesh(case), np.array([0.37, -0.21, 0.003]))}[change]
    model = Model(mesh, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface())
    slave, master, columns = mortar3d._sides(model, 0)
    search = float(2 * max(slave.radius.max(), master.radius.max()))
    if change == "tilted":
        search = 0.01
    got, expected = (f(slave, master, mesh.n_nodes, search, len(columns)) for f in (mortar3d._integrate, integrate))
    coupled = np.count_nonzero(expected[0].getnnz(axis=1)) / len(np.unique(slave.facets))
    assert 0.2 < coupled < 0.8 if change == "tilted" else coupled > 0.8
    scale = np.abs(expected[0]).max()
    np.testing.assert_allclose(got[0].toarray(), expected[0].toarray(), rtol=0, atol=1e-13 * scale)
    # gap integrals [mm^3]: round-off on the scale of a facet's area times its size
    np.testing.assert_allclose(got[1], expected[1], rtol=0, atol=1e-13 * slave.radius.max() * scale)
    np.testing.assert_array_equal(got[2], expected[2])


def test_a_mortar_gap_beyond_the_default_tolerance_is_refused_as_in_2d():
    """The set-up check of docs/models.md in 3-D mortar too: the upper body tilted by 0.2 (gaps to 0.38 mm, within
    the default search distance of twice the largest facet radius) is refused against the default tolerance, half
    the median facet size (0.25 mm), naming the interface, the count and the largest gap; stated as the geometry's
    (gap_tolerance 0.5) it is coupled."""
    from dataclasses import replace
    from frictionid.fem.sliding import mortar_builder

    mesh = _tilted(_mesh("tetra10-free"), 0.2)
    model = Model(mesh, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface())
    space = Space.build(mesh, "3d")
    with pytest.raises(InputError, match=r"'stack': 34 of 92 contact pairs \(mortar\) have an initial gap beyond "
                                         r"gap_tolerance = 0.25 mm, the largest 0.38"):
        mortar_pairs_3d(space, model, 0)
    stated = replace(model, interfaces=(replace(model.interfaces[0], gap_tolerance=0.5),))
    pairs = mortar_pairs_3d(space, stated, 0)
    assert pairs.n_pairs == 92 and 0.38 < pairs.gap.max() <= 0.5
    # finite sliding re-couples at deformed positions, where the gaps are the solution's: no set-up check there
    flat = Model(_mesh("tetra10-free"), "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface())
    deformed = mortar_builder(space, flat)(mesh.points)
    np.testing.assert_array_equal(deformed.gap, mortar_pairs_3d(space, model, 0, gap_check=False).gap)


def test_gap_tolerance_bounds_the_coupling_and_adjust_zeroes_the_gaps():
    """An interface's ``gap_tolerance`` is the mortar's search distance in 3-D: on the tilted stack (gaps growing
    to 0.02 mm) 0.01 mm couples the part within it only, as mortar_pairs_3d with that search distance does (a
    separately meshed thread has the next turn's flank behind the nut's tooth). ``adjust`` sets the pairs' initial
    gaps to zero and changes nothing else; the CalculiX deck writes it as *CLEARANCE = 0, finite sliding refuses it."""
    from dataclasses import replace
    from frictionid.fem.interface import interface_pairs
    from frictionid.fem.sliding import coupling_builder

    mesh = _tilted(_mesh("tetra10-free"), 0.01)
    model = Model(mesh, "3d", {"lower": STEEL, "upper": STEEL}, interfaces=_interface())
    space = Space.build(mesh, "3d")
    everywhere = interface_pairs(space, model, 0)[0]
    bounded = replace(model, interfaces=(replace(model.interfaces[0], gap_tolerance=0.01),))
    within = interface_pairs(space, bounded, 0)[0]
    expected = mortar_pairs_3d(space, model, 0, search_distance=0.01)
    np.testing.assert_array_equal(within.nodes, expected.nodes)
    np.testing.assert_allclose(within.gap, expected.gap, rtol=0, atol=1e-15)
    assert within.n_pairs < 0.8 * everywhere.n_pairs and np.abs(within.gap).max() <= 0.01
    assert np.abs(everywhere.gap).max() > 0.015
    adjusted = replace(model, interfaces=(replace(model.interfaces[0], adjust=True),))
    zero = interface_pairs(space, adjusted, 0)[0]
    assert np.all(zero.gap == 0) and np.abs(everywhere.gap).max() > 0
    np.testing.assert_array_equal(zero.nodes, everywhere.nodes)
    assert (zero.B != everywhere.B).nnz == 0
    np.testing.assert_array_equal(zero.weight, everywhere.weight)
    assert "*CLEARANCE" in deck_of(adjusted, MU)[0] and "*CLEARANCE" not in deck_of(model, MU)[0]
    with pytest.raises(InputError, match="sliding = 'finite'.*adjust"):
        coupling_builder(space, adjusted)
    with pytest.raises(InputError, match="adjust must be true or false"):
        ContactInterface("stack", ("A", "B"), "target", adjust="yes")


def test_outward_normal_of_a_curved_facet_on_a_flat_cell():
    """A tetra10 13 um high whose bottom facet's mid-side nodes are raised 4 um into it (the facet's centre
    5.3 um up, the cell's corner mean 3.25 um): the facet's outward normal is -z, as the straight cell's volume
    says (a thread flank's slivers had their mortar normals turned inwards by the corner mean)."""
    from frictionid.fem import mortar3d

    h, bulge = 0.013, 0.004
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, h]])
    mids = [(corners[a] + corners[b]) / 2 for a, b in ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))]
    points = np.vstack([corners, mids])
    points[[4, 5, 6], 2] += bulge
    mesh = Mesh(points, "tetra10", np.arange(10)[None], {"cell": np.array([0])}, {})
    facet = np.array([[0, 1, 2, 4, 5, 6]])
    _, _, normal = mortar3d.geometry_many(mesh.points[facet], "triangle6", (1 / 3, 1 / 3))
    assert normal[0, 2] > 0          # the facet's parameter normal points into the cell
    assert mortar3d._outward_sign(mesh, facet)[0] == -1.0
