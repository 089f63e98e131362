"""Uniform subdivision of a user's mesh ([model] refine): geometry and groups carried over exactly, a conforming
mesh that keeps the bodies apart, and a solution that converges towards the builder's on the same geometry."""

import itertools
import json
import shutil
import tomllib
from pathlib import Path

import gmsh
import numpy as np
import pytest

from frictionid.builders.gmsh_mesh import gmsh_session, mesh_and_node_sets_from_gmsh
from frictionid.builders.registry import build_model, refined
from frictionid.builders.subdivide import CORNERS, SHAPE, node_template, shape_functions, subdivide
from frictionid.cli import main
from frictionid.model.mesh import CELL_FACETS, FACET_TYPE
from helpers.meshes import stacked_rectangles_geo
from frictionid.options import ModelSpec
from helpers.differences import central_difference

FIXTURES = Path(__file__).parent / "fixtures" / "user_block"
_GAUSS = np.polynomial.legendre.leggauss(5)


def _rule(linear: str):
    """Points (q, d) and weights (q,) on the reference element of ``linear`` (Duffy-collapsed for simplices)."""
    d = len(CORNERS[linear][0])
    x, w = (_GAUSS[0] + 1) / 2, _GAUSS[1] / 2
    points = np.array(list(itertools.product(x, repeat=d)))
    weights = np.prod(np.array(list(itertools.product(w, repeat=d))), axis=1)
    if linear in ("triangle", "tetra"):
        u = points.copy()
        points[:, 1] = u[:, 1] * (1 - u[:, 0])
        weights = weights * (1 - u[:, 0])
        if d == 3:
            points[:, 2] = u[:, 2] * (1 - u[:, 0]) * (1 - u[:, 1])
            weights = weights * (1 - u[:, 0]) * (1 - u[:, 1])
    return points, weights


#: how well two :func:`measure` of one region agree: its central differences (step 1e-6) carry rounding of about
#: 1e-16 / 1e-6 relative (measured 1.4e-10 between a 27-node hexahedral block and its subdivision); a lost or
#: doubled child changes a region by at least 1 / (8 n_cells)
MEASURED = 1e-8


def measure(kind: str, points: np.ndarray, elements: np.ndarray) -> float:
    """Total length, area or volume of ``elements`` of ``kind`` through their own (isoparametric) geometry."""
    linear, _ = SHAPE[kind]
    template = node_template(kind, points, elements)
    xi, weights = _rule(linear)
    d = xi.shape[1]
    # dN/dxi_a at every quadrature point: the same offset at all of them (shape functions act point by point)
    dn = central_difference(lambda offset: shape_functions(kind, template, xi + offset), np.zeros(d), 1e-6)
    jac = np.einsum("qna,enx->eqxa", dn, points[elements])                 # (n_el, q, dim, d)
    return float(np.sum(np.sqrt(np.linalg.det(np.einsum("eqxa,eqxb->eqab", jac, jac))) * weights))


def orientation(kind: str, points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(n_cells,) sign of det(dx / dxi) at each cell's reference centroid."""
    linear, _ = SHAPE[kind]
    template = node_template(kind, points, cells)
    centre = np.mean(np.array(CORNERS[linear], dtype=float), axis=0)[None]
    dn = central_difference(lambda offset: shape_functions(kind, template, centre + offset)[0],
                            np.zeros(centre.shape[1]), 1e-6)                # (n_nodes, d) at the centroid
    return np.sign(np.linalg.det(np.einsum("na,enx->exa", dn, points[cells])))


def _gmsh_box(order: int):
    """A tetrahedral box [0, 2] x [0, 1] x [0, 1] of region "body", bottom and top boundaries, a corner node set."""
    with gmsh_session():
        occ = gmsh.model.occ
        occ.addBox(0, 0, 0, 2, 1, 1)
        occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [1], name="body")
        gmsh.model.addPhysicalGroup(2, [5], name="bottom")                  # z = 0
        gmsh.model.addPhysicalGroup(2, [6], name="top")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(order)
        mesh, _ = mesh_and_node_sets_from_gmsh("box")
    return mesh


MESHES = {
    "triangle": lambda: build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 2.0, "order": 1})).mesh,
    "triangle6": lambda: build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 2.0, "order": 2})).mesh,
    "quad": lambda: build_model(ModelSpec("block2d", {"mesh_size": 2.0, "order": 1, "quads": True})).mesh,
    "quad9": lambda: build_model(ModelSpec("block2d", {"mesh_size": 2.0, "order": 2, "quads": True})).mesh,
    "tetra": lambda: _gmsh_box(1),
    "tetra10": lambda: _gmsh_box(2),
    "hexahedron": lambda: build_model(ModelSpec.from_table({"builder": "block", "mesh_size": 5.0, "order": 1})).mesh,
    "hexahedron27": lambda: build_model(ModelSpec.from_table({"builder": "block", "mesh_size": 5.0, "order": 2})).mesh,
}


