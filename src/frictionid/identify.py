"""identify: a config in, coefficients with uncertainty out; every evaluation stored, runs resumable."""

from __future__ import annotations

import hashlib
import json
import logging
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .backends import check_backend, make_backend, solver_options
from .backends.embedded import EmbeddedBackend
from .builders.registry import build_model
from .config import Config
from .data.measurements import read_measurements
from .errors import InputError, SolverError
from .fem.points import PointsOutside
from .inverse.evaluator import JACOBIANS, Evaluator
from .inverse.least_squares import ROBUST_WEIGHTS, LeastSquares, OptimiseResult, robust_weights
from .inverse.observations import observations_from
from .inverse.optimisers import check_method, optimise
from .inverse.parameters import Parameters
from .discretisation import check_options, refine_until, with_model_error
from .inverse.adequacy import Adequacy, assess, bias_shift
from .inverse.uncertainty import Uncertainty, at_bounds, estimate
from .prefit import Prefit, prefit
from .report.outputs import write_outputs
from .run.store import RunStore

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Setup:
    """Everything an identification needs, built and validated from a config before anything runs."""

    model: object
    observations: object
    parameters: Parameters
    fingerprint: str
    model_options: dict


def fingerprint(config: Config) -> str:
    """Hash of everything that determines forward results: model, data (file bytes), observables, solver."""
    data_file = config.resolve(config.data["file"])
    content = {"model": config.model, "data": {k: v for k, v in config.data.items() if k != "file"},
               "data_bytes": hashlib.sha256(data_file.read_bytes()).hexdigest(),
               "solver": config.solver, "fixed": config.friction.get("fixed", {}),
               "jacobian": config.identify["jacobian"], "step": config.identify["step"]}
    return hashlib.sha256(json.dumps(content, sort_keys=True, default=str).encode()).hexdigest()


def prepare(config: Config) -> Setup:
    """Build the model, read and map the data, validate the parameters and options."""
    ident = config.identify
    if ident["jacobian"] not in JACOBIANS:
        raise InputError(f"{config.path}: identify.jacobian = {ident['jacobian']!r} is not one of {list(JACOBIANS)}")
    check_backend(config.solver["backend"], ident["jacobian"], solver_options(config), f"{config.path}: [solver]",
                  float(ident["step"]))
    if not float(ident["resolution"]) > 0 or int(ident["suggestions"]) < 0:
        raise InputError(f"{config.path}: identify.resolution must be > 0 and identify.suggestions >= 0, got "
                         f"{ident['resolution']!r} and {ident['suggestions']!r}")
    if int(config.run["workers"]) < 1:
        raise InputError(f"{config.path}: run.workers must be at least 1, got {config.run['workers']}")
    if config.run.get("scheduler"):
        raise InputError(f"{config.path}: run.scheduler (a Dask cluster) is not available yet; use run.workers "
                         "for parallel evaluations on this machine")
    model = build_model(config.model)
    parameters = Parameters.from_config(model.zone_names, config.friction["zones"], config.friction["bounds"],
                                        config.friction.get("fixed"))
    prior = config.identify["prior"]
    if prior is not None and not (isinstance(prior, (int, float)) and not isinstance(prior, bool)
                                  or isinstance(prior, list) and len(prior) == len(parameters.free_names)
                                  and all(isinstance(v, (int, float)) for v in prior)):
        raise InputError(f"{config.path}: identify.prior must be a number or a list of "
                         f"{len(parameters.free_names)} numbers (one per free zone {list(parameters.free_names)}), "
                         f"got {prior!r}")
    if ident["loss"] not in ROBUST_WEIGHTS or ident["loss"] != "linear" and ident["method"] != "trf":
        raise InputError(f"{config.path}: identify.loss = {ident['loss']!r} must be one of {sorted(ROBUST_WEIGHTS)}"
                         " (a robust loss only with method = \"trf\")")
    if not float(ident["loss_scale"]) > 0:
        raise InputError(f"{config.path}: identify.loss_scale must be > 0, got {ident['loss_scale']!r}")
    try:
        check_method(ident["method"], dict(ident["options"]), ident["max_iterations"], ident["tol"],
                     len(parameters.free_names))
    except InputError as exc:
        raise InputError(f"{config.path}: [identify] {exc}") from None
    check_options(ident, config.model, f"{config.path}:")
    if ident["model_error"] != "off" and config.solver["backend"] != "embedded":
        raise InputError(f"{config.path}: identify.model_error = {ident['model_error']!r} needs the embedded "
                         "backend (the estimate refines the embedded model)")
    measurements = read_measurements(config.resolve(config.data["file"]))
    observations = observations_from(measurements, model, config.data["observables"], config.data["stages"],
                                     config.data.get("noise"), config.data.get("regions"))
    return Setup(model, observations, parameters, fingerprint(config), dict(config.model))


