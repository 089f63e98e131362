"""Dual mortar interface discretisation: matching limit, patch test, weights, curved gaps, zone shares."""

import numpy as np
import pytest

from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh
from frictionid.errors import InputError
from frictionid.fem.mortar import dual_coefficients, mortar_pairs, shape_functions
from frictionid.fem.pairs import relative_operator
from frictionid.fem.space import Space
from frictionid.model import ContactInterface, Material, Mesh, Model

STEEL = Material(210000.0, 0.3)


def _line(geo, a, b, n, progression=1.0):
    tag = geo.addLine(a, b)
    geo.mesh.setTransfiniteCurve(tag, n, "Progression", progression)
    return tag


def _block(geo, x0, x1, y0, y1, bottom, top, n_side=3):
    """Rectangle surface; bottom/top: pieces (x_end, n_nodes, progression) from left to right."""
    corners = {"bl": geo.addPoint(x0, y0, 0), "br": geo.addPoint(x1, y0, 0),
               "tr": geo.addPoint(x1, y1, 0), "tl": geo.addPoint(x0, y1, 0)}
    bottom_curves, start = [], corners["bl"]
    for i, (x_end, n, prog) in enumerate(bottom):
        end = corners["br"] if i == len(bottom) - 1 else geo.addPoint(x_end, y0, 0)
        bottom_curves.append(_line(geo, start, end, n, prog))
        start = end
    top_curves, start = [], corners["tl"]
    for i, (x_end, n, prog) in enumerate(top):
        end = corners["tr"] if i == len(top) - 1 else geo.addPoint(x_end, y1, 0)
        top_curves.append(_line(geo, start, end, n, prog))
        start = end
    right = _line(geo, corners["br"], corners["tr"], n_side)
    left = _line(geo, corners["tl"], corners["bl"], n_side)
    loop = geo.addCurveLoop(bottom_curves + [right] + [-c for c in reversed(top_curves)] + [left])
    return geo.addPlaneSurface([loop]), bottom_curves, top_curves


def two_blocks(order, lower_top, upper_bottom, x0=0.0, width=1.0, y0=0.0, height=0.5, quads=False):
    """Lower block (top = 'target') under an upper block (bottom = contact zones 'z0', 'z1', ...); separate nodes.

    lower_top / upper_bottom: pieces (x_end, n_nodes, progression) of the interface curves.
    """
    with gmsh_session() as gmsh:
        geo = gmsh.model.geo
        lower, _, target = _block(geo, x0, x0 + width, y0 - height, y0, [(x0 + width, 4, 1.0)], lower_top)
        upper, zones, _ = _block(geo, x0, x0 + width, y0, y0 + height, upper_bottom, [(x0 + width, 3, 1.0)])
        geo.synchronize()
        gmsh.model.addPhysicalGroup(2, [lower], name="lower")
        gmsh.model.addPhysicalGroup(2, [upper], name="upper")
        gmsh.model.addPhysicalGroup(1, target, name="target")
        for i, curve in enumerate(zones):
            gmsh.model.addPhysicalGroup(1, [curve], name=f"z{i}")
        gmsh.option.setNumber("Mesh.RecombineAll", int(quads))
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", int(quads))    # all quads: edges are split in two
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(order)
        return mesh_from_gmsh(), len(zones)


def _model(mesh, kind, n_zones, regions=("lower", "upper")):
    interface = ContactInterface("interface", tuple(f"z{i}" for i in range(n_zones)), "target", "mortar")
    return Model(mesh, kind, {r: STEEL for r in regions}, interfaces=(interface,))


def _pairs(mesh, kind, n_zones=1):
    model = _model(mesh, kind, n_zones)
    return mortar_pairs(Space.build(mesh, kind), model, 0), model


NON_MATCHING = dict(lower_top=[(1.0, 6, 1.3)], upper_bottom=[(1.0, 9, 1.0)])


