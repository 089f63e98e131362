"""Tests of the benchmark builders: named groups, node-to-node pairing at equal tangential coordinate, initial
gaps, separate bodies, load resultants, and the analytical reference formulas (docs/design.md, verification)."""

import math

import numpy as np
import pytest

from frictionid.builders.arcs import contact_abscissae
from frictionid.builders.verification import (hertz_gap, hertz_model, hertz_reference, interference_model,
                                            lame_reference, mindlin_model, mindlin_reference, pushout_force,
                                            sleeve_model)
from frictionid.errors import InputError
from frictionid.fem.space import Space
from frictionid.model import Displacement, SurfaceForce

MATCH_TOL = 1e-9  # [mm] contact and target node must share the tangential coordinate to this (builder brief)


@pytest.fixture(scope="module")
def models():
    """Coarse versions of the four benchmarks (a few thousand nodes in all, well under a second)."""
    return {
        "hertz": hertz_model(contact_size=0.25, size=3.0, half_width_refined=2.5),
        "mindlin": mindlin_model(contact_size=0.1, size=2.0, half_width_refined=1.2),
        "interference": interference_model(size=2.0, contact_size=1.0, n_zones=3),
        "sleeve": sleeve_model(size=2.0),
    }


# name -> (regions, boundaries the loads and supports need, zones, target, tangential axis)
EXPECTED = {
    "hertz": ({"upper", "lower"}, {"upper_flat", "upper_axis", "lower_flat"}, ("left", "right"),
              "lower_contact", 0),
    "mindlin": ({"upper", "lower"}, {"upper_flat", "upper_flat_left", "upper_flat_right", "lower_flat"},
                ("left", "right"), "lower_contact", 0),
    "interference": ({"shaft", "hub"}, {"shaft_bottom", "hub_top"}, ("Z1", "Z2", "Z3"), "shaft_surface", 1),
    "sleeve": ({"shaft", "sleeve"}, {"shaft_bottom", "sleeve_top", "sleeve_outer"}, ("lower", "upper"),
               "shaft_surface", 1),
}


def pairs(mesh, zones, target, axis):
    """(contact nodes, target nodes) paired by equal coordinate ``axis``; asserts a one-to-one pairing."""
    contact = np.unique(np.concatenate([mesh.boundary_nodes(z) for z in zones]))
    candidates = mesh.boundary_nodes(target)
    offset = np.abs(mesh.points[contact, axis][:, None] - mesh.points[candidates, axis][None])
    assert np.all(np.sum(offset <= MATCH_TOL, axis=1) == 1), "a contact node has no (or several) partners"
    assert len(contact) == len(candidates), "target has nodes without a contact partner"
    return contact, candidates[offset.argmin(axis=1)]


def region_nodes(mesh, region):
    return np.unique(mesh.cells[mesh.regions[region]])


@pytest.mark.parametrize("name", EXPECTED)
def test_named_groups_and_interface(models, name):
    model, (regions, boundaries, zones, target, _) = models[name], EXPECTED[name]
    assert set(model.mesh.regions) == regions
    assert boundaries | set(zones) | {target} <= set(model.mesh.boundaries)
    assert model.zone_names == zones
    (interface,) = model.interfaces
    assert interface.target == target and interface.discretisation == "node-to-node"
    assert model.mesh.cell_type == "triangle6"


@pytest.mark.parametrize("name", EXPECTED)
def test_zone_nodes_pair_with_target_nodes(models, name):
    model, (_, _, zones, target, axis) = models[name], EXPECTED[name]
    contact, partner = pairs(model.mesh, zones, target, axis)
    assert len(contact) >= 7


@pytest.mark.parametrize("name, contact_body, target_body", [
    ("hertz", "upper", "lower"), ("mindlin", "upper", "lower"),
    ("interference", "hub", "shaft"), ("sleeve", "sleeve", "shaft")])
def test_bodies_are_separate(models, name, contact_body, target_body):
    mesh, (_, _, zones, target, _) = models[name].mesh, EXPECTED[name]
    contact_nodes, target_nodes = region_nodes(mesh, contact_body), region_nodes(mesh, target_body)
    assert np.intersect1d(contact_nodes, target_nodes).size == 0
    for zone in zones:
        assert np.all(np.isin(mesh.boundary_nodes(zone), contact_nodes))
    assert np.all(np.isin(mesh.boundary_nodes(target), target_nodes))


