"""Optimisers on analytic least-squares problems: one test class per method, shared checks through mixins."""

import dataclasses
from typing import ClassVar

import numpy as np
import pytest

from frictionid.errors import InputError, SolverError
from frictionid.inverse.least_squares import LeastSquares
from frictionid.inverse.optimisers import METHODS, optimise, remaining_step
from frictionid.inverse.stick_start import STICK_MARGIN

INF = np.inf


def problem(residuals, jacobian, x0, lower, upper, power=2.0, progress=None):
    """A LeastSquares problem with parameter names p0, p1, ..."""
    x0 = np.array(x0, dtype=float)
    extra = {} if progress is None else {"progress": progress}
    return LeastSquares(residuals, jacobian, x0, np.broadcast_to(np.asarray(lower, float), x0.shape).copy(),
                        np.broadcast_to(np.asarray(upper, float), x0.shape).copy(),
                        tuple(f"p{k}" for k in range(x0.size)), power, **extra)


def linear(lower=-10.0, upper=10.0, **kwargs):
    """r = A x - b, A (8, 3) seeded; the minimiser is numpy's lstsq solution (nonzero residual)."""
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(8, 3)), rng.normal(size=8)
    x_star = np.linalg.lstsq(a, b, rcond=None)[0]
    return problem(lambda x: a @ x - b, lambda x: a, np.zeros(3), lower, upper, **kwargs), x_star


def rosenbrock(**kwargs):
    """Rosenbrock in residual form r = (10 (x1 - x0^2), 1 - x0) from the classic start (-1.2, 1); minimum (1, 1)."""
    return problem(lambda x: np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]]),
                   lambda x: np.array([[-20 * x[0], 10.0], [-1.0, 0.0]]), [-1.2, 1.0], -5.0, 5.0, **kwargs)


def exponential_decay(**kwargs):
    """Fit y = a exp(-k t) to exact data from a = 2, k = 1.3 on t in [0, 3], starting from a = 1, k = 0.5."""
    t = np.linspace(0.0, 3.0, 20)
    y = 2.0 * np.exp(-1.3 * t)
    return problem(lambda x: x[0] * np.exp(-x[1] * t) - y,
                   lambda x: np.column_stack([np.exp(-x[1] * t), -x[0] * t * np.exp(-x[1] * t)]),
                   [1.0, 0.5], 0.0, 10.0, **kwargs), np.array([2.0, 1.3])


OUTSIDE = np.array([-0.2, 0.3])


def outside_bounds(**kwargs):
    """r = x - (-0.2, 0.3) with bounds [0, 1]: the unconstrained minimum has a negative coefficient."""
    return problem(lambda x: x - OUTSIDE, lambda x: np.eye(2), [0.1, 0.1], 0.0, 1.0, **kwargs)


def ill_conditioned():
    """r = diag(1, 30) x - (1, 2): Hessian condition number 900, trivial for Gauss-Newton."""
    a = np.diag([1.0, 30.0])
    return problem(lambda x: a @ x - np.array([1.0, 2.0]), lambda x: a, [0.0, 0.0], -10.0, 10.0)


class Progress:
    """Records progress calls; raises KeyboardInterrupt at iteration ``stop_at``."""

    def __init__(self, stop_at=None):
        self.calls, self.stop_at = [], stop_at

    def __call__(self, iteration, x, objective):
        self.calls.append((iteration, x.copy(), objective))
        if iteration == self.stop_at:
            raise KeyboardInterrupt


