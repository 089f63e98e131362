"""Tests of the block reference-test builders: named groups, conforming interfaces with separate nodes, areas."""

import numpy as np
import pytest
import skfem

from frictionid.builders.block import DEFAULT_GRADING, block_layout, block_model, block_model_2d
from frictionid.errors import InputError
from frictionid.fem.space import Space
from frictionid.model import Displacement, Pressure

MATCH_TOL = 1e-9  # [mm] contact and target node must coincide to this (brief of the conforming builders)


@pytest.fixture(scope="module")
def coarse_3d():
    """mesh_size 2.5, uniform: block 4 x 4 x 4 hexahedra, plate 2 layers."""
    return {1: block_model(mesh_size=2.5, order=1, grading=1.0), 2: block_model(mesh_size=2.5, order=2, grading=1.0)}


@pytest.fixture(scope="module")
def coarse_2d():
    return {1: block_model_2d(mesh_size=2.0, n_zones=3, order=1), 2: block_model_2d(mesh_size=2.0, n_zones=3)}


def region_nodes(mesh, region):
    return np.unique(mesh.cells[mesh.regions[region]])


def nearest_targets(mesh, zone, target):
    """(zone nodes, their nearest target nodes, distances [mm])."""
    nodes, candidates = mesh.boundary_nodes(zone), mesh.boundary_nodes(target)
    distance = np.linalg.norm(mesh.points[nodes][:, None] - mesh.points[candidates][None], axis=-1)
    return nodes, candidates[distance.argmin(axis=1)], distance.min(axis=1)


def measures(model, boundaries):
    """Area [mm^2] (3-D) or length [mm] (2-D) of each named boundary, integrated on its facets."""
    space = Space.build(model.mesh, model.kind)
    one = skfem.Functional(lambda w: 1.0 + 0.0 * w.x[0])
    return {name: one.assemble(space.facet_basis(name, vector=False)) for name in boundaries}


def assert_conforming(model, contact_body, target_body):
    mesh, interface = model.mesh, model.interfaces[0]
    contact_nodes, target_nodes = region_nodes(mesh, contact_body), region_nodes(mesh, target_body)
    matched = []
    for zone in interface.zones:
        nodes, targets, distance = nearest_targets(mesh, zone, interface.target)
        assert distance.max() < MATCH_TOL, zone
        assert np.all(np.isin(nodes, contact_nodes)) and not np.any(np.isin(nodes, target_nodes)), zone
        assert np.all(np.isin(targets, target_nodes)) and not np.any(np.isin(targets, contact_nodes)), zone
        matched.append(targets)
    return np.unique(np.concatenate(matched))


# ---------------------------------------------------------------------------------------------- 3-D

def test_3d_named_groups_and_materials(coarse_3d):
    model = coarse_3d[1]
    assert set(model.mesh.regions) == {"plate", "block"}
    assert set(model.mesh.boundaries) == {"plate_bottom", "plate_top", "block_top", "A", "B", "C", "D"}
    assert model.kind == "3d" and model.zone_names == ("A", "B", "C", "D")
    assert model.interfaces[0].target == "plate_top"
    assert (model.materials["plate"].E, model.materials["plate"].nu) == (3500.0, 0.35)
    assert (model.materials["block"].E, model.materials["block"].nu) == (71000.0, 0.33)


@pytest.mark.parametrize("order", [1, 2])
def test_3d_interface_is_conforming_with_separate_nodes(coarse_3d, order):
    model = coarse_3d[order]
    matched = assert_conforming(model, "block", "plate")
    # conforming both ways: every plate-top node in the footprint is some zone node's partner
    top = model.mesh.boundary_nodes("plate_top")
    inside = top[np.all(np.abs(model.mesh.points[top, :2]) <= 5.0 + MATCH_TOL, axis=1)]
    np.testing.assert_array_equal(matched, inside)


