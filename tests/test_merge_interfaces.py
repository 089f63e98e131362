"""Zones on several interfaces sharing one coefficient (issue 24, finding 2: ``[friction] merge`` across
interfaces): a two-sided clamp's upper and lower zones, a bolt's head and nut bearing faces. Each zone keeps its
own contact pairs (and CalculiX contact pair and friction card); the merged coefficient's sensitivity is the sum
of its zones', checked against central differences."""

from __future__ import annotations

import numpy as np
import pytest

from clamp_case import TRUE, model_options, model_table, points_csv, write_clamp
from frictionid.backends.calculix.deck import contact_pairs as deck_pairs, write_deck, zone_columns
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.registry import build_model
from frictionid.cli import main
from frictionid.data.measurements import read_measurements
from frictionid.errors import InputError
from frictionid.fem.assembly import load_channels
from frictionid.fem.interface import contact_setup
from frictionid.fem.space import Space
from frictionid.model.merge import merge_zones
from frictionid.options import ModelSpec
from helpers.differences import central_difference

POINTS = np.array([[1.0, 0.5], [5.0, -0.5], [9.0, 0.0], [14.0, 0.3], [6.0, 2.0], [6.0, -2.0]])
REGIONS = ["STRIP"] * 4 + ["UPPER", "LOWER"]
#: the same finish above and below: T1 with B1, T2 with B2; T3 and B3 keep their own
ACROSS = {"P1": ["T1", "B1"], "P2": ["T2", "B2"]}


@pytest.fixture(scope="module")
def clamp(tmp_path_factory):
    mesh = write_clamp(tmp_path_factory.mktemp("clamp") / "clamp.inp", size=0.5)
    return build_model(ModelSpec.from_table(model_options(mesh, one_target=False)))


def test_zones_of_two_interfaces_share_a_coefficient_and_keep_their_pairs(clamp):
    merged = merge_zones(clamp, ACROSS)
    assert merged.zone_names == ("P1", "P2", "T3", "B3")
    upper, lower = merged.interfaces
    assert upper.zones == ("T1", "T2", "T3") and upper.coefficients == ("P1", "P2", "T3")
    assert lower.zones == ("B1", "B2", "B3") and lower.coefficients == ("P1", "P2", "B3")
    maps = contact_setup(merged)
    assert [m.n_pairs for m in maps] == [25, 25]
    assert maps[1].zones["B1"]["coefficient"] == "P1" and maps[1].zones["B1"]["area"] == pytest.approx(4.0)


def test_a_merged_coefficient_solves_like_its_zones_and_its_sensitivity_is_their_sum(clamp):
    """At equal values the merged model predicts what the unmerged one does; the merged column of the Jacobian is
    the sum of its zones' columns and matches central differences (step 1e-4, relative 1e-5: the path is
    piecewise smooth in mu, slip states do not change within the step)."""
    merged = merge_zones(clamp, ACROSS)
    mu = {**TRUE, "B1": TRUE["T1"], "B2": TRUE["T2"]}
    full = np.array([mu[z] for z in clamp.zone_names])
    shared = np.array([mu["T1"], mu["T2"], mu["T3"], mu["B3"]])
    one = EmbeddedBackend(clamp, POINTS, ("ux", "uy", "exx"), REGIONS).predict(full, True)
    backend = EmbeddedBackend(merged, POINTS, ("ux", "uy", "exx"), REGIONS)
    two = backend.predict(shared, True)
    np.testing.assert_allclose(two.values, one.values, rtol=0, atol=1e-12)
    column = clamp.zone_names.index
    for k, members in enumerate(ACROSS.values()):
        summed = sum(one.derivatives[..., column(m)] for m in members)
        np.testing.assert_allclose(two.derivatives[..., k], summed, rtol=0, atol=1e-9 * np.abs(summed).max())
        central = central_difference(lambda m: backend.predict(m).values, shared, 1e-4, columns=[k])[..., 0]
        np.testing.assert_allclose(two.derivatives[..., k], central, rtol=0, atol=1e-5 * np.abs(central).max())
        assert np.abs(two.derivatives[..., k]).max() > 1e-4           # the merged zones are seen


