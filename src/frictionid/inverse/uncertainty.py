"""Uncertainty and identifiability of the identified coefficients from the weighted Jacobian at the solution.

Covariance C = s^2 (J^T J)^-1 over every free parameter, those the fit left on a bound included (a zone at a
bound is not known: treating it as known would make the others' errors too small), with s^2 = 1 when the
weights are stated standard deviations that explain the misfit, and s^2 = ||r||^2 / (n_obs - n_free)
otherwise (no stated noise, or a misfit the stated noise does not explain: see :mod:`.adequacy`). A parameter
in a direction the data do not see gets no standard error (never the small number a pseudo-inverse would give).

Intervals never leave the bounds: an inner parameter's 95 % interval is x +- q s clipped to [lower, upper]
(the truth lies within the bounds, so clipping loses no coverage); a parameter at a bound gets the one-sided
interval [b, b + 1.645 s] (or [b - 1.645 s, b] at an upper bound), never a symmetric one through the bound.

A parameter is reported identifiable when its standard error is within a tolerance (by default a quarter of
its bound interval), the data do not contradict each other about it (:attr:`.Adequacy.affected`), it is not on
a bound in a fit the stated noise does not explain and, where the discretisation error was estimated, that
error does not move it by more than SHIFT_LIMIT standard errors; every other one gets a reason (``why``). With
the model error included in the weights (:func:`systematic_error`), or the discretisation control's remaining
error propagated to the coefficients (:mod:`.remaining_error`), a systematic part is added to the standard error
in quadrature. The control's part is a prediction the misfit never checked (include mode scales its estimate by
the misfit and measures how far the refit moved): without include, a zone whose systematic part exceeds
SYSTEMATIC_LIMIT times its statistical standard error is not claimed (its interval would rest on that
prediction, known to a factor of about 2). A parameter claimed on a bound still needs its profile-likelihood check
(:func:`frictionid.inverse.profile.bound_verdict`), made by the identification.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from .adequacy import SHIFT_LIMIT
from .resolution import predicted_stderr

#: |correlation| above which a poorly resolved zone is said to be confounded with its partner
STRONG_CORRELATION = 0.9
#: a zone whose systematic standard error, predicted and not checked against the misfit (the discretisation
#: control's, :mod:`.remaining_error`), exceeds this many statistical ones is not claimed
SYSTEMATIC_LIMIT = 1.0


@dataclass(frozen=True)
class Uncertainty:
    """Per free parameter: stderr and ci95 (nan where not estimable), at_bound, identifiable flags and ``why``
    (the reason a parameter is not identifiable, "" otherwise); correlation (n_free, n_free) (nan rows for
    parameters the data do not see); singular_values of the weighted Jacobian with right singular vectors
    (columns of ``directions``); chi2 = ||r||^2, its degrees of freedom, and ``scale`` = s^2, the factor the
    covariance was scaled by."""

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
    scale: float = 1.0
    why: tuple[str, ...] = ()


def at_bounds(x, lower, upper, rtol: float = 1e-8) -> np.ndarray:
    """(n,) bool: x within rtol of its bound interval's width from a bound."""
    width = np.where(np.isfinite(upper - lower), upper - lower, 1.0)
    return (x - lower <= rtol * width) | (upper - x <= rtol * width)


