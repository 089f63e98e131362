"""The small-sliding check (Problem.check_small_sliding): the fixed pairing's gap error against the deformed
coupling, what it accepts and refuses against finite sliding, its message and its [solver] key."""

import json
import shutil

import numpy as np
import pytest

from frictionid.builders.block import block_model
from frictionid.cli import main
from frictionid.config import config_from_dict
from frictionid.errors import InputError, SolverError
from frictionid.fem.problem import SLIP_TOLERANCE, Problem
from frictionid.fem.sliding import pairing_gap_error
from sliding3d_case import MU, POINTS, QUANTITIES, REGIONS
from conftest import ROOT


def _moved(model, block_shift, plate_slope):
    """(n_nodes, 3) [mm]: the block translated by ``block_shift``, the plate's nodes lifted by slope * y."""
    points, u = model.mesh.points, np.zeros_like(model.mesh.points)
    block = np.unique(model.mesh.cells[model.mesh.regions["block"]])
    plate = np.setdiff1d(np.arange(model.mesh.n_nodes), block)
    u[block] += block_shift
    u[plate, 2] += plate_slope * points[plate, 1]
    return u


def test_a_pair_slid_over_a_flat_target_keeps_its_gap_and_a_tilted_target_costs_slope_times_slip():
    model = block_model(mesh_size=2.5)
    problem = Problem.build(model)
    pairs = problem.pairs
    for slope, shift in ((0.0, [0.0, 0.7, 0.0]), (0.0, [0.3, -0.4, 0.0]), (0.01, [0.0, 0.7, 0.0])):
        u = _moved(model, np.array(shift), slope)
        error = pairing_gap_error(problem, u.ravel(), (pairs.B @ u.ravel())[::3])
        # the target's surface at the slid-to point is higher by slope * slip in y than at the partner
        np.testing.assert_allclose(np.abs(error), abs(slope * shift[1]), atol=1e-12)


def test_on_a_curved_target_the_gap_error_is_the_targets_drop_between_partner_and_slid_to_point():
    """The plate's top bent into a bowl, u_z = -y^2 / (2 R), the block slid by s in y: the deformed gap at a pair
    from y0 grows by (y0 + s)^2 / (2 R), the fixed pairing's by y0^2 / (2 R); the error (2 y0 s + s^2) / (2 R),
    the curvature term s^2 / (2 R) at y0 = 0, within the facets' linear interpolation of the bowl, h^2 / (8 R)."""
    model = block_model(mesh_size=2.5)
    problem = Problem.build(model)
    pairs, radius, slide = problem.pairs, 100.0, 3.0
    points, u = model.mesh.points, np.zeros_like(model.mesh.points)
    block = np.unique(model.mesh.cells[model.mesh.regions["block"]])
    plate = np.setdiff1d(np.arange(model.mesh.n_nodes), block)
    u[block, 1] = slide
    u[plate, 2] = -points[plate, 1] ** 2 / (2 * radius)
    error = pairing_gap_error(problem, u.ravel(), (pairs.B @ u.ravel())[::3])
    y0 = pairs.position[:, 1]
    corners = points[model.mesh.boundary("plate_top")[:, :4]]
    centre = corners.mean(axis=1)
    under = corners[(np.abs(centre[:, 0]) < 5.0) & (centre[:, 1] > -5.0) & (centre[:, 1] < 5.0 + slide)]
    h = np.linalg.norm(under - np.roll(under, -1, axis=1), axis=2).max()      # facets the pairs slide over
    expected = (2 * y0 * slide + slide ** 2) / (2 * radius)
    assert expected.max() > 10 * h ** 2 / (8 * radius)
    np.testing.assert_allclose(error, expected, rtol=0, atol=h ** 2 / (8 * radius))


@pytest.mark.parametrize("order", [1, 2])
def test_the_checks_lower_quadrature_measures_the_gap_error_of_the_solvers_coupling(order):
    """The check couples with the triangle rule of degree CHECK_DEGREE (6 points) instead of the solver's 25: on
    the bowl above with the block slid 3 mm, the gap errors agree to round-off on flat 4-node facets and within
    0.5 % of the largest on curved 9-node ones (measured 0.36 %), a tenth of the facets' interpolation error."""
    from frictionid.fem.sliding import CHECK_DEGREE, check_builder, mortar_builder

    model = block_model(mesh_size=2.5, order=order)
    problem = Problem.build(model)
    pairs, radius = problem.pairs, 100.0
    points, u = model.mesh.points, np.zeros_like(model.mesh.points)
    block = np.unique(model.mesh.cells[model.mesh.regions["block"]])
    plate = np.setdiff1d(np.arange(model.mesh.n_nodes), block)
    u[block, 1] = 3.0
    u[plate, 2] = -points[plate, 1] ** 2 / (2 * radius)
    w = (pairs.B @ u.ravel())[::3]
    check, solver = (pairing_gap_error(problem, u.ravel(), w, builder(problem.space, model))
                     for builder in (check_builder, mortar_builder))
    assert CHECK_DEGREE < 10 and np.abs(solver).max() > 0.19
    bound = 1e-12 if order == 1 else 5e-3 * np.abs(solver).max()
    assert np.abs(check - solver).max() <= min(bound, 0.1 * 2.5 ** 2 / (8 * radius))


