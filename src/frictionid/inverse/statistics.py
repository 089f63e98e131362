"""What a fitted point says: weighted residuals, adequacy and uncertainty of the free coefficients, the misfit
per measurement point, and why a zone is not identifiable in terms of its contact state."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..backends.base import Backend
from .adequacy import Adequacy, assess, bias_shift
from .discretisation import SCALE_CEILING
from .evaluator import Evaluator
from .least_squares import LeastSquares, robust_weights
from .remaining_error import systematic as remaining_systematic
from .uncertainty import SYSTEMATIC_LIMIT, Uncertainty, at_bounds, estimate, systematic_error


@dataclass(frozen=True)
class FitStatistics:
    """What the fitted point says: weighted residuals r (n_obs,) (robust weights applied), model values f,
    robust weights (1 for least squares), the fit's :class:`Adequacy` and :class:`Uncertainty`."""

    r: np.ndarray
    f: np.ndarray
    weights: np.ndarray
    adequacy: Adequacy
    uncertainty: Uncertainty
    model_shift: np.ndarray | None = None
    #: (n_free,) systematic standard error in the uncertainty (model error included, or the discretisation
    #: control's remaining error propagated), None otherwise
    systematic: np.ndarray | None = None
    #: (n_free,) the fitted-minus-converged offset the control's remaining error predicts (nan on a bound), or None
    discretisation_bias: np.ndarray | None = None


def fit_statistics(evaluator: Evaluator, problem: LeastSquares, x: np.ndarray, resolution: float,
                   error=None, remaining=None) -> FitStatistics:
    """Adequacy and uncertainty of the free coefficients x with the evaluator's observations and weights;
    ``error``: the :class:`~frictionid.inverse.model_error.ModelError` estimated for this fit, if any (the
    coefficient shift its signed error causes decides, with the rest, which zones are identifiable);
    ``remaining``: the discretisation control's :class:`~frictionid.inverse.remaining_error.RemainingError` of
    the fitted model, if it ran: its effect on the coefficients is a systematic error (the larger of it and the
    "include" mode's where both exist)."""
    params, obs = evaluator.params, evaluator.obs
    r = evaluator.residuals(x)[:obs.n_obs]
    jac = evaluator.jacobian(x)[:obs.n_obs]
    # a robust fit is the least-squares fit with the weights it ends with: its statistics are computed so
    weights = robust_weights(r, problem.loss, problem.loss_scale)
    r, jac = np.sqrt(weights) * r, np.sqrt(weights)[:, None] * jac
    inner = ~at_bounds(x, params.lower, params.upper)
    model = getattr(evaluator.backend, "model", None)
    included = error is not None and error.before is not None          # "include": the error is in the weights
    adequacy = assess(r, jac, obs.labels, obs.y, evaluator.model_values(x), obs.noise_known, inner=inner,
                      sigma=obs.sigma, regions=dict(zip(obs.point_labels, obs.point_regions)),
                      model_kind=getattr(model, "kind", None), check_groups=included)
    shift = systematic = offset = limit = None
    if error is not None and error.signed is not None:
        weight = np.sqrt(weights) * obs.weight
        shift = _bound_zones_free(lambda free: bias_shift(jac, weight * error.signed, free), inner)
        if included:                                    # the scaled error's effect is part of the interval
            scale = np.maximum(np.broadcast_to(np.asarray(error.scale, dtype=float), obs.sigma.shape), 1.0)
            scaled = _bound_zones_free(lambda free: bias_shift(jac, weight * scale * error.signed, free), inner)
            systematic = systematic_error(scaled, error.before, x)
    if remaining is not None:
        weight = np.sqrt(weights) * obs.weight
        left = _bound_zones_free(lambda free: remaining_systematic(jac, weight, remaining, free)[1], inner)
        offset = remaining_systematic(jac, weight, remaining, inner)[0]
        if systematic is None:                          # a prediction the misfit did not check: claims limited
            systematic, limit = left, SYSTEMATIC_LIMIT
        else:
            systematic = np.fmax(systematic, left)
    if included and systematic is not None and adequacy.shifts:
        adequacy = adequacy.with_systematic(systematic)
    unc = estimate(jac, r, x, params.lower, params.upper, obs.noise_known, resolution, params.free_names, adequacy,
                   shift, systematic, limit)
    if included and adequacy.consistent is False:
        unc = _unexplained(unc, adequacy)
    return FitStatistics(r, evaluator.model_values(x), weights, adequacy, unc, shift, systematic, offset)


