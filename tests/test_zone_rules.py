"""Friction zones by rules (issue 14 item 2, docs/models.md "Zones by rules"): each rule kind on facets with known
answers, the quadrants of tests/fixtures/user_block as rules against the file's own groups A-D (same facets, same
results), a coarser partition of the same mesh, and every class of bad input through the command line."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.registry import build_model
from frictionid.builders.zone_rules import classify, split_facets, zone_rule, zone_rules
from frictionid.cli import main
from frictionid.config import read_config
from frictionid.data.measurements import read_measurements
from frictionid.errors import InputError
from frictionid.options import ModelSpec

FIXTURES = Path(__file__).parent / "fixtures" / "user_block"
QUANTITIES = ("ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz")
TRUTH = {"A": 0.35, "B": 0.2, "C": 0.45, "D": 0.15}
#: issue 14: zones given by rules or as the file's groups are the same facets, so the results agree to round-off
SAME_ZONES_RTOL = 1e-12
TOL = 1e-9          # [mm] boundary tolerance of the unit tests

QUADRANT_BOXES = [{"name": "SW", "box": {"min": [-5, -5, -1], "max": [0, 0, 1]}},
                  {"name": "SE", "box": {"min": [0, -5, -1], "max": [5, 0, 1]}},
                  {"name": "NW", "box": {"min": [-5, 0, -1], "max": [0, 5, 1]}},
                  {"name": "NE", "all": True}]
#: the same quadrants as half-spaces x <= 0 / x >= 0 intersected with axial sections along y
QUADRANT_PLANES = [{"name": "SW", "plane": {"point": [0, 0, 0], "normal": [-1, 0, 0]},
                    "axial": {"axis": [0, 1, 0], "max": 0.0}},
                   {"name": "SE", "axial": {"axis": [0, 1, 0], "max": 0.0}},
                   {"name": "NW", "plane": {"point": [0, 0, 0], "normal": [-1, 0, 0]}},
                   {"name": "NE", "plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}}]
AS_GROUP = {"SW": "A", "SE": "B", "NW": "C", "NE": "D"}


def options(interface: dict | None = None) -> dict:
    """The [model] table of the fixture's truth.toml, its interface replaced by ``interface``."""
    model = read_config(FIXTURES / "truth.toml").model.table()
    if interface is None:
        return model
    return {**model, "interfaces": [{"name": "block_plate", "target": "plate_top", **interface}]}


def predict(model, mu: dict) -> np.ndarray:
    """(n_stages, n_points * 9 + 1): every displacement and strain at the fixture points, and the machine force."""
    points = np.asarray(read_measurements(FIXTURES / "points.csv").coordinates)
    backend = EmbeddedBackend(model, points, QUANTITIES, None, ("block_top.y",))
    return backend.predict(model.coefficients(mu)).values


@pytest.fixture(scope="module")
def by_groups():
    """The fixture's model (zones A-D as physical groups) and its results at the truth."""
    model = build_model(ModelSpec.from_table(options()))
    return model, predict(model, TRUTH)


# ------------------------------------------------------------------------------------ the user block

@pytest.mark.parametrize("rules", [QUADRANT_BOXES, QUADRANT_PLANES], ids=["boxes", "planes"])
def test_quadrant_rules_are_the_files_zones(rules, by_groups):
    groups, expected = by_groups
    model = build_model(ModelSpec.from_table(options({"contact": ["A", "B", "C", "D"], "zone_rules": rules})))
    assert model.zone_names == ("SW", "SE", "NW", "NE")
    assert not {"A", "B", "C", "D"} & set(model.mesh.boundaries)     # the contact groups are not zones
    for zone, group in AS_GROUP.items():
        np.testing.assert_array_equal(model.mesh.boundaries[zone], groups.mesh.boundaries[group])
    got = predict(model, {zone: TRUTH[group] for zone, group in AS_GROUP.items()})
    np.testing.assert_allclose(got, expected, rtol=0, atol=SAME_ZONES_RTOL * np.abs(expected).max())


def test_zones_and_rules_together_split_the_rest(by_groups):
    """``zones`` from the file (A, B) besides rules that split the other boundaries (C, D)."""
    groups, _ = by_groups
    model = build_model(ModelSpec.from_table(options({"zones": ["A", "B"], "contact": ["C", "D"],
                                 "zone_rules": [QUADRANT_BOXES[2], QUADRANT_BOXES[3]]})))
    assert model.zone_names == ("A", "B", "NW", "NE")
    for zone, group in {"A": "A", "B": "B", "NW": "C", "NE": "D"}.items():
        np.testing.assert_array_equal(model.mesh.boundaries[zone], groups.mesh.boundaries[group])


