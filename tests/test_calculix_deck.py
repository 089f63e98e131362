"""CalculiX deck export: element types and node orders, faces of contact surfaces, loads, steps; no ccx needed."""

import re

import numpy as np
import pytest

from frictionid.backends import check_backend, make_backend
from frictionid.config import config_from_dict
from frictionid.options import SolverOptions
from frictionid.backends.calculix.backend import CalculixSettings
from frictionid.backends.calculix.deck import ContactSettings, stage_forces, write_deck
from frictionid.backends.calculix.elements import (N_KEPT, SHAPE, calculix_cells, face_lookup, fill_dropped_nodes,
                                                   lump_dropped_forces)
from frictionid.builders.verification import hertz_model, interference_model, sleeve_model
from frictionid.builders.block import block_model, block_model_2d
from frictionid.errors import InputError
from frictionid.fem.assembly import load_channels
from frictionid.fem.space import Space
from frictionid.model import Mesh

from element_models import ELEMENTS, element_model

CONTACT = ContactSettings(normal_stiffness=1e6, stick_slope=2e6)
#: CalculiX edge mid-nodes (0-based corner pairs) of C3D10 and C3D20 (CalculiX manual, element chapter)
C3D10_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
#: corner nodes of the faces S1..S6 of C3D8 as the CalculiX manual numbers them (1-based there)
CCX_HEX_FACES = [(1, 2, 3, 4), (5, 8, 7, 6), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 8, 4), (4, 8, 5, 1)]
C3D20_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]


def deck_of(model, mu, contact=CONTACT):
    channels = load_channels(Space.build(model.mesh, model.kind), model)
    return write_deck(model, mu, contact, channels.forces, channels.amplitudes), channels


def cards(deck: str, keyword: str) -> list[list[str]]:
    """Data lines following each card starting with ``keyword``."""
    out, current = [], None
    for line in deck.splitlines():
        if line.startswith("*") and not line.startswith("**"):
            current = [] if line.upper().startswith(keyword) else None
            if current is not None:
                out.append(current)
        elif current is not None and not line.startswith("**"):
            current.append(line)
    return out


def test_every_zone_gets_its_own_pair_interaction_and_friction(block3d):
    mu = [0.3, 0.2, 0.4, 0.0]
    deck, _ = deck_of(block3d, mu)
    pairs = re.findall(r"\*CONTACT PAIR, INTERACTION=(I\d), TYPE=SURFACE TO SURFACE\n(SZ\d), (ST\d)", deck)
    assert pairs == [("I1", "SZ1", "ST1"), ("I2", "SZ2", "ST1"), ("I3", "SZ3", "ST1"), ("I4", "SZ4", "ST1")]
    assert [c[0] for c in cards(deck, "*FRICTION")] == ["0.3, 2000000", "0.2, 2000000", "0.4, 2000000"]
    assert deck.count("*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR\n1000000\n") == 4
    # zone D has mu = 0: frictionless, no *FRICTION card after its interaction
    assert "*SURFACE INTERACTION, NAME=I4\n*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR\n1000000\n*CONTACT" in deck


def test_contact_surfaces_are_the_zone_facets(block3d):
    deck, _ = deck_of(block3d, [0.1] * 4)
    cells = calculix_cells(block3d.mesh.points, "hexahedron", block3d.mesh.cells)
    surfaces = {c.split("NAME=")[1].split(",")[0]: c for c in re.findall(r"\*SURFACE, NAME=\w+, TYPE=ELEMENT", deck)}
    lines = dict(zip(surfaces, cards(deck, "*SURFACE, NAME")))
    for name, boundary in [("SZ1", "A"), ("SZ4", "D"), ("ST1", "plate_top")]:
        faces = [tuple(int(v.strip().lstrip("S")) for v in line.split(",")) for line in lines[name]]
        expected = {frozenset(f[:4].tolist()) for f in block3d.mesh.boundary(boundary)}
        got = {frozenset(cells[e - 1][[n - 1 for n in CCX_HEX_FACES[s - 1]]].tolist()) for e, s in faces}
        assert got == expected


