"""A user's own mesh as a model (builder "mesh", docs/models.md "Your own mesh"): .msh, .inp and .geo files,
reference test 1 rebuilt from a user's mesh, a plane-strain twin end to end, and every class of bad input.

Fixtures: tests/fixtures/user_block (generate.py writes block.msh, the same mesh as block.inp, and plane.msh).
"""

import json
import os
import shutil
import signal
import tomllib
from pathlib import Path

import gmsh
import numpy as np
import pytest

from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.block import block_model
from frictionid.builders.gmsh_mesh import gmsh_session
from frictionid.builders.mesh import mesh_model, source_files
from frictionid.builders.registry import build_model, refined
from frictionid.cli import main
from frictionid.config import read_config
from frictionid.data.measurements import read_measurements
from frictionid.errors import InputError
from frictionid.fem.assembly import load_channels
from frictionid.fem.space import Space
from fixtures.user_block import generate
from helpers.meshes import stacked_rectangles_geo
from frictionid.options import ModelSpec

FIXTURES = Path(__file__).parent / "fixtures" / "user_block"
QUANTITIES = ("ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz")
TRUTH = {"A": 0.35, "B": 0.2, "C": 0.45, "D": 0.15}
#: the same mesh read from two formats: only the summation order of the assembly may differ (issue 14)
SAME_MESH_RTOL = 1e-9
#: issue 14: the user's mesh of reference test 1 within 2 % of range of the block builder at a similar mesh size
BUILDER_RANGE_TOL = 0.02
#: issue 14: noise-free twin on the same mesh
TWIN_TOL = 1e-3


@pytest.fixture()
def folder(tmp_path):
    """A copy of the fixtures (configs, meshes, points), so that runs write into a temporary folder."""
    shutil.copytree(FIXTURES, tmp_path / "user_block")
    return tmp_path / "user_block"


def options(name: str = "truth.toml") -> dict:
    """The [model] table of a fixture config, its file resolved against the fixture folder."""
    return read_config(FIXTURES / name).model.table()


def points() -> np.ndarray:
    source = read_measurements(FIXTURES / "points.csv")
    return np.asarray(source.coordinates)


def predict(model) -> np.ndarray:
    """(n_stages, n_points * 9 + 1): every strain and displacement at the fixture points, and the machine force."""
    backend = EmbeddedBackend(model, points(), QUANTITIES, None, ("block_top.y",))
    return backend.predict(np.array([TRUTH[z] for z in model.zone_names])).values


# ------------------------------------------------------------------------------------ reference test 1, 3-D

@pytest.mark.slow          # 58 s in the fast suite on the shared machine (about 1/7 idle)
def test_msh_and_inp_give_the_same_model_and_the_block_builders_results():
    """block.msh and block.inp (the same mesh, names in upper case, the plate bottom as a node set) give one
    result; the mesh has the block builder's layout at mesh_size 1.25 (8 divisions per block side, uniform), so
    the builder's results agree within round-off, well inside issue 14's 2 % of range."""
    from_msh = build_model(ModelSpec.from_table(options()))
    from_inp = build_model(ModelSpec.from_table({**options(), "file": str(FIXTURES / "block.inp")}))
    assert from_msh.zone_names == from_inp.zone_names == ("A", "B", "C", "D")
    assert set(from_inp.mesh.regions) == {"plate", "block"} and from_inp.mesh.n_nodes == 3374
    np.testing.assert_array_equal(from_msh.mesh.points, from_inp.mesh.points)
    msh, inp = predict(from_msh), predict(from_inp)
    np.testing.assert_allclose(inp, msh, rtol=0, atol=SAME_MESH_RTOL * np.abs(msh).max())
    builder = predict(block_model(mesh_size=1.25, block_divisions=8, grading=1.0, element="standard"))
    assert abs(msh[-1, -1] - builder[-1, -1]) <= BUILDER_RANGE_TOL * abs(builder[-1, -1])   # machine force
    for stage in (0, 1):
        ours = msh[stage, :-1].reshape(-1, len(QUANTITIES))
        theirs = builder[stage, :-1].reshape(-1, len(QUANTITIES))
        spread = np.ptp(theirs, axis=0)
        assert np.all(np.abs(ours - theirs).max(axis=0) <= BUILDER_RANGE_TOL * spread), stage


