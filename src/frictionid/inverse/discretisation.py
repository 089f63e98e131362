"""The identification's discretisation error: estimated, carried into the weights, or refined away.

``identify.model_error`` chooses what an identification does with the Richardson estimate of
:mod:`frictionid.inverse.model_error` (one extra condensation, of the model refined by 2):

- "off" (default): nothing; the fit-adequacy test still says when the misfit exceeds the stated noise;
- "estimate": the estimate at the start and the fitted coefficients is reported (``fit.model_error``);
- "include": as "estimate", then the fit is repeated from its end with sigma_eff^2 = sigma^2 + (k e)^2, so the
  intervals include the model error. The estimate gives the error's pattern over the observations; its size k
  is taken from the misfit (:func:`error_scale`: chi-square equal to its degrees of freedom, k = 0 when the
  noise explains the misfit). The chi-square test then passes by construction unless the pattern cannot
  explain the misfit: when the observations where the estimate sees no error hold more misfit than the noise
  explains, k cannot help and the fit stays inconsistent. The fit before the refit is kept
  (``ModelError.before``): how far the refit moved is part of the coefficients' systematic error
  (:func:`frictionid.inverse.uncertainty.systematic_error`).

``identify.refine_target`` (default 0.5 noise levels RMS per quantity kind) is the discretisation control
before the fit, :mod:`frictionid.inverse.discretisation_control`.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

from ..builders.registry import refined
from ..errors import InputError
from ..options import IdentifyOptions, ModelSpec
from .model_error import estimate_model_error, from_control, inflated_sigma

log = logging.getLogger(__name__)
MODES = ("off", "estimate", "include")


def check_options(identify: IdentifyOptions, model_options: ModelSpec | None, where: str) -> None:
    """Refuse a bad model_error / refine setting, and either on a model that cannot be refined, before any run."""
    mode, target, budget = identify.model_error, identify.refine_target, identify.refine_budget
    if mode not in MODES:
        raise InputError(f"{where} identify.model_error = {mode!r} is not one of {list(MODES)}")
    if not target >= 0:
        raise InputError(f"{where} identify.refine_target must be >= 0 (0: no refinement), got {target!r}")
    if budget < 1:
        raise InputError(f"{where} identify.refine_budget must be at least 1, got {budget!r}")
    if mode != "off":                   # refine_target on a model that cannot be refined: the control says so
        try:
            refined(model_options or ModelSpec(None))
        except InputError as exc:
            raise InputError(f"{where} identify.model_error needs a model frictionid can refine: "
                             f"{exc}") from None


def with_model_error(evaluator, parameters, model_options: ModelSpec, model, outcome, mode: str, refit,
                     max_memory: float | None = None, progress=None, remaining=None):
    """The discretisation error at the start and the fitted point of ``outcome`` (one extra condensation), and
    with mode "include" the fit continued from its end with sigma_eff^2 = sigma^2 + (k e)^2, k from
    :func:`error_scale`.

    ``refit(x0, offset)`` runs the optimiser from x0 with the evaluator's (new) weights, numbering its
    iterations from ``offset``. Returns the :class:`ModelError` and the outcome to report (fit and refit joined).
    ``max_memory`` [GB] and ``progress``: as :func:`~frictionid.inverse.model_error.estimate_model_error`.
    ``remaining``: the discretisation control's prediction for the fitted model
    (:class:`~frictionid.inverse.remaining_error.RemainingError`), when it ran: then it is the estimate
    (:func:`~frictionid.inverse.model_error.from_control`) and the model is not refined again.
    """
    points = [parameters.x0, outcome.x]
    obs = evaluator.obs
    if remaining is not None:
        error = from_control(remaining, obs, model_options)
    else:
        error = estimate_model_error(model_options, obs, [parameters.full(x) for x in points],
                                     coarse_values=[evaluator.model_values(x) for x in points], model=model,
                                     max_memory=max_memory, progress=progress)
    if mode != "include":
        return error, outcome
    scale = error_scale(evaluator.model_values(outcome.x) - obs.y, obs.sigma, error.estimate, len(outcome.x))
    error = replace(error, scale=scale, before=np.array(outcome.x, dtype=float))
    evaluator.reweigh(inflated_sigma(obs, error))
    second = refit(outcome.x, outcome.n_iterations + 1)
    return error, replace(second, n_iterations=outcome.n_iterations + 1 + second.n_iterations,
                          message=f"{second.message} (refit with the model error in the weights)",
                          history_x=np.vstack([outcome.history_x, second.history_x]),
                          history_objective=np.concatenate([outcome.history_objective, second.history_objective]))


def error_scale(residual: np.ndarray, sigma: np.ndarray, error: np.ndarray, n_free: int) -> float:
    """k >= 0 with sum r^2 / (sigma^2 + k^2 e^2) = n_obs - n_free: how much of the estimated model error e the
    misfit r (model - measured, at the fit without it) shows.

    The Richardson estimate gives the error's pattern over the observations more reliably than its size (its
    order p is a bound near contact edges), so its size is taken from the data: 0 when the stated noise
    explains the misfit, about 1 when the estimate is right, more when it is too small.

    >>> round(error_scale(np.array([3.0, 4.0]), np.ones(2), np.array([2.0, 2.0]), 0), 4)   # 25 / (1 + 4 k^2) = 2
    1.6956
    """
    r2, s2, e2 = (np.asarray(a, dtype=float) ** 2 for a in (residual, sigma, error))
    dof = max(len(r2) - n_free, 1)

    def excess(k: float) -> float:
        return float(np.sum(r2 / (s2 + k * k * e2))) - dof

    if excess(0.0) <= 0 or not np.any(e2 > 0):
        return 0.0
    high = 1.0
    while excess(high) > 0 and high < 1e6:
        high *= 4.0
    return float(brentq(excess, 0.0, high)) if excess(high) <= 0 else high