@pytest.mark.parametrize("quads", [False, True])
@pytest.mark.parametrize("order", [1, 2])
def test_matching_meshes_give_node_to_node_coupling(order, quads):
    mesh, n_zones = two_blocks(order, lower_top=[(1.0, 6, 1.2)], upper_bottom=[(1.0, 6, 1.2)], quads=quads)
    assert mesh.cell_type == {(1, False): "triangle", (2, False): "triangle6", (1, True): "quad",
                              (2, True): "quad9"}[order, quads]
    pairs, _ = _pairs(mesh, "plane_strain", n_zones)
    points = mesh.points
    target = mesh.boundary_nodes("target")
    match = target[np.argmin(np.linalg.norm(points[pairs.nodes, None] - points[None, target], axis=2), axis=1)]
    np.testing.assert_allclose(points[match], points[pairs.nodes], atol=1e-12)
    expected = relative_operator(pairs.frames, pairs.nodes, match[:, None], np.ones((len(match), 1)),
                                 pairs.B.shape[1])
    assert len(pairs.nodes) == len(mesh.boundary_nodes("z0"))
    assert abs(pairs.B - expected).max() < 1e-12
    np.testing.assert_allclose(pairs.gap, 0.0, atol=1e-12)
    np.testing.assert_allclose(pairs.frames[:, 0], np.tile([0.0, 1.0], (len(match), 1)), atol=1e-12)
    # moving the contact body (upper) by d towards the target closes the gap: w_N = -d
    towards = np.zeros((mesh.n_nodes, 2))
    towards[np.unique(mesh.cells[mesh.regions["upper"]]), 1] = -0.01
    np.testing.assert_allclose((pairs.B @ towards.ravel())[0::2], -0.01, rtol=1e-12)


def _linear_field(points):
    gradient = np.array([[0.3, -1.1], [0.7, 0.45]])
    return (np.array([0.2, -0.5]) + points @ gradient.T).ravel()


# far from the origin (x0 / h = 800) the facet parameters carry round-off of order 1e-13
@pytest.mark.parametrize("x0, width", [(2.0, 3.0), (100.0, 1.0)])
@pytest.mark.parametrize("kind", ["plane_strain", "axisymmetric"])
@pytest.mark.parametrize("order", [1, 2])
def test_patch_test_and_total_weight(order, kind, x0, width):
    y0 = 1.5
    mesh, n_zones = two_blocks(order, lower_top=[(x0 + width, 6, 1.3)], upper_bottom=[(x0 + width, 9, 1.0)],
                               x0=x0, width=width, y0=y0)
    pairs, _ = _pairs(mesh, kind, n_zones)
    assert np.array_equal(pairs.nodes, mesh.boundary_nodes("z0"))
    np.testing.assert_allclose(pairs.B @ _linear_field(mesh.points), 0.0, atol=1e-12)
    # whole interface: length (plane strain) or annulus area pi (r_out^2 - r_in^2) (axisymmetric)
    exact = width if kind == "plane_strain" else np.pi * ((x0 + width) ** 2 - x0**2)
    np.testing.assert_allclose(pairs.weight.sum(), exact, rtol=1e-12)
    assert np.all(pairs.weight > 0)
    np.testing.assert_allclose(pairs.gap, 0.0, atol=1e-12)


@pytest.mark.parametrize("kind", ["plane_strain", "axisymmetric"])
@pytest.mark.parametrize("order", [1, 2])
def test_weights_positive_and_dual_basis_biorthogonal(order, kind):
    mesh, n_zones = two_blocks(order, x0=0.0, **NON_MATCHING)
    pairs, _ = _pairs(mesh, kind, n_zones)
    on_axis = mesh.points[pairs.nodes, 0] == 0.0
    assert np.all(pairs.weight > 0)
    # a line3 corner node on the axis has zero whole-ring weight and is left out; a line one is kept
    assert on_axis.any() == (order == 1 or kind == "plane_strain")
    facets = mesh.boundary("z0")
    dual, integral = dual_coefficients(Space.build(mesh, kind), mesh.points[facets])
    xi, w = np.polynomial.legendre.leggauss(6)
    N, _ = shape_functions(xi, facets.shape[1])
    r = mesh.points[facets][:, :, 0] @ N.T
    length = np.linalg.norm(mesh.points[facets[:, 1]] - mesh.points[facets[:, 0]], axis=1)
    ring = 2 * np.pi * r if kind == "axisymmetric" else np.ones_like(r)
    psi = np.einsum("fik,qk->fqi", dual, N)
    cross = np.einsum("q,fq,fqi,qj->fij", w, ring * length[:, None] / 2, psi, N)
    np.testing.assert_allclose(cross, integral[:, :, None] * np.eye(facets.shape[1]), atol=1e-12)


