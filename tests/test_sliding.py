"""Finite sliding (fem/sliding.py): a plane-strain block slid 2 mm over a long base at constant normal force."""

import numpy as np
import pytest

from frictionid.errors import InputError
from frictionid.fem.problem import Problem
from sliding_case import block_on_base
from helpers.differences import central_difference

MU = np.array([0.3, 0.2])          # zones "left", "right" of the block's bottom
PULL, FORCE = 2.0, 1000.0          # [mm], [N/mm]: 2 mm = 20 % of the block, about 3 base facets
#: observation points: two in the block, two in the base [mm]
POINTS = np.array([[0.5, 1.5], [9.5, 2.5], [15.0, -1.0], [-3.0, -1.5]])


@pytest.fixture(scope="module")
def slid():
    model = block_on_base(n_block=10, n_base=41, force=FORCE, pull=PULL, n_pull=5)
    finite, small = Problem.build(model, points=POINTS, sliding="finite"), Problem.build(model)
    return model, finite, finite.solve(MU, sensitivities=True), small.solve(MU, max_slip=None), small


def _base_force_centroid(model, nodal_forces) -> float:
    """x [mm] of the centroid of the normal contact forces on the base's top nodes (undeformed positions)."""
    target = np.unique(model.mesh.boundary("target"))
    fy = nodal_forces.reshape(-1, 2)[target, 1]
    return float(model.mesh.points[target, 0] @ fy / fy.sum())


def test_gross_slip_reaction_is_mu_times_normal_force(slid):
    model, problem, solution, _, _ = slid
    assert np.all(solution.state[-1] == 2)                                      # the whole bottom slips
    pull_reaction = solution.reactions[-1, problem.reaction_labels.index("block_top.x")]
    normal = solution.zone_normal_force[-1]
    # normal forces in the pair frames of the deformed base, whose normals tilt a little: measured 1.4e-5
    np.testing.assert_allclose(normal.sum(), FORCE, rtol=1e-4)
    # Coulomb in gross slip: T = sum_z mu_z N_z (NUMERICS.md 5.1); 0.5 % asked by issue 26
    np.testing.assert_allclose(pull_reaction, MU @ normal, rtol=5e-3)


def test_base_pressure_moves_with_the_block(slid):
    model, problem, solution, small_solution, small = slid
    f = np.zeros(problem.space.n_dofs)
    f[problem.interface_dofs] = solution.interface_forces[-1]
    centroid = _base_force_centroid(model, f)
    u = problem.displacement(solution, -1)
    nodes, lam_N = solution.pairs.nodes, solution.lam[-1, :, 0]
    block_centroid = (model.mesh.points[nodes, 0] + u[nodes, 0]) @ lam_N / lam_N.sum()
    # the base carries the block's pressure where the block is now: measured 4e-4 of the pull apart
    assert abs(centroid - block_centroid) < 1e-3 * PULL
    # small sliding leaves it at the undeformed partners: the two differ by the block's slide (the couple of
    # friction and pull shifts both centroids alike); measured 3e-4 of the pull apart
    small_centroid = _base_force_centroid(model, small.pairs.B.T @ small_solution.lam[-1].ravel())
    slide = u[nodes, 0].mean()
    assert slide > 0.99 * PULL
    assert abs((centroid - small_centroid) - slide) < 5e-3 * PULL


def test_tiny_pull_finite_equals_small_sliding():
    model = block_on_base(n_block=10, n_base=41, force=1e-6, pull=1e-9, n_pull=3)
    finite, small = Problem.build(model, sliding="finite"), Problem.build(model)
    a, b = finite.solve(MU), small.solve(MU)
    for got, expected in ((a.reactions, b.reactions), (a.lam, b.lam), (a.w, b.w)):
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-8 * np.abs(expected).max())
    np.testing.assert_allclose(finite.displacement(a), small.displacement(b), rtol=0,
                               atol=1e-8 * np.abs(small.displacement(b)).max())


