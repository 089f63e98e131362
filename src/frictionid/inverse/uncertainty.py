"""Uncertainty and identifiability of the identified coefficients from the weighted Jacobian at the solution.

Covariance C = s^2 (J^T J)^-1 over the parameters not held at a bound, with s^2 = 1 when the weights are
stated standard deviations (noise known) and s^2 = ||r||^2 / (n_obs - n_free) otherwise; a parameter in a
direction the data do not see gets no standard error (never the small number a pseudo-inverse would give).
A parameter is reported identifiable when its standard error, computed with every free parameter treated as
free (so also for one that the fit left on a bound), is within a tolerance (by default a quarter of its bound
interval); parameters at a bound get no standard error ("cannot be estimated at a bound").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from .resolution import predicted_stderr


@dataclass(frozen=True)
class Uncertainty:
    """Per free parameter: stderr and ci95 (nan where not estimable), at_bound, identifiable flags;
    correlation (n_free, n_free) (nan rows for parameters at a bound); singular_values of the weighted Jacobian
    with right singular vectors (columns of ``directions``); chi2 = ||r||^2 and its degrees of freedom."""

    stderr: np.ndarray
    ci95: np.ndarray
    at_bound: np.ndarray
    identifiable: np.ndarray
    correlation: np.ndarray
    singular_values: np.ndarray
    directions: np.ndarray
    chi2: float
    dof: int
    message: str


def at_bounds(x, lower, upper, rtol: float = 1e-8) -> np.ndarray:
    """(n,) bool: x within rtol of its bound interval's width from a bound."""
    width = np.where(np.isfinite(upper - lower), upper - lower, 1.0)
    return (x - lower <= rtol * width) | (upper - x <= rtol * width)


def estimate(jac: np.ndarray, r: np.ndarray, x, lower, upper, noise_known: bool,
             tolerance: float | None = None) -> Uncertainty:
    """Uncertainty from weighted residuals r (n_obs,) and their Jacobian (n_obs, n_free) at the solution x.

    ``tolerance``: the largest standard error of an identifiable parameter (default: a quarter of its bounds).
    """
    n_obs, n_free = jac.shape
    bound = at_bounds(np.asarray(x), np.asarray(lower), np.asarray(upper))
    inner = ~bound
    dof = max(n_obs - n_free, 1)
    chi2 = float(r @ r)
    scale = 1.0 if noise_known else chi2 / dof
    u, s, vt = np.linalg.svd(jac, full_matrices=False)
    stderr = np.full(n_free, np.nan)
    correlation = np.full((n_free, n_free), np.nan)
    message = ""
    J = jac[:, inner]
    if J.size:
        sv = np.linalg.svd(J, compute_uv=False)
        if sv[-1] <= 1e-12 * sv[0]:
            message = "the Jacobian of the free parameters is singular: some combination is not resolved by the data"
        se = np.sqrt(scale) * predicted_stderr(J.T @ J)
        stderr[inner] = np.where(np.isfinite(se), se, np.nan)
        seen = np.isfinite(se)
        if seen.any():
            covariance = scale * np.linalg.inv(J[:, seen].T @ J[:, seen])
            with np.errstate(invalid="ignore", divide="ignore"):
                correlation[np.ix_(np.flatnonzero(inner)[seen], np.flatnonzero(inner)[seen])] = \
                    covariance / np.outer(se[seen], se[seen])
    quantile = stats.t.ppf(0.975, dof) if not noise_known else stats.norm.ppf(0.975)
    ci95 = np.column_stack([x - quantile * stderr, x + quantile * stderr])
    width = np.asarray(upper) - np.asarray(lower)
    limit = 0.25 * width if tolerance is None else tolerance
    identifiable = np.sqrt(scale) * predicted_stderr(jac.T @ jac) <= limit
    return Uncertainty(stderr, ci95, bound, identifiable, correlation, s, vt.T, chi2, dof, message)