@pytest.mark.parametrize("min_coverage, kept", [(0.5, [0.4, 0.5, 0.6]), (0.1, [0.3, 0.4, 0.5, 0.6, 0.7])])
def test_uncovered_contact_nodes_are_left_out(min_coverage, kept):
    with gmsh_session() as gmsh:
        geo = gmsh.model.geo
        lower, _, target = _block(geo, 0.32, 0.68, -0.5, 0.0, [(0.68, 3, 1.0)], [(0.68, 4, 1.0)])
        upper, zones, _ = _block(geo, 0.0, 1.0, 0.0, 0.5, [(1.0, 11, 1.0)], [(1.0, 3, 1.0)])
        geo.synchronize()
        gmsh.model.addPhysicalGroup(2, [lower], name="lower")
        gmsh.model.addPhysicalGroup(2, [upper], name="upper")
        gmsh.model.addPhysicalGroup(1, target, name="target")
        gmsh.model.addPhysicalGroup(1, zones, name="z0")
        gmsh.model.mesh.generate(2)
        mesh = mesh_from_gmsh()
    model = _model(mesh, "plane_strain", 1)
    pairs = mortar_pairs(Space.build(mesh, "plane_strain"), model, 0, min_coverage=min_coverage)
    # slave nodes every 0.1, target on [0.32, 0.68]: S_i / D_i is 0.16 at x = 0.3 and 0.7 (by hand,
    # int psi over the covered part of the support), 1.14 at x = 0.4 and 0.6, 1 at x = 0.5; x <= 0.2 see nothing
    np.testing.assert_allclose(np.sort(mesh.points[pairs.nodes, 0]), kept, atol=1e-12)
    translation = np.tile([0.3, 1.0], mesh.n_nodes)          # rigid translation: no relative displacement
    np.testing.assert_allclose(pairs.B @ translation, 0.0, atol=1e-12)
    inside = np.abs(mesh.points[pairs.nodes, 0] - 0.5) < 1e-9
    np.testing.assert_allclose((pairs.B @ _linear_field(mesh.points)).reshape(-1, 2)[inside], 0.0, atol=1e-12)


def two_arcs(order, radius, delta, n_slave, n_master, thickness=2.0):
    """Inner sector (outer arc r = radius, zone 'z0') and outer sector (inner arc r = radius + delta, 'target')."""
    with gmsh_session() as gmsh:
        geo = gmsh.model.geo
        centre = geo.addPoint(0, 0, 0)
        surfaces, arcs = [], []
        for r_in, r_out, half, n in ((radius - thickness, radius, np.pi / 4, n_slave),
                                     (radius + delta, radius + delta + thickness, np.pi / 4 + 0.1, n_master)):
            angles = (np.pi / 2 - half, np.pi / 2 + half)
            p = [geo.addPoint(r * np.cos(a), r * np.sin(a), 0) for r in (r_in, r_out) for a in angles]
            inner, outer = geo.addCircleArc(p[0], centre, p[1]), geo.addCircleArc(p[3], centre, p[2])
            sides = [geo.addLine(p[1], p[3]), geo.addLine(p[2], p[0])]
            for curve, count in ((inner, n), (outer, n)):
                geo.mesh.setTransfiniteCurve(curve, count)
            for curve in sides:
                geo.mesh.setTransfiniteCurve(curve, 3)
            surfaces.append(geo.addPlaneSurface([geo.addCurveLoop([inner, sides[0], outer, sides[1]])]))
            arcs.append((inner, outer))
        geo.synchronize()
        gmsh.model.addPhysicalGroup(2, [surfaces[0]], name="lower")
        gmsh.model.addPhysicalGroup(2, [surfaces[1]], name="upper")
        gmsh.model.addPhysicalGroup(1, [arcs[0][1]], name="z0")
        gmsh.model.addPhysicalGroup(1, [arcs[1][0]], name="target")
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(order)
        return mesh_from_gmsh()