class BaseMixin:
    method: str
    options: ClassVar[dict] = {}
    atol = 1e-6          # accuracy of the recovered x on the smooth test problems
    max_iterations = 500
    bad_type = ("gtol", "small")

    def run(self, prob, **kwargs):
        kwargs.setdefault("max_iterations", self.max_iterations)
        kwargs.setdefault("options", self.options)
        return optimise(prob, self.method, **kwargs)

    def test_linear_least_squares_recovers_the_lstsq_solution(self):
        prob, x_star = linear()
        result = self.run(prob)
        assert result.status == "converged"
        np.testing.assert_allclose(result.x, x_star, atol=self.atol)

    def test_exponential_decay_fit_recovers_amplitude_and_rate(self):
        prob, x_true = exponential_decay()
        result = self.run(prob)
        assert result.status == "converged"
        np.testing.assert_allclose(result.x, x_true, atol=self.atol)

    def test_progress_called_for_iterations_0_to_n_matching_the_history(self):
        progress = Progress()
        prob, _ = exponential_decay(progress=progress)
        result = self.run(prob)
        assert [call[0] for call in progress.calls] == list(range(result.n_iterations + 1))
        assert result.n_iterations >= 2
        assert result.history_x.shape == (result.n_iterations + 1, 2)
        assert result.history_objective.shape == (result.n_iterations + 1,)
        np.testing.assert_array_equal(np.array([call[1] for call in progress.calls]), result.history_x)
        np.testing.assert_array_equal([call[2] for call in progress.calls], result.history_objective)
        np.testing.assert_array_equal(result.history_x[0], prob.x0)
        assert result.history_objective[0] == prob.objective(prob.residuals(prob.x0))
        np.testing.assert_array_equal(result.x, result.history_x[-1])
        assert result.objective == result.history_objective[-1] == prob.objective(prob.residuals(result.x))

    @pytest.mark.parametrize("make", [exponential_decay, linear])
    def test_history_is_monotone_non_increasing(self, make):
        result = self.run(make()[0])
        assert np.all(np.diff(result.history_objective) <= 0)
        assert result.history_objective[-1] < result.history_objective[0]

    def test_no_point_is_evaluated_twice(self):
        # each residual evaluation is a forward solve: recording iterates must not repeat any
        prob, _ = exponential_decay()
        seen = {"residuals": [], "jacobian": []}

        def counted(name, evaluate):
            return lambda x: seen[name].append(x.tobytes()) or evaluate(x)

        self.run(dataclasses.replace(prob, residuals=counted("residuals", prob.residuals),
                                     jacobian=counted("jacobian", prob.jacobian)))
        assert len(seen["residuals"]) > 3
        for name, keys in seen.items():
            assert len(set(keys)) == len(keys), name

    def test_x0_not_mutated_and_result_frozen(self):
        prob, _ = exponential_decay()
        x0 = prob.x0.copy()
        result = self.run(prob)
        np.testing.assert_array_equal(prob.x0, x0)
        assert not np.shares_memory(result.x, prob.x0)
        with pytest.raises(dataclasses.FrozenInstanceError):
            result.x = x0
        with pytest.raises(ValueError):
            result.history_x[0, 0] = 99.0

    def test_interrupt_raised_by_progress_propagates(self):
        progress = Progress(stop_at=2)
        prob, _ = exponential_decay(progress=progress)
        with pytest.raises(KeyboardInterrupt):
            self.run(prob)
        assert [call[0] for call in progress.calls] == [0, 1, 2]

    def test_stops_at_max_iterations(self):
        result = self.run(rosenbrock(), max_iterations=3)
        assert (result.status, result.n_iterations, result.history_x.shape) == ("max_iterations", 3, (4, 2))

    def test_max_iterations_zero_returns_the_start(self):
        prob, _ = exponential_decay()
        result = self.run(prob, max_iterations=0)
        assert (result.status, result.n_iterations) == ("max_iterations", 0)
        np.testing.assert_array_equal(result.x, prob.x0)

    def test_unknown_option_is_named(self):
        with pytest.raises(InputError, match="'stepsize'.*options are"):
            self.run(linear()[0], options={"stepsize": 1.0})

    def test_option_of_wrong_type_is_named(self):
        key, value = self.bad_type
        with pytest.raises(InputError, match=f"option '{key}'"):
            self.run(linear()[0], options={key: value})

    def test_non_finite_residuals_at_the_start_raise_solver_error(self):
        prob = problem(lambda x: np.array([np.nan, 1.0]), lambda x: np.eye(2), [0.5, 0.5], 0.0, 1.0)
        with pytest.raises(SolverError, match="start"):
            self.run(prob)


