"""The seed paper's optimiser: steepest descent with Armijo backtracking, optionally projected onto the bounds."""

from __future__ import annotations

import logging

import numpy as np

from .iterates import Iterates, Option

log = logging.getLogger(__name__)

OPTIONS = {
    "initial_step": Option("float", lambda n, tol, n_free: 1.0, lambda v: v > 0, "> 0"),
    "beta": Option("float", lambda n, tol, n_free: 0.5, lambda v: 0 < v < 1, "in (0, 1)"),
    "c1": Option("float", lambda n, tol, n_free: 1e-4, lambda v: 0 < v < 1, "in (0, 1)"),
    "max_backtracks": Option("int", lambda n, tol, n_free: 30, lambda v: v >= 1, ">= 1"),
    "gtol": Option("float", lambda n, tol, n_free: tol, lambda v: v >= 0, ">= 0"),
    "bounds": Option("bool", lambda n, tol, n_free: True),
    "scaled_step": Option("bool", lambda n, tol, n_free: False),
}
"""Options of "gradient-descent".

initial_step : t0, the step every Armijo search starts from (paper section 2.2; a fresh start each iteration)
beta : factor by which a rejected step is shortened (0.5: halving)
c1 : sufficient-decrease constant of the Armijo condition
max_backtracks : shortenings tried before the search, and the run, is reported failed
gtol : stop when the (projected) gradient norm is below gtol times its value at the start
bounds : True (default; projected gradient: every trial point is projected onto [lower, upper]) or False
    (the paper: coefficients may leave [lower, upper], even become negative; a run that ends outside them is
    reported "failed", never "converged")
scaled_step : False (t0 = initial_step in units of J) or True (t0 = initial_step / max|grad J(x0)|, fixed for
    the run: the first trial step changes the steepest coefficient by initial_step). The paper leaves t0 to
    the user; True is that choice made for the objective's scale (weighted residuals give |grad J| of 1e4 and
    more, where t0 = 1 tries coefficients of 1e5 first)
"""


def gradient_descent(run: Iterates, max_iterations: int, tol: float, options: dict) -> tuple[str, str]:
    """Minimise J by steepest descent x_{k+1} = P(x_k - t_k grad J(x_k)) with Armijo step t_k.

    P is the projection onto [lower, upper] with ``options["bounds"]``, otherwise the identity, as in the
    paper (section 2.2), whose iterates could leave the physical range. The gradient comes from the
    problem's Jacobian, whatever the identification layer backs it with (the paper: forward differences).

    Parameters
    ----------
    run : Iterates
        Evaluations and record of this run; the start is recorded here as iteration 0.
    max_iterations : int
        Accepted iterations at most.
    tol : float
        Stop when the relative decrease of J in an iteration, (J_k - J_{k+1}) / J_k, is at most tol.
    options : dict
        Resolved :data:`OPTIONS`.

    Returns
    -------
    status, message : str
        "converged", "max_iterations" or "failed" (no Armijo step found), and why.
    """
    project = _projection(run, options["bounds"])
    if not options["bounds"]:
        log.warning("gradient-descent with bounds = false (the paper's method): the coefficients may leave "
                    "[lower, upper]; a run that ends outside them is reported failed")
    x = project(np.array(run.problem.x0, dtype=float))
    run.accept(x)
    objective = run.objective(x)
    first_norm = None
    options = dict(options)
    for _ in range(max_iterations):
        gradient = run.gradient(x)
        if options["scaled_step"] and first_norm is None and np.abs(gradient).max() > 0:
            options["initial_step"] = options["initial_step"] / float(np.abs(gradient).max())
        stationarity = float(np.linalg.norm(project(x - gradient) - x))
        first_norm = stationarity if first_norm is None else first_norm
        if stationarity <= options["gtol"] * first_norm:
            return "converged", f"gradient norm {stationarity:.3e} <= gtol * {first_norm:.3e} (its start value)"
        trial = _armijo(run, x, objective, gradient, project, options)
        if trial is None:
            return "failed", (f"no step satisfied the Armijo condition after {options['max_backtracks']} "
                              f"shortenings from initial_step = {options['initial_step']}")
        x_new, objective_new = trial
        run.accept(x_new)
        if objective - objective_new <= tol * objective:
            return "converged", f"relative decrease of J {(objective - objective_new) / objective:.3e} <= tol"
        x, objective = x_new, objective_new
    return "max_iterations", f"stopped after max_iterations = {max_iterations} iterations"


def _armijo(run: Iterates, x: np.ndarray, objective: float, gradient: np.ndarray, project,
            options: dict) -> tuple[np.ndarray, float] | None:
    """The first x(t) = P(x - t g), t = t0 beta^i, with J(x(t)) <= J(x) + c1 g . (x(t) - x), or None.

    Without projection the condition is the textbook J(x - t g) <= J(x) - c1 t |g|^2; with it, the
    projected-gradient form (Bertsekas, Nonlinear Programming, 2.3). A non-finite J(x(t)) fails it.
    """
    step = options["initial_step"]
    for _ in range(options["max_backtracks"] + 1):
        x_step = project(x - step * gradient)
        objective_step = run.objective(x_step)
        if objective_step <= objective + options["c1"] * float(gradient @ (x_step - x)):
            return x_step, objective_step
        step *= options["beta"]
    return None


def _projection(run: Iterates, bounded: bool):
    if not bounded:
        return lambda x: x
    lower, upper = np.asarray(run.problem.lower, float), np.asarray(run.problem.upper, float)
    return lambda x: np.clip(x, lower, upper)