@pytest.mark.slow
def test_a_users_27_node_hexahedra_of_the_builders_layout_give_the_builders_results(tmp_path):
    """gmsh's quadratic hexahedra (27 nodes, gmsh's node order read through meshio) on the builder's layout at
    2.5 mm (4 divisions per block side, uniform, the plate outside growing by 1.2 in 5 elements): the builder's
    order-2 results to round-off, every quantity at the fixture's points, both stages."""
    from element_models import write_hex_block
    path = write_hex_block(tmp_path / "hex27.msh", order=2, quarter=2, outer=5, block_z=4, plate_z=2, bump=1.0,
                           z_ratio=1.0)
    user_model = build_model(ModelSpec.from_table({**options(), "file": str(path)}))
    builder_model = block_model(mesh_size=2.5, order=2, block_divisions=4, grading=1.0)
    assert user_model.mesh.cell_type == builder_model.mesh.cell_type == "hexahedron27"
    assert user_model.mesh.n_nodes == builder_model.mesh.n_nodes
    user, builder = predict(user_model), predict(builder_model)
    n_points = len(points())
    for stage in (0, 1):                  # each quantity against its own scale (strains are 1e-4, forces 1e3)
        ours, theirs = user[stage, :-1].reshape(n_points, -1), builder[stage, :-1].reshape(n_points, -1)
        scale = np.abs(theirs).max(axis=0)
        assert np.all(np.abs(ours - theirs) <= SAME_MESH_RTOL * scale), (stage, np.abs(ours - theirs).max(axis=0) / scale)
    assert user[-1, -1] == pytest.approx(builder[-1, -1], rel=SAME_MESH_RTOL)
    assert abs(builder[-1, -1]) > 500.0                                     # the pull slides: sum mu_i N_i


@pytest.mark.slow          # 69 s in the fast suite on the shared machine (about 1/7 idle)
def test_twin_on_the_user_mesh_recovers_the_four_zones(folder):
    """Data simulated from block.msh at the truth, identified on block.inp from 0.1 (noise-free, same mesh)."""
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    assert main(["identify", str(folder / "identify.toml")]) == 0
    result = json.loads((folder / "runs/identify/result.json").read_text())
    assert result["status"] == "converged"
    for zone, value in TRUTH.items():
        assert abs(result["parameters"][zone]["value"] - value) < TWIN_TOL, zone


# ------------------------------------------------------------------------------------ plane strain, .geo

def test_plane_strain_user_mesh_end_to_end(folder):
    """plane.msh (quadratic triangles): a force per mm of thickness pushes the block, the twin recovers A, B."""
    model = build_model(ModelSpec.from_table(options("plane_truth.toml")))
    assert model.kind == "plane_strain" and model.mesh.cell_type == "triangle6"
    channels = load_channels(Space.build(model.mesh, model.kind), model)
    force = channels.forces[list(channels.names).index("SurfaceForce(block_top)")].reshape(-1, 2)
    np.testing.assert_allclose(force.sum(axis=0), [0.0, 1.0], atol=1e-12)     # unit channel: 1 N/mm in y
    assert main(["simulate", str(folder / "plane_truth.toml"), "--out", str(folder / "plane_measured.csv")]) == 0
    assert main(["identify", str(folder / "plane_identify.toml")]) == 0
    result = json.loads((folder / "runs/plane/result.json").read_text())
    assert result["status"] == "converged"
    for zone, value in {"A": 0.3, "B": 0.15}.items():
        assert abs(result["parameters"][zone]["value"] - value) < TWIN_TOL, zone


#: a ring pressed on a ring, axisymmetric (x = r, y the axis)
RING_GEO = stacked_rectangles_geo(2.0)