class BoundsMixin:
    def test_minimum_outside_the_bounds_ends_on_the_lower_bound(self):
        result = self.run(outside_bounds())
        assert result.status == "converged"
        assert result.x[0] == pytest.approx(0.0, abs=1e-9)   # active at the lower bound
        assert result.x[1] == pytest.approx(0.3, abs=self.atol)
        assert np.all(result.history_x >= 0.0) and np.all(result.history_x <= 1.0)


class RosenbrockMixin:
    def test_rosenbrock_reaches_the_minimum_at_one_one(self):
        result = self.run(rosenbrock())
        assert result.status == "converged"
        np.testing.assert_allclose(result.x, [1.0, 1.0], atol=10 * self.atol)


class PowerMixin:
    @pytest.mark.parametrize("power", [1.0, 4.0])
    def test_other_powers_have_the_same_bounded_minimiser(self, power):
        result = self.run(outside_bounds(power=power))
        assert result.x[0] == pytest.approx(0.0, abs=1e-9)
        assert result.x[1] == pytest.approx(0.3, abs=1e-5)
        assert result.objective == pytest.approx(0.2 ** power, rel=1e-5)


class ScaleMixin:
    def test_tiny_objective_is_not_taken_for_convergence(self):
        # displacements in mm give J ~ 1e-10 and less; scipy's absolute tolerances must not stop at the start
        prob, x_true = exponential_decay()
        tiny = dataclasses.replace(prob, residuals=lambda x: 1e-5 * prob.residuals(x),
                                   jacobian=lambda x: 1e-5 * prob.jacobian(x))
        result = self.run(tiny)
        assert result.status == "converged"
        np.testing.assert_allclose(result.x, x_true, atol=self.atol)


class TestTRF(BaseMixin, BoundsMixin, RosenbrockMixin, ScaleMixin):
    method = "trf"
    options: ClassVar[dict] = {"se_step": 0.0}   # scipy's own stops; TestTRFStepLeft covers se_step
    atol = 1e-8

    def test_other_powers_are_refused(self):
        with pytest.raises(InputError, match="power"):
            self.run(outside_bounds(power=1.0))

    def test_gauss_newton_needs_few_iterations_on_an_ill_conditioned_problem(self):
        result = self.run(ill_conditioned())
        assert result.status == "converged" and result.n_iterations <= 5
        np.testing.assert_allclose(result.x, [1.0, 2.0 / 30.0], atol=1e-10)

    def test_resolved_options_are_reported(self):
        result = self.run(linear()[0], tol=1e-9, max_iterations=20)
        assert result.options == {"ftol": 1e-9, "xtol": 1e-9, "gtol": 1e-9, "max_nfev": 105, "x_scale": "jac",
                                  "tr_solver": "exact", "se_step": 0.0, "final_step": True,
                                  "stick_start": True}
        assert optimise(linear()[0], "trf").options["se_step"] == 0.1

    def test_no_jacobian_at_the_iterate_where_max_iterations_stops(self):
        calls = []
        prob = rosenbrock()
        result = self.run(dataclasses.replace(prob, jacobian=lambda x: calls.append(1) or prob.jacobian(x)),
                          max_iterations=3)
        assert (result.n_iterations, len(calls)) == (3, 3)

    def test_evaluation_budget_exhausted_is_max_iterations(self):
        result = self.run(rosenbrock(), options={"max_nfev": 3})
        assert result.status == "max_iterations" and result.n_iterations < 3


def standard_errors_away(a: np.ndarray, b: np.ndarray, x: np.ndarray, x_star: np.ndarray) -> float:
    """Distance of x from x_star for r = a x - b in standard errors: sqrt(dx^T a^T a dx / s^2) with
    s^2 = ||r(x)||^2 / (n_res - n_free)."""
    r = a @ x - b
    return float(np.linalg.norm(a @ (x - x_star)) * np.sqrt((a.shape[0] - a.shape[1]) / (r @ r)))


