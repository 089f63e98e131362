"""Evaluator and uncertainty: residual rows, Jacobians, stored evaluations, calibrated standard errors."""

import numpy as np
import pytest

from frictionid.backends.base import Prediction
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.block import block_model_2d
from frictionid.inverse.evaluator import Evaluator
from frictionid.inverse.observations import Observations
from frictionid.inverse.parameters import Parameters
from frictionid.inverse.uncertainty import estimate


class LinearBackend:
    """f = A mu at one stage: a backend whose Jacobian is known exactly."""

    def __init__(self, A):
        self.A, self.calls = np.asarray(A, float), 0

    def predict(self, mu, sensitivities=False):
        self.calls += 1
        return Prediction((self.A @ mu)[None, :], self.A[None] if sensitivities else None)


def _observations(y, sigma):
    n = len(y)
    return Observations(points=np.zeros((n, 2)), point_regions=(None,) * n, quantities=("ux",),
                        row=np.arange(n), stage=np.zeros(n, int), y=np.asarray(y, float),
                        sigma=np.asarray(sigma, float), labels=tuple(map(str, range(n))), noise_known=True)


A = np.array([[1.0, 0.5, 0.0], [0.0, 2.0, 1.0], [1.0, 0.0, 3.0], [0.5, 0.5, 0.5]])
PARAMS = Parameters.from_config(("A", "B", "C"), {"A": 0.2, "B": 0.3}, bounds=(0.0, 0.6), fixed={"C": 0.1})


def test_residuals_jacobian_and_extra_rows():
    obs = _observations([1.0, 2.0, 3.0, 4.0], [0.5, 0.5, 1.0, 2.0])
    evaluator = Evaluator(LinearBackend(A), obs, PARAMS, tikhonov=4.0, prior=[0.25, 0.25], penalty=9.0)
    x = np.array([0.7, -0.1])                      # both outside [0, 0.6]
    mu = np.array([0.7, 0.0, 0.1])                 # the forward model sees max(mu, 0)
    r = evaluator.residuals(x)
    np.testing.assert_allclose(r[:4], (A @ mu - obs.y) / obs.sigma)
    np.testing.assert_allclose(r[4:6], 2.0 * (x - 0.25))
    np.testing.assert_allclose(r[6:], 3.0 * np.array([0.1, 0.1]))
    jac = evaluator.jacobian(np.array([0.3, 0.2]))
    np.testing.assert_allclose(jac[:4], A[:, :2] / obs.sigma[:, None])
    np.testing.assert_allclose(jac[4:6], 2.0 * np.eye(2))
    np.testing.assert_allclose(jac[6:], 0.0)


@pytest.mark.parametrize("kind", ["forward", "central"])
def test_finite_difference_jacobians_of_a_linear_model_are_exact(kind):
    obs = _observations([1.0, 2.0, 3.0, 4.0], [1.0] * 4)
    evaluator = Evaluator(LinearBackend(A), obs, PARAMS, jacobian=kind)
    np.testing.assert_allclose(evaluator.jacobian(np.array([0.3, 0.2])), A[:, :2], rtol=1e-8)


def test_the_same_point_is_solved_once():
    backend = LinearBackend(A)
    evaluator = Evaluator(backend, _observations([1.0] * 4, [1.0] * 4), PARAMS)
    x = np.array([0.3, 0.2])
    evaluator.residuals(x), evaluator.jacobian(x), evaluator.residuals(x.copy())
    assert backend.calls == 1 and evaluator.n_sensitivity == 1


def test_standard_errors_of_a_linear_fit_are_the_textbook_ones():
    """Known noise: C = (J^T W^2 J)^-1 exactly, with a zone at its bound counted as free (not as known)."""
    J = A[:, :2] / 0.05                                  # stderr 0.07 and 0.05: intervals inside [0, 1]
    textbook = np.sqrt(np.diag(np.linalg.inv(J.T @ J)))
    unc = estimate(J, np.zeros(4), np.array([0.3, 0.2]), np.zeros(2), np.ones(2), noise_known=True)
    np.testing.assert_allclose(unc.stderr, textbook, rtol=1e-12)
    np.testing.assert_allclose(unc.ci95[:, 1] - unc.ci95[:, 0], 2 * 1.959964 * textbook, rtol=1e-6)
    at_bound = estimate(J, np.zeros(4), np.array([0.0, 0.2]), np.zeros(2), np.ones(2), noise_known=True)
    assert at_bound.at_bound.tolist() == [True, False]
    np.testing.assert_allclose(at_bound.stderr, textbook, rtol=1e-12)
    # one-sided at the bound, never through it: [0, 1.645 s]
    np.testing.assert_allclose(at_bound.ci95[0], [0.0, 1.644854 * textbook[0]], rtol=1e-6)


