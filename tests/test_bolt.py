"""The axisymmetric bolt-nut model (reference test 2 (docs/models.md)): layout numbers, conforming flank interface,
zones, equilibrium, thread load shares against Sopwith (docs/design.md), report outputs, measurement points, bad input.

The solved model uses a 0.25 mm flank size instead of 0.1 to keep the suite fast: the load shares at 0.25, 0.2
and 0.1 mm agree to 0.01 percentage points (measured here), far inside every tolerance below.
"""

import math

import numpy as np
import pytest

from frictionid.builders.bolt import bolt_layout, bolt_model, fixed_friction, measurement_points
from frictionid.builders.registry import build_model
from frictionid.builders.thread import SQRT3
from frictionid.errors import InputError
from frictionid.fem.problem import Problem
from frictionid.report.bolt import (bolt_summary, flank_profile, nut_dilation, pitch_loads, plot_flank_profile,
                                    plot_load_shares, ring_gap, sopwith_shares, thread_loads)
from frictionid.options import ModelSpec
from helpers.differences import central_difference

FORCE = 30000.0  # [N] second-stage machine force of the default model


@pytest.fixture(scope="module")
def model():
    return bolt_model(flank_size=0.25)


@pytest.fixture(scope="module")
def problem(model):
    points = measurement_points(bolt_layout())
    return Problem.build(model, points=points, quantities=("uy",), regions=["bolt"] * len(points))


def coefficients(model, flank_mu=0.1, plate_mu=None):
    mu = {zone: flank_mu for zone in model.zone_names}
    mu.update(fixed_friction())
    if plate_mu is not None:
        mu["nut_plate"] = plate_mu
    return mu


@pytest.fixture(scope="module")
def solution(problem, model):
    return problem.solve(coefficients(model), sensitivities=True)


# ------------------------------------------------------------------------------------------ geometry

def test_m20_layout_is_the_design_md_setup():
    layout = bolt_layout("M20")
    assert (layout.length, layout.y_thread, layout.y_bearing, layout.y_top) == (120.0, 74.0, 94.5, 112.5)
    assert layout.plate2 == (0.0, 20.0) and layout.plate1 == (74.5, 94.5)
    assert (layout.r_hole, layout.r_outer) == (11.0, 40.0)
    assert layout.size.hex_radius == pytest.approx(15.75, abs=2e-3) and layout.size.da == 21.0
    assert layout.r_bearing == layout.size.hex_radius and bolt_layout(bearing_diameter="dw").r_bearing == 13.85
    assert layout.shift == pytest.approx(0.021) and layout.r_shank == pytest.approx(9.979)
    assert layout.nut_phase - (layout.bolt_phase - 1.25) == pytest.approx(0.021 / SQRT3)
    assert len(layout.flanks) == 7 and layout.sections == ((1, 2, 3), (4, 5), (6, 7))
    assert layout.thread_zones == ("A", "B", "C", "D", "E", "F")


@pytest.mark.parametrize("size, n_flanks", [("M8", 5), ("M12", 6), ("M24", 7), ("M36", 7)])
def test_other_sizes_engage_the_nut_with_complete_flanks(size, n_flanks):
    """The thread phase keeps the countersink from cutting a load flank part-way (centred teeth would leave the
    first M8 flank 10 % wide): every engaged flank has its full contact width."""
    layout = bolt_layout(size)
    s = layout.size
    assert len(layout.flanks) == n_flanks
    width = np.array([f.r_contact[1] - f.r_contact[0] for f in layout.flanks]) / (s.d / 2 - layout.shift - s.d1 / 2)
    np.testing.assert_allclose(width, 1.0, rtol=1e-12)
    assert layout.y_thread < layout.plate1[0] < layout.y_bearing < layout.y_top < layout.length
    assert layout.plate2[1] < layout.plate1[0]