def test_front_and_rear_is_the_quadrant_model_with_equal_neighbours(by_groups):
    """A coarser partition of the same mesh: rear (y <= 0) and front. With mu_A = mu_B = rear and mu_C = mu_D =
    front the quadrant model is the same contact problem (a node on a border gets the area-weighted mean)."""
    groups, _ = by_groups
    model = build_model(ModelSpec.from_table(options({"contact": ["A", "B", "C", "D"], "zone_rules": [
        {"name": "rear", "plane": {"point": [0, 0, 0], "normal": [0, -1, 0]}}, {"name": "front", "all": True}]})))
    assert model.zone_names == ("rear", "front")
    assert [len(model.mesh.boundaries[z]) for z in model.zone_names] == [32, 32]
    got = predict(model, {"rear": 0.2, "front": 0.4})
    expected = predict(groups, {"A": 0.2, "B": 0.2, "C": 0.4, "D": 0.4})
    np.testing.assert_allclose(got, expected, rtol=0, atol=SAME_ZONES_RTOL * np.abs(expected).max())
    other = predict(model, {"rear": 0.4, "front": 0.2})
    assert np.abs(other - got).max() > 1e-3 * np.abs(got).max()         # the two zones do act


def test_supports_and_loads_may_name_zones_made_by_rules(by_groups):
    """A displacement on a rule-made zone acts on that zone's nodes: the same model as naming the file's group."""
    groups, _ = by_groups
    held = {"type": "displacement", "boundary": "SW", "component": "z", "values": [0.0, 0.0]}
    table = options({"contact": ["A", "B", "C", "D"], "zone_rules": QUADRANT_BOXES})
    model = build_model(ModelSpec.from_table({**table, "loads": [*table["loads"], held],
                         "supports": [*table["supports"], {"boundary": "NE", "components": ["z"]}]}))
    assert model.loads[-1].boundary == "SW" and model.supports[-1].boundary == "NE"
    np.testing.assert_array_equal(model.mesh.boundary_nodes("SW"), groups.mesh.boundary_nodes("A"))
    np.testing.assert_array_equal(model.mesh.boundary_nodes("NE"), groups.mesh.boundary_nodes("D"))
    with pytest.raises(InputError, match="no boundary or node set of that name"):
        build_model(ModelSpec.from_table({**table, "supports": [{"boundary": "SWW", "components": ["z"]}]}))


# ------------------------------------------------------------------------------------ each rule kind

def _members(table: dict, x) -> list[bool]:
    x = np.asarray(x, dtype=float)
    return zone_rule({"name": "Z", **table}, x.shape[1], "rule").contains(x, TOL).tolist()


def test_box_includes_its_faces_and_may_be_open():
    x = [[0, 0, 0], [1, 1, 1], [1.5, 0.5, 0.5], [0.5, -1e3, 0.5]]
    assert _members({"box": {"min": [0, 0, 0], "max": [1, 1, 1]}}, x) == [True, True, False, False]
    assert _members({"box": {"min": [0, -np.inf, 0], "max": [1, 1, 1]}}, x) == [True, True, False, True]


def test_plane_takes_the_side_its_normal_points_to():
    x = [[0.5, 7, 0], [1, -3, 2], [3, 0, 0]]                      # the normal need not be a unit vector
    assert _members({"plane": {"point": [1, 0, 0], "normal": [2, 0, 0]}}, x) == [False, True, True]
    assert _members({"plane": {"point": [1, 0, 0], "normal": [-1, 0, 0]}}, x) == [True, True, False]


def test_ring_about_the_axisymmetric_axis_and_a_3d_axis():
    """2-D with the defaults (axis y through the origin): r = x of an axisymmetric model."""
    rx = [[0.5, 10], [1.0, -4], [1.7, 0], [2.5, 3]]
    assert _members({"ring": {"r_min": 1.0, "r_max": 2.0}}, rx) == [False, True, True, False]
    x = [[1, 1, 9], [2, 1, -3], [1, 3.5, 0], [-1, 1, 0]]         # about z through (1, 1, 0): r = 0, 1, 2.5, 2
    assert _members({"ring": {"axis_point": [1, 1, 0], "axis": [0, 0, 5], "r_min": 0.5, "r_max": 2}}, x) \
        == [False, True, False, True]


