"""Stick thresholds (Solution.stick_thresholds): for a zone that sticks along the whole load path, the smallest
coefficient with the same path. Checked on the clamp fixture (six zones, press then pull into gross slip) at
mu = 0.6, where U1, U2 and L1 stick throughout and the other three slip: at the thresholds (with the optimisers'
margin) every output is the same, and just below one of them that zone slips."""

from pathlib import Path

import numpy as np
import pytest

from frictionid.builders.registry import build_model
from frictionid.config import read_config
from frictionid.fem.contact import SLIP
from frictionid.fem.problem import Problem
from frictionid.inverse.stick_start import STICK_MARGIN

CLAMP = Path(__file__).parent / "fixtures" / "clamp" / "clamp.toml"


@pytest.fixture(scope="module")
def clamp():
    problem = Problem.build(build_model(read_config(CLAMP).model_spec), points=np.array([[40.0, 1.0], [40.0, 6.0]]),
                            quantities=("ux", "uy"), regions=["strip", "upper_pad"])
    return problem, problem.solve(np.full(6, 0.6))


def zone_slips(solution, z: int) -> bool:
    mine = solution.pairs.zone_share[:, z] > 0
    return bool((solution.state[:, mine] == SLIP).any())


def test_only_zones_that_stick_throughout_have_a_threshold(clamp):
    _, solution = clamp
    floor = solution.stick_thresholds()
    stuck = [not zone_slips(solution, z) for z in range(6)]
    assert stuck == [True, True, False, True, False, False]
    np.testing.assert_array_equal(np.isfinite(floor), stuck)
    assert np.all((floor[stuck] > 0.3) & (floor[stuck] < 0.6))
    # a zone that may not move has none
    movable = np.array([True, False, True, True, True, True])
    assert np.isnan(solution.stick_thresholds(movable)[1])


def test_the_path_is_the_same_at_the_thresholds_and_not_below_them(clamp):
    problem, solution = clamp
    floor = solution.stick_thresholds()
    lowered = np.where(np.isfinite(floor), floor * (1 + STICK_MARGIN), 0.6)
    at = problem.solve(lowered)
    np.testing.assert_array_equal(at.state, solution.state)
    for name in ("observations", "reactions", "lam"):
        ours, theirs = np.asarray(getattr(at, name)), np.asarray(getattr(solution, name))
        assert np.abs(ours - theirs).max() <= 1e-9 * np.abs(theirs).max(), name
    for z in np.flatnonzero(np.isfinite(floor)):     # the threshold is tight: 0.1 % below it the zone slips
        below = lowered.copy()
        below[z] = floor[z] * 0.999
        assert zone_slips(problem.solve(below), z)
