"""Model set-up checks at model build (issue 24): every contact node pairs with a target that faces it, initial
gaps within gap_tolerance, no NaN; the contact map on the console, in result.json, the report and the fields; bad
contact input exits 2 naming the config file and key, with nothing written; prescriptions of boundaries sharing a
node (finding 9); what an .inp's element type means (finding 11).

Fixture: tests/clamp_case.py, a plane-strain strip clamped between two pads (three zones per pad), with one
interface whose target spans both pads or one interface per pad.
"""

from __future__ import annotations

import json
import logging
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest

from clamp_case import TRUE, ZONES, model_options, model_table, points_csv, write_clamp
from frictionid import Parameters, identify
from frictionid.builders.mesh import mesh_model
from frictionid.builders.registry import build_model
from frictionid.cli import main
from frictionid.config import read_config
from frictionid.errors import InputError
from frictionid.fem.contact_map import FACING_DEG, GAP_FRACTION
from frictionid.fem.interface import contact_pairs, contact_setup, model_space
from frictionid.fem.space import Space
from frictionid.report.html import report_html
from frictionid.options import ModelSpec

QUANTITIES = ("ux", "uy", "exx", "exy")


def _pairs(model):
    with warnings.catch_warnings():
        warnings.simplefilter("error")                      # the NaN of the old pairing came with a RuntimeWarning
        return contact_pairs(Space.build(model.mesh, model.kind), model)


def _by_node(pairs):
    """(nodes, gaps, dense B rows, zone shares) in node order: the pairing as the solver sees it."""
    order = np.argsort(pairs.nodes)
    rows = np.concatenate([pairs.dim * order[:, None] + k for k in range(pairs.dim)], axis=1).ravel()
    return pairs.nodes[order], pairs.gap[order], pairs.B[rows].toarray(), pairs.zone_share[order]


@pytest.mark.parametrize("discretisation", ["auto", "mortar"])
def test_a_target_spanning_both_pads_pairs_each_zone_with_the_pad_it_faces(discretisation, tmp_path):
    """One interface on PADS (both pads' faces) couples exactly as one interface per pad: the same nodes, gaps,
    relative-displacement rows and zone shares; the pad behind the strip (its face turned the same way as the
    contact node's, 2 mm away) is never a partner."""
    mesh = write_clamp(tmp_path / "clamp.inp", size=0.5)
    one, two = (build_model(ModelSpec.from_table(_discretised(model_options(mesh, one_target), discretisation)))
                for one_target in (True, False))
    assert one.zone_names == two.zone_names == ZONES["T"] + ZONES["B"]
    spanning, apart = _by_node(_pairs(one)), _by_node(_pairs(two))
    np.testing.assert_array_equal(spanning[0], apart[0])
    np.testing.assert_allclose(spanning[1], 0.0, atol=1e-12)            # the pads touch the strip
    np.testing.assert_allclose(spanning[2], apart[2], atol=1e-12)
    np.testing.assert_allclose(spanning[3], apart[3], atol=1e-12)


def _discretised(options: dict, discretisation: str) -> dict:
    return {**options, "interfaces": [{**i, "discretisation": discretisation} for i in options["interfaces"]]}


def test_a_strip_thinner_than_its_facets_pairs_with_the_facing_pad(tmp_path):
    """A 0.5 mm strip of 0.5 mm facets: the far pad's face (0.5 mm away, as near as the contact facet size, far
    inside any gap tolerance by facet size) is refused by the facing check alone."""
    mesh = write_clamp(tmp_path / "clamp.inp", size=0.5, thickness=0.5)
    one, two = (build_model(ModelSpec.from_table(model_options(mesh, one_target))) for one_target in (True, False))
    spanning, apart = _by_node(_pairs(one)), _by_node(_pairs(two))
    np.testing.assert_allclose(spanning[1], 0.0, atol=1e-12)
    np.testing.assert_allclose(spanning[2], apart[2], atol=1e-12)