def test_intervals_stay_within_the_bounds():
    J = A[:, :2] / 0.5                                    # stderr about 0.4: wider than the bounds allow
    unc = estimate(J, np.zeros(4), np.array([0.05, 0.95]), np.zeros(2), np.ones(2), noise_known=True)
    assert np.all(unc.ci95 >= 0.0) and np.all(unc.ci95 <= 1.0)
    assert unc.ci95[0, 0] == 0.0 and unc.ci95[1, 1] == 1.0


def test_a_zone_at_a_bound_does_not_shrink_the_other_zones_errors():
    """Two correlated zones, one fitted onto its bound: the other's error is the one with both free."""
    J = np.array([[1.0, 0.9], [0.9, 1.0], [1.0, 1.0]]) / 0.01
    unc = estimate(J, np.zeros(3), np.array([0.3, 0.0]), np.zeros(2), np.ones(2), noise_known=True)
    conditional = 1.0 / np.linalg.norm(J[:, 0])              # zone 1 treated as known
    assert unc.stderr[0] > 5 * conditional
    np.testing.assert_allclose(unc.stderr[0], np.sqrt(np.linalg.inv(J.T @ J)[0, 0]), rtol=1e-12)


def test_a_zone_no_observation_sees_is_reported_unidentifiable():
    J = np.column_stack([A[:, 0] / 0.1, np.zeros(4)])                # sigma 0.1: stderr 0.067 for the seen zone
    unc = estimate(J, np.zeros(4), np.array([0.3, 0.2]), np.zeros(2), np.ones(2), noise_known=True)
    assert unc.identifiable.tolist() == [True, False]


def test_indistinguishable_zones_get_no_standard_error_and_bound_zones_are_judged_as_if_free():
    twins = np.column_stack([A[:, 0], A[:, 0], A[:, 1]]) / 0.01        # zones 0 and 1 act alike
    unc = estimate(twins, np.zeros(4), np.array([0.3, 0.2, 0.4]), np.zeros(3), np.ones(3), noise_known=True)
    assert np.isnan(unc.stderr[:2]).all() and unc.identifiable.tolist() == [False, False, True]
    weak = np.column_stack([A[:, 0] / 0.01, A[:, 1] / 100.0])           # zone 1 barely seen, fitted onto 0
    unc = estimate(weak, np.zeros(4), np.array([0.3, 0.0]), np.zeros(2), np.ones(2), noise_known=True,
                   tolerance=0.02)
    assert unc.at_bound.tolist() == [False, True] and unc.identifiable.tolist() == [True, False]
    strong = np.column_stack([A[:, 0], A[:, 1]]) / 0.01
    unc = estimate(strong, np.zeros(4), np.array([0.3, 0.0]), np.zeros(2), np.ones(2), noise_known=True,
                   tolerance=0.02)
    assert unc.identifiable.tolist() == [True, True]


def test_analytic_jacobian_matches_central_differences_on_the_contact_model():
    model = block_model_2d("plane_strain", pull=0.2, height=4.0, mesh_size=1.5, n_zones=3)
    points = np.array([[-5.0, 0.5], [5.0, 0.5], [-7.0, 0.0], [7.0, 0.0]])
    backend = EmbeddedBackend(model, points, ("ux", "uy"), ["block", "block", "base", "base"])
    params = Parameters.from_config(model.zone_names, {"A": 0.3, "B": 0.2, "C": 0.4}, bounds=(0.0, 1.0))
    obs = _observations(np.zeros(8), np.full(8, 1e-3))
    obs = Observations(points, (None,) * 4, ("ux", "uy"), np.arange(8), np.ones(8, int), obs.y, obs.sigma,
                       obs.labels, True)
    x = params.x0
    analytic = Evaluator(backend, obs, params).jacobian(x)
    central = Evaluator(backend, obs, params, jacobian="central", step=1e-6).jacobian(x)
    np.testing.assert_allclose(analytic, central, rtol=1e-5, atol=1e-5 * np.abs(analytic).max())


