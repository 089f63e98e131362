"""The identification's discretisation error: estimated, carried into the weights, or refined away.

``identify.model_error`` chooses what an identification does with the Richardson estimate of
:mod:`frictionid.inverse.model_error` (one extra condensation, of the model refined by 2):

- "auto" (default): "include" with the discretisation control's prediction for the fitted model where the control
  produced one on this fit (:func:`used_mode`), "off" where it did not (the control off, skipped, or not possible:
  a model object, the CalculiX backend, directional models beyond ``max_memory``); never a refinement of its own,
  so it costs no more memory than the control;
- "off": nothing; the fit-adequacy test still says when the misfit exceeds the stated noise;
- "estimate": the estimate at the start and the fitted coefficients is reported (``fit.model_error``);
- "include": as "estimate", then the fit is repeated from its end with sigma_eff^2 = sigma^2 + (k_q e)^2, so the
  intervals include the model error. The estimate gives the error's pattern over the observations of each
  quantity (ux, uy, ..., exy, force); its size k_q is taken from that quantity's misfit (:func:`error_scales`: its
  chi-square equal to its share of the degrees of freedom, 0 when the noise explains it, at most
  :data:`SCALE_CEILING`): one scale for all quantities cannot fit quantities whose estimate is off by different
  factors (the strains' estimate is an order of magnitude, the displacements' within a factor of about 2). Each
  quantity's own chi-square test then passes by construction unless the estimate cannot explain that quantity's
  misfit at a plausible size (k_q at the ceiling, or no estimated error where the misfit sits): then the fit is
  inconsistent, and an inconsistent include fit claims no zone (:mod:`frictionid.inverse.statistics`). What
  still tests the claims is the leave-group-out check, made in this mode even for a consistent fit, and the
  systematic part of the standard error: the fit before the refit is kept (``ModelError.before``), and how far
  the refit moved, or the coefficient shift of the scaled estimate, whichever is larger, is part of the
  coefficients' error (:func:`frictionid.inverse.uncertainty.systematic_error`).

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
from .adequacy import parts
from .model_error import estimate_model_error, from_control, inflated_sigma

log = logging.getLogger(__name__)
MODES = ("auto", "off", "estimate", "include")
#: the modes that estimate the error themselves when the control has not (the model refined by 2)
ESTIMATING = ("estimate", "include")
#: the largest scale k_q of the estimate a quantity's misfit may ask for: the estimate's orders are bounds, and
#: the slowest convergence measured (face displacements of the 3-D block, observed order 0.3) makes the actual
#: error 2.7 times the order-1 estimate; beyond 4 the estimate does not describe that quantity's misfit
SCALE_CEILING = 4.0


def check_options(identify: IdentifyOptions, model_options: ModelSpec | None, where: str) -> None:
    """Refuse a bad model_error / refine setting, and either on a model that cannot be refined, before any run."""
    mode, target, budget = identify.model_error, identify.refine_target, identify.refine_budget
    if mode not in MODES:
        raise InputError(f"{where} identify.model_error = {mode!r} is not one of {list(MODES)}")
    if not target >= 0:
        raise InputError(f"{where} identify.refine_target must be >= 0 (0: no refinement), got {target!r}")
    if budget < 1:
        raise InputError(f"{where} identify.refine_budget must be at least 1, got {budget!r}")
    if mode in ESTIMATING:              # "auto" and refine_target on a model that cannot be refined: the record says so
        try:
            refined(model_options or ModelSpec(None))
        except InputError as exc:
            raise InputError(f"{where} identify.model_error needs a model frictionid can refine: "
                             f"{exc}") from None


def used_mode(requested: str, remaining, record: dict | None) -> tuple[str, str]:
    """(mode, why): the mode a fit uses for ``identify.model_error = requested`` and the reason, for result.json's
    ``fit.model_error`` and the report. "auto" is "include" where the discretisation control made a prediction of
    the fitted model's error (``remaining``, :class:`~frictionid.inverse.remaining_error.RemainingError`; at the
    fitted values where its last round there was made, else at the start values) and "off" where it did not
    (``record``: the control's ``model.discretisation``, which says why); the other modes are used as given.

    >>> mode, why = used_mode("auto", None, {"target": 0.0, "status": "off"})
    >>> mode, "the discretisation control is off (identify.refine_target = 0)" in why
    ('off', True)
    >>> used_mode("estimate", None, {})
    ('estimate', 'identify.model_error = "estimate"')
    """
    lead = f'identify.model_error = "{requested}"'
    if requested != "auto":
        return requested, lead
    record = record or {}
    if remaining is None:
        cause = ("is off (identify.refine_target = 0)" if record.get("status") == "off" else
                 f"did not run ({record['why']})" if record.get("why") else "did not run")
        return "off", (f"{lead}: the discretisation control {cause}, so there is no estimate of the fitted model's "
                       "error to include")
    rounds = [r for r in record.get("at_fitted", []) if r.get("status") != "skipped"]
    where = (f"at the fitted values (round {rounds[-1]['round']})" if rounds else "at the start values" +
             (" (its estimate at the fitted values was skipped)" if record.get("at_fitted") else ""))
    return "include", (f"{lead}: the discretisation control's prediction for the fitted model, made {where}, is "
                       "included (no refinement of its own)")


def with_model_error(evaluator, parameters, model_options: ModelSpec, model, outcome, mode: str, refit,
                     max_memory: float | None = None, progress=None, remaining=None):
    """The discretisation error at the start and the fitted point of ``outcome`` (one extra condensation), and
    with mode "include" the fit continued from its end with sigma_eff^2 = sigma^2 + (k_q e)^2, one k_q per
    quantity from :func:`error_scales`.

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
    quantities = [parts(label)[1] for label in obs.labels]
    scales = error_scales(evaluator.model_values(outcome.x) - obs.y, obs.sigma, error.estimate, len(outcome.x),
                          quantities)
    error = replace(error, scale=np.array([scales[q] for q in quantities]), scales=scales,
                    before=np.array(outcome.x, dtype=float))
    evaluator.reweigh(inflated_sigma(obs, error))
    second = refit(outcome.x, outcome.n_iterations + 1)
    return error, replace(second, n_iterations=outcome.n_iterations + 1 + second.n_iterations,
                          message=f"{second.message} (refit with the model error in the weights)",
                          history_x=np.vstack([outcome.history_x, second.history_x]),
                          history_objective=np.concatenate([outcome.history_objective, second.history_objective]))


def _scale_to(residual, sigma, error, target: float) -> float:
    """k >= 0 with sum r^2 / (sigma^2 + k^2 e^2) = target; 0 when the noise alone reaches it or e is 0."""
    r2, s2, e2 = (np.asarray(a, dtype=float) ** 2 for a in (residual, sigma, error))

    def excess(k: float) -> float:
        return float(np.sum(r2 / (s2 + k * k * e2))) - target

    if excess(0.0) <= 0 or not np.any(e2 > 0):
        return 0.0
    high = 1.0
    while excess(high) > 0 and high < 1e6:
        high *= 4.0
    return float(brentq(excess, 0.0, high)) if excess(high) <= 0 else high


def error_scales(residual: np.ndarray, sigma: np.ndarray, error: np.ndarray, n_free: int, quantities,
                 ceiling: float | None = None) -> dict[str, float]:
    """{quantity: k_q}: per quantity (``quantities`` (n_obs,), e.g. "ux", "exy", "force") the scale with which
    its observations' chi-square sum r^2 / (sigma^2 + k_q^2 e^2) equals its share n_q (n_obs - n_free) / n_obs of
    the degrees of freedom; 0 when the noise explains the quantity's misfit or the estimate sees no error there,
    at most ``ceiling`` (default :data:`SCALE_CEILING`): how much of the estimated model error e each quantity's
    misfit r (model - measured, at the fit without it) shows.

    The Richardson estimate gives the error's pattern over a quantity's observations more reliably than its
    size (its order p is a bound near contact edges), so its size is taken from the data: 0 when the stated
    noise explains the misfit, about 1 when the estimate is right, more when it is too small; per quantity,
    because the estimate is off by different factors for different quantities.

    >>> scales = error_scales(np.array([3.0, 4.0, 0.5]), np.ones(3), np.array([2.0, 2.0, 1.0]), 0, ["ux", "ux", "e"])
    >>> {q: round(k, 4) for q, k in scales.items()}          # ux: 25 / (1 + 4 k^2) = 2; e: 0.25 < 1 needs none
    {'ux': 1.6956, 'e': 0.0}
    """
    ceiling = SCALE_CEILING if ceiling is None else ceiling
    quantities = np.asarray(quantities, dtype=str)
    r, s, e = (np.asarray(a, dtype=float) for a in (residual, sigma, error))
    share = max(len(r) - n_free, 1) / max(len(r), 1)
    scales = {}
    for q in dict.fromkeys(quantities.tolist()):
        rows = quantities == q
        k = _scale_to(r[rows], s[rows], e[rows], share * rows.sum())
        scales[q] = float(min(k, ceiling))
    return scales