def test_normals_that_cancel_are_refused_instead_of_a_nan():
    """Facets of opposite normals meeting at a node (a surface folded back) give it no normal: refused by name."""
    from frictionid.fem.node_to_node import _unit_normals

    integrals = np.array([[0.0, 2.0], [0.0, 1.0 - 1.0], [3.0, 4.0]])          # node 1: +n and -n of equal area
    points = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    np.testing.assert_allclose(_unit_normals(integrals, np.array([0, 2]), points, "x"), [[0, 1], [0.6, 0.8]])
    with pytest.raises(InputError, match=r"1 node\(s\) of target 'T' .* at \[1.0, 0.0\]: a surface folded back"):
        _unit_normals(integrals, np.array([0, 1, 2]), points, "target 'T'")


def test_the_contact_map_states_pairs_gaps_facing_and_zones(tmp_path):
    """The map of the spanning interface: 2 x 25 pairs (0.5 mm quads, 12 mm pads), all closed, facing exactly;
    each zone's area is its 4 mm length (plane strain, per mm thickness); tolerance GAP_FRACTION x 0.5 mm."""
    mesh = write_clamp(tmp_path / "clamp.inp", size=0.5)
    (entry,) = contact_setup(build_model(ModelSpec.from_table(model_options(mesh, True))))
    assert (entry.name, entry.target, entry.discretisation) == ("clamp", "PADS", "node-to-node")
    assert entry.n_pairs == 50 and entry.n_left_out == 0
    assert entry.state == {"closed": 50, "open": 0, "interference": 0}
    assert entry.gap == (0.0, 0.0) and entry.facing_deg == pytest.approx(0.0, abs=1e-6)
    assert entry.gap_tolerance == pytest.approx(GAP_FRACTION * 0.5)
    for zone in ZONES["T"] + ZONES["B"]:
        assert entry.zones[zone]["area"] == pytest.approx(4.0, rel=1e-12)
        assert entry.zones[zone]["pairs"] == 9                            # 8 facets: 9 nodes, borders shared
    line = entry.line()
    assert "'clamp'" in line and "50 pairs" in line and "'PADS'" in line and "50 closed" in line


def test_the_solver_uses_the_pairs_checked_at_model_build(tmp_path):
    """contact_setup's pairs are the ones the condensation takes for that model (built once), and equal to pairs
    built afresh for an equal model."""
    from frictionid.fem.problem import Problem

    options = model_options(write_clamp(tmp_path / "clamp.inp", size=1.0), True)
    model = build_model(ModelSpec.from_table(options))
    contact_setup(model)
    checked = contact_pairs(Space.build(model.mesh, model.kind), model)
    problem = Problem.build(model)
    assert problem.pairs is checked and problem.space is model_space(model)
    fresh = _pairs(build_model(ModelSpec.from_table({**options, "increments": [1, 4]})))        # another model
    assert fresh is not checked
    for name in ("nodes", "gap", "weight", "zone_share", "frames"):
        np.testing.assert_array_equal(getattr(fresh, name), getattr(checked, name))
    assert (fresh.B != checked.B).nnz == 0


@pytest.mark.parametrize("gap", [0.3, 0.8])
def test_an_open_gap_within_the_stated_tolerance_is_mapped_with_its_size_and_state(gap, tmp_path):
    """Pads 0.3 mm (within a facet size) and 0.8 mm (beyond it) off the strip: every pair open at that gap,
    accepted with gap_tolerance = gap + 0.1."""
    mesh = write_clamp(tmp_path / "clamp.inp", size=0.5, gap=gap)
    options = model_options(mesh, True)
    options["interfaces"][0]["gap_tolerance"] = gap + 0.1
    (entry,) = contact_setup(build_model(ModelSpec.from_table(options)))
    assert entry.gap == pytest.approx((gap, gap), rel=1e-9) and entry.state["open"] == 50
    assert entry.gap_tolerance == gap + 0.1


