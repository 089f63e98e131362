"""identify: a model, measurements and parameters (or a config) in, coefficients with uncertainty out; every
evaluation stored, runs resumable."""

from __future__ import annotations

import logging
import tempfile
import time
from dataclasses import replace
from functools import partial
from pathlib import Path


from .backends import make_backend
from .backends.embedded import holds
from .config import Config, config_from_dict
from .data.measurements import Measurements
from .errors import InputError, SolverError
from .fem import memory
from .fem.locate import PointsOutside
from .fitted_control import Fit, optimise_config, refine_at_fitted
from .inverse.evaluator import Evaluator
from .inverse import multistart, profile, refits
from .inverse.discretisation import ESTIMATING, used_mode, with_model_error
from .inverse.discretisation_control import control
from .inverse.fitting import make_evaluator, make_least_squares, recorded
from .inverse.least_squares import OptimiseResult
from .inverse.parameters import Parameters
from .inverse.prefit import prefit
from .model import Model
from .model_checks import checked_contact
from .paths import check_folder, input_files
from .preparation import Setup, prepare, strain_window
from .progress import iteration_lines
from .report.outputs import write_outputs
from .report.tables import prefit_summary
from .report.vtu import export_fields
from .result import IdentificationResult, fit_result, solve_timings, stopped_result
from .run.executor import make_executor
from .run.store import RunStore

log = logging.getLogger(__name__)

#: the files an identification writes into its run.dir (with its store and the fields/ folder)
RUN_FILES = ("result.json", "history.csv", "convergence.png", "residuals.png", "observations.csv", "report.html",
             "store.sqlite")


def identify(model: Model | dict, measurements: Measurements | str | Path | list, parameters: Parameters | dict, *,
             observables, stages, noise: dict | None = None, regions: dict | None = None,
             run_dir: str | Path | None = None, resume: bool = False, solver: dict | None = None, workers: int = 1,
             scheduler: str | None = None, fields: bool = True, progress=None, **options) -> IdentificationResult:
    """Identify the zone coefficients of ``model`` from ``measurements`` (the Python interface; the command line
    runs :func:`identify_config`, and both give the same result.json).

    Parameters
    ----------
    model : Model or dict
        A model object (e.g. from :func:`frictionid.builders.block.block_model_2d`) or a [model] table such as
        ``{"builder": "block2d", "mesh_size": 1.0}``; only a table can be refined (identify.model_error).
    measurements : Measurements, str, Path or list
        The measured values, or a measurement file (docs/data.md), or a list of files or file tables as
        ``[data] file`` takes them (docs/config.md: one per stage, view or specimen).
    parameters : Parameters or dict
        Start values, bounds and held zones; a dict zone -> start value means bounds [0, 1] and no held zone.
    observables, stages, noise, regions
        As the [data] keys of a config (docs/config.md).
    run_dir : str or Path, optional
        Folder of the run: its store (so that ``resume=True`` continues an interrupted run), result.json,
        history, plots and report.html. Default: none is kept (the store lives in a temporary folder).
    solver : dict, optional
        The [solver] table (default: the embedded backend).
    workers : int
        Parallel evaluations (run.workers).
    scheduler : str, optional
        A Dask cluster for them (run.scheduler): "local" or "tcp://host:port".
    fields : bool
        Write the fields of the final solve into ``run_dir``/fields/ (run.fields; with a run_dir only).
    progress : callable, optional
        ``progress(text)`` gets one line per phase and iteration; default quiet.
    **options
        [identify] keys: method, jacobian, max_iterations, tol, loss, model_error, ... (docs/config.md).

    Returns
    -------
    IdentificationResult

    Examples
    --------
    >>> from frictionid import Parameter, Parameters, identify
    >>> params = Parameters([Parameter("A", 0.1, max=0.6), Parameter("B", 0.1)])
    >>> result = identify({"builder": "block2d"}, "measured.csv", params, observables=["ux", "uy"],
    ...                   stages=[2], noise={"u": 5e-4})  # doctest: +SKIP
    >>> print(result.fit_report())  # doctest: +SKIP
    """
    if isinstance(parameters, dict):
        parameters = Parameters.from_dict(parameters)
    if not isinstance(parameters, Parameters):
        raise InputError(f"identify(): parameters must be Parameters or a dict zone -> start value, got "
                         f"{type(parameters).__name__}")
    given = measurements if isinstance(measurements, Measurements) else None
    tables = {"model": model if isinstance(model, dict) else {},
              "friction": {"zones": {p.name: p.value for p in parameters.items if p.vary},
                           "fixed": {p.name: p.value for p in parameters.items if not p.vary},
                           "bounds": {p.name: [p.min, p.max] for p in parameters.items if p.vary}},
              "data": {"file": given.source or "(measurements given in memory)" if given else
                       [m if isinstance(m, dict) else str(m) for m in measurements] if isinstance(measurements, list)
                       else str(measurements),
                       "observables": list(observables), "stages": list(stages), "noise": dict(noise or {}),
                       "regions": dict(regions or {})},
              "solver": dict(solver or {}), "identify": options,
              "run": {"dir": str(run_dir or "(temporary)"), "workers": workers, "scheduler": scheduler,
                      "fields": fields}}
    config = config_from_dict(tables, need=("friction", "data", "run") + (("model",) if isinstance(model, dict)
                                                                          else ()), name="identify()")
    echo = progress or (lambda text: None)
    setup = prepare(config, None if isinstance(model, dict) else model, given, parameters, echo)
    if run_dir is not None:
        return identify_config(config, resume, echo=echo, setup=setup)
    with tempfile.TemporaryDirectory(prefix="frictionid-") as folder:
        result = identify_config(replace(config, run=config.run.with_values(dir=folder)), echo=echo, setup=setup,
                                 write_files=False)
    return replace(result, run_dir=None)


