"""The discretisation control at the fitted values inside ``identify``: its rounds and the fit continued on the
finer model a round asks for (orchestration; the estimate and the choice are :mod:`.inverse.discretisation_refit`)."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from .backends import make_backend
from .config import Config
from .errors import InputError
from .inverse import discretisation_refit as refit_at_fitted
from .inverse.discretisation_control import values
from .inverse.evaluator import Evaluator
from .inverse.fitting import make_evaluator, make_least_squares, recorded
from .inverse.least_squares import LeastSquares, OptimiseResult
from .inverse.optimisers import optimise
from .model_checks import checked_contact
from .preparation import Setup, strain_window
from .run.executor import make_executor
from .run.store import RunStore


class Fit:
    """The fit's setup, evaluator and least-squares problem, replaced when a refit moves to a finer model; ``given``
    the [model] and model as given ((options, model); None when the discretisation control did not run)."""

    def __init__(self, setup: Setup, evaluator: Evaluator, problem: LeastSquares, given=None):
        self.setup, self.evaluator, self.problem, self.given = setup, evaluator, problem, given


def refine_at_fitted(config, fit: Fit, store: RunStore, progress, echo, outcome: OptimiseResult) -> OptimiseResult:
    """The discretisation control again at the fitted values, and the fit continued on the finer model it asks
    for, at most :data:`~.inverse.discretisation_refit.MAX_ROUNDS` times (:mod:`.inverse.discretisation_refit`);
    ``fit`` then holds the refined model's setup, evaluator and problem, and each round's record is in
    ``model.discretisation.at_fitted`` as soon as it is made (an interrupted run's result.json has it)."""
    record, ident, obs = fit.setup.discretisation, config.identify, fit.setup.observations
    if fit.given is None or record.get("status") in ("off", "skipped"):
        return outcome
    record = {**record, "at_fitted": []}      # the control's own record stays as it made it (a study may share it)
    fit.setup = replace(fit.setup, discretisation=record)
    window = strain_window(fit.setup.window, obs)
    current, rounds = tuple(record["factors"].values()), record["at_fitted"]
    for index in range(1, refit_at_fitted.MAX_ROUNDS + 1):
        params = fit.setup.parameters
        mu = params.full(outcome.x)
        rounds.append({"round": index, "at": dict(zip(params.names, map(float, mu))),
                       "objective": float(outcome.objective), "n_iterations": int(outcome.n_iterations)})
        try:
            decision = refit_at_fitted.at_fitted(*fit.given, obs, mu, current, fit.evaluator.model_values(outcome.x),
                                                 ident.refine_target, ident.refine_budget, config.solver.max_memory,
                                                 window, config.solver.factorisation, store, echo, index,
                                                 record["memory_scale"])
            rounds[-1].update(decision.record)
            if decision.remaining is not None:
                fit.setup = replace(fit.setup, remaining_error=decision.remaining)
            if decision.factors is None:
                break
            outcome = _refit(config, fit, store, progress, echo, outcome, decision, mu, window, rounds[-1])
        except InputError as exc:       # a refined model refused (memory, contact set-up): the fit so far stays
            rounds[-1].update(status="skipped", why=str(exc))
            echo(f"discretisation control at the fitted values: {exc}; the fit so far is reported")
            break
        current = decision.factors
    return outcome


def _refit(config, fit: Fit, store: RunStore, progress, echo, outcome, decision, mu, window, row: dict):
    """The fit continued from ``outcome`` on ``decision``'s refined model; ``fit`` switched to it."""
    begun, obs, solver = time.perf_counter(), fit.setup.observations, config.solver
    contact = checked_contact(decision.model, config.where, echo, solver.sliding)
    memo = refit_at_fitted.StoredEstimate(store, mu)
    fine = memo.values("refined " + refit_at_fitted.phase(decision.options),        # kept: the refit condenses it
                       lambda: values(decision.model, obs, mu, window, keep=True, factorisation=solver.factorisation))
    left, row["check_refined"] = decision.remaining_of(fine, obs)
    setup = replace(fit.setup, model=decision.model, model_options=decision.options, contact=contact,
                    remaining_error=left)
    backend = make_backend(setup.model, obs.points, obs.quantities, obs.point_regions, solver,
                           f"{config.where}: [solver]", obs.reactions, window)
    executor = make_executor(backend, config.run.workers, config.run.scheduler, config.run.retries,
                             f"{config.where}:")
    evaluator = make_evaluator(backend, obs, setup.parameters,
                               refit_at_fitted.PhaseStore(store, refit_at_fitted.phase(decision.options)),
                               config.identify, executor)
    evaluator.count(fit.evaluator)
    fit.evaluator.close()
    problem = make_least_squares(evaluator, config.identify, recorded(evaluator, store, progress,
                                                                      outcome.n_iterations + 1), outcome.x)
    fit.setup, fit.evaluator, fit.problem = setup, evaluator, problem
    echo(f"refit on the refined model from the fitted values ({setup.model.mesh.n_nodes:,} nodes) ...")
    second = optimise_config(problem, config)
    row.update(refit={"value": dict(zip(setup.parameters.names, map(float, setup.parameters.full(second.x)))),
                      "objective": float(second.objective), "n_iterations": int(second.n_iterations),
                      "status": second.status, "seconds": round(time.perf_counter() - begun, 1)})
    echo(f"refit {second.status}: J={second.objective:.6e} after {second.n_iterations} iterations "
         f"({row['refit']['seconds']:.1f} s)")
    return replace(second, n_iterations=outcome.n_iterations + 1 + second.n_iterations,
                   message=f"{second.message} (refit on the model the discretisation control chose at the fitted "
                           "values)",
                   history_x=np.vstack([outcome.history_x, second.history_x]),
                   history_objective=np.concatenate([outcome.history_objective, second.history_objective]))


def optimise_config(problem: LeastSquares, config: Config) -> OptimiseResult:
    ident = config.identify
    return optimise(problem, ident.method, max_iterations=ident.max_iterations, tol=ident.tol,
                    options=ident.method_options)
