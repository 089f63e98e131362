"""A fit the way ``identify`` fits, without a config or a run store: observations at given points, least squares
from the parameters' start, with identify.model_error "estimate" or "include" the model error and its refit,
then the statistics result.json reports (used by the claims and coverage tests' seeded replicates)."""

from __future__ import annotations

import numpy as np

from frictionid.inverse.discretisation import with_model_error
from frictionid.options import ModelSpec
from frictionid.inverse.evaluator import Evaluator
from frictionid.inverse.least_squares import LeastSquares
from frictionid.inverse.observations import Observations
from frictionid.inverse.optimisers import optimise
from frictionid.inverse.statistics import fit_statistics


def point_observations(points: np.ndarray, regions, quantities: tuple[str, ...], y: np.ndarray,
                       sigma: float) -> Observations:
    """Observations of every quantity at every point at stage 2 (point-major rows), values ``y``, noise ``sigma``."""
    n, q = len(y), len(quantities)
    labels = tuple(f"P{i // q + 1}:{quantities[i % q]}@2" for i in range(n))
    return Observations(points, regions, quantities, np.arange(n), np.ones(n, int), y, np.full(n, sigma), labels,
                        True)


def fit_as_identify(backend, model, model_table: dict, params, obs: Observations, mode: str, resolution: float):
    """(the optimiser's outcome, :class:`~frictionid.inverse.statistics.FitStatistics`) of a trf fit of ``obs``
    with ``backend``; ``mode``: identify.model_error ("off", "estimate", "include"), estimated on the model
    built from ``model_table``."""
    return fits_as_identify(backend, model, model_table, params, obs, (mode,), resolution)[mode]


def fits_as_identify(backend, model, model_table: dict, params, obs: Observations, modes: tuple[str, ...],
                     resolution: float) -> dict:
    """{mode: :func:`fit_as_identify`'s (outcome, statistics)} for "off" and at most one other mode of the same
    ``obs``, sharing the least-squares fit every mode starts with (identify fits so: the model error's estimate
    and refit continue from it); "off"'s statistics are taken before the refit reweighs the evaluator."""
    others = [mode for mode in modes if mode != "off"]
    assert len(others) <= 1 and len(set(modes)) == len(modes), modes
    evaluator = Evaluator(backend, obs, params)

    def fit(x0):
        problem = LeastSquares(evaluator.residuals, evaluator.jacobian, x0, params.lower, params.upper,
                               params.free_names, noise_known=True)
        return optimise(problem, "trf"), problem

    outcome, problem = fit(params.x0)
    out = {"off": (outcome, fit_statistics(evaluator, problem, outcome.x, resolution, None))} if "off" in modes else {}
    for mode in others:
        error, outcome = with_model_error(evaluator, params, ModelSpec.from_table(model_table), model, outcome, mode,
                                          lambda x0, offset: fit(x0)[0])
        out[mode] = outcome, fit_statistics(evaluator, problem, outcome.x, resolution, error)
    return out
