"""optimise: minimise J(x) = ||r(x)||^n of a LeastSquares problem within its bounds with a method chosen by name."""

from __future__ import annotations

import logging
from dataclasses import replace
from numbers import Integral, Real

import numpy as np
from scipy.optimize import Bounds, least_squares, minimize

from ..errors import InputError, SolverError
from . import gradient_descent as descent
from .iterates import Iterates, Option, resolve_options
from .least_squares import ROBUST_WEIGHTS, LeastSquares, OptimiseResult, robust_weights
from .stick_start import stick_start
from .uncertainty import at_bounds

log = logging.getLogger(__name__)


def _positive(value) -> bool:
    return value > 0


def _scale(value) -> bool:
    return value in ("jac", "se") if isinstance(value, str) else value > 0


_TOLERANCE = Option("float", lambda n, tol, n_free: tol, _positive, "> 0")

TRF_OPTIONS = {
    "ftol": _TOLERANCE, "xtol": _TOLERANCE, "gtol": _TOLERANCE,
    "max_nfev": Option("int", lambda n, tol, n_free: 5 * (n + 1), _positive, "> 0"),
    "x_scale": Option("scale", lambda n, tol, n_free: "jac", _scale, "(> 0)"),
    "tr_solver": Option("str", lambda n, tol, n_free: "exact", lambda v: v in ("exact", "lsmr"),
                        '("exact" or "lsmr")'),
    "se_step": Option("float", lambda n, tol, n_free: 0.1, lambda v: v >= 0, ">= 0"),
    "final_step": Option("bool", lambda n, tol, n_free: True),
    "stick_start": Option("bool", lambda n, tol, n_free: True),
}
"""Options of "trf" (scipy.optimize.least_squares): ftol, xtol, gtol (default tol), max_nfev (residual
evaluations; default 5 (max_iterations + 1), a guard against long runs of rejected steps), x_scale ("jac":
scipy's column norms of the Jacobian, updated each iteration; "se": the standard errors the start's Jacobian
predicts, sqrt(diag((J^T J)^-1)), held; or a number), tr_solver ("exact" or "lsmr", scipy's), and se_step
(default 0.1; 0 turns it off): stop at an accepted iterate once the Gauss-Newton step still to go is shorter
than se_step standard errors (see ``remaining_step``), and final_step (default true): at that stop, take the
Gauss-Newton step left as one more iterate where it lowers the objective (least squares only; one more solve,
without the optimiser's trust region: see ``_final_step``), and stick_start (default true): a zone that sticks
along the whole load path at the start has no sensitivity there, and the optimiser could only move it once the
others made it slip; it starts instead at its stick threshold, where the objective is the same (see
``stick_start.stick_start``)."""

LM_OPTIONS = {key: TRF_OPTIONS[key] for key in ("ftol", "xtol", "gtol", "max_nfev", "x_scale", "se_step",
                                                "final_step", "stick_start")}
"""Options of "lm" (Levenberg-Marquardt, MINPACK through scipy.optimize.least_squares): those of "trf" but
tr_solver. It does not know bounds: a run that ends outside them is reported "failed"."""

LBFGSB_OPTIONS = {
    "ftol": _TOLERANCE, "gtol": _TOLERANCE,
    "max_nfev": Option("int", lambda n, tol, n_free: 5 * (n + 1), _positive, "> 0"),
    "maxcor": Option("int", lambda n, tol, n_free: 10, _positive, "> 0"),
    "maxls": Option("int", lambda n, tol, n_free: 20, _positive, "> 0"),
}
"""Options of "lbfgsb" (scipy L-BFGS-B on J / J(x0)): ftol, gtol (default tol), max_nfev (evaluations of r and
its Jacobian; default 5 (max_iterations + 1)), maxcor, maxls."""