def printed(values: np.ndarray) -> np.ndarray:
    """values rounded to 7 significant digits, as ccx prints its results."""
    return np.array([float(f"{v:.6e}") for v in values])


@pytest.mark.parametrize("options", [{"x_scale": "se"}, {"tr_solver": "lsmr"}])
def test_trf_scaled_by_standard_errors_or_with_lsmr_reaches_the_same_minima(options):
    for prob, x_star in (linear(), exponential_decay()):
        result = optimise(prob, "trf", max_iterations=200, options={"se_step": 0.0, **options})
        assert result.status == "converged" and result.options == {**result.options, **options}
        np.testing.assert_allclose(result.x, x_star, atol=1e-6)


def test_x_scale_se_is_the_standard_errors_at_the_start(monkeypatch):
    """The scale passed to scipy is sqrt(diag((J^T J)^-1)) of the start's Jacobian (here constant)."""
    import frictionid.inverse.optimisers as optimisers
    seen = []
    real = optimisers.least_squares
    monkeypatch.setattr(optimisers, "least_squares", lambda *a, **k: seen.append(k["x_scale"]) or real(*a, **k))
    a = np.array([[1.0, 0.9], [1.0, 1.1], [0.0, 2.0]])
    optimise(problem(lambda x: a @ x - 1.0, lambda x: a, [0.0, 0.0], -10.0, 10.0), "trf",
             options={"x_scale": "se"})
    np.testing.assert_allclose(seen[0], np.sqrt(np.diag(np.linalg.inv(a.T @ a))), rtol=1e-12)


class TestLM(BaseMixin, RosenbrockMixin, ScaleMixin):
    method = "lm"
    options: ClassVar[dict] = {"se_step": 0.0}

    def test_a_minimum_outside_the_bounds_is_failed(self):
        result = self.run(outside_bounds())
        np.testing.assert_allclose(result.x, OUTSIDE, atol=1e-8)
        assert result.status == "failed" and "outside the bounds" in result.message

    def test_fewer_residuals_than_parameters_are_refused(self):
        with pytest.raises(InputError, match="'lm' needs at least as many residuals"):
            self.run(problem(lambda x: x[:1], lambda x: np.eye(2)[:1], [0.1, 0.1], 0.0, 1.0))