@pytest.mark.parametrize("delta", [0.05, -0.02])
@pytest.mark.parametrize("order, min_rate, max_error", [(1, 1.8, 1.5e-3), (2, 3.5, 2e-7)])
def test_concentric_arcs_gap_converges_to_radial_gap(order, min_rate, max_error, delta):
    radius, segments, errors = 10.0, np.array([8, 16, 32]), []
    for n in segments:
        mesh = two_arcs(order, radius, delta, n_slave=n + 1, n_master=int(1.4 * n))
        pairs, _ = _pairs(mesh, "plane_strain")
        assert len(pairs.nodes) == len(mesh.boundary_nodes("z0"))
        # n is the outward normal of the target (the inner face of the outer sector): towards the centre;
        # exactly radial inside (symmetric neighbours), one-sided at the two ends of the arc
        radial = pairs.position / np.linalg.norm(pairs.position, axis=1)[:, None]
        error = np.linalg.norm(pairs.frames[:, 0] + radial, axis=1)
        corners, count = np.unique(mesh.boundary("z0")[:, :2], return_counts=True)
        ends = np.isin(pairs.nodes, corners[count == 1])
        assert np.all(error[~ends] < 1e-8) and np.all(error[ends] < 0.5 * np.pi / 2 / n)
        errors.append(np.max(np.abs(pairs.gap - delta)))
    rate = np.polyfit(np.log(1.0 / segments), np.log(errors), 1)[0]
    assert rate > min_rate, (errors, rate)
    # measured at 32 segments: 9.3e-4 (line; the facet sagitta radius * dtheta^2 / 8 is 3.0e-3) and 9.4e-8 (line3)
    assert errors[-1] < max_error, errors


def test_zone_shares_split_at_the_zone_border():
    # upper bottom: zone z0 on [0, 0.4] with 3 facets, zone z1 on [0.4, 1] with 8 facets
    mesh, n_zones = two_blocks(1, lower_top=[(1.0, 7, 1.0)], upper_bottom=[(0.4, 4, 1.0), (1.0, 9, 1.0)])
    pairs, model = _pairs(mesh, "plane_strain", n_zones)
    np.testing.assert_allclose(pairs.zone_share.sum(axis=1), 1.0, rtol=1e-14)
    x = pairs.position[:, 0]
    h0, h1 = 0.4 / 3, 0.6 / 8
    expected = np.where(x < 0.4 - 1e-9, 1.0, np.where(x > 0.4 + 1e-9, 0.0, h0 / (h0 + h1)))
    np.testing.assert_allclose(pairs.zone_share[:, model.zone_names.index("z0")], expected, atol=1e-12)
    np.testing.assert_allclose(pairs.mu([0.1, 0.3])[np.abs(x - 0.4) < 1e-9], 0.1 * expected[np.abs(x - 0.4) < 1e-9]
                               + 0.3 * (1 - expected[np.abs(x - 0.4) < 1e-9]), rtol=1e-12)


@pytest.mark.parametrize("order", [1, 2])
def test_zone_shares_quadratic_and_linear_sum_to_one(order):
    mesh, n_zones = two_blocks(order, lower_top=[(1.0, 5, 1.2)], upper_bottom=[(0.55, 5, 1.0), (1.0, 4, 1.1)])
    pairs, _ = _pairs(mesh, "axisymmetric", n_zones)
    np.testing.assert_allclose(pairs.zone_share.sum(axis=1), 1.0, rtol=1e-14)
    border = np.abs(pairs.position[:, 0] - 0.55) < 1e-9
    assert border.sum() == 1 and np.all((pairs.zone_share[border] > 0) & (pairs.zone_share[border] < 1))
    assert np.all(np.isin(pairs.zone_share[~border], [0.0, 1.0]))