def test_calculix_writes_one_contact_pair_and_friction_per_zone_at_the_shared_value(clamp):
    merged = merge_zones(clamp, ACROSS)
    channels = load_channels(Space.build(merged.mesh, merged.kind), merged)
    deck = write_deck(merged, [0.31, 0.22, 0.13, 0.44], _contact(), channels.forces, channels.amplitudes)
    frictions = [float(line.split(",")[0]) for line in _after(deck, "*FRICTION")]
    assert frictions == [0.31, 0.22, 0.13, 0.31, 0.22, 0.44]                 # T1 T2 T3 | B1 B2 B3
    assert len(deck_pairs(merged)) == 6 and zone_columns(merged) == [0, 1, 2, 0, 1, 3]
    assert "** zone B1 of interface lower (coefficient P1), mu = 0.31" in deck


def test_merges_on_one_interface_and_across_combine(clamp):
    """T1 + T2 on the upper interface become one zone (their facets' union, as before); T3 + B3 across."""
    merged = merge_zones(clamp, {"TT": ["T1", "T2"], "X3": ["T3", "B3"]})
    assert merged.zone_names == ("TT", "X3", "B1", "B2")
    assert merged.interfaces[0].zones == ("TT", "T3") and merged.interfaces[1].zones == ("B1", "B2", "B3")
    assert len(merged.mesh.boundary("TT")) == len(clamp.mesh.boundary("T1")) + len(clamp.mesh.boundary("T2"))
    twice = merge_zones(clamp, {"A": ["T1", "T2", "B1", "B2"]})      # two members on each interface
    assert twice.zone_names == ("A", "T3", "B3")
    assert twice.interfaces[0].zones == ("A@upper", "T3") and twice.interfaces[1].zones == ("A@lower", "B3")


def test_a_bolts_head_and_nut_bearing_share_a_coefficient():
    model = build_model(ModelSpec.from_table({"builder": "bolt", "merge": {"bearing": ["head_plate", "nut_plate"]}}))
    assert model.zone_names[-1] == "bearing" and "head_plate" not in model.zone_names
    head, nut = (m for m in contact_setup(model) if m.name in ("head", "nut_bearing"))
    assert head.zones["head_plate"]["coefficient"] == nut.zones["nut_plate"]["coefficient"] == "bearing"


def test_simulate_takes_a_merge_across_interfaces_from_the_config(tmp_path):
    """[friction] merge across the clamp's two interfaces: the merged coefficients' simulation equals the
    unmerged one at equal values."""
    write_clamp(tmp_path / "clamp.inp", size=0.5)
    (tmp_path / "points.csv").write_text(points_csv(("ux", "uy")))
    data = '[data]\nfile = "points.csv"\nobservables = ["ux", "uy"]\nstages = [2]\n'
    (tmp_path / "merged.toml").write_text(
        model_table("clamp.inp", False) + '[friction]\nzones = { P1 = 0.3, P2 = 0.2, T3 = 0.3, B3 = 0.25 }\n'
        'merge = { P1 = ["T1", "B1"], P2 = ["T2", "B2"] }\n' + data)
    (tmp_path / "apart.toml").write_text(
        model_table("clamp.inp", False) + '[friction]\nzones = { T1 = 0.3, B1 = 0.3, T2 = 0.2, B2 = 0.2, T3 = 0.3, '
        'B3 = 0.25 }\n' + data)
    values = {}
    for name in ("merged", "apart"):
        assert main(["simulate", str(tmp_path / f"{name}.toml"), "--out", str(tmp_path / f"{name}.csv")]) == 0
        values[name] = read_measurements(tmp_path / f"{name}.csv").values
    assert "coefficients: P1=0.3, P2=0.2, T3=0.3, B3=0.25" in (tmp_path / "merged.csv").read_text()
    for quantity in ("ux", "uy"):
        np.testing.assert_allclose(values["merged"][quantity], values["apart"][quantity], rtol=0, atol=1e-12)
        assert np.abs(values["apart"][quantity]).max() > 1e-4


def test_a_merged_name_that_is_another_boundary_is_refused(clamp):
    with pytest.raises(InputError, match="'LID'"):
        merge_zones(clamp, {"LID": ["T1", "T2"]})


def _contact():
    from frictionid.backends.calculix.deck import ContactSettings

    return ContactSettings(normal_stiffness=1e6, stick_slope=1e5, pair_type="SURFACE TO SURFACE")


def _after(deck: str, keyword: str) -> list[str]:
    lines = deck.splitlines()
    return [lines[k + 1] for k, line in enumerate(lines) if line == keyword]