def test_3d_zones_are_the_quadrants(coarse_3d):
    mesh = coarse_3d[1].mesh
    for zone, (sx, sy) in {"A": (-1, -1), "B": (1, -1), "C": (-1, 1), "D": (1, 1)}.items():
        xy = mesh.points[mesh.boundary_nodes(zone), :2]
        assert np.all(sx * xy[:, 0] >= 0) and np.all(sy * xy[:, 1] >= 0), zone
        assert np.all(np.abs(mesh.points[mesh.boundary_nodes(zone), 2]) < MATCH_TOL), zone
        np.testing.assert_allclose(np.ptp(xy, axis=0), [5.0, 5.0], atol=MATCH_TOL)


@pytest.mark.parametrize("order", [1, 2])
def test_3d_areas(coarse_3d, order):
    model = coarse_3d[order]
    area = measures(model, model.zone_names + ("block_top", "plate_top"))
    for zone in model.zone_names:
        assert area[zone] == pytest.approx(25.0, rel=1e-12)
    assert area["block_top"] == pytest.approx(100.0, rel=1e-12)
    assert area["plate_top"] == pytest.approx(1600.0, rel=1e-12)


def test_3d_load_path():
    model = block_model(pull=0.3, force=1500.0, mesh_size=5.0, n_press=2, n_pull=7)
    assert [(s.name, s.n_increments) for s in model.stages] == [("press", 2), ("pull", 7)]
    assert Pressure("block_top", (15.0, 15.0)) in model.loads          # 1500 N on 10 mm x 10 mm
    assert Displacement("block_top", 0, (0.0, 0.0)) in model.loads
    assert Displacement("block_top", 1, (0.0, 0.3)) in model.loads
    assert [(s.boundary, tuple(s.components)) for s in model.supports] == [("plate_bottom", (0, 1, 2))]


def test_3d_cell_and_node_counts(coarse_3d):
    # mesh_size 2.5: block 4 x 4 x 4 cells; plate 2 layers, 4 + 2 * 5 cells across, since outside the footprint
    # 5 elements growing by 1.2 are the fewest that cover 15 mm starting at 2.5 mm (2.5 * sum 1.2^k, k < 5 >= 15)
    linear, quadratic = coarse_3d[1].mesh, coarse_3d[2].mesh
    assert (linear.cell_type, quadratic.cell_type) == ("hexahedron", "hexahedron27")
    for mesh, nodes_per_cell_edge in [(linear, 1), (quadratic, 2)]:
        assert (len(mesh.regions["block"]), len(mesh.regions["plate"])) == (64, 14 * 14 * 2)
        block_nodes = (4 * nodes_per_cell_edge + 1) ** 3
        plate_nodes = (14 * nodes_per_cell_edge + 1) ** 2 * (2 * nodes_per_cell_edge + 1)
        assert len(region_nodes(mesh, "block")) == block_nodes
        assert mesh.n_nodes == block_nodes + plate_nodes


def test_3d_block_divisions():
    mesh = block_model(mesh_size=2.5, block_divisions=6).mesh
    assert len(mesh.regions["block"]) == 6 * 6 * 4
    assert len(mesh.boundary("A")) == 9


@pytest.fixture(scope="module")
def graded_3d():
    """Graded 4:1: linear 8 x 8 block bottom with 3 plate layers and its uniform twin; quadratic 4 x 4 (whose
    mid-nodes at the quarter points move)."""
    kwargs = dict(mesh_size=1.7, block_divisions=8)
    return {1: block_model(**kwargs, order=1, grading=4.0), "uniform": block_model(**kwargs, order=1, grading=1.0),
            2: block_model(mesh_size=2.5, order=2, grading=4.0)}


def ticks(mesh, axis, region, where):
    """Sorted distinct node coordinates along ``axis`` of the region's nodes selected by ``where(points)``."""
    points = mesh.points[region_nodes(mesh, region)]
    return np.unique(np.round(points[where(points), axis], 9))


@pytest.mark.parametrize("order", [1, 2])
def test_3d_graded_interface_stays_conforming(graded_3d, order):
    model = graded_3d[order]
    matched = assert_conforming(model, "block", "plate")
    top = model.mesh.boundary_nodes("plate_top")
    inside = top[np.all(np.abs(model.mesh.points[top, :2]) <= 5.0 + MATCH_TOL, axis=1)]
    np.testing.assert_array_equal(matched, inside)
    if order == 2:
        return                                        # areas: the map moves only node coordinates, as order 1
    area = measures(model, model.zone_names + ("block_top", "plate_top"))
    for zone in model.zone_names:
        assert area[zone] == pytest.approx(25.0, rel=1e-12)
    assert area["plate_top"] == pytest.approx(1600.0, rel=1e-12)