@pytest.mark.parametrize("name, R1, R2", [("hertz", 10.0, 13.0), ("mindlin", 8.0, 8.0)])
def test_cylinder_gap_is_the_circle_formula(models, name, R1, R2):
    mesh = models[name].mesh
    contact, partner = pairs(mesh, ("left", "right"), "lower_contact", 0)
    x = mesh.points[contact, 0]
    gap = mesh.points[contact, 1] - mesh.points[partner, 1]
    np.testing.assert_allclose(gap, hertz_gap(x, R1, R2), rtol=0, atol=1e-12)
    # mid-nodes included, every node is on its circle
    np.testing.assert_allclose(np.hypot(x, mesh.points[contact, 1] - R1), R1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.hypot(x, mesh.points[partner, 1] + R2), R2, rtol=0, atol=1e-12)
    small = np.abs(x) <= 0.5
    np.testing.assert_allclose(gap[small], x[small] ** 2 / 2 * (1 / R1 + 1 / R2), rtol=2e-3, atol=1e-15)


@pytest.mark.parametrize("name, half_width, spacing", [("hertz", 2.5, 0.25), ("mindlin", 1.2, 0.1)])
def test_cylinder_zones_split_at_zero_one_element_per_spacing(models, name, half_width, spacing):
    mesh = models[name].mesh
    left, right = mesh.points[mesh.boundary_nodes("left")], mesh.points[mesh.boundary_nodes("right")]
    assert left[:, 0].max() == pytest.approx(0.0, abs=MATCH_TOL) and left[:, 0].min() < -half_width + 1e-9
    assert right[:, 0].min() == pytest.approx(0.0, abs=MATCH_TOL) and right[:, 0].max() > half_width - 1e-9
    xs = contact_abscissae(half_width, spacing)
    expected = np.linspace(xs[0], xs[-1], 2 * len(xs) - 1)        # ends and mid-nodes of one element each
    np.testing.assert_allclose(np.sort(np.r_[left[:, 0], right[1:, 0]]), expected, atol=MATCH_TOL)


@pytest.mark.parametrize("name, gap, bore", [("interference", -0.01, 10.0), ("sleeve", 0.0, 10.0)])
def test_axisymmetric_gap_and_zone_spans(models, name, gap, bore):
    model = models[name]
    mesh, (_, _, zones, target, _) = model.mesh, EXPECTED[name]
    contact, partner = pairs(mesh, zones, target, 1)
    np.testing.assert_allclose(mesh.points[contact, 0], bore, atol=1e-12)
    # gap along the shaft's outward normal +r: bore radius minus shaft radius
    np.testing.assert_allclose(mesh.points[contact, 0] - mesh.points[partner, 0], gap, rtol=0, atol=1e-12)
    spans = [np.ptp(mesh.points[mesh.boundary_nodes(z), 1]) for z in zones]
    np.testing.assert_allclose(spans, 10.0 / len(zones), rtol=1e-12)
    lows = [mesh.points[mesh.boundary_nodes(z), 1].min() for z in zones]
    assert np.all(np.diff(lows) > 0), "zones must be numbered bottom up"


def test_mindlin_loads_carry_no_moment_about_the_contact(models):
    """With balance_moment the flat-face forces plus the expected Q (at height R) sum to (Q, -P), no moment."""
    model, mesh = models["mindlin"], models["mindlin"].mesh
    force, moment = np.array([0.936, 0.0]), -8.0 * 0.936          # Q_expected acting at the flat face, y = R
    for load in model.loads:
        if isinstance(load, Displacement):
            assert (load.boundary, load.component, load.values) == ("upper_flat", 0, (0.0, 0.0285))
            continue
        assert isinstance(load, SurfaceForce)
        ends = mesh.points[mesh.boundary(load.boundary)[:, :2]]              # straight facets
        length = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
        centre = length @ ends.mean(axis=1) / length.sum()
        f = np.zeros(2)
        f[load.component] = load.values[-1]
        force += f
        moment += centre[0] * f[1] - centre[1] * f[0]
    np.testing.assert_allclose(force, [0.936, -10.0], rtol=1e-12)
    assert moment == pytest.approx(0.0, abs=1e-9)


def test_space_builds_on_the_quadratic_cylinders(models):
    """Relocated arc mid-nodes keep every cell in the node order scikit-fem expects."""
    space = Space.build(models["hertz"].mesh, "plane_strain")
    assert space.basis.N == 2 * models["hertz"].mesh.n_nodes


def test_hertz_reference_reproduces_vm191():
    ref = hertz_reference()
    assert ref["a"] == pytest.approx(1.20, rel=0.01)      # Ansys VM191: b = 1.20 mm
    assert ref["E_star"] == pytest.approx(16000.0, rel=1e-12)
    assert ref["p0"] == pytest.approx(2 * 3200.0 / (math.pi * ref["a"]), rel=1e-12)