def _least_squares(evaluator: Evaluator, parameters: Parameters, config: Config, store: RunStore,
                   progress, offset: int = 0, x0=None) -> LeastSquares:
    """The problem the optimiser sees; its iterations are stored and shown numbered from ``offset`` (a refit
    continues the numbers of the fit before it) and it starts at ``x0`` (default the configured start)."""
    done = {row["iteration"] for row in store.iterations()}

    def on_iteration(iteration, x, objective):
        iteration += offset
        if iteration not in done:
            store.record_iteration(iteration, x, objective)
            done.add(iteration)
        progress(iteration, parameters.full(x), objective, evaluator)

    return LeastSquares(evaluator.residuals, evaluator.jacobian, parameters.x0 if x0 is None else x0, parameters.lower,
                        parameters.upper, parameters.free_names, float(config.identify["power"]), on_iteration,
                        evaluator.obs.noise_known, config.identify["loss"], float(config.identify["loss_scale"]))


def identify(config: Config, resume: bool = False, progress=lambda *args: None, on_prefit=lambda report: None) -> dict:
    """Run (or resume) the identification a config describes; returns and writes result.json.

    ``progress(iteration, mu, objective, evaluator)`` is called after each iteration, ``on_prefit(Prefit)``
    once before fitting with the resolution of the planned data (see :mod:`frictionid.prefit`).
    """
    setup = prepare(config)
    run_dir = config.resolve(config.run["dir"])
    start = time.perf_counter()
    obs = setup.observations
    if float(config.identify["refine_target"]) > 0:
        options, model, _ = refine_until(setup.model_options, setup.model, obs, setup.parameters.full(setup.parameters.x0),
                                         float(config.identify["refine_target"]), int(config.identify["refine_budget"]))
        setup = replace(setup, model=model, model_options=options)
    try:                    # built before the store is opened: bad points leave no store behind
        backend = make_backend(config.solver["backend"], setup.model, obs.points, obs.quantities, obs.point_regions,
                               solver_options(config), f"{config.path}: [solver]", obs.reactions)
    except PointsOutside as exc:
        raise exc.named(obs.point_labels, obs.source) from None
    store = RunStore.open(run_dir, config.text, setup.fingerprint, resume)
    evaluator = Evaluator(backend,
                          setup.observations, setup.parameters, store, config.identify["jacobian"],
                          float(config.identify["step"]), float(config.identify["tikhonov"]),
                          config.identify["prior"], float(config.identify["penalty"]), int(config.run["workers"]))
    problem = _least_squares(evaluator, setup.parameters, config, store, progress)
    store.set_status("running")
    try:
        return _finish(config, setup, evaluator, problem, store, run_dir, start, on_prefit, progress)
    finally:
        evaluator.close()