def identify_config(config: Config, resume: bool = False, echo=lambda text: None, on_prefit=None,
                    on_iteration=None, setup: Setup | None = None, write_files: bool = True) -> IdentificationResult:
    """Run (or resume) the identification a config describes; writes result.json and the run's files.

    ``echo(text)`` gets one line per phase (model, condensation, resolution, iterations, model error);
    ``on_prefit(Prefit)`` is called once before fitting with the resolution of the planned data (see
    :mod:`frictionid.inverse.prefit`; default: its summary goes to ``echo``), ``on_iteration(iteration, mu, objective,
    evaluator)`` after each iteration with all zones' coefficients mu; ``setup`` is :func:`prepare`'s
    (built here when not given); ``write_files=False`` keeps only the store (no result.json, plots, report).
    """
    run_dir = check_folder(config.resolve(config.run.dir), f"{config.where}: run.dir",
                           input_files(config), RUN_FILES if write_files else ())
    setup = setup or prepare(config, echo=echo)
    start = time.perf_counter()
    obs = setup.observations
    max_memory = config.solver.max_memory
    if config.solver.backend == "embedded" and holds(setup.model, obs.points, obs.quantities, obs.point_regions,
                                                     strain_window(setup.window, obs), config.solver.factorisation,
                                                     config.solver.sliding):
        log.info("model: its condensation is held from an earlier run of this session; nothing more to estimate")
    elif config.solver.backend == "embedded":   # before the discretisation control, which condenses the model
        log.info(memory.check(setup.model, "model", max_memory, config.solver.factorisation).line())
    chosen = control(setup.model_options, setup.model, obs, setup.parameters.full(setup.parameters.x0),
                     config.identify.refine_target, config.identify.refine_budget, max_memory,
                     echo, strain_window(setup.window, obs), config.solver.backend, config.solver.factorisation)
    sliding = config.solver.sliding
    contact = setup.contact if chosen.model is setup.model else checked_contact(chosen.model, config.where, echo,
                                                                                   sliding)
    refined = chosen.model is not setup.model
    given = (setup.model_options, setup.model) if chosen.record.get("factors") else None
    setup = replace(setup, model=chosen.model, model_options=chosen.options, contact=contact,
                    discretisation=chosen.record, remaining_error=chosen.remaining)
    if config.solver.backend == "embedded":
        if refined:     # the control checked this model against max_memory when it chose it; a second check a
            # moment later sees only the process's resident memory drift (and refused its choice by 0.2 GB)
            log.info(memory.estimate(setup.model, "model (checked by the discretisation control)", max_memory,
                                     config.solver.factorisation, scale=chosen.record["memory_scale"]).line())
        if config.identify.model_error in ESTIMATING and setup.remaining_error is None:  # refused now, not after
            memory.check_growth(setup.model, 2, "model error: the model refined by 2", max_memory)
    try:                    # built before the store is opened: bad points leave no store behind
        condensed = time.perf_counter()
        backend = make_backend(setup.model, obs.points, obs.quantities, obs.point_regions, config.solver,
                               f"{config.where}: [solver]", obs.reactions,
                               strain_window(setup.window, obs))
    except PointsOutside as exc:
        raise exc.named(obs.point_labels, obs.source) from None
    backend_s = time.perf_counter() - condensed
    echo(f"{config.solver.backend} backend ready: {obs.n_obs:,} observations at {len(obs.points)} points "
         f"({backend_s:.1f} s{', condensed' if config.solver.backend == 'embedded' else ''})")
    executor = make_executor(backend, config.run.workers, config.run.scheduler,
                             config.run.retries, f"{config.where}:")
    try:
        store = RunStore.open(run_dir, config.text, setup.fingerprint, resume)
    except BaseException:
        executor.close()
        raise
    if executor.parallel:
        echo(f"parallel solves: {executor.describe()}")
    evaluator = make_evaluator(backend, setup.observations, setup.parameters, store, config.identify, executor)
    progress = iteration_lines(echo, on_iteration)
    problem = make_least_squares(evaluator, config.identify, recorded(evaluator, store, progress), stick_floor=True)
    if on_prefit is None:
        def on_prefit(report):
            echo(prefit_summary(report.as_dict()))
    store.set_status("running")
    fit = Fit(setup, evaluator, problem, given)
    try:
        result = _finish(config, fit, store, run_dir, start, on_prefit, progress, write_files, echo, backend_s)
    finally:
        fit.evaluator.close()
    return IdentificationResult(result, run_dir if write_files else None)


