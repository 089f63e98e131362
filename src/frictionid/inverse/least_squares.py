"""LeastSquares: what every optimiser sees, and OptimiseResult: what every optimiser returns.

The objective is J(x) = ||r(x)||^n with r the weighted residuals of the free parameters x (penalties and
Tikhonov terms are extra residual rows, so n = 2 is a plain least-squares problem). Optimisers never see the
forward model: they call ``residuals`` and ``jacobian``, which the identification layer backs with the
forward solver, the run store and the chosen Jacobian (analytic or finite differences).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class LeastSquares:
    """A bounded (weighted) least-squares problem in the free parameters.

    Attributes
    ----------
    residuals : x (n_free,) -> r (n_res,)
    jacobian : x (n_free,) -> dr/dx (n_res, n_free); a finite-difference or analytic Jacobian
    x0, lower, upper : (n_free,) start and bounds (lower <= x0 <= upper; +-inf allowed)
    names : parameter names, for messages and progress
    power : n in J = ||r||^n (2: least squares)
    progress : called after each accepted iteration with (iteration, x, J); may raise to stop the run
    noise_known : the residuals are divided by stated standard deviations, so the covariance of x is
        (J^T J)^-1; otherwise it is scaled by ||r||^2 / (n_res - n_free) (see :mod:`.uncertainty`)
    loss : "linear" (least squares) or a robust loss of scipy.optimize.least_squares ("soft_l1", "huber",
        "cauchy", "arctan"), "trf" only; loss_scale : the residual (in units of the weights, i.e. of the
        stated noise) beyond which the robust loss down-weights an observation
    stick_floor : x -> (n_free,) or None, optional: per parameter the lowest value it can take with the
        residuals unchanged (a friction zone that sticks along the whole load path: its stick threshold), NaN
        where it cannot move so; None where unknown (see ``Evaluator.stick_floor``)
    """

    residuals: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    x0: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    names: tuple[str, ...]
    power: float = 2.0
    progress: Callable[[int, np.ndarray, float], None] = lambda iteration, x, objective: None
    noise_known: bool = False
    loss: str = "linear"
    loss_scale: float = 3.0
    stick_floor: Callable[[np.ndarray], np.ndarray | None] | None = None

    def objective(self, r: np.ndarray) -> float:
        """J = ||r||^power."""
        return float(np.linalg.norm(r) ** self.power)

    def gradient(self, r: np.ndarray, jac: np.ndarray) -> np.ndarray:
        """dJ/dx = power ||r||^(power - 2) jac^T r."""
        norm = np.linalg.norm(r)
        if norm == 0:
            return np.zeros(jac.shape[1])
        return self.power * norm ** (self.power - 2) * (jac.T @ r)


@dataclass(frozen=True)
class OptimiseResult:
    """Outcome of an optimiser run.

    status: "converged" | "max_iterations" | "failed"; history: one row per accepted iteration
    (iteration 0 = start) with x and J; n_iterations counts accepted iterations.
    """

    x: np.ndarray
    objective: float
    status: str
    message: str
    n_iterations: int
    history_x: np.ndarray
    history_objective: np.ndarray
    options: dict = field(default_factory=dict)


#: robust losses of scipy.optimize.least_squares: rho'(z) with z = (r / f_scale)^2, the weight each
#: observation keeps at the solution (iteratively reweighted least squares)
ROBUST_WEIGHTS = {
    "linear": lambda z: np.ones_like(z),
    "soft_l1": lambda z: 1.0 / np.sqrt(1.0 + z),
    "huber": lambda z: np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1.0))),
    "cauchy": lambda z: 1.0 / (1.0 + z),
    "arctan": lambda z: 1.0 / (1.0 + z ** 2),
}


def robust_weights(r: np.ndarray, loss: str, loss_scale: float) -> np.ndarray:
    """(n,) weights in (0, 1] a robust loss gives residuals r at a solution: rho'((r / loss_scale)^2).

    Multiplying r and the rows of the Jacobian by their square roots gives the weighted least-squares
    problem the robust fit solves there, and from it the covariance (the down-weighted observations treated
    as outliers).

    >>> robust_weights(np.array([0.5, 3.0, 30.0]), "huber", 3.0).round(3).tolist()
    [1.0, 1.0, 0.1]
    """
    return ROBUST_WEIGHTS[loss]((np.asarray(r, dtype=float) / loss_scale) ** 2)
