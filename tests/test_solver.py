"""Embedded contact solver: gross slip, sensitivities against central differences, self-consistency."""

import numpy as np
import pytest

from frictionid.builders.block import block_model_2d
from frictionid.fem.contact import SLIP, STICK
from frictionid.fem.problem import Problem
from helpers.differences import check_sensitivities

MU = np.array([0.15, 0.35])


@pytest.fixture(scope="module", params=["triangle6", "quad9", "triangle"])
def gross(request):
    """Plane-strain block pulled far enough that every closed pair slips (pull 0.5 mm, height 4 mm)."""
    options = {"triangle6": {}, "quad9": {"quads": True}, "triangle": {"order": 1}}[request.param]
    problem = Problem.build(block_model_2d("plane_strain", pull=0.5, height=4.0, mesh_size=1.0, **options))
    return problem, problem.solve(MU, sensitivities=True)


def test_gross_slip_tangential_reaction_equals_sum_mu_n(gross):
    problem, solution = gross
    closed = solution.state[-1] != 0
    assert np.all(solution.state[-1][closed] == SLIP)
    normal = solution.zone_normal_force[-1]
    pulled = solution.reactions[-1][solution.reaction_labels.index("block_top.x")]
    assert abs(pulled) == pytest.approx(MU @ normal, rel=1e-8)   # docs/design.md, verification, exact for Coulomb


def test_every_slipping_pair_is_on_the_friction_cone(gross):
    problem, solution = gross
    lam, slip = solution.lam[-1], solution.state[-1] == SLIP
    mu_pair = problem.pairs.mu(MU)
    np.testing.assert_allclose(np.abs(lam[slip, 1]), mu_pair[slip] * lam[slip, 0], rtol=1e-8)


def test_reactions_balance_the_contact_forces(gross):
    problem, solution = gross
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert reactions["base_bottom.y"] == pytest.approx(200.0, rel=1e-10)     # the applied pressing force
    assert reactions["base_bottom.x"] == pytest.approx(-reactions["block_top.x"], rel=1e-10)


def test_friction_dissipates_in_every_increment(gross):
    problem, solution = gross
    ds = np.diff(np.concatenate([np.zeros((1,) + solution.slip.shape[1:]), solution.slip]), axis=0)
    work = np.einsum("ipk,ipk->i", solution.lam[:, :, 1:], ds)
    assert np.all(work <= 1e-12 * np.abs(solution.lam).max())


def test_zero_friction_gives_no_shear():
    problem = Problem.build(block_model_2d("plane_strain", pull=0.1, height=4.0, mesh_size=2.0))
    solution = problem.solve([0.0, 0.0])
    assert np.max(np.abs(solution.lam[:, :, 1])) <= 1e-10 * np.max(solution.lam[:, :, 0])


@pytest.mark.parametrize("pull", [0.01, 0.5], ids=["partial-slip", "gross-slip"])
def test_sensitivities_match_central_differences(pull):
    problem = Problem.build(block_model_2d("plane_strain", pull=pull, height=4.0, mesh_size=1.0))
    solution = check_sensitivities(problem, MU)                           # rtol 1e-6, h 1e-6
    states = np.bincount(solution.state[-1], minlength=3)
    assert states[SLIP] > 0 and (pull > 0.1 or states[STICK] > 0)        # the regime the id claims


def test_a_flat_conforming_interface_has_the_target_normal_and_no_gap(gross):
    problem, _ = gross
    np.testing.assert_allclose(problem.pairs.frames[:, 0], [[0.0, 1.0]] * problem.pairs.n_pairs, atol=1e-12)
    np.testing.assert_allclose(problem.pairs.gap, 0.0, atol=1e-12)