def _finish(config, setup, evaluator: Evaluator, problem: LeastSquares, store: RunStore, run_dir: Path,
            start: float, on_prefit, progress) -> dict:
    """Check the resolution, optimise, then write the result; an interruption or a solver failure still
    leaves result.json."""
    try:
        factory = EmbeddedBackend if evaluator.backend.has_sensitivities else None
        report = prefit(evaluator, setup.model, float(config.identify["resolution"]),
                        int(config.identify["suggestions"]), factory)
        on_prefit(report)
        outcome = _optimise(problem, config)
        error = None
        if config.identify["model_error"] != "off":
            error, outcome = _with_model_error(config, setup, evaluator, store, progress, outcome)
    except KeyboardInterrupt:
        _stopped(config, setup, evaluator, store, run_dir, "interrupted",
                 "stopped by the user; continue with --resume", time.perf_counter() - start)
        raise
    except SolverError as exc:
        _stopped(config, setup, evaluator, store, run_dir, "failed", str(exc), time.perf_counter() - start)
        raise
    result = _result(config, setup, evaluator, problem, outcome, report, time.perf_counter() - start, error)
    store.put_result(result)
    store.set_status(result["status"])
    write_outputs(run_dir, result, store, config.text, config.resolve(config.data["file"]))
    return result


def _optimise(problem: LeastSquares, config: Config) -> OptimiseResult:
    ident = config.identify
    return optimise(problem, ident["method"], max_iterations=int(ident["max_iterations"]), tol=float(ident["tol"]),
                    options=dict(ident["options"]))


def _with_model_error(config, setup, evaluator: Evaluator, store: RunStore, progress, outcome: OptimiseResult):
    """The discretisation error along the fit, and with "include" the refit (:func:`~.discretisation.
    with_model_error`); the refit's iterations are stored after the fit's."""
    def refit(x0, offset):
        return _optimise(_least_squares(evaluator, setup.parameters, config, store, progress, offset, x0), config)

    return with_model_error(evaluator, setup.parameters, setup.model_options, setup.model, outcome,
                            config.identify["model_error"], refit)


def _stopped(config, setup, evaluator: Evaluator, store: RunStore, run_dir: Path, status: str, message: str,
             wall: float) -> None:
    """result.json of a run that did not finish: the last stored iterate, the counts, the reason."""
    iterations = store.iterations()
    x = iterations[-1].x if iterations else setup.parameters.x0
    mu = setup.parameters.full(np.asarray(x))
    result = {"status": status, "message": message, "method": config.identify["method"],
              "jacobian": config.identify["jacobian"], "backend": config.solver["backend"],
              "parameters": {p.name: {"value": float(v), "initial": p.value, "fixed": not p.vary}
                             for p, v in zip(setup.parameters.items, mu)},
              "n_iterations": len(iterations) - 1 if iterations else 0, "n_forward_solves": evaluator.n_forward,
              "n_sensitivity_solves": evaluator.n_sensitivity, "n_replayed": evaluator.n_replayed,
              "wall_time_s": wall}
    store.set_status(status, message)
    store.put_result(result)
    write_outputs(run_dir, result, store, config.text, config.resolve(config.data["file"]))