def test_frictionless_sliding_carries_no_tangential_force(slid):
    model, problem, _, _, _ = slid
    solution = problem.solve([0.0, 0.0])
    assert np.abs(solution.lam[:, :, 1]).max() <= 1e-12 * FORCE
    # the deformed base's tilt gives the normal force a small x component: measured 1.9e-4 N per 1000 N
    assert abs(solution.reactions[-1, problem.reaction_labels.index("block_top.x")]) < 1e-5 * FORCE


@pytest.fixture(scope="module")
def partly_slipping():
    """Pressed in two increments, pulled 4 um in four: stick, partial slip, then gross slip."""
    model = block_on_base(n_block=10, n_base=41, force=FORCE, pull=0.004, n_press=2, n_pull=4)
    problem = Problem.build(model, points=POINTS, sliding="finite")
    return model, problem, problem.solve(MU, sensitivities=True)


@pytest.mark.parametrize("case", ["slid", "partly_slipping"])
def test_sensitivities_against_central_differences_of_the_finite_sliding_solve(case, request):
    model, problem, solution = request.getfixturevalue(case)[:3]
    if case == "partly_slipping":
        assert np.any(solution.state == 1) and np.any(solution.state[-2] == 2)
    n_reactions = solution.reactions.size

    def outputs(mu):                    # reactions and observations in one vector: one pair of solves per zone
        solved = problem.solve(mu)
        return np.concatenate([solved.reactions.ravel(), np.asarray(solved.observations).ravel()])

    central = central_difference(outputs, MU, 1e-6)
    for z in range(len(MU)):
        for got, fd, tolerance in (
                (solution.d_reactions[:, :, z], central[:n_reactions, z].reshape(solution.reactions.shape), 1e-5),
                (np.asarray(solution.d_observations)[:, :, z],
                 central[n_reactions:, z].reshape(np.shape(solution.observations)), 1e-5)):
            # with the coupling's change with the displacements: measured 6.1e-7 / 5.5e-7 (reactions) and
            # 1.3e-6 / 1.2e-6 (displacements at the points) of the largest derivative; with each increment's
            # coupling held (dB/du du/dmu left out) 4.5e-4 and 1.3e-3 (docs/solver.md)
            np.testing.assert_allclose(got, fd, rtol=0, atol=tolerance * np.abs(fd).max())


def test_observations_are_the_displacements_at_the_points(slid):
    model, problem, solution, _, _ = slid
    u = problem.displacement(solution, -1)
    # the observation rows at nodes of the mesh would be exact; at interior points they interpolate u: compare
    # against the same interpolation from the nodal displacements
    from frictionid.fem.points import point_operator
    rows = point_operator(problem.space, POINTS, ("ux", "uy"), None, model.materials, None)
    np.testing.assert_allclose(np.asarray(solution.observations)[-1], rows @ u.ravel(), rtol=1e-9,
                               atol=1e-12)


def test_unknown_sliding_value_is_refused(slid):
    with pytest.raises(InputError, match="sliding"):
        Problem.build(slid[0], sliding="large")


def test_finite_sliding_with_twist_is_refused(slid):
    import dataclasses
    twisted = dataclasses.replace(slid[0], kind="axisymmetric_twist")
    with pytest.raises(InputError, match="sliding = 'finite' needs a plane-strain, axisymmetric or 3-D model, got "
                                         "kind 'axisymmetric_twist'"):
        Problem.build(twisted, sliding="finite")


def _simulate(folder, solver: str) -> int:
    from block2d_case import MODEL, POINTS, REGIONS, TRUE
    from frictionid.cli import main
    (folder / "points.csv").write_text(POINTS)
    config = folder / "sliding.toml"
    config.write_text(MODEL + "[friction]\nzones = { " + ", ".join(f"{k} = {v}" for k, v in TRUE.items())
                      + ' }\n[data]\nfile = "points.csv"\nobservables = ["ux", "uy"]\nstages = [2]\n' + REGIONS
                      + solver + '[run]\ndir = "runs"\nfields = false\n')
    return main(["simulate", str(config), "--out", str(folder / "simulated.csv")])