def test_3d_grading_refines_edges_borders_and_interface(graded_3d):
    graded, uniform = graded_3d[1].mesh, graded_3d["uniform"].mesh
    assert (graded.n_cells >= uniform.n_cells) and len(graded.regions["block"]) == len(uniform.regions["block"])
    bottom = lambda p: np.abs(p[:, 2]) < MATCH_TOL                              # noqa: E731
    for axis in (0, 1):
        x = ticks(graded, axis, "block", bottom)
        np.testing.assert_allclose(x[[0, 4, 8]], [-5.0, 0.0, 5.0], atol=1e-12)  # zone borders stay put
        np.testing.assert_allclose(x, -x[::-1], atol=1e-12)
        h = np.diff(x[4:])                                                       # 4 elements on 0 < x < 5
        np.testing.assert_allclose(np.diff(ticks(uniform, axis, "block", bottom)), 1.25, atol=1e-12)
        assert h[0] < 1.25 and h[-1] < 1.25 and h[1] > 1.25 and h[2] > 1.25   # small at border and edge
        s = np.linspace(0.0, 1.0, 5)                   # the documented map, slopes 1 -/+ 0.6 cos(2 pi s)
        np.testing.assert_allclose(x[4:], 5.0 * (s - 0.6 * np.sin(2 * np.pi * s) / (2 * np.pi)), atol=1e-12)
        # the plate column under the block carries the same ticks; outside, it grows from the edge size
        plate = ticks(graded, axis, "plate", lambda p: np.abs(p[:, 2]) < MATCH_TOL)
        np.testing.assert_allclose(plate[np.abs(plate) <= 5.0 + MATCH_TOL], x, atol=1e-12)
        outside = np.diff(plate[plate >= 5.0 - MATCH_TOL])
        assert outside[0] == pytest.approx(h[-1] * 1.2, rel=0.25) and np.all(np.diff(outside) > 0)
    for region, far in [("block", 10.0), ("plate", -5.0)]:
        z = ticks(graded, 2, region, lambda p: np.abs(p[:, 0]) < MATCH_TOL)
        dz = np.abs(np.diff(z if far > 0 else z[::-1]))                          # from the interface outwards
        assert z[0 if far > 0 else -1] == pytest.approx(0.0, abs=1e-12) and np.abs(z).max() == pytest.approx(abs(far))
        assert np.all(np.diff(dz) > 0)                                           # smallest at the interface


def test_3d_grading_one_is_the_uniform_mesh(coarse_3d):
    mesh = coarse_3d[1].mesh
    for axis, region in [(0, "block"), (1, "block"), (2, "block"), (2, "plate")]:
        x = np.unique(np.round(mesh.points[region_nodes(mesh, region), axis], 9))
        x = x[np.abs(x) <= 5.0 + MATCH_TOL] if axis < 2 else x
        np.testing.assert_allclose(np.diff(x), 2.5, rtol=1e-12)


def test_3d_defaults_are_graded_with_incompatible_modes():
    """The defaults chosen with benchmarks/block_strains.py: grading DEFAULT_GRADING and, for linear hexahedra,
    incompatible modes; quadratic hexahedra keep the standard element (incompatible modes need order 1)."""
    default, quadratic = block_model(mesh_size=2.5), block_model(mesh_size=2.5, order=2)
    assert (default.element, quadratic.element) == ("incompatible", "standard")
    assert DEFAULT_GRADING > 1.0
    np.testing.assert_array_equal(default.mesh.points,
                                  block_model(mesh_size=2.5, grading=DEFAULT_GRADING, element="standard").mesh.points)
    np.testing.assert_array_equal(quadratic.mesh.points,
                                  block_model(mesh_size=2.5, order=2, grading=DEFAULT_GRADING).mesh.points)


# ---------------------------------------------------------------------------------------------- 2-D