def test_sector_angles_in_the_right_hand_sense_and_across_zero():
    """About z from x: (cos a, sin a) at a = 0, 30, 60, 180, 300, 330 deg; -45 ... 45 wraps through 0."""
    angles = np.radians([0, 30, 60, 180, 300, 330])
    x = np.column_stack([np.cos(angles), np.sin(angles), np.linspace(-5, 5, 6)])
    sector = {"axis": [0, 0, 1], "reference": [1, 0, 0]}
    across_zero = {**sector, "from_deg": -45, "to_deg": 45}
    assert _members({"sector": across_zero}, x) == [True, True, False, False, False, True]
    fourth = {**sector, "from_deg": 270, "to_deg": 360}
    assert _members({"sector": fourth}, x) == [True, False, False, False, True, True]
    # about y (the default axis) from x (the default reference): the right-hand sense turns x towards -z
    x = [[1, 3, 0], [0, -2, -1], [0, 0, 1], [-1, 0, -1e-3]]
    assert _members({"sector": {"from_deg": 0, "to_deg": 90}}, x) == [True, True, False, False]
    # 2-D: about axis_point, counter-clockwise from the reference
    assert _members({"sector": {"axis_point": [1, 1], "reference": [0, 1], "from_deg": 0, "to_deg": 90}},
                    [[1, 2], [0, 1], [2, 1], [0.5, 0.5]]) == [True, True, False, False]


def test_axial_section_along_an_oblique_axis():
    x = [[1, 1, 0], [2, 2, 0], [-1, 1, 5], [-1, -1, 0]]          # s = sqrt 2, 2 sqrt 2, 0, -sqrt 2
    assert _members({"axial": {"axis_point": [0, 0, 0], "axis": [1, 1, 0], "min": 0, "max": 2 ** 0.5}}, x) \
        == [True, False, True, False]


def test_several_kinds_intersect_and_the_first_matching_rule_wins():
    """Two radial bands x two axial sections of an axisymmetric flank (the bolt's zones), then the rest."""
    rules = zone_rules([{"name": "outer_1", "ring": {"r_min": 9}, "axial": {"max": 100}},
                        {"name": "inner_1", "axial": {"max": 100}},
                        {"name": "outer", "ring": {"r_min": 9}},
                        {"name": "rest", "all": True}], 2, "zone_rules")
    x = np.array([[9.5, 99], [8.5, 99], [9.0, 100], [9.5, 101], [8.5, 101]])
    assert classify(x, rules, TOL).tolist() == [0, 1, 0, 2, 3]


def test_split_facets_keeps_each_zones_facets_in_order():
    points = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0]], dtype=float)
    facets = np.array([[3, 4], [0, 1], [2, 3], [1, 2]])               # centroids x = 3.5, 0.5, 2.5, 1.5
    rules = zone_rules([{"name": "left", "box": {"min": [0, -1], "max": [2, 1]}}, {"name": "right", "all": True}],
                       2, "zone_rules")
    split = split_facets(points, facets, rules, "zone_rules")
    assert list(split) == ["left", "right"]
    assert split["left"].tolist() == [[0, 1], [1, 2]] and split["right"].tolist() == [[3, 4], [2, 3]]


# ------------------------------------------------------------------------------------ bad input

RULES_AT = 'target = "plate_top"\n'
A_BOX = '[[model.interfaces.zone_rules]]\nname = "SW"\nbox = { min = [-5, -5, -1], max = [0, 0, 1] }\n'
REST = '[[model.interfaces.zone_rules]]\nname = "rest"\nall = true\n'


def _rule(body: str) -> str:
    return f"[[model.interfaces.zone_rules]]\n{body}\n"