NELDER_MEAD_OPTIONS = {
    "xatol": Option("float", lambda n, tol, n_free: float(np.sqrt(tol)), _positive, "> 0"),
    "fatol": _TOLERANCE,
    # the simplex costs n_free + 1 evaluations, an iteration at most n_free + 2 (reflect, contract, shrink)
    "max_nfev": Option("int", lambda n, tol, n_free: n_free + 1 + (n_free + 2) * n, _positive, "> 0"),
    "adaptive": Option("bool", lambda n, tol, n_free: False),
}
"""Options of "nelder-mead" (scipy Nelder-Mead on J / J(x0) with bounds): xatol (default sqrt(tol): J changes
quadratically in x near a minimum), fatol (default tol), max_nfev (default n_free + 1 + (n_free + 2)
max_iterations, so that max_iterations is the limit that binds), adaptive."""


class _IterationLimit(Exception):
    """Stops least_squares from inside its Jacobian call once max_iterations iterates are accepted."""


class _StepLeftSmall(Exception):
    """Stops least_squares from inside its Jacobian call when the Gauss-Newton step left is below se_step."""


def remaining_step(r: np.ndarray, jac: np.ndarray, x, lower, upper, noise_known: bool = False) -> float:
    """Length of the Gauss-Newton step still to go from x, in standard errors of the estimate.

    The full step dx = -J^+ r over the parameters that are not held at a bound (at a bound with the gradient
    J^T r pushing outwards) would lower chi^2 = ||r||^2 by d = ||J dx||^2. Measured with the covariance
    s^2 (J^T J)^-1, the step's length is sqrt(d / s^2), with s^2 = chi^2 / (n_res - n_free) (the errors the
    residuals show), or, when the residuals are weighted by stated noise, the smaller of that and 1 (the
    stated errors): a fit far better than the stated noise (noise-free twin data) is not cut short, nor one
    far worse (model error). Near a minimum with nonzero residual the length shrinks to 0 while chi^2 does not
    (finite-difference Jacobians of a code that prints 7 digits, model error); at a zero-residual minimum
    d / chi^2 stays near 1. inf when it cannot be measured (chi^2 = 0 or no degrees of freedom).

    Examples
    --------
    >>> jac = np.array([[1.0], [1.0]])
    >>> round(remaining_step(np.array([0.5, -0.5]), jac, [0.3], [0.0], [1.0]), 12)   # at the minimum
    0.0
    >>> round(remaining_step(np.array([1.0, 0.0]), jac, [0.3], [0.0], [1.0]), 6)     # dx = -0.5, s = 1
    0.707107
    >>> round(remaining_step(np.array([3.0, 1.0]), jac, [0.3], [0.0], [1.0]), 6)     # s^2 = 10
    0.894427
    >>> round(remaining_step(np.array([3.0, 1.0]), jac, [0.3], [0.0], [1.0], noise_known=True), 6)  # s^2 = 1
    2.828427
    """
    r, jac, x = np.asarray(r, dtype=float), np.asarray(jac, dtype=float), np.asarray(x, dtype=float)
    n_res, n_free = jac.shape
    chi2 = float(r @ r)
    if chi2 == 0 or n_res <= n_free:
        return np.inf
    s2 = chi2 / (n_res - n_free)
    if noise_known:
        s2 = min(s2, 1.0)
    decrease = float(np.sum((jac @ gauss_newton_step(r, jac, x, lower, upper)) ** 2))
    return float(np.sqrt(decrease / s2))


def gauss_newton_step(r: np.ndarray, jac: np.ndarray, x, lower, upper) -> np.ndarray:
    """(n_free,) the full Gauss-Newton step -J^+ r over the parameters not held at a bound (at a bound with the
    gradient J^T r pushing outwards), 0 for the held ones.

    >>> gauss_newton_step(np.array([1.0, 0.0]), np.array([[1.0], [1.0]]), [0.3], [0.0], [1.0])
    array([-0.5])
    """
    r, jac, x = np.asarray(r, dtype=float), np.asarray(jac, dtype=float), np.asarray(x, dtype=float)
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    gradient = jac.T @ r
    bound = at_bounds(x, lower, upper)
    lower_side = np.abs(x - lower) <= np.abs(x - upper)
    held = bound & np.where(lower_side, gradient > 0, gradient < 0)
    step = np.zeros(jac.shape[1])
    if (~held).any():
        step[~held] = -np.linalg.lstsq(jac[:, ~held], r, rcond=None)[0]
    return step