def test_adjust_sets_meshed_gaps_to_zero_and_the_map_names_them_as_meshed(tmp_path):
    """``adjust = true`` in [[model.interfaces]]: pads meshed 0.05 mm off the strip (two meshes of one surface
    that do not meet) are solved as touching: the contact forces and the reactions equal the touching clamp's (the
    pads' rigid offset changes no stiffness) and so do the pairs' normal approaches, which with the gap kept
    are 0.05 mm larger; and the map, its console line, result.json's entry and the report
    say the gaps were set to zero from 0.05 mm as meshed."""
    from frictionid.fem.problem import Problem

    def solved(gap, adjust):
        options = model_options(write_clamp(tmp_path / f"clamp_{gap}.inp", size=1.0, gap=gap), True)
        options["interfaces"][0].update(adjust=adjust, gap_tolerance=0.1)
        model = build_model(ModelSpec.from_table(options))
        (entry,) = contact_setup(model)
        return entry, Problem.build(model).solve(dict(TRUE))

    touching, meshed_apart, apart = solved(0.0, False), solved(0.05, True), solved(0.05, False)
    entry = meshed_apart[0]
    assert entry.gap == (0.0, 0.0) and entry.adjusted_from == pytest.approx((0.05, 0.05), rel=1e-9)
    assert entry.state["closed"] == entry.n_pairs and touching[0].adjusted_from is None
    assert "initial gap 0 to 0 mm (tolerance 0.1, set to zero from 0.05 to 0.05 mm as meshed)" in entry.line()
    assert entry.as_dict()["adjusted_from"] == pytest.approx([0.05, 0.05]) and touching[0].as_dict()["adjusted_from"] is None
    page = report_html({"status": "converged", "parameters": {}, "model": {"contact": [entry.as_dict()]}}, {})
    assert "0 to 0 (set to zero from 0.05 to 0.05 as meshed)" in page
    reference, adjusted, gap = (solution for _, solution in (touching, meshed_apart, apart))
    scale = np.abs(reference.lam).max()
    np.testing.assert_allclose(adjusted.lam, reference.lam, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(adjusted.reactions, reference.reactions, rtol=0,
                               atol=1e-9 * np.abs(reference.reactions).max())
    np.testing.assert_allclose(adjusted.w, reference.w, rtol=0, atol=1e-12)
    # kept, the gap is closed first: the pads' normal approach is 0.05 mm larger (forces alike: load-controlled)
    np.testing.assert_allclose(gap.w[..., 0] - reference.w[..., 0], -0.05, atol=1e-9)


def test_adjust_in_the_config_must_be_true_or_false(tmp_path):
    options = model_options(write_clamp(tmp_path / "clamp.inp", size=1.0), True)
    options["interfaces"][0]["adjust"] = "yes"
    with pytest.raises(InputError, match=r"\[\[model.interfaces\]\] 1 adjust: must be true .* got 'yes'"):
        build_model(ModelSpec.from_table(options))


# ---------------------------------------------------------------------------------------- bad input, exit 2

def _folder(tmp_path, gap: float = 0.0, interfaces: str | None = None, one_target: bool = True,
            thickness: float = 2.0):
    write_clamp(tmp_path / "clamp.inp", size=0.5, gap=gap, thickness=thickness)
    (tmp_path / "points.csv").write_text(points_csv(QUANTITIES))
    table = model_table("clamp.inp", one_target)
    if interfaces is not None:
        table = table[:table.index("[[model.interfaces]]")] + interfaces
    zones = "{ " + ", ".join(f"{k} = {v}" for k, v in TRUE.items()) + " }"
    (tmp_path / "bad.toml").write_text(table + f'[friction]\nzones = {zones}\n[data]\nfile = "points.csv"\n'
                                       'observables = ["ux", "uy"]\nstages = [2]\n')
    return tmp_path


SWAPPED = ('[[model.interfaces]]\nname = "top"\nzones = ["T1", "T2", "T3"]\ntarget = "PAD_BOTTOM_FACE"\n{}'
           '[[model.interfaces]]\nname = "bottom"\nzones = ["B1", "B2", "B3"]\ntarget = "PAD_TOP_FACE"\n{}')
NODE_TO_NODE = 'discretisation = "node-to-node"\n'
SPANNING = '[[model.interfaces]]\nname = "clamp"\nzones = ["T1", "T2", "T3", "B1", "B2", "B3"]\ntarget = "PADS"\n'
BAD_CONTACT = {
    "gap beyond the default tolerance": (
        dict(gap=0.4), ["bad.toml", "[[model.interfaces]] 'clamp'", "50 of 50 contact pairs", "largest 0.4 mm",
                        "gap_tolerance = 0.25 mm"]),
    "gap beyond a stated tolerance": (
        dict(gap=0.4, interfaces=SPANNING + "gap_tolerance = 0.3\n"),
        ["bad.toml", "'clamp'", "gap_tolerance = 0.3 mm", "largest 0.4 mm"]),
    # the pads swapped: the lower pad's face 0.5 mm below the strip's top face, turned the same way
    "target facing away (mortar)": (
        dict(thickness=0.5, interfaces=SWAPPED.format("", "")),
        ["bad.toml", "[[model.interfaces]] 'top'", "25 contact nodes (mortar)",
         f"normals opposed within {FACING_DEG:g} deg", "'PAD_BOTTOM_FACE'"]),
    "target facing away (node-to-node)": (
        dict(thickness=0.5, interfaces=SWAPPED.format(NODE_TO_NODE, NODE_TO_NODE)),
        ["bad.toml", "[[model.interfaces]] 'top'", "25 of 25 contact nodes", "no partner",
         f"normals opposed within {FACING_DEG:g} deg"]),
    "negative gap_tolerance": (
        dict(interfaces=SPANNING + "gap_tolerance = -0.1\n"), ["[[model.interfaces]] 1 gap_tolerance", "-0.1"]),
    "gap_tolerance as text": (
        dict(interfaces=SPANNING + 'gap_tolerance = "0.5"\n'), ["[[model.interfaces]] 1 gap_tolerance", "'0.5'"]),
}


@pytest.mark.parametrize("case", BAD_CONTACT, ids=list(BAD_CONTACT))
@pytest.mark.parametrize("command", ["simulate", "identify"])
def test_bad_contact_set_up_exits_2_naming_file_and_key_and_writes_nothing(case, command, tmp_path, capsys):
    arguments, expected = BAD_CONTACT[case]
    folder = _folder(tmp_path, **arguments)
    with open(folder / "bad.toml", "a") as config:
        config.write('noise = { u = 0.001 }\n[run]\ndir = "run"\n')
    before = sorted(p.name for p in folder.iterdir())
    extra = ["--out", str(folder / "out.csv")] if command == "simulate" else []
    assert main([command, str(folder / "bad.toml"), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("frictionid: error:") and "Traceback" not in err
    for part in expected:
        assert part in err, (part, err)
    assert sorted(p.name for p in folder.iterdir()) == before


def test_the_model_object_refuses_a_bad_gap_tolerance():
    from frictionid.model import ContactInterface

    for bad in (0.0, -1.0, float("nan"), "0.5", True):
        with pytest.raises(InputError, match="gap_tolerance"):
            ContactInterface("i", ("A",), "t", gap_tolerance=bad)


# ------------------------------------------------------------------------------- end to end, on the console

def test_simulate_prints_one_contact_line_per_interface_and_the_fields_carry_the_map(tmp_path, capsys):
    """Pads overlapping the strip by 0.01 mm: the console line says so, and contact_<stage>.vtu holds the initial
    gap at every contact node, the facing angle and each facet's interface and zone."""
    folder = _folder(tmp_path, gap=-0.01, one_target=False)
    assert main(["simulate", str(folder / "bad.toml"), "--out", str(folder / "out.csv")]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("contact ")]
    assert len(lines) == 2
    assert "'upper'" in lines[0] and "'PAD_TOP_FACE'" in lines[0] and "25 pairs" in lines[0]
    assert "'lower'" in lines[1] and "'PAD_BOTTOM_FACE'" in lines[1] and "25 interference" in lines[1]
    assert "initial gap -0.01 to -0.01 mm (tolerance 0.25)" in lines[1]
    contact = meshio.read(folder / "out.fields" / "contact_1.vtu")
    np.testing.assert_allclose(contact.point_data["initial_gap_mm"], -0.01, rtol=1e-9)
    np.testing.assert_allclose(contact.point_data["facing_deg"], 0.0, atol=1e-6)
    interface, zone = contact.cell_data["interface"][0], contact.cell_data["zone"][0]
    centre_y = contact.points[contact.cells[0].data].mean(axis=1)[:, 1]
    np.testing.assert_array_equal(interface, np.where(centre_y > 0, 0, 1))      # upper: the strip's top face
    np.testing.assert_array_equal(zone // 3, interface)                         # T1-T3, then B1-B3


def test_the_report_shows_the_contact_map(tmp_path):
    mesh = write_clamp(tmp_path / "clamp.inp", size=0.5)
    contact = [entry.as_dict() for entry in contact_setup(build_model(ModelSpec.from_table(model_options(mesh, True))))]
    page = report_html({"status": "converged", "parameters": {}, "model": {"contact": contact}}, {})
    section = page[page.index("<h2>Contact set-up</h2>"):]
    section = section[:section.index("</section>")]
    assert "<td class=\"text\">PADS</td>" in section and "<td>50</td>" in section and "50 closed" in section
    assert all(f"<td class=\"text\">{zone}</td>" in section for zone in TRUE)
    assert "no contact map" in report_html({"status": "failed", "parameters": {}}, {})


@pytest.mark.slow
def test_twin_from_a_finer_correctly_paired_model_gives_the_same_coefficients_on_one_spanning_target(tmp_path):
    """Issue 24's acceptance: data made on a correctly paired finer model (0.25 mm, one interface per pad); the
    model whose one target spans both pads gives coefficients within 3 standard errors of the correctly paired
    model's (here: the same, as it pairs alike), and result.json carries the contact map."""
    write_clamp(tmp_path / "fine.inp", size=0.25)
    write_clamp(tmp_path / "coarse.inp", size=0.5)
    (tmp_path / "points.csv").write_text(points_csv(QUANTITIES))
    zones = "{ " + ", ".join(f"{k} = {v}" for k, v in TRUE.items()) + " }"
    (tmp_path / "truth.toml").write_text(model_table("fine.inp", False) + f"[friction]\nzones = {zones}\n[data]\n"
                                         'file = "points.csv"\nobservables = ["ux", "uy", "exx", "exy"]\n'
                                         "stages = [2]\n")
    assert main(["simulate", str(tmp_path / "truth.toml"), "--out", str(tmp_path / "measured.csv")]) == 0
    results = {}
    for name, one_target in (("spanning", True), ("apart", False)):
        results[name] = identify(model_options(tmp_path / "coarse.inp", one_target), tmp_path / "measured.csv",
                                 Parameters.from_dict(dict.fromkeys(TRUE, 0.1)), observables=list(QUANTITIES),
                                 stages=[2], noise={"u": 0.0002, "e": 2e-5}, run_dir=tmp_path / name)
    spanning, apart = results["spanning"], results["apart"]
    for zone, truth in TRUE.items():
        se = apart.stderr[zone]
        assert abs(spanning.coefficients[zone] - apart.coefficients[zone]) < 3 * se, zone
        assert abs(apart.coefficients[zone] - truth) < 3 * se, zone
    stored = json.loads((tmp_path / "spanning" / "result.json").read_text())["model"]["contact"]
    assert [(c["name"], c["target"], c["n_pairs"], c["state"]["closed"]) for c in stored] == [("clamp", "PADS", 50, 50)]


# ------------------------------------------------------------- prescriptions on boundaries sharing a node

def _with_left_displacement(options: dict, values) -> dict:
    return {**options, "loads": [*options["loads"], {"type": "displacement", "boundary": "LOWER_LEFT",
                                                     "component": "x", "values": values}]}


def test_a_zero_displacement_sharing_a_node_with_a_support_is_compatible(tmp_path):
    """Issue 24, finding 9: BASE is fixed and LOWER_LEFT (sharing BASE's corner node) held at x = 0 by a zero
    displacement: both hold that node's x at zero, so the model solves, and like BASE alone plus a support of
    LOWER_LEFT in x."""
    from frictionid.fem.problem import Problem

    options = model_options(write_clamp(tmp_path / "clamp.inp", size=1.0), one_target=False)
    zero = Problem.build(build_model(ModelSpec.from_table(_with_left_displacement(options, [0.0, 0.0])))).solve(TRUE)
    support = {**options, "supports": [*options["supports"], {"boundary": "LOWER_LEFT", "components": ["x"]}]}
    held = Problem.build(build_model(ModelSpec.from_table(support))).solve(TRUE)
    np.testing.assert_allclose(zero.lam, held.lam, rtol=0, atol=1e-9 * np.abs(held.lam).max())


def test_conflicting_prescriptions_on_a_shared_node_name_both_boundaries_and_the_node(tmp_path, capsys):
    folder = _folder(tmp_path)
    text = (folder / "bad.toml").read_text().replace(
        "[[model.interfaces]]", '[[model.loads]]\ntype = "displacement"\nboundary = "LOWER_LEFT"\ncomponent = "x"\n'
                                "values = [0.0, 0.01]\n[[model.interfaces]]", 1)
    (folder / "bad.toml").write_text(text)
    assert main(["simulate", str(folder / "bad.toml"), "--out", str(folder / "out.csv")]) == 2
    err = capsys.readouterr().err
    for part in ("support 'BASE' holds it at zero", "displacement on 'LOWER_LEFT' prescribes [0.0, 0.01]",
                 "node", "[0.0, -3.0]", "component x"):
        assert part in err, (part, err)
    assert not (folder / "out.csv").exists() and "Traceback" not in err


# ------------------------------------------------------------------------------------- an .inp's element type

FIXTURES = Path(__file__).parent / "fixtures" / "user_block"


def test_an_inp_of_c3d8i_is_computed_with_incompatible_modes_and_a_contradicting_element_is_warned(tmp_path,
                                                                                                      caplog):
    """Issue 24, finding 11: the deck's C3D8I mean incompatible modes; its C3D8 plain hexahedra; a config element
    that contradicts the deck is computed as configured, with a warning naming both."""
    (tmp_path / "block.inp").write_text((FIXTURES / "block.inp").read_text().replace("TYPE=C3D8,", "TYPE=C3D8I,"))
    options = {**read_config(FIXTURES / "truth.toml").model.table(), "file": str(tmp_path / "block.inp")}
    assert build_model(ModelSpec.from_table(options)).element == "incompatible"
    assert build_model(ModelSpec.from_table({**options, "file": str(FIXTURES / "block.inp")})).element == "standard"
    with caplog.at_level(logging.WARNING, logger="frictionid"):
        assert build_model(ModelSpec.from_table({**options, "element": "standard"})).element == "standard"
    assert "[model] element = 'standard' contradicts block.inp, whose C3D8I elements mean element 'incompatible'" \
        in caplog.text


@pytest.mark.parametrize("element_type, kind, note", [
    ("CPE4R", "plane_strain", "CPE4R has reduced integration (one point, hourglass control)"),
    ("CPE4I", "plane_strain", "CPE4I has incompatible modes, which frictionid has for 8-node hexahedra (C3D8I) only"),
    ("CPS4", "plane_strain", "CPS4 is a plane stress element, [model] kind = 'plane_strain'"),
    ("CAX4", "plane_strain", "CAX4 is an axisymmetric element, [model] kind = 'plane_strain'"),
])
def test_what_a_decks_element_type_means_and_frictionid_computes_otherwise_is_warned(element_type, kind, note,
                                                                                       tmp_path, caplog):
    path = tmp_path / "square.inp"
    path.write_text("*NODE\n1, 0, 0\n2, 1, 0\n3, 1, 1\n4, 0, 1\n"
                    f"*ELEMENT, TYPE={element_type}, ELSET=SQUARE\n1, 1, 2, 3, 4\n*NSET, NSET=CORNERS\n1, 2\n")
    with caplog.at_level(logging.WARNING, logger="frictionid"):
        model = mesh_model(path, kind=kind, materials={"SQUARE": {"E": 1.0, "nu": 0.3}},
                           supports=[{"boundary": "CORNERS"}])
    assert model.element == "standard" and f"square.inp: {note}" in caplog.text