def test_elements_regions_and_line_length(block3d):
    deck, _ = deck_of(block3d, [0.1] * 4)
    assert "*ELEMENT, TYPE=C3D8I, ELSET=E1" in deck and "*ELEMENT, TYPE=C3D8I, ELSET=E2" in deck  # the default element
    assert all(len(line.split(",")) <= 16 for line in deck.splitlines() if not line.startswith("*"))
    n_elements = sum(len(lines) for lines in cards(deck, "*ELEMENT"))
    assert n_elements == block3d.mesh.n_cells
    assert "*ELASTIC\n3500, 0.35\n*SOLID SECTION, ELSET=E1, MATERIAL=M1" in deck


def test_steps_follow_the_load_path(block3d):
    deck, channels = deck_of(block3d, [0.1] * 4)
    assert [c[0] for c in cards(deck, "*STATIC")] == ["1, 1., 1e-06, 1", "0.1, 1., 1e-07, 0.1"]
    assert [c[0] for c in cards(deck, "*CONTROLS")] == ["4, 8, 9, 16, 10, 4, , 20"] * 2
    boundary = cards(deck, "*BOUNDARY")
    assert boundary[0] == ["N1, 1, 1", "N1, 2, 2", "N1, 3, 3"]          # plate_bottom held
    assert boundary[2] == ["N3, 1, 1, 0", "N3, 2, 2, 0.2"]               # block_top pulled in stage 2
    cload = cards(deck, "*CLOAD")[1]
    total = sum(float(line.split(",")[2]) for line in cload if line.split(",")[1].strip() == "3")
    assert total == pytest.approx(-2000.0, rel=1e-12)                    # the pressure's 2000 N, downwards
    assert len(cards(deck, "*CONTACT PRINT")) == 2 * 4


def test_load_scale_scales_every_applied_force_and_displacement(block3d):
    channels = load_channels(Space.build(block3d.mesh, block3d.kind), block3d)
    full = write_deck(block3d, [0.1] * 4, CONTACT, channels.forces, channels.amplitudes)
    scaled = write_deck(block3d, [0.1] * 4, CONTACT, channels.forces, channels.amplitudes, load_scale=0.01)
    assert cards(scaled, "*BOUNDARY")[2] == ["N3, 1, 1, 0", "N3, 2, 2, 0.002"]
    for stage in (0, 1):
        a, b = ([[float(v) for v in line.split(",")] for line in cards(deck, "*CLOAD")[stage]] for deck in (full, scaled))
        np.testing.assert_array_equal(np.array(a)[:, :2], np.array(b)[:, :2])            # the same nodes and dofs
        np.testing.assert_allclose(np.array(b)[:, 2], 0.01 * np.array(a)[:, 2], rtol=1e-12)   # 13 digits printed
    # nothing else changes: penalty slopes, coefficients, steps
    rest = [line for line in full.splitlines() if not re.match(r"^\d+, \d, ", line) and "0.2" not in line]
    assert rest == [line for line in scaled.splitlines() if not re.match(r"^\d+, \d, ", line) and "0.002" not in line]


def test_every_number_fits_the_20_characters_ccx_reads(block3d):
    """ccx reads a number's first 20 characters: -4.16666666666667e-05 (21) comes back as about -4.17."""
    channels = load_channels(Space.build(block3d.mesh, block3d.kind), block3d)
    deck = write_deck(block3d, [1 / 3] * 4, CONTACT, channels.forces, channels.amplitudes, load_scale=1 / 3e6)
    fields = [f.strip() for line in deck.splitlines() if line and not line.startswith("*") for f in line.split(",")]
    assert any(re.fullmatch(r"-\d\.\d+e-\d\d", f) for f in fields)          # the case that broke it is there
    assert max(map(len, fields)) <= 20


@pytest.mark.parametrize("model, gap", [(lambda: interference_model(), "-0.01"),
                                        (lambda: hertz_model(), "")])
def test_load_scale_needs_contact_that_starts_closed(model, gap):
    """An initial gap or interference does not scale with the loads: load_scale is refused, before ccx is
    looked for, naming the key and the size of the gap."""
    with pytest.raises(InputError, match=f"load_scale: the model has initial contact gaps \\(up to {gap}"):
        make_backend(model(), None, ("ux",), solver=SolverOptions(backend="calculix", ccx="/nonexistent/ccx", load_scale=0.01))
    with pytest.raises(InputError, match="apt-get install calculix-ccx"):       # at 1 the model is fine
        make_backend(model(), None, ("ux",), solver=SolverOptions(backend="calculix", ccx="/nonexistent/ccx"))