def _facets(kind: str, cells: np.ndarray) -> np.ndarray:
    """(n, n_facet_corners) sorted corner tuples of every facet of every cell."""
    return np.sort(np.concatenate([cells[:, list(face)] for face in CELL_FACETS[kind]]), axis=1)


@pytest.mark.parametrize("kind", list(MESHES))
def test_every_cell_type_keeps_its_regions_and_boundaries_exactly(kind):
    mesh = MESHES[kind]()
    assert mesh.cell_type == kind
    corner = int(mesh.cells[0, 0])
    points, cells, children, facets, sets = subdivide(mesh.points, kind, mesh.cells, dict(mesh.boundaries),
                                                      {"corner": np.array([corner])})
    d = len(CORNERS[SHAPE[kind][0]][0])
    assert cells.shape == (len(mesh.cells) * 2 ** d, mesh.cells.shape[1]) and children.shape[1] == 2 ** d
    np.testing.assert_array_equal(points[:mesh.n_nodes], mesh.points)          # the parent's nodes kept
    for name, index in mesh.regions.items():                                    # area or volume per region
        assert measure(kind, points, cells[children[index].ravel()]) == pytest.approx(
            measure(kind, mesh.points, mesh.cells[index]), rel=MEASURED)
    facet = FACET_TYPE[kind]
    for name, f in mesh.boundaries.items():                                     # length or area per boundary
        assert len(facets[name]) == 2 ** (d - 1) * len(f)
        assert measure(facet, points, facets[name]) == pytest.approx(measure(facet, mesh.points, f), rel=MEASURED)
    # every child is oriented like its parent
    corners = len(CORNERS[SHAPE[kind][0]])
    np.testing.assert_array_equal(orientation(kind, points, cells)[children],
                                  np.repeat(orientation(kind, mesh.points, mesh.cells)[:, None], 2 ** d, axis=1))
    # conforming: each facet of the refined mesh is shared by at most two cells, and the refined mesh has as many
    # unshared facets as the coarse one has, times 2^(d-1): no node was made twice, none was merged across bodies
    _, count_before = np.unique(_facets(kind, mesh.cells[:, :corners]), axis=0, return_counts=True)
    _, count_after = np.unique(_facets(kind, cells[:, :corners]), axis=0, return_counts=True)
    assert count_after.max() == 2 and (count_after == 1).sum() == 2 ** (d - 1) * (count_before == 1).sum()
    assert sets["corner"].tolist() == [corner]                 # a node set of one node gains no node


def test_curved_quadratic_cells_keep_their_curved_geometry():
    """Mid-edge nodes moved off the straight edges: the children follow the parent's quadratic map, so the area
    of every region is unchanged to quadrature accuracy."""
    mesh = MESHES["triangle6"]()
    rng = np.random.default_rng(1)
    points = mesh.points.copy()
    mids = np.unique(mesh.cells[:, 3:])
    points[mids] += rng.uniform(-0.1, 0.1, (len(mids), 2))
    new, cells, children, _, _ = subdivide(points, "triangle6", mesh.cells, {}, {})
    for index in mesh.regions.values():
        assert measure("triangle6", new, cells[children[index].ravel()]) == pytest.approx(
            measure("triangle6", points, mesh.cells[index]), rel=1e-9)


def test_a_node_set_gains_the_nodes_between_its_nodes():
    mesh = MESHES["quad"]()
    edge = mesh.boundaries["base_bottom"]
    nodes = np.unique(edge)
    points, _, _, facets, sets = subdivide(mesh.points, "quad", mesh.cells, {"b": edge}, {"b": nodes})
    assert sorted(sets["b"].tolist()) == sorted(np.unique(facets["b"]).tolist())
    assert np.allclose(points[sets["b"], 1], -5.0)


def _user_config(folder: Path, name: str, refine: int, extra: str = "") -> Path:
    text = (FIXTURES / "plane_truth.toml").read_text().replace('kind = "plane_strain"',
                                                               f'kind = "plane_strain"\nrefine = {refine}')
    path = folder / f"{name}.toml"
    path.write_text(text + extra)
    return path


def _values(path: Path) -> np.ndarray:
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    names = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:]]
    return np.array([[float(r[names.index(q)]) for q in ("ux", "uy")] for r in rows])


@pytest.mark.slow                                                   # three simulations: 60 s
def test_the_refined_user_mesh_converges_to_the_builders_solution(tmp_path):
    """plane.msh (quadratic triangles, 1 mm, 0.5 mm on the interface) is the block2d builder's geometry and load:
    subdivided once its displacements come closer to the builder's on a 0.25 mm quadratic mesh, by more than 2.
    Measured: RMS 0.21, 0.060, 0.017 um for refine = 0, 1, 2 at the fixture's points (both stages)."""
    shutil.copy(FIXTURES / "plane.msh", tmp_path)
    shutil.copy(FIXTURES / "plane_points.csv", tmp_path)
    text = (FIXTURES / "plane_truth.toml").read_text()
    builder = tmp_path / "builder.toml"
    builder.write_text('[model]\nbuilder = "block2d"\npull = 0.05\nmesh_size = 0.25\norder = 2\n[friction]'
                       + text.split("[friction]")[1])
    rms = []
    for name, config in (("builder", builder), ("r0", _user_config(tmp_path, "r0", 0)),
                         ("r1", _user_config(tmp_path, "r1", 1))):
        assert main(["simulate", str(config), "--out", str(tmp_path / f"{name}.csv")]) == 0
        if name != "builder":
            difference = _values(tmp_path / f"{name}.csv") - _values(tmp_path / "builder.csv")
            rms.append(np.sqrt(np.mean(difference ** 2)))
    assert rms[1] < rms[0] / 2 and rms[0] < 5e-4                  # [mm]