def test_mesh_regions_bodies_and_cells(model):
    mesh = model.mesh
    assert mesh.cell_type == "triangle6" and set(mesh.regions) == {"bolt", "nut", "plate1", "plate2"}
    nodes = {r: np.unique(mesh.cells[mesh.regions[r]]) for r in mesh.regions}
    for a in nodes:
        for b in nodes:
            if a < b:
                assert np.intersect1d(nodes[a], nodes[b]).size == 0, f"{a} and {b} share nodes"
    assert model.zone_names == ("A", "B", "C", "D", "E", "F", "head_plate", "nut_plate")


def _partners(mesh, contact_names, target):
    contact = np.unique(np.concatenate([mesh.boundary_nodes(z) for z in contact_names]))
    targets = mesh.boundary_nodes(target)
    distance = np.linalg.norm(mesh.points[contact][:, None] - mesh.points[targets][None], axis=2)
    return contact, targets, distance


@pytest.mark.parametrize("zones, target", [(("A", "B", "C", "D", "E", "F"), "nut_contact"),
                                           (("head_plate",), "plate2_head"), (("nut_plate",), "plate1_nut")])
def test_interfaces_are_conforming_at_zero_gap(model, problem, zones, target):
    contact, targets, distance = _partners(model.mesh, zones, target)
    assert len(contact) == len(targets)
    assert np.all(np.sum(distance < 1e-9, axis=1) == 1), "a contact node has no (or several) coincident partners"
    interface = [i for i, f in enumerate(model.interfaces) if f.zones == zones][0]
    assert np.max(np.abs(problem.pairs.gap[problem.pairs.interface == interface])) < 1e-12


def test_free_flanks_open_by_es_over_sqrt3(model):
    """Every nut free-flank node faces the bolt free flank |es|/sqrt(3) = 0.0242 mm below it (axially)."""
    layout, mesh = bolt_layout(), model.mesh
    s, shift = layout.size, layout.shift
    nodes = mesh.boundary_nodes("nut_free")
    r, y = mesh.points[nodes].T
    inside = (r > s.d1 / 2 + 1e-9) & (r < s.d / 2 - shift - 1e-9)
    z_bolt = layout.bolt_phase + np.floor((y - layout.bolt_phase) / s.P) * s.P
    bolt_free = z_bolt + (s.d / 2 + s.H / 8 - shift - r) / SQRT3
    assert inside.sum() >= 20
    np.testing.assert_allclose(y[inside] - bolt_free[inside], 0.042 / SQRT3, atol=1e-9)


def test_zone_areas_and_membership(model, problem):
    """Zone ring areas: pi (r_a + r_b) * slant length per flank segment; A-C outer (r > d2/2), D-F inner."""
    layout = bolt_layout()
    s, r_split = layout.size, layout.size.d2 / 2
    slant = 1 / math.cos(math.pi / 6)
    outer = math.pi * (r_split + s.d / 2 - layout.shift) * (s.d / 2 - layout.shift - r_split) * slant
    inner = math.pi * (s.d1 / 2 + r_split) * (r_split - s.d1 / 2) * slant
    area = (problem.pairs.weight[:, None] * problem.pairs.zone_share).sum(axis=0)
    counts = [len(part) for part in layout.sections]
    np.testing.assert_allclose(area[:6], [outer * n for n in counts] + [inner * n for n in counts], rtol=1e-9)
    mesh = model.mesh
    for zone, (radial, section) in zip("ABCDEF", [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)]):
        r, y = mesh.points[mesh.boundary_nodes(zone)].T
        assert (np.all(r >= r_split - 1e-9) if radial == 0 else np.all(r <= r_split + 1e-9))
        flanks = [layout.flanks[i - 1] for i in layout.sections[section]]
        assert y.min() >= min(f.straight[0][1] for f in flanks) and y.max() <= max(f.straight[1][1] for f in flanks)


# ------------------------------------------------------------------------------------------ solution

def test_global_equilibrium(solution):
    """The reaction at plate 2's rim balances the machine force at every increment."""
    forces = np.r_[np.linspace(0, 10000.0, 4)[1:], np.linspace(10000.0, FORCE, 4)[1:]]
    y = solution.reaction_labels.index("plate2_rim.y")
    np.testing.assert_allclose(-solution.reactions[:, y], forces, rtol=1e-9)