class TestTRFStepLeft:
    """The se_step stop: at an accepted iterate, the Gauss-Newton step still to go, in standard errors."""

    def test_linear_problem_stops_within_se_step_of_the_minimum(self):
        rng = np.random.default_rng(7)
        a, b = rng.normal(size=(8, 3)), rng.normal(size=8)
        x_star = np.linalg.lstsq(a, b, rcond=None)[0]
        result = optimise(problem(lambda x: a @ x - b, lambda x: a, np.zeros(3), -10.0, 10.0), "trf",
                          options={"final_step": False})
        assert result.status == "converged" and "step left" in result.message
        # for a linear problem the step left is exactly the distance to the minimum
        assert standard_errors_away(a, b, result.x, x_star) < 0.1
        assert standard_errors_away(a, b, result.history_x[-2], x_star) >= 0.1

    def test_final_step_takes_the_step_left_as_one_more_iterate(self):
        rng = np.random.default_rng(7)
        a, b = rng.normal(size=(8, 3)), rng.normal(size=8)
        x_star = np.linalg.lstsq(a, b, rcond=None)[0]
        prob = problem(lambda x: a @ x - b, lambda x: a, np.zeros(3), -10.0, 10.0)
        stopped = optimise(prob, "trf", options={"final_step": False})
        result = optimise(prob, "trf")
        assert result.n_iterations == stopped.n_iterations + 1
        np.testing.assert_array_equal(result.history_x[:-1], stopped.history_x)
        # the Gauss-Newton step of a linear problem ends at its minimum
        np.testing.assert_allclose(result.x, x_star, rtol=0, atol=1e-12)
        assert f"Gauss-Newton step left (iteration {result.n_iterations}" in result.message
        assert result.objective < stopped.objective

    def test_final_step_not_tried_where_no_solve_could_show_its_gain(self):
        # a start 1e-7 standard errors from the minimum: the step left would lower chi^2 by about 1e-16 of it
        rng = np.random.default_rng(7)
        a, b = rng.normal(size=(8, 3)), rng.normal(size=8)
        x_star = np.linalg.lstsq(a, b, rcond=None)[0]
        calls = []
        prob = problem(lambda x: calls.append(1) or a @ x - b, lambda x: a, x_star + 1e-8, -10.0, 10.0)
        result = optimise(prob, "trf")
        assert "would lower chi^2 by less than 1e-09 of it: not taken" in result.message
        assert result.n_iterations == 0 and len(calls) == 1

    def test_final_step_neither_beyond_max_iterations_nor_with_a_robust_loss(self):
        rng = np.random.default_rng(7)
        a, b = rng.normal(size=(8, 3)), rng.normal(size=8)
        prob = problem(lambda x: a @ x - b, lambda x: a, np.zeros(3), -10.0, 10.0)
        stopped = optimise(prob, "trf", options={"final_step": False})
        at_limit = optimise(prob, "trf", max_iterations=stopped.n_iterations + 1)
        assert at_limit.n_iterations == stopped.n_iterations + 1 and at_limit.status == "converged"
        limited = optimise(prob, "trf", max_iterations=stopped.n_iterations)
        assert limited.n_iterations == stopped.n_iterations and "Gauss-Newton step left" not in limited.message
        robust = optimise(dataclasses.replace(prob, loss="soft_l1"), "trf")
        assert "step left" in robust.message and "Gauss-Newton step left (iteration" not in robust.message

    @pytest.mark.parametrize("misfit, s2", [(0.1, "residual"), (10.0, "stated")])
    def test_with_stated_noise_the_smaller_of_stated_and_residual_errors_counts(self, misfit, s2):
        # residuals divided by stated noise: chi^2 / dof about misfit^2; the step is measured in the smaller
        # errors, so neither a fit far better than the noise (twin data) nor a poor one is cut short
        rng = np.random.default_rng(5)
        a = 30.0 * rng.normal(size=(40, 3))
        b = a @ np.array([0.3, 0.2, 0.4]) + misfit * rng.normal(size=40)
        x_star = np.linalg.lstsq(a, b, rcond=None)[0]
        prob = dataclasses.replace(problem(lambda x: a @ x - b, lambda x: a, np.zeros(3), -10.0, 10.0),
                                   noise_known=True)
        x = x_star + np.array([1e-3, 0.0, 0.0])
        r, dof = a @ x - b, 40 - 3
        stated = np.linalg.norm(a @ (x - x_star))            # sqrt(d): the step in stated errors (s = 1)
        residual = stated * np.sqrt(dof / (r @ r))
        expected = residual if s2 == "residual" else stated
        assert remaining_step(r, a, x, prob.lower, prob.upper, noise_known=True) == pytest.approx(expected, rel=1e-9)
        assert remaining_step(r, a, x, prob.lower, prob.upper) == pytest.approx(residual, rel=1e-9)
        result = optimise(prob, "trf")
        assert result.status == "converged" and "step left" in result.message
        assert np.linalg.norm(a @ (result.x - x_star)) < 0.1 * min(1.0, np.sqrt((result.objective) / dof)) * 1.001

    def test_zero_residual_fit_is_not_stopped_early(self):
        # d / chi^2 stays near 1 when the data can be fitted exactly: the step left never looks small
        prob, x_true = exponential_decay()
        result = optimise(prob, "trf")
        assert result.status == "converged" and "step left" not in result.message
        np.testing.assert_allclose(result.x, x_true, atol=1e-8)

    def test_parameter_held_at_a_bound_is_left_out_of_the_step(self):
        # the unconstrained minimum has x0 = -0.2 < 0: the step left counts only x1, free in the interior
        rng = np.random.default_rng(11)
        a = rng.normal(size=(12, 2))
        b = a @ OUTSIDE + 0.01 * rng.normal(size=12)
        result = optimise(problem(lambda x: a @ x - b, lambda x: a, [0.1, 0.1], 0.0, 1.0), "trf")
        assert result.status == "converged" and "step left" in result.message
        assert result.x[0] == pytest.approx(0.0, abs=1e-9)
        x1 = np.linalg.lstsq(a[:, 1:], b, rcond=None)[0][0]           # the minimum with x0 = 0
        assert standard_errors_away(a[:, 1:], b, result.x[1:], np.array([x1])) < 0.1

    def test_spares_jacobians_on_printed_results_with_finite_differences(self):
        # a ccx-like evaluation: 7 printed digits, forward differences with step 1e-2, noisy data
        t = np.linspace(0.0, 3.0, 20)
        y = 2.0 * np.exp(-1.3 * t) + 0.01 * np.random.default_rng(3).normal(size=t.size)

        def residuals(x):
            return printed(x[0] * np.exp(-x[1] * t)) - y

        def forward_differences(x):
            return np.column_stack([(residuals(x + 1e-2 * e) - residuals(x)) / 1e-2 for e in np.eye(2)])

        runs = {}
        for se_step in (0.0, 0.1):
            calls = []
            prob = problem(residuals, lambda x: calls.append(1) or forward_differences(x), [1.0, 0.5], 0.0, 10.0)
            runs[se_step] = optimise(prob, "trf", options={"se_step": se_step}), len(calls)
        (full, full_calls), (stopped, stopped_calls) = runs[0.0], runs[0.1]
        assert "step left" in stopped.message and "step left" not in full.message
        assert stopped_calls < full_calls
        assert stopped.objective == pytest.approx(full.objective, rel=1e-4)

    def test_negative_se_step_is_refused(self):
        with pytest.raises(InputError, match="'se_step'.*>= 0"):
            optimise(linear()[0], "trf", options={"se_step": -0.1})