def test_geo_file_axisymmetric_force_is_the_whole_ring_and_ctrl_c_still_works(tmp_path):
    (tmp_path / "rings.geo").write_text(RING_GEO)
    # Python's own handler, as the command line has it (a test runner's worker may ignore SIGINT instead)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        model = mesh_model(tmp_path / "rings.geo", kind="axisymmetric", stages=["press"],
                           materials={"lower": {"E": 200000, "nu": 0.3}, "upper": {"E": 200000, "nu": 0.3}},
                           supports=[{"boundary": "bottom", "components": ["x", "y"]}],
                           loads=[{"type": "force", "boundary": "upper_top", "component": "y",
                                   "values": [-1000.0]}],
                           interfaces=[{"name": "rings", "zones": ["upper_bottom"], "target": "lower_top"}])
        handler = signal.getsignal(signal.SIGINT)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert handler is signal.default_int_handler                               # gmsh left Python's handler
    assert model.kind == "axisymmetric" and model.mesh.points[:, 0].min() == pytest.approx(2.0)
    channels = load_channels(Space.build(model.mesh, model.kind), model)
    force = channels.forces[0].reshape(-1, 2)
    np.testing.assert_allclose(force.sum(axis=0), [0.0, 1.0], atol=1e-10)    # whole ring: 1 N at unit amplitude


# ------------------------------------------------------------------------------------ bad input

def _edited(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new)


MECHANISM = ('[[model.supports]]\nboundary = "plate_bottom"\ncomponents = ["x", "y", "z"]',
             '[[model.supports]]\nboundary = "plate_bottom"\ncomponents = ["z"]')
BAD_INPUT = {
    "missing file": ([('file = "block.msh"', 'file = "no_such_mesh.msh"')], ["no_such_mesh.msh", "no such file"]),
    "unknown group": ([('boundary = "plate_bottom"', 'boundary = "plate_botom"')],
                      ["plate_botom", "did you mean 'plate_bottom'?", "plate_top"]),
    "zone on the far side": ([('zones = ["A", "B", "C", "D"]', 'zones = ["A", "B", "C", "block_top"]')],
                             ["'block_top' is not on the contact side", "block_plate"]),
    "zone on the target body": ([('zones = ["A", "B", "C", "D"]', 'zones = ["A", "B", "C", "plate_bottom"]')],
                                ["'plate_bottom' is not on the contact side", "same body"]),
    "region without material": ([("block = { E = 71000, nu = 0.33 }\n", "")],
                                ["[model.materials]", "['block'] have no material"]),
    "mechanism": ([MECHANISM, ('component = "x"', 'component = "z"'),
                   ("values = [0.0, 0.0]", "values = [-0.01, -0.01]"),
                   ('component = "y"\nvalues = [0.0, 0.2]', 'component = "z"\nvalues = [-0.01, -0.01]')],
                  ["[[model.supports]]", "'plate'", "'block'", "translation in x", "rotation about z"]),
    "unknown key": ([('target = "plate_top"', 'targets = "plate_top"')], ["unknown key 'targets'", "'target'"]),
    "pressure on a node set": ([('type = "pressure"                  # 20 MPa on the 10 x 10 mm block top: '
                                 '2000 N\nboundary = "block_top"', 'type = "pressure"\nboundary = "plate_bottom"'),
                                ('file = "block.msh"', 'file = "block.inp"')],
                               ["'plate_bottom'", "node set", "*SURFACE"]),
}