def test_load_shares_default_setup(model, solution):
    """docs/models.md set-up (flanks 0.1, head and nut on the plates 0.15): shares sum to the force; they decay from
    the bearing face over threads 1-6, the last thread takes a little more than the sixth (end effect of the
    bolt beyond the nut). Plate 1 gives under the nut (it bends under the rim load) and the nut's bearing face slides
    outward on it, so the distribution is flatter than Sopwith's: first thread 20.6 % here (0.1 mm mesh: 20.6 %),
    lam P 0.21; CalculiX agrees (test_calculix_run.py); the study: examples/bolt-m20/load_shares.py."""
    loads = thread_loads(model, solution)
    assert loads.applied == FORCE
    assert loads.force.sum() == pytest.approx(FORCE, rel=5e-3)
    assert np.all(np.diff(loads.share[:-1]) < 0)
    assert 0.18 < loads.share[0] < 0.23 and 0.15 < loads.lam_p < 0.3
    np.testing.assert_allclose(loads.share, sopwith_shares(loads.lam_p, 7), atol=0.012)   # within 1.2 points


def test_pitch_shares_cut_between_the_rings_are_the_thread_shares(model, solution):
    """The cut per pitch of axial position (the one a 3-D helix is compared by) gives the axisymmetric model's own
    thread shares when it starts between two flanks; cut at the bearing face instead it splits flanks (which lie
    0.73 to 1.04 pitches above it)."""
    layout, share = bolt_layout(), thread_loads(model, solution).share
    y_start = ring_gap(model, solution, layout.size.P)
    assert layout.y_bearing < y_start < layout.y_bearing + layout.size.P
    np.testing.assert_allclose(pitch_loads(model, solution, y_start, layout.size.P, 7), share, rtol=0, atol=1e-12)
    at_face = pitch_loads(model, solution, layout.y_bearing, layout.size.P, 7)
    assert at_face.sum() == pytest.approx(1.0) and np.abs(at_face - share).max() > 0.01


def test_load_shares_with_the_nut_held_radially_agree_with_sopwith(model, problem):
    """Acceptance (docs/design.md): with the nut bearing face held radially (nut-plate mu = 1, sticking over the
    outer half) - Sopwith's assumption of axial thread springs - the shares decay monotonically, sum to the
    force within 0.5 %, the first thread carries 25-35 %, and the fitted lam P lies in 0.3-0.45."""
    loads = thread_loads(model, problem.solve(coefficients(model, plate_mu=1.0)))
    assert loads.force.sum() == pytest.approx(FORCE, rel=5e-3)
    assert np.all(np.diff(loads.share) < 0)
    assert 0.25 <= loads.share[0] <= 0.35
    assert 0.3 <= loads.lam_p <= 0.45
    np.testing.assert_allclose(loads.share, sopwith_shares(loads.lam_p, 7), atol=0.02)


def test_first_share_grows_with_the_radial_hold_of_the_nut(model, problem):
    """Nut-plate friction 0 -> 0.15 -> 1 holds the nut's bearing face ever more: the first share rises."""
    first = [thread_loads(model, problem.solve(coefficients(model, plate_mu=mu))).share[0] for mu in (0, 0.15, 1)]
    assert first[0] < first[1] - 0.02 and first[1] < first[2] - 0.1


def test_bearing_on_dw_moves_load_to_the_first_thread(model, solution):
    """ISO 4032 bearing face (dw = 27.7, ring chamfered beyond): the plate pushes the nut nearer the thread,
    so the nut flares less and the first thread carries more than with the whole ring face (24.8 vs 20.6 %)."""
    dw_model = bolt_model(flank_size=0.25, bearing_diameter="dw")
    problem = Problem.build(dw_model)
    area = (problem.pairs.weight[:, None] * problem.pairs.zone_share).sum(axis=0)
    assert area[dw_model.zone_names.index("nut_plate")] == pytest.approx(math.pi * (13.85 ** 2 - 11 ** 2), rel=1e-9)
    first = thread_loads(dw_model, problem.solve(coefficients(dw_model))).share[0]
    assert first > thread_loads(model, solution).share[0] + 0.03