def test_simulate_with_finite_sliding_agrees_with_small_sliding_on_a_short_slide(tmp_path, capsys):
    def read():
        lines = [line for line in (tmp_path / "simulated.csv").read_text().splitlines() if line[:1] == "P"]
        return np.array([[float(v) for v in line.split(",")[-2:]] for line in lines])

    assert _simulate(tmp_path, '[solver]\nsliding = "finite"\n') == 0
    finite = read()
    contact = [line for line in capsys.readouterr().out.splitlines() if line.startswith("contact ")]
    assert contact and all(line.endswith("finite sliding: re-coupled by dual mortar in the deformed configuration "
                                         "at every increment") for line in contact), contact
    assert _simulate(tmp_path, "") == 0
    small = read()
    assert "finite sliding" not in capsys.readouterr().out
    assert finite.shape == small.shape and len(finite) >= 6
    # block2d slides less than a facet: the updated coupling changes the displacements a little, not nothing
    difference = np.abs(finite - small).max()
    assert 0 < difference < 1e-2 * np.ptp(small)


def test_a_bad_sliding_value_exits_2_naming_file_and_key(tmp_path, capsys):
    assert _simulate(tmp_path, '[solver]\nsliding = "large"\n') == 2
    err = capsys.readouterr().err
    assert "sliding.toml" in err and "solver.sliding" in err and "finite" in err and "Traceback" not in err