def test_noisy_twin_recovers_within_three_standard_errors():
    """Same-mesh data plus 0.5 um Gaussian noise: the error of each free zone is within 3 stated stderr."""
    from frictionid.inverse.least_squares import LeastSquares
    from frictionid.inverse.optimisers import optimise
    model = block_model_2d("plane_strain", pull=0.2, height=4.0, mesh_size=1.0, n_zones=2)
    points = np.array([[x, y] for x in (-5.0, 5.0) for y in (0.25, 0.5, 1.0, 2.0)]
                      + [[x, 0.0] for x in (-9.0, -7.0, -6.0, -5.5, 5.5, 6.0, 7.0, 9.0)])
    regions = ["block"] * 8 + ["base"] * 8
    backend = EmbeddedBackend(model, points, ("ux", "uy"), regions)
    truth = np.array([0.35, 0.2])
    clean = backend.predict(truth).values[1]
    noisy = clean + np.random.default_rng(7).normal(0.0, 5e-4, clean.shape)
    obs = Observations(points, tuple(regions), ("ux", "uy"), np.arange(len(clean)), np.ones(len(clean), int),
                       noisy, np.full(len(clean), 5e-4), tuple(map(str, range(len(clean)))), True)
    params = Parameters.from_config(model.zone_names, {"A": 0.1, "B": 0.1}, bounds=(0.0, 1.0))
    evaluator = Evaluator(backend, obs, params)
    problem = LeastSquares(evaluator.residuals, evaluator.jacobian, params.x0, params.lower, params.upper,
                           params.free_names)
    x = optimise(problem, "trf").x
    unc = estimate(evaluator.jacobian(x), evaluator.residuals(x), x, params.lower, params.upper, True)
    assert np.all(np.abs(x - truth) < 3 * unc.stderr)
    assert np.all(unc.stderr < 0.05)                 # and the statement is not vacuous


@pytest.mark.parametrize("kind", ["forward", "central"])
def test_parallel_finite_differences_equal_the_serial_ones(kind, tmp_path):
    from frictionid.run.store import RunStore
    model = block_model_2d("plane_strain", pull=0.2, height=4.0, mesh_size=1.5, n_zones=3)
    points = np.array([[-5.0, 0.5], [5.0, 0.5], [-7.0, 0.0], [7.0, 0.0]])
    backend = EmbeddedBackend(model, points, ("ux", "uy"), ["block", "block", "base", "base"])
    params = Parameters.from_config(model.zone_names, {"A": 0.3, "B": 0.2, "C": 0.4}, bounds=(0.0, 1.0))
    obs = Observations(points, (None,) * 4, ("ux", "uy"), np.arange(8), np.ones(8, int), np.zeros(8),
                       np.full(8, 1e-3), tuple(map(str, range(8))), True)
    jacobians, counts = [], []
    for workers in (1, 2):
        store = RunStore.open(tmp_path / f"w{workers}", "", "f", resume=False)
        evaluator = Evaluator(backend, obs, params, store, jacobian=kind, workers=workers)
        jacobians.append(evaluator.jacobian(params.x0))
        evaluator.close()
        counts.append((evaluator.n_forward, store.n_evaluations("forward")))
    np.testing.assert_array_equal(jacobians[0], jacobians[1])
    assert counts[0] == counts[1] == ((4, 4) if kind == "forward" else (6, 6))   # x + 3 steps, or +- 3 steps


class FailingBackend(LinearBackend):
    """f = A mu^2 (Gauss-Newton from below overshoots), except that the solve fails (SolverError) when a
    coefficient exceeds ``limit``."""

    def __init__(self, A, limit):
        super().__init__(A)
        self.limit = limit

    def predict(self, mu, sensitivities=False):
        from frictionid.errors import SolverError
        self.calls += 1
        if np.any(mu > self.limit):
            raise SolverError(f"contact did not converge at {mu}")
        return Prediction((self.A @ mu ** 2)[None, :], (self.A * 2 * mu)[None] if sensitivities else None)


