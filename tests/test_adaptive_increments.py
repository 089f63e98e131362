"""Adaptive increments (Problem.solve(increments="adaptive")): a step grows only where the contact settled, so the
stage ends agree with the fixed increments; every stage end is reached exactly."""

import numpy as np
import pytest

from frictionid.builders.block import block_model, block_model_2d
from frictionid.errors import InputError
from frictionid.fem.problem import Problem


@pytest.fixture(scope="module")
def plane_strain():
    """Press in 2 increments, pull in 12: gross slip from the third pull increment on, states and (in 2-D)
    slip directions unchanged after that."""
    return Problem.build(block_model_2d(pull=0.1, height=4.0, mesh_size=2.0, contact_size=1.0, n_zones=2,
                                        n_press=2, n_pull=12))


def test_adaptive_steps_grow_in_gross_slip_and_keep_the_stage_ends(plane_strain):
    fixed = plane_strain.solve([0.3, 0.2], sensitivities=True)
    adaptive = plane_strain.solve([0.3, 0.2], sensitivities=True, increments="adaptive")
    assert adaptive.n_increments < fixed.n_increments
    stages = range(len(plane_strain.model.stages))
    ends_f = [fixed.stage_end(s) for s in stages]
    ends_a = [adaptive.stage_end(s) for s in stages]
    assert np.allclose(adaptive.amplitude[ends_a], fixed.amplitude[ends_f], rtol=1e-15, atol=1e-15)   # stage ends
    assert np.all(np.diff(adaptive.amplitude[:, -1]) >= 0)
    for name in ("lam", "w", "reactions", "d_reactions"):
        a, b = np.asarray(getattr(fixed, name))[ends_f], np.asarray(getattr(adaptive, name))[ends_a]
        # 2-D gross slip under proportional load: the path does not depend on the steps
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(a)), name


def test_unknown_increments_is_refused(plane_strain):
    with pytest.raises(InputError, match="increments"):
        plane_strain.solve([0.3, 0.2], increments="automatic")


def test_3d_steps_do_not_grow_while_slip_directions_turn():
    """3-D block, 20 pull increments: the slip directions keep turning, so the steps stay nominal nearly
    everywhere and the stage ends stay within 1e-4 of the fixed path's contact forces (relative to their
    largest); the fixed path itself moves by 2e-4 between 20 and 40 increments (docs/solver.md). Growing on
    Newton's count alone took 7 steps and moved them by 1.3e-3."""
    problem = Problem.build(block_model(mesh_size=2.5, n_pull=20))
    mu = [0.3, 0.2, 0.4, 0.25]
    fixed, adaptive = problem.solve(mu), problem.solve(mu, increments="adaptive")
    ends_f = [fixed.stage_end(s) for s in range(2)]
    ends_a = [adaptive.stage_end(s) for s in range(2)]
    error = np.max(np.abs(fixed.lam[ends_f] - adaptive.lam[ends_a])) / np.max(np.abs(fixed.lam[ends_f]))
    assert error <= 1e-4


def test_solver_increments_key_reaches_the_embedded_backend(plane_strain):
    from frictionid.backends import make_backend
    from frictionid.config import config_from_dict

    tables = {"model": {"builder": "block2d"}, "friction": {"zones": {"A": 0.1, "B": 0.1}}}
    assert config_from_dict(tables).solver.increments == "fixed"
    config = config_from_dict({**tables, "solver": {"increments": "adaptive"}})
    with pytest.raises(InputError, match="solver.increments"):
        config_from_dict({**tables, "solver": {"increments": "automatic"}})
    backend = make_backend(plane_strain.model, np.array([[-5.0, 0.5]]), ("ux",), ["block"], solver=config.solver)
    assert backend.increments == "adaptive"
    fixed = make_backend(plane_strain.model, np.array([[-5.0, 0.5]]), ("ux",), ["block"])
    adaptive, reference = backend.predict([0.3, 0.2], True), fixed.predict([0.3, 0.2], True)
    assert np.allclose(adaptive.values, reference.values, rtol=1e-9, atol=0)
    assert np.allclose(adaptive.derivatives, reference.derivatives, rtol=1e-9, atol=1e-12)