def test_2d_named_groups_and_loads(coarse_2d):
    model = coarse_2d[2]
    assert set(model.mesh.regions) == {"base", "block"}
    assert set(model.mesh.boundaries) == {"base_bottom", "base_top", "block_top", "A", "B", "C"}
    assert model.kind == "plane_strain" and model.zone_names == ("A", "B", "C")
    assert model.interfaces[0].target == "base_top"
    assert Pressure("block_top", (20.0, 20.0)) in model.loads          # 200 N/mm on a 10 mm wide top
    assert Displacement("block_top", 0, (0.0, 0.2)) in model.loads
    assert not any(getattr(load, "component", None) == 1 for load in model.loads)


@pytest.mark.parametrize("order", [1, 2])
def test_2d_interface_is_conforming_with_separate_nodes(coarse_2d, order):
    model = coarse_2d[order]
    matched = assert_conforming(model, "block", "base")
    top = model.mesh.boundary_nodes("base_top")
    inside = top[np.abs(model.mesh.points[top, 0]) <= 5.0 + MATCH_TOL]
    np.testing.assert_array_equal(matched, inside)


@pytest.mark.parametrize("order", [1, 2])
def test_2d_zone_lengths_from_left_to_right(coarse_2d, order):
    model = coarse_2d[order]
    length = measures(model, model.zone_names + ("block_top", "base_top"))
    for k, zone in enumerate(model.zone_names):
        assert length[zone] == pytest.approx(10.0 / 3, rel=1e-12)
        x = model.mesh.points[model.mesh.boundary_nodes(zone), 0]
        np.testing.assert_allclose([x.min(), x.max()], [-5.0 + 10.0 * k / 3, -5.0 + 10.0 * (k + 1) / 3], atol=1e-12)
    assert length["block_top"] == pytest.approx(10.0, rel=1e-12)
    assert length["base_top"] == pytest.approx(40.0, rel=1e-12)


@pytest.mark.parametrize("quads, cell_types", [(False, ("triangle", "triangle6")), (True, ("quad", "quad9"))])
def test_2d_linear_and_quadratic_counts(quads, cell_types):
    linear = block_model_2d(mesh_size=2.0, order=1, quads=quads).mesh
    quadratic_model = block_model_2d(mesh_size=2.0, order=2, quads=quads)
    quadratic = quadratic_model.mesh
    assert (linear.cell_type, quadratic.cell_type) == cell_types
    assert_conforming(quadratic_model, "block", "base")
    assert quadratic.n_cells == linear.n_cells
    # Euler, two simply connected bodies: edges = vertices + cells - 2; quad9 adds a node per cell
    extra = linear.n_cells if quads else 0
    assert quadratic.n_nodes == 2 * linear.n_nodes + linear.n_cells - 2 + extra


def test_2d_contact_size_refines_the_interface_only():
    refined = block_model_2d(mesh_size=2.0, contact_size=0.25, order=1).mesh
    uniform = block_model_2d(mesh_size=0.25, order=1).mesh
    assert len(refined.boundary("A")) == len(uniform.boundary("A")) == 20    # 5 mm zone / 0.25 mm
    assert len(refined.boundary("base_bottom")) < len(uniform.boundary("base_bottom")) / 4
    assert refined.n_nodes < uniform.n_nodes / 2

def test_3d_bands_split_only_the_intervals_next_to_the_edges_and_the_interface(graded_3d):
    """edge_splits / interface_splits 3 on the graded mesh: the x, y intervals whose middle lies within 1 mm of
    x, y = +-5 (inside the footprint and in the plate) and the z layers within 1 mm of z = 0 are split into 3
    equal parts of the graded parameter; every other node line stays where it was; the interface stays
    conforming, and the layout's node count (what the discretisation control prices) is the mesh's."""
    kwargs = dict(mesh_size=1.7, block_divisions=8)
    given = graded_3d[1]
    split = block_model(**kwargs, edge_splits=3, interface_splits=3)
    assert split.mesh.n_nodes == block_layout(**kwargs, edge_splits=3, interface_splits=3).n_nodes() > given.mesh.n_nodes
    assert given.mesh.n_nodes == block_layout(**kwargs).n_nodes()
    assert_conforming(split, "block", "plate")
    for axis in (0, 1, 2):
        old = np.unique(np.round(given.mesh.points[:, axis], 6))        # gmsh's progression outside: 1e-8
        new = np.unique(np.round(split.mesh.points[:, axis], 6))
        assert set(old) <= set(new)                                        # nothing moved, lines added
        near = 5.0 if axis < 2 else 0.0
        middles = np.abs(np.abs((old[:-1] + old[1:]) / 2) - near)
        inside_band = middles < 1.0
        if axis < 2:                              # the quadrant border side of the footprint's half is not split
            inside_band &= np.abs((old[:-1] + old[1:]) / 2) > 2.5
        added = [np.sum((new > a + 1e-9) & (new < b - 1e-9)) for a, b in zip(old[:-1], old[1:])]
        assert np.array_equal(np.array(added), np.where(inside_band, 2, 0)), (axis, added, inside_band)
        assert np.sum(inside_band) >= 2                                      # one each side at least