def stuck_zone(floor=None):
    """(problem, x*): a friction-like parameter p0 whose output is flat from its threshold t = 0.25 + 0.5 p1 up
    (a zone that sticks: its force, not its coefficient, counts), started at 0.9 where it sticks; the data
    are made at p* = (0.2, 0.3, 0.4), where it slips (t = 0.4). ``floor``: the stick_floor (default the true
    threshold where p0 sticks)."""
    a = np.random.default_rng(2).normal(size=(12, 3))
    x_star = np.array([0.2, 0.3, 0.4])

    def threshold(x):
        return 0.25 + 0.5 * x[1]

    def residuals(x):
        return a @ np.array([min(x[0], threshold(x)), x[1], x[2]]) - a @ x_star

    def jacobian(x):
        stuck = x[0] >= threshold(x)
        return np.column_stack([a[:, 0] * (not stuck), a[:, 1] + 0.5 * a[:, 0] * stuck, a[:, 2]])

    def true_floor(x):
        return np.array([threshold(x) if x[0] >= threshold(x) else np.nan, np.nan, np.nan])

    prob = dataclasses.replace(problem(residuals, jacobian, [0.9, 0.1, 0.1], 0.0, 1.0),
                               stick_floor=true_floor if floor is None else floor)
    return prob, x_star