def _trf(run: Iterates, max_iterations: int, tol: float, options: dict) -> tuple[str, str]:
    """Bounded trust-region reflective Gauss-Newton (scipy.optimize.least_squares, method "trf"); see
    :func:`_gauss_newton`."""
    return _gauss_newton(run, max_iterations, options, "trf")


def _lm(run: Iterates, max_iterations: int, tol: float, options: dict) -> tuple[str, str]:
    """Levenberg-Marquardt without bounds (scipy.optimize.least_squares, method "lm", MINPACK); see
    :func:`_gauss_newton`."""
    return _gauss_newton(run, max_iterations, options, "lm")


def _x_scale(run: Iterates, x0: np.ndarray, x_scale):
    """scipy's x_scale for an option value: "se" becomes the standard errors sqrt(diag((J^T J)^-1)) the
    Jacobian at the start predicts (in any common unit: only their ratios and the first trust region depend on
    it), 1 / |column| where that matrix is singular."""
    if not isinstance(x_scale, str) or x_scale != "se":
        return x_scale
    jac = run.jacobian(x0)
    norms = np.linalg.norm(jac, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        se = np.sqrt(np.diag(np.linalg.pinv(jac.T @ jac)))
        fallback = np.where(norms > 0, 1.0 / norms, 1.0)
    return np.where(np.isfinite(se) & (se > 0) & (np.linalg.matrix_rank(jac) == jac.shape[1]), se, fallback)


def _gauss_newton(run: Iterates, max_iterations: int, options: dict, method: str) -> tuple[str, str]:
    """Gauss-Newton with a trust region ("trf", bounded) or Levenberg-Marquardt ("lm", unbounded) through
    scipy.optimize.least_squares.

    least_squares evaluates the Jacobian at the start and at every accepted iterate and nowhere else, so the
    Jacobian call is where an iterate is recorded; at the max_iterations-th one the run stops before the
    (expensive) Jacobian is evaluated. Its start is moved strictly inside the bounds (by 1e-10 relative)
    when x0 lies on one. It works on r / ||r(x0)||: its gtol is absolute, and residuals in mm are small.
    With the Jacobian at an accepted iterate the run also stops ("converged") when the step left is below
    se_step standard errors: scipy's own tests can keep it trying steps that gain nothing at a minimum with
    nonzero residual, each costing a finite-difference Jacobian.
    """
    problem = run.problem
    x0 = np.array(problem.x0, dtype=float)
    moved = ""
    if options["stick_start"] and problem.stick_floor is not None:
        x0, moved = stick_start(run, x0)
    status, message = _scipy_least_squares(run, x0, max_iterations, options, method)
    return status, moved + message


def _scipy_least_squares(run: Iterates, x0: np.ndarray, max_iterations: int, options: dict,
                         method: str) -> tuple[str, str]:
    """:func:`_gauss_newton` from ``x0``."""
    problem = run.problem
    r0 = run.residuals(x0)
    norm = float(np.linalg.norm(r0))
    if not np.isfinite(norm):
        raise SolverError(f"the residuals at the start x0 = {x0.tolist()} are not finite")
    if method == "lm" and len(r0) < len(x0):
        raise InputError(f"method 'lm' needs at least as many residuals as free parameters, got {len(r0)} "
                         f"residuals for {len(x0)} parameters; use 'trf'")
    scale = 1.0 / norm if norm > 0 else 1.0

    def jacobian(x):
        if run.accept(x) >= max_iterations:
            raise _IterationLimit
        jac = run.jacobian(x)
        if options["se_step"] > 0:
            r = run.residuals(x)
            root = np.sqrt(robust_weights(r, problem.loss, problem.loss_scale))   # 1 for least squares
            left = remaining_step(root * r, root[:, None] * jac, x, problem.lower, problem.upper,
                                  problem.noise_known)
            if left < options["se_step"]:
                raise _StepLeftSmall(f"the Gauss-Newton step left is {left:.3g} standard errors "
                                     f"< se_step = {options['se_step']:g}")
        return jac * scale

    try:
        bounded = {"bounds": (problem.lower, problem.upper), "tr_solver": options["tr_solver"],
                   "loss": problem.loss, "f_scale": problem.loss_scale * scale} if method == "trf" else {}
        fit = least_squares(lambda x: run.residuals(x) * scale, x0, jac=jacobian, method=method,
                            x_scale=_x_scale(run, x0, options["x_scale"]), ftol=options["ftol"],
                            xtol=options["xtol"], gtol=options["gtol"], max_nfev=options["max_nfev"], **bounded)
    except _IterationLimit:
        return "max_iterations", f"stopped after max_iterations = {max_iterations} iterations"
    except _StepLeftSmall as stop:
        message = str(stop)
        if options["final_step"] and run.n_iterations < max_iterations:
            message += _final_step(run)
        return "converged", message
    if fit.status == 0:
        return "max_iterations", f"{fit.message} (max_nfev = {options['max_nfev']})"
    return ("converged" if fit.status > 0 else "failed"), fit.message


#: the final step is not tried where it would lower chi^2 by at most this fraction (the forward solves' own
#: accuracy: a solve could not show the gain)
FINAL_STEP_GAIN = 1e-9


def _final_step(run: Iterates) -> str:
    """Take the Gauss-Newton step left at the se_step stop (clipped to the bounds) as one more iterate where it
    lowers the objective; what happened, for the run's message.

    At a stop with less than se_step standard errors to go the optimiser's next iteration would be about this step
    (its trust region no longer binds there), at the cost of one evaluation of the residuals instead of the
    optimiser's trial steps; with analytic sensitivities that solve also gives the Jacobian there, from which the
    fit's statistics are computed (the returned point's own, as at any other stop). Least squares only: a robust
    loss is not the objective this compares."""
    problem = run.problem
    if problem.loss != "linear":
        return ""
    x, r, jac = run.x, run.residuals(run.x), run.jacobian(run.x)
    lower, upper = np.asarray(problem.lower, dtype=float), np.asarray(problem.upper, dtype=float)
    step = gauss_newton_step(r, jac, x, lower, upper)
    if not np.sum((jac @ step) ** 2) > FINAL_STEP_GAIN * (r @ r):
        return f"; the Gauss-Newton step left would lower chi^2 by less than {FINAL_STEP_GAIN:g} of it: not taken"
    trial = np.clip(x + step, lower, upper)
    before = run.objective(x)
    try:
        after = run.objective(trial)
    except SolverError as error:
        log.info("final Gauss-Newton step not taken: the solve failed (%s)", error)
        return "; the final Gauss-Newton step's solve failed: not taken"
    if not after < before:
        return f"; the final Gauss-Newton step did not lower the objective ({after:.8g}): not taken"
    iteration = run.accept(trial)
    return (f"; then the Gauss-Newton step left (iteration {iteration}, one solve): objective {before:.8g} -> "
            f"{after:.8g}")


def _lbfgsb(run: Iterates, max_iterations: int, tol: float, options: dict) -> tuple[str, str]:
    """L-BFGS-B on J / J(x0) with gradient ``problem.gradient``; the scaling makes ftol relative to J(x0)."""
    problem = run.problem
    x0 = np.array(problem.x0, dtype=float)
    scale = _objective_scale(run, x0)

    def objective_and_gradient(x):
        r = run.residuals(x)
        return problem.objective(r) * scale, problem.gradient(r, run.jacobian(x)) * scale

    fit = minimize(objective_and_gradient, x0, jac=True, method="L-BFGS-B", callback=_recorder(run),
                   bounds=Bounds(problem.lower, problem.upper),
                   options={"maxiter": max_iterations, "maxfun": options["max_nfev"], "ftol": options["ftol"],
                            "gtol": options["gtol"], "maxcor": options["maxcor"], "maxls": options["maxls"]})
    return {0: "converged", 1: "max_iterations"}.get(fit.status, "failed"), str(fit.message)


def _nelder_mead(run: Iterates, max_iterations: int, tol: float, options: dict) -> tuple[str, str]:
    """Derivative-free Nelder-Mead on J / J(x0) within the bounds; never evaluates the Jacobian."""
    problem = run.problem
    x0 = np.array(problem.x0, dtype=float)
    scale = _objective_scale(run, x0)
    fit = minimize(lambda x: run.objective(x) * scale, x0, method="Nelder-Mead", callback=_recorder(run),
                   bounds=Bounds(problem.lower, problem.upper),
                   # scipy counts building the simplex as its first iteration
                   options={"maxiter": max_iterations + 1, "maxfev": options["max_nfev"], "xatol": options["xatol"],
                            "fatol": options["fatol"], "adaptive": options["adaptive"]})
    return ("converged" if fit.status == 0 else "max_iterations"), str(fit.message)


def _objective_scale(run: Iterates, x0: np.ndarray) -> float:
    """Record the start and return 1 / J(x0) (1 if J(x0) = 0): scipy's absolute tolerances become relative."""
    run.accept(x0)
    objective = run.objective(x0)
    return 1.0 / objective if objective > 0 else 1.0


def _recorder(run: Iterates):
    def callback(intermediate_result):  # scipy passes the result object only to a parameter of this name
        run.accept(intermediate_result.x)
    return callback


METHODS = {
    "trf": (_trf, TRF_OPTIONS),
    "lm": (_lm, LM_OPTIONS),
    "lbfgsb": (_lbfgsb, LBFGSB_OPTIONS),
    "gradient-descent": (descent.gradient_descent, descent.OPTIONS),
    "nelder-mead": (_nelder_mead, NELDER_MEAD_OPTIONS),
}
"""Method name -> (function(run, max_iterations, tol, options) -> (status, message), its options)."""


def optimise(problem: LeastSquares, method: str = "trf", *, max_iterations: int = 100, tol: float = 1e-10,
             options: dict | None = None) -> OptimiseResult:
    """Minimise J(x) = ||r(x)||^power of ``problem`` with the named method.

    Parameters
    ----------
    problem : LeastSquares
        Residuals, Jacobian, start and bounds; never modified (``problem.x0`` included).
    method : str
        "trf" (bounded trust-region Gauss-Newton, power 2 only), "lm" (Levenberg-Marquardt, power 2, no
        bounds: a run ending outside them is failed), "lbfgsb" (L-BFGS-B within the bounds),
        "gradient-descent" (the seed paper's steepest descent with Armijo steps, projected onto the bounds
        unless ``options={"bounds": False}``) or "nelder-mead" (derivative-free, within the bounds). A run
        that ends outside the bounds is reported "failed", whatever the method said.
    max_iterations : int
        Accepted iterations at most (>= 0).
    tol : float
        Convergence tolerance (> 0), passed to each method's own tolerances (see its options).
    options : dict, optional
        Method options, see ``TRF_OPTIONS``, ``LM_OPTIONS``, ``LBFGSB_OPTIONS``, ``NELDER_MEAD_OPTIONS`` and
        ``gradient_descent.OPTIONS``.

    Returns
    -------
    OptimiseResult
        Last accepted iterate and the history of all of them (row 0: the start); ``options`` holds the
        resolved method options. ``problem.progress(iteration, x, J)`` was called for every row.

    Raises
    ------
    InputError
        Unknown method, bad option (the key is named), bad limits or problem, power != 2 with "trf".
    SolverError
        Non-finite residuals at the start, or whatever the problem's callables raise. An exception raised
        by ``problem.progress`` (e.g. KeyboardInterrupt) propagates unchanged.

    Examples
    --------
    >>> problem = LeastSquares(lambda x: x - 2.0, lambda x: np.eye(1), np.array([0.0]), np.array([0.0]),
    ...                        np.array([1.0]), ("mu",))
    >>> result = optimise(problem, "trf")
    >>> result.status, round(float(result.x[0]), 8)
    ('converged', 1.0)
    """
    resolved = check_method(method, options, max_iterations, tol, len(problem.names))
    _check_problem(problem, method)
    run_method, _ = METHODS[method]
    log.info("%s on %d parameters %s, max_iterations = %d, tol = %g, options %s", method, len(problem.names),
             list(problem.names), max_iterations, tol, resolved)
    run = Iterates(problem)
    if max_iterations == 0:
        run.accept(np.array(problem.x0, dtype=float))
        return run.result("max_iterations", "max_iterations = 0: the start only", resolved)
    status, message = run_method(run, max_iterations, tol, resolved)
    result = run.result(status, message, resolved)
    return _within_bounds(result, problem)


def _within_bounds(result: OptimiseResult, problem: LeastSquares) -> OptimiseResult:
    """The result, or a "failed" one when it ends outside the bounds: a point outside them is never reported
    converged (only the paper's unbounded gradient descent can get there)."""
    lower, upper = np.asarray(problem.lower, dtype=float), np.asarray(problem.upper, dtype=float)
    slack = 1e-10 * np.where(np.isfinite(upper - lower), upper - lower, 1.0)
    outside = [f"{name} = {value:.6g}" for name, value, lo, hi, tol in
               zip(problem.names, result.x, lower, upper, slack) if not lo - tol <= value <= hi + tol]
    if not outside:
        return result
    message = (f"ended outside the bounds ({', '.join(outside)}; bounds {lower.tolist()} .. {upper.tolist()}): "
               f"not a physical result. {result.message}")
    log.warning("%s", message)
    return replace(result, status="failed", message=message)


def check_method(method: str, options: dict | None, max_iterations: int, tol: float, n_free: int) -> dict:
    """Validate a method name, its limits and options before anything is computed; the resolved options."""
    if method not in METHODS:
        raise InputError(f"method {method!r} is not known; the methods are {sorted(METHODS)}")
    _check_limits(max_iterations, tol)
    return resolve_options(method, METHODS[method][1], options, max_iterations, tol, n_free)


def _check_limits(max_iterations, tol) -> None:
    if not isinstance(max_iterations, Integral) or isinstance(max_iterations, bool) or max_iterations < 0:
        raise InputError(f"max_iterations must be an integer >= 0, not {max_iterations!r}")
    if not isinstance(tol, Real) or isinstance(tol, bool) or not tol > 0:
        raise InputError(f"tol must be a number > 0, not {tol!r}")


def _check_problem(problem: LeastSquares, method: str) -> None:
    """Shapes, start within the bounds, lower < upper, a usable power; InputError naming what is wrong."""
    n_free = len(problem.names)
    arrays = {"x0": problem.x0, "lower": problem.lower, "upper": problem.upper}
    for name, values in arrays.items():
        if np.shape(values) != (n_free,):
            raise InputError(f"problem.{name} has shape {np.shape(values)}; expected ({n_free},), one value "
                             f"per parameter {list(problem.names)}")
    x0, lower, upper = (np.asarray(a, dtype=float) for a in arrays.values())
    for k, name in enumerate(problem.names):
        if not (np.isfinite(x0[k]) and lower[k] <= x0[k] <= upper[k] and lower[k] < upper[k]):
            raise InputError(f"parameter {name!r}: start {x0[k]} and bounds [{lower[k]}, {upper[k]}] must "
                             "satisfy lower <= start <= upper, lower < upper, start finite")
    if not problem.power > 0:
        raise InputError(f"power must be > 0, not {problem.power}")
    if problem.loss not in ROBUST_WEIGHTS:
        raise InputError(f"loss {problem.loss!r} is not one of {sorted(ROBUST_WEIGHTS)}")
    if problem.loss != "linear" and method != "trf":
        raise InputError(f"a robust loss ({problem.loss!r}) needs method 'trf', not {method!r}")
    if not problem.loss_scale > 0:
        raise InputError(f"loss_scale must be > 0, not {problem.loss_scale}")
    if method in ("trf", "lm") and problem.power != 2:
        raise InputError(f"method {method!r} solves least-squares problems (power 2), not power {problem.power}; "
                         "use 'lbfgsb', 'gradient-descent' or 'nelder-mead'")