def test_3d_interior_splits_only_the_intervals_across_the_footprint_outside_the_edge_band(graded_3d):
    """interior_splits 3 on the graded mesh: the x, y intervals under the footprint whose middle lies 1 mm or more
    from x, y = +-5 are split into 3 (where the pull's lift-off front lies); the edge band's intervals, the plate
    outside the footprint and the layers stay; the interface stays conforming and the layout counts the nodes."""
    kwargs = dict(mesh_size=1.7, block_divisions=8)
    given = graded_3d[1]
    split = block_model(**kwargs, interior_splits=3)
    assert split.mesh.n_nodes == block_layout(**kwargs, interior_splits=3).n_nodes() > given.mesh.n_nodes
    assert_conforming(split, "block", "plate")
    for axis in (0, 1, 2):
        old = np.unique(np.round(given.mesh.points[:, axis], 6))
        new = np.unique(np.round(split.mesh.points[:, axis], 6))
        assert set(old) <= set(new)                                        # nothing moved, lines added
        middles = np.abs((old[:-1] + old[1:]) / 2)
        interior = (middles < 5.0) & (5.0 - middles >= 1.0) if axis < 2 else np.zeros(len(middles), bool)
        added = [np.sum((new > a + 1e-9) & (new < b - 1e-9)) for a, b in zip(old[:-1], old[1:])]
        assert np.array_equal(np.array(added), np.where(interior, 2, 0)), (axis, added, interior)
        assert axis == 2 or np.sum(interior) >= 4                          # two each side of the border at least


# ---------------------------------------------------------------------------------------------- bad input

@pytest.mark.parametrize("builder, kwargs, argument", [
    (block_model, {"pull": 0.0}, "pull"),
    (block_model, {"force": -1.0}, "force"),
    (block_model, {"mesh_size": float("nan")}, "mesh_size"),
    (block_model, {"pull": True}, "pull"),                  # a bool is no length (it passed as 1 mm)
    (block_model, {"order": 3}, "order"),
    (block_model, {"n_press": 0}, "n_press"),
    (block_model, {"n_pull": 2.5}, "n_pull"),
    (block_model, {"block_divisions": 5}, "block_divisions"),
    (block_model, {"grading": 0.5}, "grading"),
    (block_model, {"grading": float("inf")}, "grading"),
    (block_model, {"edge_splits": 0}, "edge_splits"),
    (block_model, {"interface_splits": 1.5}, "interface_splits"),
    (block_model, {"edge_band": -1.0}, "edge_band"),
    (block_model, {"interface_band": 0.0}, "interface_band"),
    (block_model, {"interior_splits": 0}, "interior_splits"),
    (block_model_2d, {"kind": "axisymmetric"}, "kind"),
    (block_model_2d, {"width": 0.0}, "width"),
    (block_model_2d, {"base_width": 8.0}, "base_width"),
    (block_model_2d, {"contact_size": -0.1}, "contact_size"),
    (block_model_2d, {"n_zones": 0}, "n_zones"),
    (block_model_2d, {"order": 0}, "order"),
    (block_model_2d, {"mesh_size": "1"}, "mesh_size"),
])
def test_bad_arguments_name_the_argument(builder, kwargs, argument):
    with pytest.raises(InputError, match=f"`{argument}`"):
        builder(**kwargs)