def test_report_profile_dilation_states_and_plot(model, problem, solution, tmp_path):
    profile = flank_profile(model, solution)
    assert len(profile.flank) == np.sum(np.isin(problem.pairs.nodes, model.mesh.boundary_nodes("nut_contact")) |
                                        np.isin(problem.pairs.nodes, np.concatenate(
                                            [model.mesh.boundary_nodes(z) for z in "ABCDEF"])))
    assert np.all(profile.pressure > 0) and np.all(profile.state == 2)      # all flanks slip at mu = 0.1
    np.testing.assert_allclose(np.abs(profile.traction), 0.1 * profile.pressure, rtol=1e-9)
    y, u_r = nut_dilation(model, problem.displacement(solution))
    assert u_r[0] > 0.003 and u_r[0] > u_r[-1]                               # dilates most at the bearing face
    states = solution.zone_state()
    assert set(states) == set(model.zone_names) and all(s["slip"] == pytest.approx(1.0) for s in states.values())
    path = plot_load_shares(thread_loads(model, solution), tmp_path / "shares.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert plot_flank_profile(profile, tmp_path / "flanks.png").read_bytes()[:4] == b"\x89PNG"
    lines = bolt_summary(model, solution).splitlines()
    loads = thread_loads(model, solution)
    assert "Sopwith fit lam P" in lines[0] and lines[1].startswith("thread")
    rows = [line.split() for line in lines[2:2 + loads.n_threads]]
    assert [int(r[0]) for r in rows] == list(range(1, loads.n_threads + 1))  # one row per engaged thread
    np.testing.assert_allclose([float(r[1]) for r in rows], loads.force, atol=0.05)
    assert lines[2 + loads.n_threads].startswith("zone")
    assert [line.split()[0] for line in lines[3 + loads.n_threads:]] == list(solution.zone_names)


def test_measurement_points_and_sensitivities(problem, solution):
    """10 default points on flanks 1, 2 at 1/6 .. 5/6 of the straight flank; their uy is sensitive to the
    flank zones (analytic sensitivity against a central difference in zone A)."""
    layout = bolt_layout()
    points = measurement_points(layout)
    assert points.shape == (10, 2)
    np.testing.assert_allclose(points[0], layout.flanks[0].along(1 / 6))
    np.testing.assert_allclose(points[9], layout.flanks[1].along(5 / 6))
    assert np.all(solution.observations[-1] > 0)                            # pulled up with plate 1 and nut
    mu = solution.mu.copy()
    h = 1e-4
    central = central_difference(lambda m: problem.solve(m).observations[-1], mu, h, columns=[0])[..., 0]
    np.testing.assert_allclose(solution.d_observations[-1, :, 0], central, rtol=1e-5, atol=1e-12)


# ------------------------------------------------------------------------------------------ bad input

def test_points_off_the_flanks_are_refused():
    layout = bolt_layout()
    good = layout.flanks[3].along(0.5)
    assert measurement_points(layout, [good]).shape == (1, 2)
    with pytest.raises(InputError, match=r"`points`\[1\] = \[9.0, 50.0\] is not on an engaged bolt load flank"):
        measurement_points(layout, [good, [9.0, 50.0]])
    with pytest.raises(InputError, match=r"`flanks`: 9 is not an engaged flank; expected 1 ... 7"):
        measurement_points(layout, flanks=(1, 9))


@pytest.mark.parametrize("options, message", [
    ({"size": "M21"}, r"`size` = 'M21' has no tabulated dimensions"),
    ({"engaged_length": 19.0}, r"`engaged_length` = 19 mm is longer than the nut: expected at most the M20 nut "
                               r"height m = 18 mm"),
    ({"engaged_length": 1.0}, r"`engaged_length` = 1 mm leaves no complete load flank engaged"),
    ({"forces": []}, r"`forces` must be a list of machine forces"),
    ({"forces": [1000.0, -5.0]}, r"`forces\[1\]` must be a finite number > 0"),
    ({"flank_size": 1.0}, r"`flank_size` = 1 mm is too coarse for M20"),
    ({"length": 50.0}, r"`length` = 50 mm is too short for M20"),
    ({"n_axial": 8}, r"`n_axial` must be an integer in \[1, 7\]"),
    ({"bearing_diameter": 21.0}, r"`bearing_diameter` must be \"dw\" or a number of mm in \(22, 31.5\]"),
    ({"clearance": -0.01}, r"`clearance` must be a number of mm in \[0, H/4 = 0.541\)"),
    ({"nut_mesh": "separate"}, r"`nut_mesh`: 3-D only"),
    ({"root_size": 0.2, "root_refinement": "engaged"}, r"`root_size`, `root_refinement`: 3-D only"),
])
def test_bad_options_name_the_key(options, message):
    with pytest.raises(InputError, match=message):
        bolt_model(**options)


def test_registry_builds_the_bolt_and_checks_options():
    with pytest.raises(InputError, match=r"\[model\] flank_sise: not an option of builder 'bolt' \(did you mean "
                                         r"'flank_size'\?\)"):
        build_model(ModelSpec.from_table({"builder": "bolt", "flank_sise": 0.2}))
    model = build_model(ModelSpec.from_table({"builder": "bolt", "size": "M12", "forces": [5000.0], "flank_size": 0.3}))
    assert model.n_stages == 1 and model.zone_names[:6] == ("A", "B", "C", "D", "E", "F")


def test_quadratic_cells_are_not_inverted(model):
    """det J of every 6-node triangle at its corners and mid-edge points is positive (curved root arcs
    included: docs/design.md saw inverted quadratic quads there)."""
    mesh = model.mesh
    x = mesh.points[mesh.cells]                                            # (n_cells, 6, 2), meshio order
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    straight = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]                    # det J of the straight-sided cell
    for xi, eta in [(0, 0), (1, 0), (0, 1), (0.5, 0), (0.5, 0.5), (0, 0.5), (1 / 3, 1 / 3)]:
        l0, l1, l2 = 1 - xi - eta, xi, eta
        # derivatives of the P2 shape functions (corners 0-2, mid-edges 01, 12, 20) by xi and eta
        d_xi = np.array([-(4 * l0 - 1), 4 * l1 - 1, 0, 4 * (l0 - l1), 4 * l2, -4 * l2])
        d_eta = np.array([-(4 * l0 - 1), 0, 4 * l2 - 1, -4 * l1, 4 * l1, 4 * (l0 - l2)])
        j = np.stack([d_xi @ x, d_eta @ x], axis=1)                        # (n_cells, 2, 2)
        det = np.linalg.det(j)
        assert np.min(det / straight) > 0.5, f"a distorted or inverted cell at ({xi}, {eta})"
    assert straight.min() > 0