def test_plane_strain_cells_turn_counter_clockwise():
    model = block_model_2d(mesh_size=4.0, order=2)
    cells = np.array(model.mesh.cells)
    cells[0] = cells[0][[0, 2, 1, 5, 4, 3]]                   # one clockwise cell
    out = calculix_cells(model.mesh.points, "triangle6", cells)
    a, b, c = (model.mesh.points[out[:, k]] for k in range(3))
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert np.all(area > 0)
    mid = model.mesh.points[out[:, 3]]
    np.testing.assert_allclose(mid, (a + b) / 2, atol=1e-12)   # node 4 of CPE6 on edge 1-2
    deck, _ = deck_of(model, [0.1, 0.1])
    assert "TYPE=CPE6" in deck and cards(deck, "*SOLID SECTION")[0] == ["1."]


def test_tetra10_node_order_is_calculix_order():
    corners = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2]])
    points = np.vstack([corners, [(corners[a] + corners[b]) / 2 for a, b in C3D10_EDGES]])
    # meshio's tetra10 order is the same as CalculiX's C3D10: the exported cell is unchanged
    mesh = Mesh(points, "tetra10", [np.arange(10)], {"r": [0]}, {})
    out = calculix_cells(mesh.points, "tetra10", mesh.cells)
    np.testing.assert_array_equal(out, mesh.cells)
    assert SHAPE["tetra10"] == "tet" and len(face_lookup("tetra10", out)) == 4


@pytest.mark.parametrize("builder, cell_type", [
    # uniform: straight-sided cells with mid-nodes at the edge midpoints, so that the coordinates are a field the
    # serendipity interpolation reproduces (a graded mesh's mid-nodes sit at mapped positions)
    (lambda: block_model(mesh_size=5.0, order=2, grading=1.0), "hexahedron27"),
    (lambda: block_model_2d(mesh_size=4.0, order=2, quads=True), "quad9"),
])
def test_dropped_nodes_are_interpolated_back(builder, cell_type):
    mesh = builder().mesh
    assert mesh.cell_type == cell_type
    kept = calculix_cells(mesh.points, cell_type, mesh.cells)
    if cell_type == "hexahedron27":
        for k, (a, b) in enumerate(C3D20_EDGES):
            np.testing.assert_allclose(mesh.points[kept[:, 8 + k]], (mesh.points[kept[:, a]] + mesh.points[kept[:, b]]) / 2,
                                       atol=1e-9)
    blank = np.zeros_like(mesh.points)
    used = np.unique(kept)
    blank[used] = mesh.points[used]
    # serendipity interpolation of a linear field (the coordinates) is exact at face and centre nodes
    np.testing.assert_allclose(fill_dropped_nodes(cell_type, mesh.cells, blank), mesh.points, atol=1e-9)


def test_axisymmetric_nodal_forces_are_whole_ring():
    # ccx 2.20 divides *CLOAD on CAX elements by 180 itself (measured in test_calculix_run.py)
    model = sleeve_model(size=1.0)
    deck, channels = deck_of(model, [0.1] * model.n_zones)
    whole_ring = channels.amplitudes[-1] @ channels.forces
    cload = cards(deck, "*CLOAD")[-1]
    written = sum(float(line.split(",")[1 + 1]) for line in cload if line.split(",")[1].strip() == "1")
    assert written == pytest.approx(whole_ring[0::2].sum(), rel=1e-12)
    assert abs(written) > 1e3
    assert "TYPE=CAX" in deck and "NAXIS, 1, 1" in deck      # the solid shaft has nodes on the axis


def test_wrong_number_of_coefficients(block3d):
    with pytest.raises(InputError, match="need 4 coefficients"):
        deck_of(block3d, [0.1, 0.2])


@pytest.mark.parametrize("solver, message", [
    ({"timeout": 0}, "solver.timeout must be > 0"),
    ({"threads": 0}, "solver.threads must be >= 1"),
    ({"contact": "mortar"}, "solver.contact must be .*surface-to-surface.*got 'mortar'"),
    ({"keep_work": "yes"}, "solver.keep_work must be true or false"),
    ({"stick_slope": -1.0}, "solver.stick_slope must be > 0"),
    ({"load_scale": 0.0}, "solver.load_scale must be > 0"),
    ({"tmeout": 10}, "unknown key solver.tmeout .did you mean 'timeout'"),
])
def test_bad_settings_are_refused_where_the_config_is_read(solver, message):
    """CalculixSettings takes the [solver] options as config.py checked them: the checks are config.py's."""
    with pytest.raises(InputError, match=message):
        config_from_dict({"model": {"builder": "block2d"}, "friction": {"zones": {"A": 0.1}}, "solver": solver})