def test_a_failed_trial_solve_is_a_rejected_step_stored_and_replayed(tmp_path):
    from frictionid.errors import SolverError
    from frictionid.run.store import RunStore
    store = RunStore.open(tmp_path / "run", "", "f", resume=False)
    backend = FailingBackend(A, limit=0.5)
    obs = _observations([1.0] * 4, [1.0] * 4)
    evaluator = Evaluator(backend, obs, PARAMS, store)
    assert np.all(np.isinf(evaluator.residuals(np.array([0.55, 0.2])))) and backend.calls == 1
    assert evaluator.n_failed == 1 and store.n_evaluations() == 1
    replay = Evaluator(backend, obs, PARAMS, RunStore.open(tmp_path / "run", "", "f", resume=True))
    assert np.all(np.isinf(replay.residuals(np.array([0.55, 0.2])))) and backend.calls == 1
    failing_start = Parameters.from_config(("A", "B", "C"), {"A": 0.6, "B": 0.3}, bounds=(0.0, 1.0),
                                           fixed={"C": 0.1})
    with pytest.raises(SolverError):
        Evaluator(backend, obs, failing_start).residuals(failing_start.x0)


@pytest.mark.parametrize("method", ["trf", "gradient-descent"])
def test_methods_step_back_from_coefficients_where_the_solver_fails(method):
    """Data made at (0.45, 0.25) near a region (mu > 0.46) where every solve fails: both methods get there."""
    from frictionid.inverse.least_squares import LeastSquares
    from frictionid.inverse.optimisers import optimise
    truth = np.array([0.45, 0.25, 0.1])
    obs = _observations(A @ truth ** 2, [1e-3] * 4)
    evaluator = Evaluator(FailingBackend(A, limit=0.46), obs, PARAMS)
    problem = LeastSquares(evaluator.residuals, evaluator.jacobian, PARAMS.x0, PARAMS.lower, np.ones(2),
                           PARAMS.free_names)
    result = optimise(problem, method, max_iterations=200)
    assert evaluator.n_failed > 0, "the test must make the optimiser try a failing point"
    np.testing.assert_allclose(result.x, truth[:2], atol=1e-3)


@pytest.mark.parametrize("workers", [1, 2])
def test_a_failed_finite_difference_solve_takes_the_column_from_the_other_side(tmp_path, workers):
    """x + h lies where the solver fails: that column comes from x - h (exactly the backward difference of the
    model f = A mu^2); the failure is stored, also when the perturbed points are solved in worker processes."""
    from frictionid.run.store import RunStore
    store = RunStore.open(tmp_path / "run", "", "f", resume=False)
    obs = _observations([1.0] * 4, [1.0] * 4)
    evaluator = Evaluator(FailingBackend(A, limit=0.5), obs, PARAMS, store, jacobian="forward", step=1e-2,
                          workers=workers)
    x, h = np.array([0.495, 0.2]), 1e-2
    try:
        jac = evaluator.jacobian(x)
    finally:
        evaluator.close()
    mu = np.array([0.495, 0.2, 0.1])
    np.testing.assert_allclose(jac[:, 0], A[:, 0] * (mu[0] ** 2 - (mu[0] - h) ** 2) / h, rtol=1e-10)
    np.testing.assert_allclose(jac[:, 1], A[:, 1] * ((mu[1] + h) ** 2 - mu[1] ** 2) / h, rtol=1e-10)
    assert evaluator.n_failed == 1 and evaluator.n_forward == 4   # x, x + h e_A (failed), x + h e_B, x - h e_A
    assert store.n_evaluations() == 4


def test_finite_differences_failing_on_both_sides_end_with_a_solver_error():
    from frictionid.errors import SolverError

    class OnlyHere(LinearBackend):
        def predict(self, mu, sensitivities=False):
            if abs(mu[0] - 0.3) > 1e-12:
                raise SolverError("increment 2 did not converge")
            return super().predict(mu, sensitivities)

    evaluator = Evaluator(OnlyHere(A), _observations([1.0] * 4, [1.0] * 4), PARAMS, jacobian="central")
    with pytest.raises(SolverError, match=r"both sides of mu = \[0.3, 0.2, 0.1\] failed"):
        evaluator.jacobian(np.array([0.3, 0.2]))