def test_large_size_at_the_default_flank_size_builds_its_contact_pairs():
    """M30 at 0.1 mm: facet bases on 0.1 mm quadratic cells 180 mm from the origin (fem/space.py: the inverse
    isoparametric map stops at 1e-10; scikit-fem's 1e-12 was out of round-off's reach there and raised)."""
    from frictionid.fem.interface import contact_pairs
    from frictionid.fem.space import Space
    model = bolt_model(size="M30", forces=(50000.0,))
    pairs = contact_pairs(Space.build(model.mesh, model.kind), model)
    thread = pairs.interface == 0
    assert np.max(np.abs(pairs.gap[thread])) < 1e-12
    layout = bolt_layout("M30")
    full = math.pi * (layout.size.d1 / 2 + layout.size.d / 2 - layout.shift) \
        * (layout.size.d / 2 - layout.shift - layout.size.d1 / 2) / math.cos(math.pi / 6)
    # every M30 flank is complete (see test_other_sizes...): flank ring areas sum to n_flanks * full
    assert pairs.weight[thread].sum() == pytest.approx(len(layout.flanks) * full, rel=1e-9)


def test_flank_slip_direction_is_the_wedge(problem, solution, model):
    """On the load flanks t1 = (cos 30, sin 30); the bolt slides inwards relative to the nut at the first
    threads (the wedge contracts the bolt and dilates the nut), and friction acts on the bolt along +t1."""
    profile = flank_profile(model, solution)
    frames = problem.pairs.frames[problem.pairs.interface == 0]
    t1 = np.broadcast_to([math.cos(math.pi / 6), math.sin(math.pi / 6)], frames[:, 1].shape)
    np.testing.assert_allclose(frames[:, 1], t1, atol=1e-9)
    first = profile.flank == 1
    assert np.all(profile.slip[first] < -3e-3) and np.all(profile.traction[first] > 0)   # slip about -6 um