def test_three_dimensional_model_is_refused():
    mesh = Mesh(points=np.eye(4, 3), cell_type="tetra", cells=[[0, 1, 2, 3]], regions={"lower": [0]},
                boundaries={"z0": [[0, 1, 2]], "target": [[1, 2, 3]]})
    model = Model(mesh, "3d", {"lower": STEEL},
                  interfaces=(ContactInterface("interface", ("z0",), "target", "mortar"),))
    with pytest.raises(InputError, match="only 2-D"):
        mortar_pairs(Space.build(mesh, "3d"), model, 0)
    with pytest.raises(InputError, match="interface_index 3"):
        mortar_pairs(Space.build(mesh, "3d"), model, 3)


def _deformed(mesh, amplitude):
    """The mesh moved by a smooth non-affine field (a bent, sheared interface) of the given amplitude [mm]."""
    x, y = mesh.points[:, 0], mesh.points[:, 1]
    shift = amplitude * np.column_stack([np.sin(3 * y + 1) + 0.5 * x, np.cos(2 * x) * (1 + y)])
    return Mesh(points=mesh.points + shift, cell_type=mesh.cell_type, cells=mesh.cells,
                regions=dict(mesh.regions), boundaries=dict(mesh.boundaries))


def _slid_sideways(mesh, offset):
    """The upper block moved by offset along x: its contact side overhangs the target's end."""
    points = mesh.points.copy()
    upper = np.unique(mesh.cells[mesh.regions["upper"]])
    points[upper, 0] += offset
    return Mesh(points=points, cell_type=mesh.cell_type, cells=mesh.cells, regions=dict(mesh.regions),
                boundaries=dict(mesh.boundaries))


@pytest.mark.parametrize("change", ["none", "bent", "overhang", "arcs"])
@pytest.mark.parametrize("kind", ["plane_strain", "axisymmetric"])
@pytest.mark.parametrize("order", [1, 2])
def test_vectorised_coupling_equals_the_segment_by_segment_integration(order, kind, change):
    """All candidate pairs integrated at once give the per-segment loop's matrices to round-off: non-matching,
    bent (curved, non-parallel facets), overhanging (partly covered nodes, facets projecting outside) and
    concentric arcs with an interference."""
    from mortar2d_segments import integrate, padded_rows
    from frictionid.fem import mortar

    if change == "arcs":
        mesh, n_zones = two_arcs(order, 10.0, -0.02, n_slave=13, n_master=17), 1
    else:
        mesh, n_zones = two_blocks(order, x0=0.5, **NON_MATCHING)
        mesh = {"none": mesh, "bent": _deformed(mesh, 0.02), "overhang": _slid_sideways(mesh, 0.37)}[change]
    model = _model(mesh, kind, n_zones)
    space = Space.build(mesh, kind)
    slave, master, columns = mortar._surfaces(model, 0)
    search = float(max(slave.chord_length().max(), master.chord_length().max()))
    got, expected = (f(space, slave, master, search, len(columns)) for f in (mortar._integrate, integrate))
    assert expected[0].nnz > 0
    scale = np.abs(expected[0]).max()
    np.testing.assert_allclose(got[0].toarray(), expected[0].toarray(), rtol=0, atol=1e-13 * scale)
    # gap integrals [mm^2]: round-off on the scale of a facet's length times the search distance
    np.testing.assert_allclose(got[1], expected[1], rtol=0, atol=1e-13 * search * expected[2].max())
    np.testing.assert_array_equal(got[2], expected[2])
    np.testing.assert_allclose(got[3], expected[3], rtol=0, atol=1e-9)        # degrees; NaN where no coupling
    nodes = np.unique(slave.facets)
    covered = np.asarray(expected[0].sum(axis=1)).ravel()[nodes]
    nodes, covered = nodes[covered > 0], covered[covered > 0]
    for a, b in zip(mortar._padded_rows(expected[0], nodes, covered), padded_rows(expected[0], nodes, covered)):
        np.testing.assert_array_equal(a, b)