def test_a_user_mesh_is_refined_by_subdivision_for_the_model_error(tmp_path, capsys):
    """identify.model_error works for builder = "mesh": the estimate refines the file's mesh once."""
    assert refined(ModelSpec.from_table({"builder": "mesh", "file": "joint.msh", "refine": 1}), 4).option("refine") == 3
    table = tomllib.loads((FIXTURES / "identify.toml").read_text())["model"]     # block.inp, the 3-D block
    table["file"] = str(FIXTURES / table["file"])
    coarse, fine = build_model(ModelSpec.from_table(table)), build_model(ModelSpec.from_table({**table, "refine": 1}))
    assert fine.mesh.n_cells == 8 * coarse.mesh.n_cells and fine.zone_names == coarse.zone_names
    for name, facets in coarse.mesh.boundaries.items():          # loads and zones: 4 facets per facet
        if np.all(facets == facets[:, :1]):                      # the plate bottom, a node set (*NSET) in the .inp
            nodes = np.unique(fine.mesh.boundaries[name])        # gains the nodes between its nodes: 23^2 -> 45^2
            assert len(nodes) == (2 * np.sqrt(len(facets)) - 1) ** 2 and np.allclose(fine.mesh.points[nodes, 2], -5)
        else:
            assert len(fine.mesh.boundaries[name]) == 4 * len(facets)
    for folder_file in ("plane.msh", "plane_points.csv"):
        shutil.copy(FIXTURES / folder_file, tmp_path)
    config = _user_config(tmp_path, "estimate", 0)
    assert main(["simulate", str(config), "--out", str(tmp_path / "measured.csv")]) == 0
    text = config.read_text().replace('file = "plane_points.csv"', 'file = "measured.csv"')
    config.write_text(text + 'noise = { u = 0.0005, force = 0.5 }\n[identify]\nmodel_error = "estimate"\n'
                      '[run]\ndir = "runs/estimate"\n')
    assert main(["identify", str(config)]) == 0
    error = json.loads((tmp_path / "runs/estimate/result.json").read_text())["fit"]["model_error"]
    assert error["refined_options"]["refine"] == 1 and error["summary"]["all"]["rms"] > 0


@pytest.mark.parametrize("refine", [-1, 1.5, True, "1"])
def test_a_bad_refine_exits_2_naming_the_key(tmp_path, capsys, refine):
    shutil.copy(FIXTURES / "plane.msh", tmp_path)
    shutil.copy(FIXTURES / "plane_points.csv", tmp_path)
    text = _user_config(tmp_path, "bad", 0).read_text().replace("refine = 0", f"refine = {json.dumps(refine)}")
    (tmp_path / "bad.toml").write_text(text)
    assert main(["simulate", str(tmp_path / "bad.toml"), "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert "refine" in err and "whole number >= 0" in err and "Traceback" not in err


GEO = stacked_rectangles_geo(0.0, "Mesh.MeshSizeFactor = 2;\n")


def test_a_geo_is_meshed_again_with_its_sizes_halved_on_top_of_its_own_factor(tmp_path):
    (tmp_path / "rings.geo").write_text(GEO)
    table = {"builder": "mesh", "file": str(tmp_path / "rings.geo"), "kind": "plane_strain",
             "materials": {"lower": {"E": 1000, "nu": 0.3}, "upper": {"E": 1000, "nu": 0.3}},
             "supports": [{"boundary": "bottom"}],
             "loads": [{"type": "displacement", "boundary": "upper_top", "component": "y", "values": [-0.01]}],
             "interfaces": [{"name": "i", "zones": ["upper_bottom"], "target": "lower_top"}]}
    coarse, fine = build_model(ModelSpec.from_table(table)), build_model(refined(ModelSpec.from_table(table)))
    spacing = [np.ptp(m.mesh.points[np.unique(m.mesh.boundaries["upper_top"]), 0])
               / (len(m.mesh.boundaries["upper_top"])) for m in (coarse, fine)]
    assert spacing[0] == pytest.approx(1.0, rel=0.01) and spacing[1] == pytest.approx(0.5, rel=0.01)
    for name, index in coarse.mesh.regions.items():
        assert measure("triangle", fine.mesh.points, fine.mesh.cells[fine.mesh.regions[name]]) == pytest.approx(
            measure("triangle", coarse.mesh.points, coarse.mesh.cells[index]), rel=1e-9)