BAD_INPUT = {
    "rule matching no facet": (_rule('name = "far"\nbox = { min = [50, 50, -1], max = [60, 60, 1] }') + REST,
                               ["zone_rules 1 ('far'): the zone would be empty", "matches no facet",
                                "x [-4.375, 4.375]"]),
    "rule after all": (REST + A_BOX, ["zone_rules 2 ('SW'): the zone would be empty",
                                      "the 16 facet(s) it matches are taken by the rules before it"]),
    "facets matched by no rule": (A_BOX, ["zone_rules: 48 of 64 facet(s) match no rule",
                                          "x [-4.375, 4.375], y [-4.375, 4.375], z [0, 0]", "all = true"]),
    "unknown kind": (_rule('name = "SW"\nboxx = { min = [-5, -5, -1], max = [0, 0, 1] }') + REST,
                     ["zone_rules 1: unknown key 'boxx' (did you mean 'box'?)", "'sector'"]),
    "unknown key of a kind": (_rule('name = "W"\nplane = { point = [0, 0, 0], normall = [-1, 0, 0] }') + REST,
                              ["zone_rules 1 plane: unknown key 'normall' (did you mean 'normal'?)"]),
    "zero normal": (_rule('name = "W"\nplane = { point = [0, 0, 0], normal = [0, 0, 0] }') + REST,
                    ["zone_rules 1 plane.normal: must not be the zero vector"]),
    "zero axis": (_rule('name = "in"\nring = { axis_point = [0, 0, 0], axis = [0, 0, 0], r_max = 2 }') + REST,
                  ["zone_rules 1 ring.axis: must not be the zero vector"]),
    "reference along the axis": (_rule('name = "q"\nsector = { axis = [0, 0, 1], reference = [0, 0, 2], '
                                       'from_deg = 0, to_deg = 90 }') + REST,
                                 ["zone_rules 1 sector.reference: must not be parallel to the axis"]),
    "vector of the wrong length": (_rule('name = "W"\nplane = { point = [0, 0], normal = [-1, 0, 0] }') + REST,
                                   ["zone_rules 1 plane.point: must be a list of 3 finite numbers"]),
    "no kind": (_rule('name = "W"') + REST, ["zone_rules 1 ('W'): needs a rule kind", "'axial'"]),
    "all not true": (A_BOX + _rule('name = "rest"\nall = false'), ["zone_rules 2 ('rest') all: must be true"]),
    "name of a boundary": (A_BOX + _rule('name = "plate_top"\nall = true'),
                           ["zone_rules 2 name = 'plate_top'", "block.msh has a boundary of that name"]),
    "name of a region": (A_BOX + _rule('name = "block"\nall = true'),
                         ["zone_rules 2 name = 'block'", "block.msh has a region of that name"]),
    "name twice": (A_BOX + _rule('name = "SW"\nall = true'), ["zone_rules 2 name: zone 'SW' is named by an earlier"]),
}


@pytest.fixture()
def folder(tmp_path):
    shutil.copytree(FIXTURES, tmp_path / "user_block")
    return tmp_path / "user_block"


def _run_bad(folder, capsys, text: str, expected: list[str]):
    (folder / "bad.toml").write_text(text)
    with pytest.raises(InputError) as error:
        build_model(read_config(folder / "bad.toml").model)
    for part in expected:
        assert part in str(error.value), (part, str(error.value))
    assert main(["simulate", str(folder / "bad.toml"), "--out", str(folder / "out.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"frictionid: error: {folder / 'bad.toml'}: [model]: [[model.interfaces]] 1")
    assert expected[0] in err
    assert "Traceback" not in err


def _with(zones_line: str, rules: str) -> str:
    text = (FIXTURES / "truth.toml").read_text()
    old = 'zones = ["A", "B", "C", "D"]\n'
    assert old in text and RULES_AT in text
    return text.replace(old, zones_line).replace(RULES_AT, RULES_AT + rules)


@pytest.mark.parametrize("case", BAD_INPUT, ids=list(BAD_INPUT))
def test_bad_rules_name_the_key_and_exit_2(case, folder, capsys):
    rules, expected = BAD_INPUT[case]
    _run_bad(folder, capsys, _with('contact = ["A", "B", "C", "D"]\n', rules), expected)


BAD_COMBINATION = {
    "zones and rules over the same facets": ('zones = ["A"]\ncontact = ["A", "B", "C", "D"]\n', REST,
                                             ["zones and zone_rules are ambiguous: 16 facet(s) of contact",
                                              "['A']"]),
    "rules without contact": ("", REST, ["zone_rules: need contact"]),
    "contact without rules": ('contact = ["A", "B", "C", "D"]\n', "", ["contact: a contact surface is split",
                                                                       "zone_rules, which are missing"]),
    "neither zones nor rules": ("", "", ["needs zones", "or contact and zone_rules"]),
    "unknown contact": ('contact = ["A", "B", "C", "DD"]\n', REST, ["contact = 'DD'", "did you mean 'D'?"]),
    "misspelt zone_rules": ('contact = "A"\n', "zone_rule = 1\n", ["unknown key 'zone_rule'",
                                                                   "did you mean 'zone_rules'?"]),
}


@pytest.mark.parametrize("case", BAD_COMBINATION, ids=list(BAD_COMBINATION))
def test_zones_contact_and_rules_that_do_not_fit_together_are_refused(case, folder, capsys):
    zones_line, rules, expected = BAD_COMBINATION[case]
    _run_bad(folder, capsys, _with(zones_line, rules), expected)