def test_the_block_pulled_0_2_mm_is_accepted_and_finite_sliding_agrees_with_it():
    """Mesh 2.5 (25 pairs): gap error 0.016 of the contact's normal displacement range (measured); the
    observations of finite and small sliding differ by 0.68 % of their range (measured 1.32 um of 195 um), most
    of it the deformed frames' tilt, not the slip (docs/solver.md)."""
    model = block_model(mesh_size=2.5)
    small = Problem.build(model, points=POINTS, regions=REGIONS, quantities=QUANTITIES)
    solution = small.solve(MU)                                               # the check runs and accepts
    ratio = max(found["ratio"] for found in small.gap_errors(solution))
    assert 0.0 < ratio < 0.5 * SLIP_TOLERANCE
    finite = Problem.build(model, points=POINTS, regions=REGIONS, quantities=QUANTITIES, sliding="finite").solve(MU)
    small_obs, finite_obs = (np.asarray(s.observations[-1]) for s in (solution, finite))
    assert np.abs(finite_obs - small_obs).max() < 0.01 * np.ptp(small_obs)


def test_the_2_mm_pull_is_refused_naming_where_and_what_to_do_and_finite_sliding_differs_materially():
    """Mesh 5, 2 mm (9 pairs): gap error 0.235 of the normal displacement range (measured); finite sliding's
    normal forces differ from small sliding's by 14 % of the largest (measured 64.8 of 469.9 N)."""
    model = block_model(pull=2.0, mesh_size=5.0, n_pull=20)
    problem = Problem.build(model)
    with pytest.raises(SolverError) as error:
        problem.solve(MU)
    message = str(error.value)
    for words in ("interface 'block_plate'", "stage 2 (pull)", "increment 21", "gap error averages",
                  "of the normal deformation the contact resolves (", f"[solver] slip_tolerance = {SLIP_TOLERANCE:g}", "contact node",
                  "position [", "slip 1.9", '[solver] sliding = "finite"', "(false: no check)"):
        assert words in message, (words, message)
    small = problem.solve(MU, max_slip=None)                                 # off
    problem.solve(MU, max_slip=0.5)                                          # looser than the error: accepted
    finite = Problem.build(model, sliding="finite").solve(MU)
    difference = np.abs(finite.lam[-1, :, 0] - small.lam[-1, :, 0]).max()
    assert difference > 0.05 * small.lam[-1, :, 0].max()


def _coupling_misses(problem, which, by=0.3):
    """Make the deformed coupling's undeformed gap miss the pairing's own at the pairs ``which`` by ``by`` mm, as it
    does where it projects onto another facet (the coarse 3-D helix: a flank narrower than an element)."""
    reference = problem._coupled_gap.copy()
    reference[which] += by
    problem.__dict__["_coupled_gap"] = reference


def test_pairs_the_coupling_does_not_measure_are_left_out_of_the_mean_not_counted_as_errors():
    """Every other pair's coupling made to miss it by 0.3 mm (a 3-D M6 helix showed this: 0.25 mm "gap error" at
    a pair that slid 1.6 um): those pairs are unmeasured, the mean is the other pairs', and the 0.2 mm pull is
    still accepted; the one-element slip rule holds them instead."""
    model = block_model(mesh_size=2.5)
    problem = Problem.build(model)
    solution = problem.solve(MU, max_slip=None)
    before = max(problem.gap_errors(solution), key=lambda found: found["ratio"])         # the pull's end
    missed = np.arange(problem.pairs.n_pairs) % 2 == 1
    _coupling_misses(problem, missed)
    after = next(found for found in problem.gap_errors(solution) if found["increment"] == before["increment"])
    closed = solution.state[before["increment"]] != 0
    assert before["unmeasured"] == 0 and after["unmeasured"] == np.count_nonzero(missed & closed) > 0
    assert 0.0 < after["ratio"] < SLIP_TOLERANCE and after["ratio"] != before["ratio"]
    assert 0.0 < after["unmeasured_slip"] < 1.0
    problem.check_small_sliding(solution)                                     # accepted