class TestStickStart:
    def test_a_parameter_stuck_at_the_start_starts_at_its_threshold(self):
        prob, x_star = stuck_zone()
        result = optimise(prob, "trf")
        start = result.history_x[0]
        assert start[0] == pytest.approx(0.3 * (1 + STICK_MARGIN), rel=1e-12) and start[1:].tolist() == [0.1, 0.1]
        assert result.history_objective[0] == prob.objective(prob.residuals(prob.x0))     # the same objective
        assert result.message.startswith("started at the stick thresholds") and "p0 0.9 -> 0.3" in result.message
        np.testing.assert_allclose(result.x, x_star, atol=1e-8)

    def test_without_it_the_stuck_parameter_never_moves(self):
        # its Jacobian column stays zero while it sticks, and the others can explain the data only in part
        prob, x_star = stuck_zone()
        result = optimise(prob, "trf", options={"stick_start": False})
        assert result.history_x[0].tolist() == [0.9, 0.1, 0.1] and result.x[0] == 0.9
        assert result.objective > 1e-3

    def test_a_floor_that_would_change_the_objective_is_not_taken(self):
        prob, _ = stuck_zone(floor=lambda x: np.array([0.1, np.nan, np.nan]))      # below the true threshold
        result = optimise(prob, "trf")
        assert result.history_x[0].tolist() == [0.9, 0.1, 0.1]
        assert "stick thresholds" not in result.message

    def test_lm_starts_there_too_and_a_missing_floor_changes_nothing(self):
        prob, x_star = stuck_zone()
        assert optimise(prob, "lm").history_x[0][0] == pytest.approx(0.3 * (1 + STICK_MARGIN), rel=1e-12)
        plain = optimise(dataclasses.replace(prob, stick_floor=None), "trf")
        assert plain.history_x[0].tolist() == [0.9, 0.1, 0.1]


class TestLBFGSB(BaseMixin, BoundsMixin, RosenbrockMixin, PowerMixin, ScaleMixin):
    method = "lbfgsb"
    atol = 1e-6
    bad_type = ("maxcor", 2.5)


class TestNelderMead(BaseMixin, BoundsMixin, RosenbrockMixin, PowerMixin, ScaleMixin):
    method = "nelder-mead"
    atol = 1e-5          # xatol defaults to sqrt(tol) = 1e-5
    bad_type = ("adaptive", "yes")

    def test_never_calls_the_jacobian(self):
        def jacobian(x):
            raise AssertionError("Nelder-Mead evaluated the Jacobian")
        prob, x_true = exponential_decay()
        result = self.run(dataclasses.replace(prob, jacobian=jacobian))
        np.testing.assert_allclose(result.x, x_true, atol=self.atol)


class TestGradientDescent(BaseMixin):
    """The paper's method as it was: unbounded (bounds = False)."""

    method = "gradient-descent"
    options: ClassVar[dict] = {"bounds": False}
    max_iterations = 5000
    # it stops on the relative decrease of J, quadratic in the distance to a minimum with nonzero residual,
    # so x is only good to about sqrt(tol) times the problem's scale there
    atol = 1e-4
    bad_type = ("bounds", 1)

    def test_without_bounds_goes_negative_like_the_paper_and_is_not_called_converged(self):
        # r = x - c: the unit step 2c - x0 fails Armijo (no decrease), its half lands on c exactly
        result = self.run(outside_bounds())
        np.testing.assert_allclose(result.history_x[1], OUTSIDE, atol=1e-15)
        assert result.x[0] < 0
        assert result.status == "failed" and "outside the bounds" in result.message

    def test_the_default_projects_onto_the_bounds(self):
        result = optimise(outside_bounds(), self.method, max_iterations=100)
        assert result.status == "converged" and np.all(result.x >= 0.0)

    def test_needs_many_more_iterations_than_trf_when_ill_conditioned(self):
        descent = self.run(ill_conditioned(), max_iterations=300)
        gauss_newton = optimise(ill_conditioned(), "trf")
        assert descent.status == "max_iterations" and gauss_newton.status == "converged"
        assert descent.n_iterations >= 50 * gauss_newton.n_iterations
        assert descent.objective > 1e3 * gauss_newton.objective

    def test_uphill_gradient_fails_the_armijo_search_without_moving(self):
        prob = outside_bounds()
        result = self.run(dataclasses.replace(prob, jacobian=lambda x: -np.eye(2)))
        assert (result.status, result.n_iterations) == ("failed", 0)
        assert "Armijo" in result.message

    def test_scaled_step_first_tries_the_given_change_of_the_steepest_coefficient(self):
        # r = 1000 (x - c): |grad J(x0)| is about 1e6, so t0 = 1 would try x of order 1e5 first
        scale, target = 1000.0, np.array([0.4, 0.25])
        tried = []

        def residuals(x):
            tried.append(np.array(x))
            return scale * (x - target)

        prob = problem(residuals, lambda x: scale * np.eye(2), [0.1, 0.1], 0.0, 1.0)
        result = self.run(prob, options={"scaled_step": True, "initial_step": 0.05}, max_iterations=1)
        gradient = 2 * scale ** 2 * (np.array([0.1, 0.1]) - target)
        first = np.array([0.1, 0.1]) - 0.05 / np.abs(gradient).max() * gradient
        np.testing.assert_allclose(tried[1], first, rtol=1e-12)
        assert np.abs(tried[1] - [0.1, 0.1]).max() == pytest.approx(0.05)
        assert result.objective < result.history_objective[0] and len(tried) == 2   # accepted at once

    @pytest.mark.parametrize("key, value", [("beta", 1.0), ("c1", 0.0), ("initial_step", -1.0),
                                            ("max_backtracks", 0)])
    def test_armijo_parameters_out_of_range_are_named(self, key, value):
        with pytest.raises(InputError, match=f"option '{key}'"):
            self.run(linear()[0], options={key: value})