def estimate(jac: np.ndarray, r: np.ndarray, x, lower, upper, noise_known: bool,
             tolerance: float | None = None, names=None, adequacy=None, model_shift=None,
             systematic=None, systematic_limit: float | None = None) -> Uncertainty:
    """Uncertainty from weighted residuals r (n_obs,) and their Jacobian (n_obs, n_free) at the solution x.

    ``tolerance``: the largest standard error of an identifiable parameter (default: a quarter of its bounds);
    ``names``: parameter names for the reasons; ``adequacy``: the fit's :class:`~.adequacy.Adequacy` (its
    consistency decides s^2, its ``affected`` zones are not identifiable); ``model_shift``: (n_free,) how far
    the estimated discretisation error moved each coefficient (:func:`~.adequacy.bias_shift`; nan unknown): a
    zone moved by more than SHIFT_LIMIT standard errors is not identifiable; ``systematic``: (n_free,) standard
    error of a systematic part (the model error's effect on each coefficient, :func:`systematic_error`), added
    in quadrature to the statistical one; ``systematic_limit``: a zone whose systematic error exceeds this many
    statistical standard errors is not claimed (None: the systematic part only widens the interval).

    Examples
    --------
    >>> jac = np.array([[10.0, 0.0], [0.0, 10.0], [10.0, 10.0]])
    >>> unc = estimate(jac, np.zeros(3), np.array([0.3, 0.0]), np.zeros(2), np.ones(2), noise_known=True)
    >>> unc.at_bound.tolist(), np.round(unc.ci95, 4).tolist()
    ([False, True], [[0.14, 0.46], [0.0, 0.1343]])
    """
    x, lower, upper = (np.asarray(a, dtype=float) for a in (x, lower, upper))
    n_obs, n_free = jac.shape
    names = tuple(names) if names is not None else tuple(f"x{k}" for k in range(n_free))
    bound = at_bounds(x, lower, upper)
    dof = max(n_obs - n_free, 1)
    chi2 = float(r @ r)
    explained = noise_known and (adequacy is None or adequacy.consistent is not False)
    scale = 1.0 if explained else max(chi2 / dof, 1.0)
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    message = ""
    if s.size and s[-1] <= 1e-12 * s[0]:
        message = "the Jacobian of the free parameters is singular: some combination is not resolved by the data"
    information = jac.T @ jac
    se = np.sqrt(scale) * predicted_stderr(information)
    systematic = np.zeros(n_free) if systematic is None else np.nan_to_num(np.asarray(systematic, dtype=float))
    statistical, se = se, np.hypot(se, systematic)
    stderr = np.where(np.isfinite(se), se, np.nan)
    correlation = np.full((n_free, n_free), np.nan)
    seen = np.isfinite(se)
    if seen.any():
        covariance = scale * np.linalg.inv(information[np.ix_(seen, seen)])
        with np.errstate(invalid="ignore", divide="ignore"):
            correlation[np.ix_(seen, seen)] = covariance / np.outer(se[seen], se[seen])
    ci95 = _intervals(x, lower, upper, stderr, bound, stats.norm.ppf(0.975) if noise_known
                      else stats.t.ppf(0.975, dof), stats.norm.ppf(0.95) if noise_known else stats.t.ppf(0.95, dof))
    limit = np.broadcast_to(0.25 * (upper - lower) if tolerance is None else tolerance, (n_free,))
    affected = np.zeros(n_free, dtype=bool) if adequacy is None else adequacy.affected
    shift = np.full(n_free, np.nan) if model_shift is None else np.asarray(model_shift, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        moved = np.nan_to_num(np.abs(shift) / se, nan=0.0) > SHIFT_LIMIT
    unexplained = bound & (adequacy is not None and adequacy.consistent is False)
    model_made = (se > limit) & (systematic > statistical)
    dominated = ~model_made & (np.zeros(n_free, dtype=bool) if systematic_limit is None else
                               systematic > systematic_limit * np.nan_to_num(statistical, nan=np.inf))
    identifiable = (se <= limit) & ~affected & ~moved & ~unexplained & ~dominated
    why = tuple("" if identifiable[k] else
                adequacy.why_affected(k, names) if affected[k] else
                _why_bound(lower[k] if x[k] - lower[k] <= upper[k] - x[k] else upper[k], adequacy)
                if unexplained[k] else
                _why_systematic(systematic[k], statistical[k]) if dominated[k] and se[k] <= limit[k] else
                f"standard error {se[k]:.3g} > {limit[k]:g}, {systematic[k]:.3g} of it systematic: the mesh's "
                "estimated discretisation error moves it (" + ("the remaining error the discretisation control "
                "predicts for the fitted mesh" if systematic_limit is not None else "by the estimate's coefficient "
                "shift or by including the error in the weights") + "): refine the mesh (identify.refine_target) or "
                "observe where the model converges" if model_made[k] else
                _why_unresolved(k, jac, se, limit[k], correlation, vt, s, names) if not moved[k] else
                f"the mesh's estimated discretisation error moves it by {shift[k]:+.3g} ({abs(shift[k]) / se[k]:.1f} "
                "standard errors): refine the mesh (identify.refine_target) or observe where the model converges"
                for k in range(n_free))
    return Uncertainty(stderr, ci95, bound, identifiable, correlation, s, vt.T, chi2, dof, message, scale, why)


def _why_systematic(systematic: float, statistical: float) -> str:
    """Why a resolved zone whose systematic error exceeds its statistical one is not claimed."""
    return (f"the model's remaining discretisation error moves it by up to {systematic:.3g}, more than its "
            f"statistical standard error {statistical:.3g}: its interval would rest on that estimate, known to a "
            "factor of about 2 (docs/fit-quality.md); refine further (identify.refine_target, refine_budget, "
            "[solver] max_memory) or observe where the model converges")


def _why_bound(value: float, adequacy) -> str:
    """Why a zone on a bound is not claimed in a fit the stated noise does not explain."""
    return (f"on its bound ({value:g}) in a fit the stated noise does not explain (reduced chi-square "
            f"{adequacy.reduced_chi2:.3g} > {adequacy.threshold:.3g}): the misfit, not the data, may hold it there; "
            "a value on a bound is claimed only in a consistent fit (include the model error: identify.model_error "
            "= \"include\")")


def systematic_error(scaled_shift, before, after) -> np.ndarray:
    """(n_free,) standard error of the part of a coefficient's error a model error makes (include mode).

    The error included as variance is a fixed vector, not noise: it does not average out over many
    observations, so the statistical standard error understates its effect. Two measures of that effect,
    the larger kept: ``scaled_shift`` (n_free,), the linearised move of the coefficients were the model
    corrected by its estimated error scaled to the size each quantity's misfit shows (at least the estimate
    itself: :func:`~.adequacy.bias_shift` of max(k_q, 1) e); and how far including the error in the weights
    moved the fit (``after`` - ``before``): under a right model both weightings estimate the same coefficients.

    >>> systematic_error(np.array([0.01, np.nan]), np.array([0.1, 0.2]), np.array([0.13, 0.2])).tolist()
    [0.03, 0.0]
    """
    moved = np.abs(np.asarray(after, dtype=float) - np.asarray(before, dtype=float))
    return np.maximum(moved, np.nan_to_num(np.abs(np.asarray(scaled_shift, dtype=float)), nan=0.0))


def _intervals(x, lower, upper, stderr, bound, two_sided: float, one_sided: float) -> np.ndarray:
    """(n, 2) 95 % intervals within the bounds: two-sided and clipped inside, one-sided at a bound."""
    lo, hi = x - two_sided * stderr, x + two_sided * stderr
    at_lower = bound & (np.abs(x - lower) <= np.abs(upper - x))
    lo = np.where(bound, np.where(at_lower, x, x - one_sided * stderr), lo)
    hi = np.where(bound, np.where(at_lower, x + one_sided * stderr, x), hi)
    return np.column_stack([np.clip(lo, lower, upper), np.clip(hi, lower, upper)])


def _why_unresolved(k: int, jac, se, limit: float, correlation, vt, s, names) -> str:
    """Why the data do not pin down parameter k: not observed, confounded with others, or too little signal."""
    column = np.linalg.norm(jac[:, k])
    if column <= 1e-12 * max(np.linalg.norm(jac), 1e-300):
        return "not observed: no observation changes with it"
    if not np.isfinite(se[k]):
        blind = vt[s <= 1e-12 * s[0]] if s.size else vt
        partners = [names[j] for j in range(len(names)) if j != k and np.any(np.abs(blind[:, j]) > 1e-8)]
        return (f"the data see it only in a combination with {', '.join(partners)}" if partners
                else "the data see no combination that contains it")
    row = np.where(np.arange(len(names)) == k, 0.0, np.nan_to_num(np.abs(correlation[k]), nan=0.0))
    j = int(np.argmax(row)) if row.size else k
    text = f"standard error {se[k]:.3g} > {limit:g}"
    if row.size and row[j] > STRONG_CORRELATION:
        return f"{text}: correlated with {names[j]} (r = {correlation[k, j]:+.2f})"
    return f"{text}: too little signal in the data"