def test_an_unmeasured_pair_sliding_past_its_element_is_refused_by_the_slip_rule():
    """The 3 mm pull on 2.5 mm elements with no pair measured by the coupling: the slip (2.9 mm) exceeds the local
    element length, and the check names that rule."""
    model = block_model(pull=3.0, mesh_size=2.5, n_pull=30)
    problem = Problem.build(model)
    solution = problem.solve(MU, max_slip=None)
    _coupling_misses(problem, np.ones(problem.pairs.n_pairs, dtype=bool))
    found = problem.gap_errors(solution)
    assert all(f["ratio"] == 0.0 for f in found) and max(f["unmeasured_slip"] for f in found) > 1.0
    with pytest.raises(SolverError, match=r"exceeds 1 x the local element length .* pairs the deformed coupling "
                                          r"does not measure"):
        problem.check_small_sliding(solution)


def test_another_coupling_is_measured_against_its_own_undeformed_gaps():
    """gap_errors with a builder of its own (e.g. another quadrature) takes that builder's undeformed coupling as
    the reference: a builder whose every gap is off by 0.01 mm gives the check's errors, not 0.01 mm more."""
    from dataclasses import replace

    from frictionid.fem.sliding import check_builder

    model = block_model(pull=0.2, mesh_size=2.5, n_pull=10)
    problem = Problem.build(model)
    solution = problem.solve(MU, max_slip=None)
    check = check_builder(problem.space, model)
    found = problem.gap_errors(solution)
    offset = problem.gap_errors(solution, builder=lambda points: replace(check(points), gap=check(points).gap + 0.01))
    assert found and max(f["mean"] for f in found) > 0
    for a, b in zip(found, offset):
        assert (a["interface"], a["increment"], a["worst"]) == (b["interface"], b["increment"], b["worst"])
        np.testing.assert_allclose([b["mean"], b["largest"]], [a["mean"], a["largest"]], rtol=1e-9, atol=1e-15)


@pytest.mark.slow
def test_edge_elements_shorter_than_the_slip_give_the_same_gap_error_as_the_mesh_as_given():
    """The 3-D block with its footprint's edges split by 3 in a 0.5 mm band (edge elements 0.139 mm, slip 0.14
    mm): accepted, and its gap error is that of the mesh as given (measured 0.0198 and 0.0202): the error is the
    solution's, not the element length's."""
    ratios = []
    for options in ({}, {"edge_splits": 3, "edge_band": 0.5}):
        problem = Problem.build(block_model(mesh_size=1.0, n_pull=5, **options))
        solution = problem.solve(MU)
        ratios.append(max(found["ratio"] for found in problem.gap_errors(solution)))
    assert (np.linalg.norm(solution.slip, axis=2) / problem.pair_length()).max() > 1.0
    assert ratios[1] == pytest.approx(ratios[0], rel=0.1) and ratios[1] < SLIP_TOLERANCE


@pytest.mark.parametrize("value, accepted", [(0.2, True), (False, True), (0, False), (-1.0, False), (True, False),
                                             ("loose", False)])
def test_slip_tolerance_takes_a_positive_number_or_false(value, accepted):
    tables = {"model": {"builder": "block2d"}, "friction": {"zones": {"A": 0.1, "B": 0.1}},
              "solver": {"slip_tolerance": value}}
    if accepted:
        assert config_from_dict(tables).solver.slip_tolerance == value
        return
    with pytest.raises(InputError, match=r"solver.slip_tolerance must be a number > 0 .*or false"):
        config_from_dict(tables)


def test_the_backend_checks_on_request_with_its_setting():
    """predict (a fit's trial points) solves unchecked; check_sliding makes the check at the setting."""
    from frictionid.backends.embedded import EmbeddedBackend
    model = block_model(pull=2.0, mesh_size=5.0, n_pull=20)
    backend = EmbeddedBackend(model, POINTS, QUANTITIES, REGIONS)
    backend.predict(MU)
    with pytest.raises(SolverError, match=f"slip_tolerance = {SLIP_TOLERANCE:g}"):
        backend.check_sliding(MU)
    EmbeddedBackend(model, POINTS, QUANTITIES, REGIONS, slip_tolerance=False).check_sliding(MU)