def test_a_node_the_target_no_longer_covers_stays_paired_and_open(slid):
    from frictionid.fem.pairs import ContactPairs
    from frictionid.fem.sliding import UNCOVERED_GAP, aligned
    pairs = slid[1].pairs
    dim, lost = pairs.dim, 3
    keep = np.setdiff1d(np.arange(pairs.n_pairs), [lost])[::-1]              # another order, one node less
    rows = (dim * keep[:, None] + np.arange(dim)).ravel()
    current = ContactPairs(pairs.nodes[keep], pairs.position[keep], pairs.frames[keep, ::-1], pairs.weight[keep],
                           pairs.zone_share[keep], pairs.gap[keep] + 0.5, pairs.B[rows], pairs.interface[keep])
    got = aligned(pairs, current)
    others = np.setdiff1d(np.arange(pairs.n_pairs), [lost])
    np.testing.assert_array_equal(got.nodes, pairs.nodes)
    np.testing.assert_array_equal(got.gap[others], pairs.gap[others] + 0.5)
    assert got.gap[lost] == UNCOVERED_GAP
    np.testing.assert_array_equal(got.frames[others], pairs.frames[others, ::-1])     # the current frames
    np.testing.assert_array_equal(got.frames[lost], pairs.frames[lost])
    full = (dim * others[:, None] + np.arange(dim)).ravel()
    assert abs(got.B[full] - pairs.B[full]).max() == 0
    # the lost node's rows: its frame on its own displacement only, no target
    row = got.B[dim * lost:dim * lost + dim].tocoo()
    assert set(row.col // dim) == {pairs.nodes[lost]}
    np.testing.assert_array_equal(row.toarray()[:, dim * pairs.nodes[lost]:dim * pairs.nodes[lost] + dim],
                                  pairs.frames[lost])


def test_a_slide_past_the_end_of_the_target_is_reported_with_the_node():
    from frictionid.builders.verification import sleeve_model
    from frictionid.errors import SolverError
    # the sleeve's target is the shaft's surface along the sleeve's initial bore only (y = 0 to 10 mm): pushed
    # down, the sleeve's lowest bore node leaves it, the coupling drops the node, the node comes back, ...
    problem = Problem.build(sleeve_model(push=2.0, size=1.0, n_push=5), sliding="finite")
    with pytest.raises(SolverError, match=r"contact node\(s\) \[\d+\] \(first at \[10.0, 0.0\]\) move on and off "
                                          "the end of the target"):
        problem.solve([0.2, 0.3])


def test_keeping_a_coupling_while_the_pairs_move_under_its_fraction_of_a_facet_keeps_the_path(monkeypatch):
    """The seed's block test in plane strain (2 mm at 2000 N/mm, 20 increments, soft epoxy base): keeping a
    coupling while every pair moves by at most RECOUPLE_FRACTION (1e-4) of its facet since the coupling's
    configuration builds 72 couplings instead of 92 (re-coupled until the fixed point converges) and changes the
    reactions by 8.7e-6 of the largest and the displacements at 6 points by 2.1e-6 of their range (measured;
    3e-4 of a facet: 62 couplings, 3.0e-5 / 6.7e-6; 3e-3: 38 couplings, 1.8e-4 / 1.2e-4, over the 1e-4 here)."""
    from frictionid.builders.block import block_model_2d
    from frictionid.fem import sliding

    model = block_model_2d("plane_strain", pull=2.0, force=2000.0, height=4.0, mesh_size=1.0, n_zones=4,
                           n_press=1, n_pull=20, order=1)
    points = np.array([[-4.5, 1.0], [4.5, 3.0], [-8.0, -1.0], [12.0, -1.0], [-3.0, -0.5], [3.0, -0.5]])
    problem = Problem.build(model, points=points, sliding="finite")
    built = []
    coupling = sliding.Coupling.__init__
    monkeypatch.setattr(sliding.Coupling, "__init__", lambda self, *a: built.append(1) or coupling(self, *a))
    mu = np.array([0.3, 0.2, 0.4, 0.25])
    kept = problem.solve(mu)
    n_kept, built[:] = len(built), []
    monkeypatch.setattr(sliding, "RECOUPLE_FRACTION", 0.0)
    reference = problem.solve(mu)
    assert n_kept < 0.85 * len(built)
    np.testing.assert_allclose(kept.reactions, reference.reactions, rtol=0,
                               atol=1e-4 * np.abs(reference.reactions).max())
    observed = np.asarray(reference.observations)
    np.testing.assert_allclose(np.asarray(kept.observations), observed, rtol=0, atol=1e-4 * np.ptp(observed))


def test_with_mumps_the_re_coupling_takes_the_interface_displacements_from_the_schur_factors(monkeypatch):
    """Each fixed-point pass needs the interface dofs' displacements only: with "mumps" they come from the Schur
    complements' kept factors, no MUMPS factorisation during the solve (before, the first pass made every body's
    factor again), and the solution is SuperLU's whole-field one to round-off (measured 4e-14 of the largest
    multiplier, 6e-11 of the largest reaction sensitivity)."""
    from frictionid.builders.block import block_model_2d
    from frictionid.fem import mumps_schur
    if not mumps_schur.available():
        pytest.skip("python-mumps (MUMPS) is not installed")
    factorised = []
    original = mumps_schur.SchurFactor._factor_timed
    monkeypatch.setattr(mumps_schur.SchurFactor, "_factor_timed", lambda self: factorised.append(1) or original(self))
    model = block_model_2d(pull=1.0, mesh_size=2.0)
    mumps = Problem.build(model, factorisation="mumps", sliding="finite")
    made = len(factorised)
    solution = mumps.solve([0.3, 0.2], sensitivities=True)
    assert len(factorised) == made > 0
    reference = Problem.build(model, factorisation="superlu", sliding="finite").solve([0.3, 0.2], sensitivities=True)
    assert np.abs(solution.w[-1, :, 1]).max() > 0.5                           # slid half the pull and more
    for key in ("lam", "w", "reactions", "d_reactions"):
        got, expected = getattr(solution, key), getattr(reference, key)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-8 * np.abs(expected).max(), err_msg=key)