def _bound_zones_free(measure, inner: np.ndarray) -> np.ndarray:
    """(n_free,) ``measure(free)``, a linearised coefficient shift over the zones ``free`` (bool (n_free,)): that
    of the ``inner`` zones for them, that of every zone free for the zones on a bound. A zone on a bound is
    counted free in the covariance (:func:`~.uncertainty.estimate`), so its systematic part is measured free
    too: held there, how far the model error pulls it off the bound would not be measured at all (0), and a
    claim on a bound would rest on less than a claim inside (docs/fit-quality.md)."""
    if inner.all():
        return measure(inner)
    on_bound = measure(np.ones_like(inner))
    return np.where(inner, measure(inner), on_bound)


def _unexplained(unc: Uncertainty, adequacy) -> Uncertainty:
    """No zone claimed in a fit that the noise and the included model error do not explain: the estimate,
    scaled per quantity up to its ceiling, does not describe the misfit, so the intervals built on it do not
    hold (docs/fit-quality.md)."""
    which = (f"{', '.join(adequacy.kinds_beyond)} beyond the noise" if adequacy.kinds_beyond else
             f"reduced chi-square {adequacy.reduced_chi2:.3g} > {adequacy.threshold:.3g}")
    reason = (f"the fit with the model error included does not explain the data ({which}): the estimated "
              f"discretisation error, scaled per quantity up to {SCALE_CEILING:g} times, does not describe that "
              "misfit, so no interval resting on it is claimed")
    why = tuple(reason + (f"; {w}" if w else "") for w in unc.why)
    return replace(unc, identifiable=np.zeros_like(unc.identifiable), why=why)


def point_misfit(obs, r: np.ndarray) -> list[dict]:
    """Per measurement point: its label, model coordinates [mm] and RMS weighted residual (noise units)."""
    point, n_points = obs.point, len(obs.point_labels)
    seen = point >= 0                                   # the machine force ("force@2") belongs to no point
    count = np.bincount(point[seen], minlength=n_points)
    total = np.bincount(point[seen], weights=np.asarray(r, dtype=float)[seen] ** 2, minlength=n_points)
    return [{"point": label, "xyz": [float(v) for v in xyz], "rms": float(np.sqrt(total[i] / count[i]))}
            for i, (label, xyz) in enumerate(zip(obs.point_labels, obs.points)) if count[i]]


#: area fraction below which a zone counts as carrying no load (lifted off) or not slipping (stuck)
_STATE_SHARE = 0.01


def contact_reasons(backend: Backend, mu: np.ndarray, stages, free, unc) -> list[str]:
    """Each free zone's reason for not being identifiable, with what the contact does there at the observed
    stages (lifted off, stuck) when the backend can tell; "" for identifiable zones."""
    why = list(unc.why)
    states = getattr(backend, "contact_states", None)
    if states is None or all(unc.identifiable):
        return why
    per_stage = states(mu)
    names = ", ".join(str(s + 1) for s in stages)
    for k, zone in enumerate(free):
        if unc.identifiable[k]:
            continue
        seen = [per_stage[s][zone] for s in stages]
        if all(state["open"] > 1 - _STATE_SHARE for state in seen):
            why[k] = f"lifted off at the observed stage(s) {names}: its friction acts on nothing; " + why[k]
        elif all(state["slip"] < _STATE_SHARE for state in seen):
            why[k] = (f"sticks at the observed stage(s) {names}: friction shows only where a surface slips; "
                      + why[k])
    return why