def _finish(config, fit: Fit, store: RunStore, run_dir: Path, start: float, on_prefit, progress,
            write_files: bool = True, echo=lambda text: None, backend_s: float | None = None) -> dict:
    """Check the resolution, optimise, refit where the control at the fitted values asks for a finer model, then
    write the result; an interruption or a solver failure still leaves result.json (with ``write_files``; the
    store keeps the result either way)."""
    setup, evaluator, problem = fit.setup, fit.evaluator, fit.problem
    try:
        factory = (partial(make_backend, solver=config.solver)    # the embedded backend, [solver] as configured
                   if evaluator.backend.has_sensitivities else None)
        report = prefit(evaluator, setup.model, config.identify.resolution,
                        config.identify.suggestions, factory)
        on_prefit(report)
        outcome, starts = multistart.optimise_starts(problem, lambda problem: optimise_config(problem, config),
                                                     evaluator, store, config.identify.starts, config.identify.seed,
                                                     iteration_lines, echo)
        outcome = refine_at_fitted(config, fit, store, progress, echo, outcome)
        setup, evaluator, problem = fit.setup, fit.evaluator, fit.problem
        error, mode = None, used_mode(config.identify.model_error, setup.remaining_error, setup.discretisation)
        if config.identify.model_error == "auto":
            echo(f"model error: {mode[0]}: {mode[1]}")
        if mode[0] != "off":
            echo(f"fit {outcome.status}; model error: " + ("the discretisation control's prediction for the fitted "
                 "model" if setup.remaining_error is not None else "the model refined by 2 at the start and the "
                 "fitted point") + " ...")
            error, outcome = _with_model_error(config, setup, evaluator, store, progress, outcome, mode[0])
            echo(f"model error: RMS {error.summary['all']['rms']:.3g} noise levels, largest "
                 f"{error.summary['all']['max']:.3g} ({error.seconds:.1f} s)")
        check_sliding = getattr(evaluator.backend, "check_sliding", None)
        if check_sliding is not None:   # the answer within small sliding (its trial points were solved unchecked)
            check_sliding(setup.parameters.full(outcome.x))
    except KeyboardInterrupt:
        _stopped(config, fit.setup, fit.evaluator, store, run_dir, "interrupted",
                 "stopped by the user; continue with --resume", time.perf_counter() - start, write_files)
        raise
    except SolverError as exc:
        _stopped(config, fit.setup, fit.evaluator, store, run_dir, "failed", str(exc), time.perf_counter() - start,
                 write_files)
        raise
    result = fit_result(config, setup, evaluator, problem, outcome, report, time.perf_counter() - start, error, mode)
    held = refits.HeldRefits(evaluator, setup.parameters, evaluator.store, config.identify,
                             lambda problem: optimise_config(problem, config))
    held.check_bounds(result, echo)
    if starts:
        result["starts"] = starts
    zones = profile.profiled_zones(config.identify.profile, setup.parameters.free_names, f"{config.where}:")
    if zones:
        echo(f"profiles of {', '.join(zones)}: {config.identify.profile_points} refits each ...")
        result["profiles"] = held.profiles(zones, result)
    result["timings"] = solve_timings(store, backend_s)
    store.put_result(result)
    store.set_status(result["status"])
    if write_files:
        write_outputs(run_dir, result, store, config.text, setup.data_file)
        if config.run.fields:
            export_fields(evaluator.backend, [result["parameters"][z]["value"] for z in setup.model.zone_names],
                          run_dir / "fields", echo)
    return result


def _with_model_error(config, setup, evaluator: Evaluator, store: RunStore, progress, outcome: OptimiseResult,
                      mode: str):
    """The discretisation error along the fit, and with "include" the refit (:func:`~.inverse.discretisation.
    with_model_error`); the refit's iterations are stored after the fit's."""
    def refit(x0, offset):
        return optimise_config(make_least_squares(evaluator, config.identify,
                                                  recorded(evaluator, store, progress, offset), x0), config)

    try:
        return with_model_error(evaluator, setup.parameters, setup.model_options, setup.model, outcome,
                                mode, refit, config.solver.max_memory,
                                remaining=setup.remaining_error)
    except InputError as exc:       # after the fit: stored as a failed run, the fit kept (_stopped)
        raise SolverError(str(exc)) from None


def _stopped(config, setup, evaluator: Evaluator, store: RunStore, run_dir: Path, status: str, message: str,
             wall: float, write_files: bool = True) -> None:
    """Store (and with ``write_files`` write) the result.json of a run that did not finish."""
    result = stopped_result(config, setup, evaluator, store.iterations(), status, message, wall)
    store.set_status(status, message)
    store.put_result(result)
    if write_files:
        write_outputs(run_dir, result, store, config.text, setup.data_file)