def _result(config, setup, evaluator: Evaluator, problem: LeastSquares, outcome: OptimiseResult, report: Prefit,
            wall: float, error=None) -> dict:
    params, obs = setup.parameters, evaluator.obs          # obs.sigma with the model error, if included
    free = list(params.free_names)
    stats = fit_statistics(evaluator, problem, outcome.x, float(config.identify["resolution"]), error)
    r, f, weights, adequacy, unc = stats.r, stats.f, stats.weights, stats.adequacy, stats.uncertainty
    why = contact_reasons(evaluator.backend, params.full(outcome.x), sorted(set(obs.stage.tolist())), free, unc)
    parameters = {}
    for p in params.items:
        entry = {"value": p.value, "initial": p.value, "fixed": not p.vary}
        if p.vary:
            k = free.index(p.name)
            stderr = unc.stderr[k]
            entry.update(value=float(outcome.x[k]), stderr=None if np.isnan(stderr) else float(stderr),
                         ci95=None if np.isnan(stderr) else [float(v) for v in unc.ci95[k]],
                         at_bound=bool(unc.at_bound[k]), identifiable=bool(unc.identifiable[k]))
            if why[k]:
                entry["why"] = why[k]
        parameters[p.name] = entry
    return {
        "status": outcome.status, "message": outcome.message, "method": config.identify["method"],
        "jacobian": config.identify["jacobian"], "backend": config.solver["backend"], "parameters": parameters,
        "objective": {"initial": float(outcome.history_objective[0]), "final": float(outcome.objective)},
        "fit": {"n_obs": obs.n_obs, "chi2": unc.chi2, "dof": unc.dof, "noise_known": obs.noise_known,
                "error_scale": float(np.sqrt(unc.scale)), **adequacy.as_dict(free),
                "loss": problem.loss, "n_downweighted": int(np.sum(weights < 0.5)),
                "rms_residual": float(np.sqrt(np.mean((f - obs.y) ** 2))),
                "points": point_misfit(obs, r),
                "observations": [{"label": label, "measured": float(y), "model": float(v),
                                  "sigma": float(s) if obs.noise_known else None}
                                 for label, y, v, s in zip(obs.labels, obs.y, f, obs.sigma)],
                "model_error": None if error is None else {
                    "mode": config.identify["model_error"], **error.as_dict(),
                    "shift": {name: None if not np.isfinite(v) else float(v)
                              for name, v in zip(free, stats.model_shift)}}},
        "model": setup.model_options,
        "identifiability": {"singular_values": unc.singular_values.tolist(),
                            "directions": {name: unc.directions[i].tolist() for i, name in enumerate(free)},
                            "correlation": np.where(np.isnan(unc.correlation), None, unc.correlation).tolist(),
                            "message": unc.message, "prefit": report.as_dict()},
        "n_iterations": int(outcome.n_iterations), "n_forward_solves": evaluator.n_forward,
        "n_sensitivity_solves": evaluator.n_sensitivity, "n_replayed": evaluator.n_replayed,
        "n_failed_solves": evaluator.n_failed, "wall_time_s": wall,
        "history": {"objective": outcome.history_objective.tolist(),
                    "coefficients": [params.full(x).tolist() for x in outcome.history_x]},
    }


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


def fit_statistics(evaluator: Evaluator, problem: LeastSquares, x: np.ndarray, resolution: float,
                   error=None) -> FitStatistics:
    """Adequacy and uncertainty of the free coefficients x with the evaluator's observations and weights;
    ``error``: the :class:`~frictionid.inverse.model_error.ModelError` estimated for this fit, if any (the
    coefficient shift its signed error causes decides, with the rest, which zones are identifiable)."""
    params, obs = evaluator.params, evaluator.obs
    r = evaluator.residuals(x)[:obs.n_obs]
    jac = evaluator.jacobian(x)[:obs.n_obs]
    # a robust fit is the least-squares fit with the weights it ends with: its statistics are computed so
    weights = robust_weights(r, problem.loss, problem.loss_scale)
    r, jac = np.sqrt(weights) * r, np.sqrt(weights)[:, None] * jac
    inner = ~at_bounds(x, params.lower, params.upper)
    adequacy = assess(r, jac, obs.labels, obs.y, evaluator.model_values(x), obs.noise_known, inner=inner)
    shift = None
    if error is not None and error.signed is not None:
        shift = bias_shift(jac, np.sqrt(weights) * obs.weight * error.signed, inner)
    unc = estimate(jac, r, x, params.lower, params.upper, obs.noise_known, resolution, params.free_names, adequacy,
                   shift)
    return FitStatistics(r, evaluator.model_values(x), weights, adequacy, unc, shift)


def point_misfit(obs, r: np.ndarray) -> list[dict]:
    """Per measurement point: its label, model coordinates [mm] and RMS weighted residual (noise units)."""
    point_of = [label.rpartition(":")[0] for label in obs.labels]
    out = []
    for label, xyz in zip(obs.point_labels, obs.points):
        rows = np.array([p == label for p in point_of])
        if rows.any():
            out.append({"point": label, "xyz": [float(v) for v in xyz],
                        "rms": float(np.sqrt(np.mean(r[rows] ** 2)))})
    return out


#: area fraction below which a zone counts as carrying no load (lifted off) or not slipping (stuck)
_STATE_SHARE = 0.01


def contact_reasons(backend, mu: np.ndarray, stages, free, unc) -> list[str]:
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