@pytest.mark.parametrize("case", BAD_INPUT, ids=list(BAD_INPUT))
def test_bad_input_names_the_key_and_exits_2_without_traceback(case, folder, capsys):
    edits, expected = BAD_INPUT[case]
    text = (folder / "truth.toml").read_text()
    for old, new in edits:
        text = _edited(text, old, new)
    (folder / "bad.toml").write_text(text)
    with pytest.raises(InputError) as error:
        build_model(read_config(folder / "bad.toml").model)
    for part in expected:
        assert part in str(error.value), (part, str(error.value))
    assert main(["simulate", str(folder / "bad.toml"), "--out", str(folder / "out.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("frictionid: error:") and expected[0] in err and "Traceback" not in err


def test_bodies_sharing_nodes_at_the_interface_are_refused_with_the_count(tmp_path):
    """gmsh's fragment merges the touching block and base into one conforming mesh: 11 shared interface nodes."""
    path = tmp_path / "merged.msh"
    with gmsh_session("merged"):
        occ = gmsh.model.occ
        base, block = occ.addRectangle(-10, -2, 0, 20, 2), occ.addRectangle(-5, 0, 0, 10, 10)
        occ.fragment([(2, base)], [(2, block)])
        occ.synchronize()
        lines = {}
        for _, tag in gmsh.model.getEntities(1):
            x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, tag)
            lines.setdefault((round(y0, 6), round(y1, 6), round(x1 - x0, 6)), []).append(tag)
        gmsh.model.addPhysicalGroup(2, [base], name="base")
        gmsh.model.addPhysicalGroup(2, [block], name="block")
        gmsh.model.addPhysicalGroup(1, lines[(0.0, 0.0, 10.0)], name="contact")        # shared by both
        gmsh.model.addPhysicalGroup(1, lines[(-2.0, -2.0, 20.0)], name="bottom")
        for _, tag in gmsh.model.getEntities(1):
            gmsh.model.mesh.setTransfiniteCurve(tag, 11)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    with pytest.raises(InputError, match=r"11 node\(s\) of its zones are also nodes of target 'contact'"):
        mesh_model(path, kind="plane_strain", materials={"base": {"E": 1, "nu": 0.3}, "block": {"E": 1, "nu": 0.3}},
                   supports=[{"boundary": "bottom"}],
                   interfaces=[{"name": "joint", "zones": ["contact"], "target": "contact"}])


NODES = """** six nodes of two squares
*Node
1, 0, 0
2, 1, 0
3, 1, 1
4, 0, 1
5, 2, 0
6, 2, 1
"""
DECK = """*HEADING
two squares side by side, x in [0, 2], y in [0, 1]
*INCLUDE, INPUT=nodes.inp
*ELEMENT, TYPE={type}, ELSET=Left
1, 1, 2, 3, 4
*ELEMENT, TYPE={type}, ELSET=RIGHT
2, 2, 5, 6, 3
*NSET, NSET={nset}, GENERATE
1, 4, 3
*SURFACE, NAME=Bottom
Left, S1
2, S1
"""


def test_inp_names_are_case_insensitive_but_two_spellings_of_one_name_are_refused(tmp_path, caplog):
    """Also: *INCLUDE, GENERATE, element-face surfaces built from an element set and an element number."""
    (tmp_path / "nodes.inp").write_text(NODES)
    path = tmp_path / "two.inp"
    path.write_text(DECK.format(type="CPE4", nset="fixed"))
    model = mesh_model(path, kind="plane_strain", materials={"left": {"E": 1, "nu": 0.3}, "Right": {"E": 1, "nu": 0.3}},
                       supports=[{"boundary": "FIXED"}], loads=[{"type": "pressure", "boundary": "bottom",
                                                                 "values": [1.0]}])
    assert "keywords ignored" in caplog.text and "*HEADING" in caplog.text           # the note
    assert set(model.mesh.regions) == {"left", "Right"}
    assert model.mesh.boundary_nodes("FIXED").tolist() == [0, 3]
    assert sorted(model.mesh.boundary_nodes("bottom").tolist()) == [0, 1, 4]
    path.write_text(DECK.format(type="CPE4", nset="fixed") + "*ELSET, ELSET=right\n1\n")
    with pytest.raises(InputError, match="element set 'right' and 'RIGHT' differ only in case"):
        mesh_model(path, kind="plane_strain", materials={"left": {"E": 1, "nu": 0.3}})


def test_inp_element_type_without_a_cell_is_refused_by_name(tmp_path):
    (tmp_path / "nodes.inp").write_text(NODES)
    path = tmp_path / "shell.inp"
    path.write_text(DECK.format(type="S4R", nset="fixed"))
    with pytest.raises(InputError, match="element type 'S4R' has no matching cell"):
        mesh_model(path, kind="plane_strain", materials={"left": {"E": 1, "nu": 0.3}})


def test_a_user_mesh_is_refined_by_subdivision(folder):
    """tests/test_subdivide.py has the geometry, the groups and the convergence; here: the option it raises."""
    table = options("plane_identify.toml")
    once = refined(ModelSpec.from_table(table))
    assert once.option("refine") == 1 and refined(once).option("refine") == 2


def test_relative_file_is_resolved_against_the_config_folder(folder, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)                                           # not the config's folder
    assert tomllib.loads((folder / "truth.toml").read_text())["model"]["file"] == "block.msh"
    assert read_config(folder / "truth.toml").model.option("file") == str(folder.resolve() / "block.msh")


def _two_regions(folder):
    """The two-region plane-strain deck (its nodes in an *INCLUDE file) written to ``folder`` and its [model]
    table."""
    (folder / "nodes.inp").write_text(NODES)
    path = folder / "two.inp"
    path.write_text(DECK.format(type="CPE4", nset="fixed"))
    return path, {"builder": "mesh", "file": str(path), "kind": "plane_strain",
                  "materials": {"left": {"E": 1, "nu": 0.3}, "right": {"E": 1, "nu": 0.3}},
                  "supports": [{"boundary": "fixed"}]}


def test_a_mesh_file_written_again_builds_a_new_model(tmp_path):
    """build_model keeps recent models by their [model] table; a rewritten mesh file must not return the old one."""
    path, table = _two_regions(tmp_path)
    first = build_model(ModelSpec.from_table(table))
    assert build_model(ModelSpec.from_table(table)) is first
    (tmp_path / "nodes.inp").write_text(NODES.replace("6, 2, 1", "6, 2, 1.5"))
    path.write_text(DECK.format(type="CPE4", nset="fixed") + "** written again\n")
    second = build_model(ModelSpec.from_table(table))
    assert second is not first and second.mesh.points[:, 1].max() == 1.5


def test_an_included_file_written_again_builds_a_new_model(tmp_path):
    """The deck untouched, only its *INCLUDE file rewritten (same size): a new model, not the kept one."""
    path, table = _two_regions(tmp_path)
    first = build_model(ModelSpec.from_table(table))
    assert source_files(path) == [path, tmp_path / "nodes.inp"]
    (tmp_path / "nodes.inp").write_text(NODES.replace("6, 2, 1", "6, 2, 2"))
    stat = (tmp_path / "nodes.inp").stat()
    os.utime(tmp_path / "nodes.inp", ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))   # coarse clocks
    second = build_model(ModelSpec.from_table(table))
    assert second is not first and second.mesh.points[:, 1].max() == 2.0


def test_source_files_follow_geo_include_and_merge(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "inner.geo").write_text('Merge "shape.step";\n')
    (tmp_path / "sub" / "shape.step").write_text("ISO-10303-21;\n")
    (tmp_path / "outer.geo").write_text('// Include "commented.geo";\nInclude "sub/inner.geo";\n'
                                        'Merge "missing.msh";\n')
    assert source_files(tmp_path / "outer.geo") == [tmp_path / "outer.geo", tmp_path / "sub" / "inner.geo",
                                                    tmp_path / "sub" / "shape.step"]


STRIP_GEO = """// a strip held at its bottom in y and at one corner point in x (a physical point group)
SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 4, 1};
Physical Surface("strip") = {1};
Physical Curve("bottom") = {1};
Physical Curve("top") = {3};
Physical Point("corner") = {1};
Point(10) = {9, 9, 0};
Physical Point("far") = {10};                  // construction geometry: a node of no cell
Mesh.MeshSizeMax = 0.5;
"""


def test_physical_points_of_a_gmsh_file_are_node_sets_for_supports(tmp_path, caplog):
    """A point group holds the one node at (0, 0) in x; without it the strip slides in x (a mechanism, refused).
    A point group outside the mesh is no node set, with a warning."""
    (tmp_path / "strip.geo").write_text(STRIP_GEO)
    options = dict(kind="plane_strain", materials={"strip": {"E": 1000.0, "nu": 0.3}},
                   loads=[{"type": "pressure", "boundary": "top", "values": [1.0]}])
    model = mesh_model(tmp_path / "strip.geo", supports=[{"boundary": "bottom", "components": ["y"]},
                                                         {"boundary": "corner", "components": ["x"]}], **options)
    nodes = model.mesh.boundary_nodes("corner")
    assert len(nodes) == 1 and np.allclose(model.mesh.points[nodes[0]], [0.0, 0.0])
    assert "physical group 'far' (points) has no node of a cell" in caplog.text
    with pytest.raises(InputError, match="translation in x"):
        mesh_model(tmp_path / "strip.geo", supports=[{"boundary": "bottom", "components": ["y"]}], **options)
    with pytest.raises(InputError, match="'corner'.*node set"):
        mesh_model(tmp_path / "strip.geo", supports=[{"boundary": "bottom", "components": ["y"]},
                                                     {"boundary": "corner", "components": ["x"]}],
                   **{**options, "loads": [{"type": "pressure", "boundary": "corner", "values": [1.0]}]})


@pytest.mark.slow
@pytest.mark.parametrize("family", ["hex", "tet10"])
def test_a_user_mesh_of_another_layout_gives_the_block_builders_machine_force(family, tmp_path, monkeypatch):
    """Issue 14's "within 2 % of the block builder at a similar mesh size" where it holds on a mesh of another
    layout: the machine force at the end of the pull (gross slip). 2.5 mm: the builder's default (graded,
    incompatible modes, 800 nodes) against gmsh's uniform standard hexahedra (generate.py's layout, 632 nodes)
    and gmsh's quadratic tetrahedra (2,772 nodes). Measured -0.12 % and -0.77 % (benchmarks/user_mesh_convergence.py,
    which also has the displacements and strains: those differ by more than 2 % of range on every affordable
    mesh, as the builder's own results do between 1.25 and 1 mm)."""
    if family == "tet10":
        from element_models import write_tet_block
        path = write_tet_block(tmp_path / "tet10.msh", order=2, quarter=2, outer=3, block_z=4, plate_z=2)
    else:
        for name, value in {"N_QUARTER": 2, "N_OUTER": 4, "N_BLOCK_Z": 4, "N_PLATE_Z": 2}.items():
            monkeypatch.setattr(generate, name, value)      # the module is shared: restored after the test
        path = tmp_path / "hex.msh"
        generate.write_block_msh(path)
    user = predict(build_model(ModelSpec.from_table({**options(), "file": str(path)})))
    builder = predict(block_model(mesh_size=2.5))
    assert abs(user[-1, -1] - builder[-1, -1]) <= BUILDER_RANGE_TOL * abs(builder[-1, -1])
    assert abs(builder[-1, -1]) > 500.0                                     # the pull slides: sum mu_i N_i


def test_a_file_gmsh_cannot_parse_leaves_later_files_readable(tmp_path):
    """gmsh's script parser keeps a failed file's unread tokens: without the reset the next .geo of the process
    failed ("Unknown variable", "syntax error" at line 0); a .msh that is not one is refused before gmsh."""
    from frictionid.builders.gmsh_mesh import read_gmsh_file
    square = tmp_path / "square.geo"
    square.write_text("h = 0.5;\nPoint(1) = {0, 0, 0, h}; Point(2) = {1, 0, 0, h}; Point(3) = {1, 1, 0, h};\n"
                      "Point(4) = {0, 1, 0, h}; Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4};\n"
                      "Line(4) = {4, 1}; Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};\n"
                      'Physical Surface("plate") = {1};\n')
    (tmp_path / "bad.geo").write_text("Point(1) = {0, 0, 0, 1};\nthis is not a script ; with tokens left over\n")
    (tmp_path / "bad.msh").write_text("this is not a mesh\n")
    n_nodes = read_gmsh_file(square)[0].n_nodes
    with pytest.raises(InputError, match="not a gmsh mesh file"):
        read_gmsh_file(tmp_path / "bad.msh")
    with pytest.raises(InputError, match="bad.geo: gmsh could not mesh it"):
        read_gmsh_file(tmp_path / "bad.geo")
    assert read_gmsh_file(square)[0].n_nodes == n_nodes