def test_the_demo_fits_the_papers_mesh_as_given(tmp_path):
    """The demo compares algorithms on the paper's mesh; its noise-free twin states that mesh's own error as its
    noise, so the discretisation control (on by default, off in the test session) would refine the fit towards
    a target it cannot reach and change the study: its configs switch it off themselves."""
    from frictionid.config import read_config
    from frictionid.studies.bolt import write_config

    path = write_config(tmp_path, "trf", "measured_exact.csv", "trf", "analytic", 10, 0.25, 3e-7)
    assert read_config(path, need=("model", "friction", "data", "run")).identify.refine_target == 0


def _helix_pairs(pitch: float, n_turns: int, n_per_turn: int = 24, radius: float = 3.0):
    """A model and solution stand-in with thread pairs on a right-hand helix (teeth at y = k P + P theta / 2 pi,
    theta = atan2(-z, x), as frictionid.builders.bolt3d_geometry places them); turn k's pairs each carry k + 1 N
    axially."""
    from types import SimpleNamespace
    theta = -math.pi + 2 * math.pi * (np.arange(n_per_turn) + 0.5) / n_per_turn
    turn = np.repeat(np.arange(n_turns), n_per_turn)
    angle = np.tile(theta, n_turns)
    position = np.column_stack([radius * np.cos(angle), turn * pitch + pitch * angle / (2 * math.pi),
                                -radius * np.sin(angle)])
    n_pairs = len(turn)
    lam = np.zeros((1, n_pairs, 3))
    lam[0, :, 0] = turn + 1.0                                   # the frames' first row is +y
    frames = np.tile(np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), (n_pairs, 1, 1))
    mesh = SimpleNamespace(boundaries={"thread_1": None}, boundary_nodes=lambda name: np.arange(n_pairs))
    pairs = SimpleNamespace(n_pairs=n_pairs, nodes=np.arange(n_pairs), frames=frames, position=position)
    return SimpleNamespace(mesh=mesh), SimpleNamespace(pairs=pairs, lam=lam)


def test_pitch_shares_by_the_helical_coordinate_are_the_turns_loads():
    """With the lead, each helix turn (seam at theta = +-pi) falls in the bin of the ring it passes at theta = 0,
    whatever the cut inside the gap between turns; by axial position alone the turns are split across the cuts."""
    pitch, model_and_solution = 1.0, _helix_pairs(1.0, 3)
    expected = np.array([1.0, 2.0, 3.0]) / 6.0
    for y_start in (-0.5, -0.3):
        turns = pitch_loads(*model_and_solution, y_start, pitch, 3, lead=pitch)
        np.testing.assert_allclose(turns, expected, rtol=0, atol=1e-12)
    axial = pitch_loads(*model_and_solution, -0.3, pitch, 3)
    assert axial.sum() == pytest.approx(1.0) and np.abs(axial - expected).max() > 0.02
    x = model_and_solution[1].pairs.position[:, 0]
    half = pitch_loads(*model_and_solution, -0.5, pitch, 3, lead=pitch, where=x > 0)   # theta in (-pi/2, pi/2)
    np.testing.assert_allclose(half, expected, rtol=0, atol=1e-12)
    first = pitch_loads(*model_and_solution, -0.5, pitch, 3, lead=pitch, where=np.arange(72) < 24)
    np.testing.assert_allclose(first, [1.0, 0.0, 0.0], rtol=0, atol=1e-12)


def test_the_helical_coordinate_needs_a_3d_model(model, solution):
    with pytest.raises(InputError, match="3-D model"):
        pitch_loads(model, solution, 90.0, 2.5, 7, lead=2.5)