def test_missing_ccx_names_the_setting_and_the_package(block3d):
    with pytest.raises(InputError, match=r"solver.ccx = '/nonexistent/ccx'.*apt-get install calculix-ccx"):
        check_backend(SolverOptions(backend="calculix", ccx="/nonexistent/ccx"), "forward")
    with pytest.raises(InputError, match="apt-get install calculix-ccx"):
        make_backend(block3d, None, ("ux",), solver=SolverOptions(backend="calculix", ccx="/nonexistent/ccx"))


def test_backend_choice_is_checked():
    with pytest.raises(InputError, match="no analytic sensitivities.*'forward' or 'central'"):
        check_backend(SolverOptions(backend="calculix", ccx="/nonexistent/ccx"), "analytic")
    with pytest.raises(InputError, match="backend = 'ansys' is not one of"):
        check_backend(SolverOptions(backend="ansys"))


def test_small_finite_difference_step_is_logged(caplog):
    # "sh" stands in for an executable found on PATH
    check_backend(SolverOptions(backend="calculix", ccx="sh"), "forward", step=1e-2)
    assert not caplog.records
    check_backend(SolverOptions(backend="calculix", ccx="sh"), "forward", step=1e-4)
    assert "identify.step = 0.0001 is small for ccx results" in caplog.text


def test_loads_on_dropped_nodes_move_to_kept_ones():
    # hexahedron27 -> C3D20: the pressure's share on the face-centre nodes must not be lost
    model = block_model(mesh_size=5.0, order=2)
    deck, _ = deck_of(model, [0.1] * 4)
    kept = set(np.unique(calculix_cells(model.mesh.points, "hexahedron27", model.mesh.cells)).tolist())
    cload = [line.split(",") for line in cards(deck, "*CLOAD")[0]]
    assert {int(node) - 1 for node, _, _ in cload} <= kept
    total = sum(float(value) for _, dof, value in cload if dof.strip() == "3")
    assert total == pytest.approx(-2000.0, rel=1e-12)


@pytest.mark.parametrize("builder, cell_type", [
    (lambda: block_model(mesh_size=5.0, order=2), "hexahedron27"),
    (lambda: block_model_2d(mesh_size=4.0, order=2, quads=True), "quad9"),
])
def test_moved_loads_do_the_same_work(builder, cell_type):
    """Forces moved off dropped nodes do the same virtual work on any field CalculiX can represent."""
    mesh = builder().mesh
    rng = np.random.default_rng(5)
    forces = rng.normal(size=mesh.points.shape)
    field = fill_dropped_nodes(cell_type, mesh.cells, rng.normal(size=mesh.points.shape))
    moved = lump_dropped_forces(cell_type, mesh.cells, forces)
    assert np.sum(moved * field) == pytest.approx(np.sum(forces * field), rel=1e-12)
    dropped = np.setdiff1d(np.arange(mesh.n_nodes), calculix_cells(mesh.points, cell_type, mesh.cells))
    assert dropped.size and np.all(moved[dropped] == 0)


# ------------------------------------------------------------------- every number as ccx 2.20 reads it back

def read_as_ccx(field: str):
    """A data field as ccx 2.20 reads it: blanks removed (its input reader drops them), then the first 20
    characters as a real (nodes.f, cload.f, boundaries.f, ...: ``read(textpart(k)(1:20), '(f20.0)')``; measured:
    1.000000000000000e-03, 21 characters, came back as 1.0, and leading blanks do not count)."""
    return float(field.replace(" ", "")[:20])


def with_round_off(model, seed=14):
    """The model's mesh with gmsh-like round-off in every coordinate: values at zero become +-1e-8 .. 1e-17
    (e.g. -2.41620220683044e-08, the coordinate of the issue) and the others get all 17 digits."""
    import dataclasses
    rng = np.random.default_rng(seed)
    points = np.array(model.mesh.points, dtype=float)
    zero = points == 0.0
    points[zero] = rng.choice([-1.0, 1.0], zero.sum()) * 10.0 ** rng.uniform(-17, -8, zero.sum())
    points[~zero] *= 1.0 + rng.uniform(-1e-15, 1e-15, (~zero).sum())
    points.flat[np.flatnonzero(zero)[0]] = -2.41620220683044e-08
    mesh = Mesh(points, model.mesh.cell_type, model.mesh.cells, dict(model.mesh.regions), dict(model.mesh.boundaries))
    return dataclasses.replace(model, mesh=mesh)


