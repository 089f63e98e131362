"""Fields for ParaView: the VTU files of a solve against independent evaluations of the same model, and the
files identify and simulate write (docs/results.md, Fields for ParaView)."""

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.verification import interference_model
from frictionid.cli import main
from frictionid.fem.points import QUANTITIES
from frictionid.fem.problem import Problem
from frictionid.fem.fields import strain_names
from frictionid.report.vtu import export_fields, write_fields

EXAMPLE = Path(__file__).parents[1] / "examples" / "first"
MU = {"block3d": {"A": 0.3, "B": 0.2, "C": 0.4, "D": 0.25}, "block2d": {"A": 0.3, "B": 0.15},
      "interference": {"Z1": 0.2, "Z2": 0.3}}


@pytest.fixture(scope="module")
def interference():
    """An axisymmetric shrink fit and push-out, coarse (1 mm cells)."""
    return interference_model(size=1.0, n_push=4)


def _cell_regions_of_nodes(mesh) -> list[str]:
    """A region holding each node (two bodies touching at the interface: their own coincident nodes)."""
    region = np.empty(mesh.n_nodes, dtype=np.int64)
    region[mesh.cells.ravel()] = np.repeat(mesh.cell_region, mesh.cells.shape[1])
    return [mesh.region_names[r] for r in region]


def _corner_centres(mesh) -> np.ndarray:
    """Centre of each cell as the mean of its corners: the image of the reference centroid for the straight-sided
    (affine or trilinear) cells of these meshes."""
    n_corners = {"hexahedron": 8, "triangle6": 3, "triangle": 3, "quad": 4}[mesh.cell_type]
    return mesh.points[mesh.cells[:, :n_corners]].mean(axis=1)


def _written(model, mu, folder):
    """The fields at mu written to folder; and an independent solve observing every node and cell centre."""
    write_fields(folder, EmbeddedBackend(model, None, (), keep=False).fields(mu))
    mesh = model.mesh
    points = np.vstack([mesh.points, _corner_centres(mesh)])
    regions = _cell_regions_of_nodes(mesh) + [mesh.region_names[r] for r in mesh.cell_region]
    quantities = QUANTITIES[model.kind]
    problem = Problem.build(model, points=points, quantities=quantities, regions=regions)
    solution = problem.solve(mu)
    return problem, solution, quantities


@pytest.mark.parametrize("name", ["block3d", "block2d", "interference"])
def test_solid_fields_equal_the_point_operator_at_nodes_and_cell_centres(name, request, tmp_path):
    model = request.getfixturevalue(name)
    problem, solution, quantities = _written(model, MU[name], tmp_path)
    mesh, dim = model.mesh, model.dim
    strains = strain_names(model.kind)
    for stage in range(model.n_stages):
        observed = solution.observations[solution.stage_end(stage)].reshape(-1, len(quantities))
        at_nodes, at_centres = observed[:mesh.n_nodes], observed[mesh.n_nodes:]
        vtu = meshio.read(tmp_path / f"solid_{stage + 1}.vtu")
        assert vtu.cells[0].type == mesh.cell_type and np.array_equal(vtu.cells[0].data, mesh.cells)
        u = vtu.point_data["displacement_mm"]
        assert u.shape == (mesh.n_nodes, 3) and np.all(u[:, dim:] == 0)
        # independent: the observation rows of a second condensation, cells found by point location
        np.testing.assert_allclose(u[:, :dim], at_nodes[:, :dim], rtol=0, atol=1e-10)
        assert np.abs(u).max() > 1e-4                          # a displacement that tests something
        scale = np.abs(at_centres[:, dim:]).max()
        assert scale > 1e-6
        for k, name_ in enumerate(strains):
            np.testing.assert_allclose(vtu.cell_data[name_][0], at_centres[:, dim + k], rtol=0, atol=1e-9 * scale)
        np.testing.assert_array_equal(vtu.cell_data["region"][0], mesh.cell_region)
    if model.kind == "plane_strain":
        assert np.all(vtu.cell_data["ezz"][0] == 0)


@pytest.mark.parametrize("name, force", [("block3d", 2000.0), ("block2d", 200.0)])
def test_contact_pressure_integrates_to_the_press_force_and_states_count_as_solved(name, force, request, tmp_path):
    """The press force of the block test (DESIGN.md reference test 1; block2d: 200 N per mm thickness) is carried
    by the contact alone at every stage: the top face is free in z (y in 2-D)."""
    model = request.getfixturevalue(name)
    _, solution, _ = _written(model, MU[name], tmp_path)
    for stage in range(model.n_stages):
        contact = meshio.read(tmp_path / f"contact_{stage + 1}.vtu")
        data = contact.point_data
        assert np.sum(data["pressure_MPa"] * data["area_mm2"]) == pytest.approx(force, rel=1e-9)
        assert np.all(data["state"] >= 0)                     # node-to-node: a pair at every contact node
        counts = np.bincount(data["state"], minlength=3)
        assert counts.tolist() == np.bincount(solution.state[solution.stage_end(stage)], minlength=3).tolist()
        assert data["traction_MPa"].shape == data["slip_mm"].shape == (len(contact.points), 3)
        # node by node against the independent solve, matched by position
        end, pairs = solution.stage_end(stage), solution.pairs
        node = np.argmin(np.linalg.norm(contact.points[:, None, :model.dim] - pairs.position[None], axis=2), axis=0)
        np.testing.assert_allclose(contact.points[node, :model.dim], pairs.position, rtol=0, atol=1e-12)
        np.testing.assert_allclose(data["pressure_MPa"][node], solution.pressure[end], rtol=1e-9, atol=1e-9)
        np.testing.assert_array_equal(data["state"][node], solution.state[end])
        tangential = np.einsum("pk,pkd->pd", solution.slip[end], pairs.frames[:, 1:])
        np.testing.assert_allclose(data["slip_mm"][node, :model.dim], tangential, rtol=0, atol=1e-12)
    assert counts[2] > 0                                       # the pull slips somewhere: the check sees slip
    # zones: each facet's id names the zone its centre lies in (A x<0 y<0, B x>0 y<0, C x<0 y>0, D x>0 y>0 in
    # 3-D; A x<0, B x>0 in 2-D), and carries that zone's coefficient
    centre = contact.points[contact.cells[0].data].mean(axis=1)
    expected = (centre[:, 0] > 0).astype(int) + (2 * (centre[:, 1] > 0) if model.dim == 3 else 0)
    np.testing.assert_array_equal(contact.cell_data["zone"][0], expected)
    np.testing.assert_array_equal(contact.cell_data["mu"][0], np.array(list(MU[name].values()))[expected])