@pytest.mark.parametrize("mu, c_over_a", [(0.2, 0.729), (0.3, 0.829)])
def test_mindlin_reference_reproduces_numerics_md(mu, c_over_a):
    ref = mindlin_reference(mu)
    # docs/design.md, verification: E* = 109.89, R_eff = 4, a = 0.6808 mm, p0 = 9.351 MPa
    assert ref["E_star"] == pytest.approx(109.89, rel=1e-4)
    assert ref["R"] == pytest.approx(4.0, rel=1e-12)
    assert ref["a"] == pytest.approx(0.6808, rel=2e-4)
    assert ref["p0"] == pytest.approx(9.351, rel=2e-4)
    assert ref["c"] / ref["a"] == pytest.approx(c_over_a, abs=6e-4)
    q, a, c, p0 = ref["q"], ref["a"], ref["c"], ref["p0"]
    assert q(0.0) == pytest.approx(mu * p0 * (1 - c / a), rel=1e-12)
    assert q(c * (1 + 1e-12)) == pytest.approx(q(c * (1 - 1e-12)), rel=1e-5)    # continuous at the stick edge
    assert q(1.01 * a) == 0.0 and q(-0.5 * a) == q(0.5 * a)


def test_mindlin_reference_gross_slip_has_no_stick_zone():
    ref = mindlin_reference(0.05)
    assert ref["c"] == 0.0
    assert ref["q"](0.0) == pytest.approx(0.05 * ref["p0"], rel=1e-12)


def lame_by_compatibility(a, b, delta, E, nu):
    """Plane-strain fit pressure from u_hub(a) - u_shaft(a) = delta with the textbook Lame displacements."""
    hub = a * (1 + nu) / E * ((1 - 2 * nu) * a ** 2 + b ** 2) / (b ** 2 - a ** 2)   # per unit bore pressure
    shaft = -a * (1 + nu) * (1 - 2 * nu) / E                                         # solid, external pressure
    return delta / (hub - shaft)


def test_lame_reference():
    ref = lame_reference(10.0, 20.0, 0.01, 210000.0, 0.3)
    assert ref["p_c"] == pytest.approx(lame_by_compatibility(10.0, 20.0, 0.01, 210000.0, 0.3), rel=1e-12)
    assert ref["p_c"] == pytest.approx(86.538, rel=1e-4)
    stress = lame_reference(10.0, 20.0, 0.01, 210000.0, 0.3, condition="plane_stress")["p_c"]
    assert stress == pytest.approx(210000.0 * 0.01 * 300.0 / (2 * 10.0 * 400.0), rel=1e-12)
    hollow = lame_reference(10.0, 20.0, 0.01, 210000.0, 0.3, shaft_inner=5.0)["p_c"]
    assert hollow < ref["p_c"]


def test_pushout_force():
    # F = sum mu_i p_i 2 pi a L_i (docs/design.md, verification)
    assert pushout_force([0.1, 0.3], [80.0, 90.0], 10.0, [4.0, 6.0]) == pytest.approx(
        2 * math.pi * 10.0 * (0.1 * 80.0 * 4.0 + 0.3 * 90.0 * 6.0), rel=1e-12)
    assert pushout_force(0.2, 50.0, 10.0, 10.0) == pytest.approx(0.2 * 50.0 * 2 * math.pi * 100.0, rel=1e-12)


def test_loads_and_stages(models):
    fit, sleeve = models["interference"], models["sleeve"]
    assert [s.name for s in fit.stages] == ["fit", "push"] and fit.stages[0].n_increments == 1
    (push,) = fit.loads
    assert push.boundary == "hub_top" and push.values == (0.0, -0.05)
    assert [s.name for s in sleeve.stages] == ["press", "push"]
    assert [s.name for s in models["mindlin"].stages] == ["press", "shift"]
    assert models["hertz"].kind == "plane_strain" and fit.kind == "axisymmetric"


@pytest.mark.parametrize("build, kwargs, word", [
    (hertz_model, dict(half_width_refined=10.0), "half_width_refined"),
    (mindlin_model, dict(contact_size=0.0), "contact_size"),
    (interference_model, dict(delta=-0.01), "delta"),
    (interference_model, dict(n_zones=0), "n_zones"),
    (interference_model, dict(hub_length=30.0), "hub_length"),
    (sleeve_model, dict(pressure=-1.0), "pressure"),
])
def test_bad_input_names_the_argument(build, kwargs, word):
    with pytest.raises(InputError, match=word):
        build(**kwargs)
