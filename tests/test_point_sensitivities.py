"""Sensitivities at points the condensation does not observe, from the solution's contact sensitivities: what the
pre-fit suggestions rank candidate points by, without condensing the model a second time."""

import numpy as np
import pytest

from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.block import block_model, block_model_2d
from frictionid.fem import problem as problem_module
from frictionid.fem.problem import Problem
from frictionid.inverse import prefit as prefit_module
from frictionid.inverse.evaluator import Evaluator
from frictionid.inverse.observations import Observations
from frictionid.inverse.parameters import Parameters

MU = np.array([0.3, 0.15, 0.45, 0.2])


@pytest.mark.parametrize("make, quantities", [
    (lambda: block_model_2d(mesh_size=1.0, n_zones=4), ("ux", "uy", "exx", "exy")),
    (lambda: block_model(mesh_size=2.0), ("ux", "uy", "uz", "ezz")),
])
def test_point_sensitivities_equal_those_of_a_condensation_that_observes_the_points(make, quantities):
    """Reference: the same model condensed with the points' rows (Problem.build with points), whose
    d_observations come from the condensed rows: another path through the same equations."""
    model = make()
    mu = MU[:len(model.zone_names)]
    points, regions = prefit_module.candidate_points(model, np.zeros((0, model.dim)), 12)   # as the suggestions
    observed = Problem.build(model, points=points[:2], quantities=("uy",), regions=regions[:2])
    found = observed.point_sensitivities(observed.solve(mu, sensitivities=True), points, quantities, regions)
    reference = Problem.build(model, points=points, quantities=quantities, regions=regions)
    solution = reference.solve(mu, sensitivities=True)
    expected = np.asarray(solution.d_observations)[[solution.stage_end(s) for s in range(model.n_stages)]]
    assert found.shape == expected.shape and np.abs(expected).max() > 0
    np.testing.assert_allclose(found, expected, rtol=0, atol=1e-8 * np.abs(expected).max())


def test_without_sensitivities_there_are_none():
    model = block_model_2d(mesh_size=1.0, n_zones=4)
    problem = Problem.build(model)
    assert problem.point_sensitivities(problem.solve(MU), np.array([[0.0, 1.0]]), ("uy",)) is None


def test_the_suggestions_condense_the_model_once(monkeypatch):
    """The pre-fit check ranks 120 candidate points from the fit's own condensation: Problem.build runs once."""
    model = block_model_2d(mesh_size=1.0, n_zones=3)
    builds = []
    build = Problem.build.__func__
    monkeypatch.setattr(problem_module.Problem, "build",
                        classmethod(lambda cls, *a, **k: builds.append(1) or build(cls, *a, **k)))
    points = np.array([[-5.0, 2.0], [-5.0, 3.0]])
    n = 4
    obs = Observations(points=points, point_regions=("block", "block"), quantities=("ux", "uy"),
                       row=np.arange(n), stage=np.full(n, 1), y=np.zeros(n), sigma=np.full(n, 5e-4),
                       labels=tuple(map(str, range(n))), noise_known=True)
    params = Parameters.from_config(model.zone_names, {z: 0.1 for z in model.zone_names})
    backend = EmbeddedBackend(model, obs.points, obs.quantities, obs.point_regions, keep=False)
    report = prefit_module.prefit(Evaluator(backend, obs, params), model, 0.05, 5, EmbeddedBackend)
    assert report.additions and len(builds) == 1