def test_collections_list_every_stage_and_the_readme_names_units_zones_and_regions(block2d, tmp_path):
    write_fields(tmp_path, EmbeddedBackend(block2d, None, (), keep=False).fields(MU["block2d"]))
    for name in ("solid", "contact"):
        sets = ET.parse(tmp_path / f"{name}.pvd").getroot().findall("Collection/DataSet")
        assert [(d.get("timestep"), d.get("file"), d.get("name")) for d in sets] == [
            (str(k + 1), f"{name}_{k + 1}.vtu", s.name) for k, s in enumerate(block2d.stages)]
    readme = (tmp_path / "README.txt").read_text()
    for text in ("displacement_mm", "pressure_MPa", "traction_MPa", "slip_mm", "0 open, 1 stick, 2 slip",
                 "0 A mu = 0.3", "1 B mu = 0.15", "plane strain", "tensor shear"):
        assert text in readme
    for k, region in enumerate(block2d.mesh.region_names):
        assert f"  {k} {region}\n" in readme


def test_a_second_export_with_fewer_stages_leaves_no_stale_stage_files(block2d, tmp_path):
    (tmp_path / "solid_7.vtu").write_text("old")
    (tmp_path / "contact_7.vtu").write_text("old")
    paths = write_fields(tmp_path, EmbeddedBackend(block2d, None, (), keep=False).fields(MU["block2d"]))
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)


def _example(tmp_path: Path, fields: str = "") -> Path:
    folder = tmp_path / "first"
    shutil.copytree(EXAMPLE, folder)
    for name in ("truth.toml", "identify.toml"):
        path = folder / name
        text = path.read_text() + ("" if "[run]" in path.read_text() else "[run]\n")
        path.write_text(text.replace("[run]\n", f"[run]\n{fields}"))
    return folder


def test_simulate_then_identify_on_the_first_example_write_the_fields(tmp_path, capsys):
    folder = _example(tmp_path)
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    assert main(["identify", str(folder / "identify.toml")]) == 0
    out = capsys.readouterr().out
    assert out.count("fields: 7 files") == 2
    for written in (folder / "measured.fields", folder / "runs/first/fields"):
        assert sorted(p.name for p in written.iterdir()) == ["README.txt", "contact.pvd", "contact_1.vtu",
                                                             "contact_2.vtu", "solid.pvd", "solid_1.vtu",
                                                             "solid_2.vtu"]
    truth = meshio.read(folder / "measured.fields/contact_2.vtu").cell_data
    assert {(int(z), float(mu)) for z, mu in zip(truth["zone"][0], truth["mu"][0])} == {(0, 0.30), (1, 0.15)}
    fitted = meshio.read(folder / "runs/first/fields/contact_2.vtu").cell_data
    result = json.loads((folder / "runs/first/result.json").read_text())["parameters"]
    assert {(int(z), float(mu)) for z, mu in zip(fitted["zone"][0], fitted["mu"][0])} == {
        (0, result["A"]["value"]), (1, result["B"]["value"])}


def test_fields_false_writes_none(tmp_path, capsys):
    folder = _example(tmp_path, "fields = false\n")
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    (folder / "identify.toml").write_text((folder / "identify.toml").read_text().replace(
        '[identify]\n', '[identify]\nmax_iterations = 1\n'))
    assert main(["identify", str(folder / "identify.toml")]) == 0
    assert "fields:" not in capsys.readouterr().out
    assert (folder / "runs/first/result.json").exists()
    assert not (folder / "measured.fields").exists() and not (folder / "runs/first/fields").exists()


def test_a_fields_value_that_is_not_a_boolean_exits_2_naming_the_key(tmp_path, capsys):
    folder = _example(tmp_path, 'fields = "yes"\n')
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 2
    assert "run.fields must be true or false, got 'yes'" in capsys.readouterr().err


def test_a_backend_without_fields_writes_nothing_and_says_so(tmp_path):
    class Calculix:                                             # as the CalculiX backend: no fields method
        name = "calculix"

    lines = []
    assert export_fields(Calculix(), [0.1, 0.2], tmp_path / "fields", lines.append) == []
    assert lines == ["fields: not written; the calculix backend does not provide them yet"]
    assert not (tmp_path / "fields").exists()