def _pulled(folder, pull: float, tolerance: str) -> None:
    """examples/first in ``folder`` with the pull and [solver] slip_tolerance set in both configs."""
    shutil.copytree(ROOT / "examples" / "first", folder)
    for name in ("truth.toml", "identify.toml"):
        path = folder / name
        text = path.read_text().replace("pull = 0.05", f"pull = {pull}")
        path.write_text(text + f"[solver]\nslip_tolerance = {tolerance}\n")


def test_simulate_and_identify_check_their_answer(tmp_path, capsys):
    """The plane-strain block pulled 2 mm (gross slip, ratio about 0.36): simulate refuses its solve (exit 1, the
    message); identify fits, then refuses the fitted point, and result.json keeps the fit as "failed" with the
    message; with slip_tolerance = false both go through."""
    folder = tmp_path / "first"
    _pulled(folder, 2.0, "0.1")
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 1
    assert "beyond [solver] slip_tolerance = 0.1" in capsys.readouterr().err
    _pulled(tmp_path / "off", 2.0, "false")
    assert main(["simulate", str(tmp_path / "off" / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    assert main(["identify", str(folder / "identify.toml")]) == 1
    result = json.loads((folder / "runs" / "first" / "result.json").read_text())
    assert result["status"] == "failed" and "beyond [solver] slip_tolerance = 0.1" in result["message"]
    assert len(result["history"]["coefficients"]) > 1                  # the fit's iterations are kept
    shutil.copy(folder / "measured.csv", tmp_path / "off")
    assert main(["identify", str(tmp_path / "off" / "identify.toml")]) == 0


def test_the_displacements_of_several_increments_come_from_one_solve_and_equal_each_one():
    problem = Problem.build(block_model(mesh_size=2.5))
    solution = problem.solve(MU)
    together = problem.displacement(solution, [0, 5, -1])
    one_by_one = np.array([problem.displacement(solution, k) for k in (0, 5, -1)])
    np.testing.assert_allclose(together, one_by_one, rtol=0, atol=1e-12 * np.abs(one_by_one).max())
    assert np.abs(one_by_one[2] - one_by_one[1]).max() > 0.01                 # the increments differ


def test_the_configs_default_is_the_solvers():
    from frictionid.options import SolverOptions
    assert SolverOptions().slip_tolerance == SLIP_TOLERANCE


def test_a_single_closed_pair_is_measured_against_its_own_normal_displacement(tmp_path):
    """The coarse axisymmetric block of the element cross-check (CAX3) ends its pull with one closed pair: the
    range of the target's normal displacement over the closed pairs is 0 there, and the gap error is measured
    against that pair's normal displacement instead (it stopped the solve with a division by zero)."""
    from test_calculix_elements import element_model
    model, zones = element_model("CAX3", tmp_path)
    problem = Problem.build(model)
    solution = problem.solve(np.array([zones[z] for z in model.zone_names]), max_slip=None)
    assert np.count_nonzero(solution.state[-1]) == 1
    last = next(found for found in problem.gap_errors(solution) if found["increment"] == len(solution.state) - 1)
    u = problem.displacement(solution, [len(solution.state) - 1])[0]
    closed = solution.state[-1] != 0
    pairs = problem.pairs
    target_n = np.einsum("pi,pi->p", pairs.frames[:, 0, :], u[pairs.nodes]) - solution.w[-1, :, 0]
    assert last["mean"] > 0.0 and last["spread"] == pytest.approx(abs(target_n[closed][0]), rel=1e-12)
    assert np.isfinite(last["ratio"]) and last["ratio"] < SLIP_TOLERANCE
    problem.check_small_sliding(solution)                                      # accepted, no error


def test_a_pickled_backend_ships_no_solution_and_still_checks():
    """predict keeps its last solution for check_sliding in its own process; a copy sent to a worker holds none
    and solves when asked to check."""
    import pickle

    from frictionid.backends.embedded import EmbeddedBackend
    backend = EmbeddedBackend(block_model(mesh_size=5.0), POINTS, QUANTITIES, REGIONS)
    backend.predict(MU)
    assert backend._last is not None
    copy = pickle.loads(pickle.dumps(backend))
    assert copy._last is None
    copy.check_sliding(MU)


def _interfaces_observed(model):
    """The model's interface dofs as observation rows: "mumps" then eliminates them last (the 3-D bolt's are
    anyway; the block's plate top reaches beyond the dofs the contact rows touch)."""
    from frictionid.fem.sliding import interface_dofs, selection
    n = model.mesh.points.shape[1]
    return selection(interface_dofs(model, n), n * model.mesh.n_nodes)


@pytest.mark.parametrize("kind", ["3d", "plane_strain"])
def test_with_mumps_the_check_makes_no_factor_again_and_finds_what_the_whole_field_gives(kind, monkeypatch):
    """The check's displacements on the interfaces from the Schur complements' kept factors (Condensed.
    displacement_at): during solve + check MUMPS factorises nothing (before, the check made every body's factor
    again), and the gap errors equal those of the whole field to round-off, in the 2 mm pull the check refuses
    too (its ratio 0.27 measured)."""
    from frictionid.builders.block import block_model_2d
    from frictionid.fem import mumps_schur
    from frictionid.fem.condense import Condensed
    from frictionid.fem.sliding import interface_dofs
    if not mumps_schur.available():
        pytest.skip("python-mumps (MUMPS) is not installed")
    factorised = []
    original = mumps_schur.SchurFactor._factor_timed
    monkeypatch.setattr(mumps_schur.SchurFactor, "_factor_timed", lambda self: factorised.append(1) or original(self))
    for pull, n_pull in ((0.2, 10), (2.0, 20)):
        model = block_model(pull=pull, mesh_size=5.0, n_pull=n_pull) if kind == "3d" else \
            block_model_2d(pull=pull, n_pull=n_pull, mesh_size=2.0)
        problem = Problem.build(model, observe=_interfaces_observed(model), factorisation="mumps")
        made = len(factorised)
        solution = problem.solve(MU if kind == "3d" else [0.3, 0.2], max_slip=None if pull > 1 else SLIP_TOLERANCE)
        fast = problem.gap_errors(solution)
        assert len(factorised) == made                         # no MUMPS factorisation in solve and check
        checked = sorted({found["increment"] for found in fast})
        on, alone = problem.interface_displacement(solution, checked)
        whole = problem.displacement(solution, checked)
        assert alone and len(factorised) > made                # the whole field makes the factors again
        on_interfaces = interface_dofs(model, model.mesh.points.shape[1])
        on, whole = on.reshape(len(checked), -1), whole.reshape(len(checked), -1)
        np.testing.assert_allclose(on[:, on_interfaces], whole[:, on_interfaces], rtol=0,
                                   atol=1e-12 * np.abs(whole).max())
        # prescribed dofs (the block's top: pulled) among those asked for, in any order
        c = problem.condensed
        dofs = np.concatenate([c.prescribed[::-3], on_interfaces[::-1]])
        at = c.displacement_at(dofs, *problem._loads(solution, np.array(checked)))
        np.testing.assert_allclose(at, whole[:, dofs], rtol=0, atol=1e-12 * np.abs(whole).max())
        assert np.abs(at[-1, :len(c.prescribed[::-3])]).max() > 0.1 * pull
        with monkeypatch.context() as m:
            m.setattr(Condensed, "displacement_at", lambda *args: None)
            full = problem.gap_errors(solution)
        # the worst pair where the errors are above round-off: in the press (increment 0) every error is 1e-17 mm,
        # zero to the check (its mean 0), and which pair's round-off is largest differs between the two routes
        assert [(f["interface"], f["increment"], f["worst"] if f["mean"] > 0 else None, f["unmeasured"])
                for f in fast] == \
            [(f["interface"], f["increment"], f["worst"] if f["mean"] > 0 else None, f["unmeasured"]) for f in full]
        for a, b in zip(fast, full):
            for key in ("mean", "spread", "ratio", "largest"):
                assert a[key] == pytest.approx(b[key], rel=1e-9, abs=1e-15), key
        assert (max(f["ratio"] for f in fast) > SLIP_TOLERANCE) == (pull > 1)


def test_without_the_interfaces_last_the_check_takes_the_whole_field():
    """The block's plate top is not all among the dofs the contact rows touch: the whole field, the same errors."""
    from frictionid.fem import mumps_schur
    if not mumps_schur.available():
        pytest.skip("python-mumps (MUMPS) is not installed")
    model = block_model(mesh_size=5.0)
    problem, observed = (Problem.build(model, factorisation="mumps", **kw)
                         for kw in ({}, {"observe": _interfaces_observed(model)}))
    solution = problem.solve(MU)
    assert not problem.interface_displacement(solution, [len(solution.stage) - 1])[1]
    ratios = [[f["ratio"] for f in p.gap_errors(s)] for p, s in ((problem, solution), (observed, observed.solve(MU)))]
    assert ratios[0] == pytest.approx(ratios[1], rel=1e-9, abs=1e-15) and max(ratios[0]) > 0
