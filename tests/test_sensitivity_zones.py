"""Sensitivities to some zones only: a fit's held zones' columns are never read, so a solve takes the
sensitivities to the free zones alone (one solve with the Jacobian per zone and increment fewer per held zone)."""

import numpy as np
import pytest

from frictionid.backends.base import Prediction
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.block import block_model_2d
from frictionid.fem.problem import Problem, sensitivity_zones
from frictionid.inverse.evaluator import Evaluator
from frictionid.inverse.observations import Observations
from frictionid.inverse.parameters import Parameters

MU = np.array([0.3, 0.15, 0.45, 0.2])
POINTS = np.array([[-5.0, 2.0], [-5.0, 3.0], [3.0, 1.0]])


@pytest.fixture(scope="module")
def block():
    model = block_model_2d(mesh_size=1.0, n_zones=4)
    problem = Problem.build(model, points=POINTS, quantities=("ux", "uy"))
    return model, problem, problem.solve(MU, sensitivities=True)


def test_the_asked_zones_columns_are_every_zones_and_the_others_nan(block):
    """Zones 0 and 2 of four: their columns of d_x, d_observations, d_reactions and of the point sensitivities
    are the full solve's (to round-off), the others NaN; the solution itself is the same."""
    model, problem, full = block
    part = problem.solve(MU, sensitivities=[2, 0])
    np.testing.assert_array_equal(part.observations, full.observations)
    for name in ("d_x", "d_observations", "d_reactions"):
        a, b = np.asarray(getattr(part, name)), np.asarray(getattr(full, name))
        assert a.shape == b.shape and np.abs(b[..., [0, 2]]).max() > 0, name
        np.testing.assert_allclose(a[..., [0, 2]], b[..., [0, 2]], rtol=0, atol=1e-10 * np.abs(b).max())
        assert np.isnan(a[..., [1, 3]]).all(), name
    points = np.array([[0.0, 1.0], [2.0, 0.5]])
    found, expected = (problem.point_sensitivities(s, points, ("ux", "exx")) for s in (part, full))
    np.testing.assert_allclose(found[..., [0, 2]], expected[..., [0, 2]], rtol=0, atol=1e-10 * np.abs(expected).max())
    assert np.isnan(found[..., [1, 3]]).all()


def test_which_zones():
    assert sensitivity_zones(False, 4) is None and sensitivity_zones([], 4) is None
    np.testing.assert_array_equal(sensitivity_zones(True, 3), [0, 1, 2])
    np.testing.assert_array_equal(sensitivity_zones((3, 1, 3), 4), [1, 3])
    with pytest.raises(ValueError, match="outside the model's 4 zones"):
        sensitivity_zones([4], 4)


def test_the_embedded_backend_gives_the_asked_zones():
    model = block_model_2d(mesh_size=1.0, n_zones=4)
    backend = EmbeddedBackend(model, POINTS, ("ux", "uy"), (None,) * len(POINTS), keep=False)
    full, part = backend.predict(MU, True).derivatives, backend.predict(MU, (1, 3)).derivatives
    np.testing.assert_allclose(part[:, :, [1, 3]], full[:, :, [1, 3]], rtol=0, atol=1e-10 * np.abs(full).max())
    assert np.isnan(part[:, :, [0, 2]]).all()


class _Asked:
    """f = A mu; records which zones each solve was asked the derivatives of."""

    def __init__(self, A):
        self.A, self.asked = np.asarray(A, float), []

    def predict(self, mu, sensitivities=False):
        self.asked.append(sensitivities)
        return Prediction((self.A @ mu)[None, :], self.A[None] if sensitivities else None)


def test_a_fit_asks_for_its_free_zones_only():
    """Zone B held: the evaluator's Jacobian asks the backend for zones A and C (indices 0 and 2)."""
    A = np.array([[1.0, 0.5, 0.0], [0.0, 2.0, 1.0], [1.0, 0.0, 3.0]])
    params = Parameters.from_config(("A", "B", "C"), {"A": 0.2, "C": 0.3}, bounds=(0.0, 0.6), fixed={"B": 0.1})
    obs = Observations(points=np.zeros((3, 2)), point_regions=(None,) * 3, quantities=("ux",), row=np.arange(3),
                       stage=np.zeros(3, int), y=np.ones(3), sigma=np.ones(3), labels=("0", "1", "2"),
                       noise_known=True)
    backend = _Asked(A)
    jacobian = Evaluator(backend, obs, params).jacobian(np.array([0.2, 0.3]))
    np.testing.assert_allclose(jacobian[:3], A[:, [0, 2]])
    assert backend.asked == [(0, 2)]


def test_a_refit_asks_for_the_zones_it_is_given_and_solves_again_where_a_stored_column_is_missing(tmp_path):
    """The refits of a profile (one zone held each) share their stored evaluations: each asks for the
    identification's free zones (``sensitive``), and an evaluation stored without one of its free zones' columns
    (NaN) is solved again instead of being read."""
    from frictionid.run.store import RunStore
    A = np.array([[1.0, 0.5, 0.0], [0.0, 2.0, 1.0], [1.0, 0.0, 3.0]])
    held = Parameters.from_config(("A", "B", "C"), {"B": 0.2, "C": 0.3}, bounds=(0.0, 0.6), fixed={"A": 0.1})
    obs = Observations(points=np.zeros((3, 2)), point_regions=(None,) * 3, quantities=("ux",), row=np.arange(3),
                       stage=np.zeros(3, int), y=np.ones(3), sigma=np.ones(3), labels=("0", "1", "2"),
                       noise_known=True)
    store = RunStore.open(tmp_path / "run", "", "f", resume=False)
    x = np.array([0.2, 0.3])
    partial = A.copy()
    partial[:, 1] = np.nan                      # stored by a refit that held B
    store.record(x, "forward+sensitivities", {"f": A @ [0.1, 0.2, 0.3], "dfdmu": partial})
    backend = _Asked(A)
    evaluator = Evaluator(backend, obs, held, store, sensitive=np.ones(3, bool))
    np.testing.assert_allclose(evaluator.jacobian(x)[:3], A[:, 1:])
    assert backend.asked == [(0, 1, 2)] and evaluator.n_replayed == 0
