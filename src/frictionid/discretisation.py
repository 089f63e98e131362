"""The identification's discretisation error: estimated, carried into the weights, or refined away.

``identify.model_error`` chooses what an identification does with the Richardson estimate of
:mod:`frictionid.inverse.model_error` (one extra condensation, of the model refined by 2):

- "off" (default): nothing; the fit-adequacy test still says when the misfit exceeds the stated noise;
- "estimate": the estimate at the start and the fitted coefficients is reported (``fit.model_error``);
- "include": as "estimate", then the fit is repeated from its end with sigma_eff^2 = sigma^2 + e^2, so the
  chi-square test and the intervals include the model error.

``identify.refine_target`` > 0 refines the model (element sizes halved, up to ``identify.refine_budget``
times) before fitting until the estimated error at the start values is below that many noise levels RMS; a
budget that runs out ends the run with the error reached.
"""

from __future__ import annotations

import logging

import numpy as np

from .builders.registry import build_model, refined
from .errors import InputError, SolverError
from .inverse.model_error import ModelError, estimate_model_error

log = logging.getLogger(__name__)
MODES = ("off", "estimate", "include")


def check_options(identify: dict, model_options: dict, where: str) -> None:
    """Refuse a bad model_error / refine setting, and either on a model that cannot be refined, before any run."""
    mode, target, budget = identify["model_error"], identify["refine_target"], identify["refine_budget"]
    if mode not in MODES:
        raise InputError(f"{where} identify.model_error = {mode!r} is not one of {list(MODES)}")
    if not target >= 0:
        raise InputError(f"{where} identify.refine_target must be >= 0 (0: no refinement), got {target!r}")
    if budget < 1:
        raise InputError(f"{where} identify.refine_budget must be at least 1, got {budget!r}")
    if mode != "off" or target > 0:
        try:
            refined(model_options)
        except InputError as exc:
            raise InputError(f"{where} identify.model_error / refine_target need a model frictionid can refine: "
                             f"{exc}") from None


def refine_until(model_options: dict, model, observations, mu, target: float, budget: int):
    """Halve the element sizes until the estimated error at ``mu`` is below ``target`` noise levels RMS.

    Returns the [model] options, the model and the last :class:`ModelError` (of the returned model).

    Raises
    ------
    SolverError
        When ``budget`` refinements do not reach the target; the message names the error reached.
    """
    options = dict(model_options)
    for level in range(budget + 1):
        error = estimate_model_error(options, observations, [mu], model=model)
        rms = error.summary["all"]["rms"]
        log.info("model error with %s: %.3g noise levels RMS (target %g)", options, rms, target)
        if rms <= target:
            return options, model, error
        if level == budget:
            break
        options = error.refined_options
        model = build_model(options, "[model] (refined)")
    raise SolverError(f"identify.refine_budget = {budget} refinement(s) did not bring the estimated model error "
                      f"below identify.refine_target = {target:g}: it is {rms:.3g} noise levels RMS (max "
                      f"{error.summary['all']['max']:.3g}) with {options}. Raise the budget or the target, or "
                      "observe points farther from the contact edges")


def estimate_at(model_options: dict, model, observations, mu_points, values) -> ModelError:
    """The estimate at the given coefficient sets (all zones), with the model's own values there."""
    return estimate_model_error(model_options, observations, [np.asarray(mu) for mu in mu_points],
                                coarse_values=values, model=model)