@pytest.mark.parametrize("element", ["block2d default"] + list(ELEMENTS))
def test_every_number_reads_back_as_written(element, tmp_path):
    """Issue 14: every field of the deck, read as ccx reads it, is the value frictionid meant within the 13
    printed digits, for every element type the deck writes, on meshes with gmsh round-off coordinates (the
    default 2-D block's triangles have them; the others get them added). Written with 15 digits, a coordinate
    like -2.41620220683044e-08 (21 characters) came back as -2.416202206830 and turned cells inside out
    ('nonpositive jacobian determinant')."""
    if element == "block2d default":
        model, mu = block_model_2d(), [0.3, 0.2]
    else:
        model, zones = element_model(element, tmp_path)
        model, mu = with_round_off(model), [zones[z] for z in model.zone_names]
    deck, channels = deck_of(model, mu)
    digits = 5e-13                                      # half a unit in the 13th significant digit
    keyword = None
    for line in deck.splitlines():
        if line.startswith("*"):
            keyword = keyword if line.startswith("**") else line.split(",")[0]
            continue
        if keyword == "*HEADING":                       # free text
            continue
        for field in line.split(","):
            text = field.strip()
            try:
                value = float(text)
            except ValueError:          # names (set, surface), face labels S1..S6, defaults left empty
                assert re.fullmatch(r"([A-Z][A-Z0-9]*)?", text), line
                continue
            if re.fullmatch(r"\d+", text):
                assert len(text) <= 10, line             # integers are read from 10 characters
            assert read_as_ccx(field) == value, f"{text!r} is read as {read_as_ccx(field)!r} by ccx"
    # the coordinates and nodal forces ccx reads are the model's within the printed digits
    nodes = np.array([[read_as_ccx(f) for f in line.split(",")] for line in cards(deck, "*NODE")[0]])
    np.testing.assert_array_equal(nodes[:, 0], np.arange(1, model.mesh.n_nodes + 1))
    points = np.column_stack([model.mesh.points, np.zeros((model.mesh.n_nodes, 3 - model.dim))])
    assert np.all(np.abs(nodes[:, 1:] - points) <= digits * np.abs(points))
    assert np.abs(points).min() < 1e-8 and np.any(np.abs(points) > 1.0)     # round-off and ordinary values
    written = stage_forces(model, channels.forces, channels.amplitudes)
    for stage, lines in enumerate(cards(deck, "*CLOAD")):
        for line in lines:
            node, dof, value = (read_as_ccx(f) for f in line.split(","))
            expected = written[stage, int(node) - 1, int(dof) - 1]
            assert abs(value - expected) <= digits * abs(expected)
    # the cells CalculiX gets are those of the model, with positive volume (turned counter-clockwise in 2-D)
    cells = np.array([[int(read_as_ccx(f)) for f in ",".join(chunk).split(",")]
                      for chunk in _element_records(cards(deck, "*ELEMENT"), N_KEPT[model.mesh.cell_type] + 1)])
    assert len(cells) == model.mesh.n_cells
    kept = calculix_cells(np.asarray(model.mesh.points), model.mesh.cell_type, model.mesh.cells)
    np.testing.assert_array_equal(cells[np.argsort(cells[:, 0]), 1:] - 1, kept)
    assert np.all(_corner_volumes(nodes[:, 1:], kept, model.mesh.cell_type) > 0)


def _element_records(blocks, n_entries):
    """Element data lines joined into records of ``n_entries`` entries (C3D20 takes two lines)."""
    for lines in blocks:
        record = []
        for line in lines:
            record.append(line)
            if sum(len(r.split(",")) for r in record) == n_entries:
                yield record
                record = []
        assert not record


def _corner_volumes(points, cells, cell_type):
    """Signed area (2-D, of the first three corners) or volume (3-D, of the corner tetrahedron at node 1)."""
    if SHAPE[cell_type] in ("tri", "quad"):
        a, b, c = (points[cells[:, k], :2] for k in (0, 1, 2))
        return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    corners = (0, 1, 2, 3) if SHAPE[cell_type] == "tet" else (0, 1, 3, 4)
    a, b, c, d = (points[cells[:, k]] for k in corners)
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)