class TestProjectedGradientDescent(BaseMixin, BoundsMixin, PowerMixin):
    method = "gradient-descent"            # bounds = True is the default
    max_iterations = 5000
    atol = 1e-4          # as TestGradientDescent


def test_unknown_method_names_the_known_ones():
    with pytest.raises(InputError, match="'bfgs'.*gradient-descent.*lbfgsb.*nelder-mead.*trf"):
        optimise(linear()[0], "bfgs")
    assert set(METHODS) == {"trf", "lm", "lbfgsb", "gradient-descent", "nelder-mead"}


@pytest.mark.parametrize("kwargs, match", [({"max_iterations": -1}, "max_iterations"),
                                           ({"max_iterations": 2.5}, "max_iterations"),
                                           ({"tol": 0.0}, "tol"), ({"options": [1]}, "options")])
def test_bad_limits_are_named(kwargs, match):
    with pytest.raises(InputError, match=match):
        optimise(linear()[0], "trf", **kwargs)


def test_start_outside_the_bounds_names_the_parameter():
    prob = dataclasses.replace(outside_bounds(), x0=np.array([0.1, 1.5]))
    with pytest.raises(InputError, match="'p1'"):
        optimise(prob, "lbfgsb")


def test_a_robust_loss_resists_outliers_that_pull_least_squares_off():
    """y = a t + b with sigma 1 and three gross outliers: soft_l1 stays within noise of the truth."""
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 60)
    y = 0.4 * t + 0.2 + rng.normal(0.0, 0.01, t.size)
    y[[5, 30, 50]] += 0.5                                                  # 50 noise levels
    design = np.column_stack([t, np.ones_like(t)]) / 0.01
    prob = problem(lambda x: design @ x - y / 0.01, lambda x: design, [0.1, 0.1], 0.0, 1.0)
    plain = optimise(prob, "trf")
    robust = optimise(dataclasses.replace(prob, loss="soft_l1", loss_scale=3.0), "trf")
    assert np.abs(plain.x - [0.4, 0.2]).max() > 0.02
    np.testing.assert_allclose(robust.x, [0.4, 0.2], atol=0.01)


@pytest.mark.parametrize("changes, match", [({"loss": "l1"}, "loss 'l1' is not one of"),
                                            ({"loss": "huber", "loss_scale": 0.0}, "loss_scale must be > 0")])
def test_bad_robust_loss_settings_are_named(changes, match):
    with pytest.raises(InputError, match=match):
        optimise(dataclasses.replace(linear()[0], **changes), "trf")


def test_a_robust_loss_needs_trf():
    with pytest.raises(InputError, match="needs method 'trf'"):
        optimise(dataclasses.replace(linear()[0], loss="huber"), "lbfgsb")
