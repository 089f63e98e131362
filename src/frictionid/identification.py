"""identify: a model, measurements and parameters (or a config) in, coefficients with uncertainty out; every
evaluation stored, runs resumable."""

from __future__ import annotations

import hashlib
import json
import logging
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .backends import check_backend, make_backend, solver_options
from .backends.embedded import EmbeddedBackend
from .builders.registry import build_model
from .config import Config, config_from_dict
from .data.measurements import Measurements
from .data.dic.window import choose as choose_window
from .data.sources import data_digest, data_paths, read_sources
from .errors import InputError, SolverError
from .fem import memory
from .fem.locate import PointsOutside
from .fem.points import StrainWindow
from .inverse.evaluator import JACOBIANS, Evaluator
from .inverse.least_squares import ROBUST_WEIGHTS, LeastSquares, OptimiseResult, robust_weights
from .inverse.observations import observations_from
from .inverse.optimisers import check_method, optimise
from .inverse.parameters import Parameters
from .discretisation import check_options, with_model_error
from .discretisation_control import control
from .inverse.adequacy import Adequacy, assess, bias_shift
from .inverse.uncertainty import Uncertainty, at_bounds, estimate, systematic_error
from .model import Model
from .paths import check_folder, input_files
from .model_checks import checked_contact, model_line
from .prefit import Prefit, prefit
from .report.outputs import write_outputs
from .report.vtu import export_fields
from .report.tables import prefit_summary
from .result import IdentificationResult
from .run import multistart, profile, refits
from .run.executor import check_scheduler, make_executor
from .run.store import RunStore

log = logging.getLogger(__name__)

#: the files an identification writes into its run.dir (with its store and the fields/ folder)
RUN_FILES = ("result.json", "history.csv", "convergence.png", "residuals.png", "observations.csv", "report.html",
             "store.sqlite")


@dataclass(frozen=True)
class Setup:
    """Everything an identification needs, built and validated before anything runs; ``model_options`` is the
    [model] table the model was built from ({} for a model given as an object), ``data_file`` the measurement
    file (None for measurements given as an object)."""

    model: object
    observations: object
    parameters: Parameters
    fingerprint: str
    model_options: dict
    data_file: Path | None = None
    frames: tuple = ()
    #: the fit's DIC strain window (:class:`~frictionid.data.dic.window.WindowChoice`), None: none
    window: object = None
    #: how each DIC export was read (format, coordinates, strain measure, points): result.json's ``data.files``
    files: tuple = ()
    #: the contact map checked at model build (:func:`~frictionid.fem.interface.contact_setup`)
    contact: tuple = ()
    #: what the discretisation control did (:mod:`~frictionid.discretisation_control`): result.json's
    #: ``model.discretisation``
    discretisation: dict | None = None


def fingerprint(config: Config, model: Model | None = None, measurements: Measurements | None = None) -> str:
    """Hash of everything that determines forward results: model (its [model] table, or the model's own
    fingerprint when given as an object), data (file bytes, or the content of given measurements),
    observables, solver."""
    data = {k: v for k, v in config.data.items() if k != "file"}
    content = {"model": config.model if model is None else model.fingerprint(), "data": data,
               "data_bytes": data_digest(config.data, config.resolve)
               if measurements is None else measurements.digest(),
               "solver": config.solver, "fixed": config.friction.get("fixed", {}),
               "jacobian": config.identify["jacobian"], "step": config.identify["step"]}
    return hashlib.sha256(json.dumps(content, sort_keys=True, default=str).encode()).hexdigest()


def prepare(config: Config, model: Model | None = None, measurements: Measurements | None = None,
            parameters: Parameters | None = None, echo=lambda text: None) -> Setup:
    """Build the model, read and map the data, validate the parameters and options; a model, measurements or
    parameters given as objects are used instead of the config's [model], data.file and [friction]."""
    with config.naming_keys():
        return _prepare(config, model, measurements, parameters, echo)


def _prepare(config: Config, model, measurements, parameters, echo) -> Setup:
    ident, where = config.identify, config.where
    # types and ranges of every key are config.py's (TYPES, RANGES); the names a key takes, their owners'
    if ident["jacobian"] not in JACOBIANS:
        raise InputError(f"{where}: identify.jacobian = {ident['jacobian']!r} is not one of {list(JACOBIANS)}")
    check_backend(config.solver["backend"], ident["jacobian"], solver_options(config), f"{where}: [solver]",
                  float(ident["step"]))
    check_scheduler(config.run.get("scheduler"), f"{where}:")
    given_model, model_options = model, config.model_options if model is None else {}
    if model is None:
        start = time.perf_counter()
        model = build_model(model_options, f"{where}: [model]")
        echo(model_line(model, config.model.get("builder"), time.perf_counter() - start))
    contact = checked_contact(model, where, echo)
    if parameters is None:
        parameters = Parameters.from_config(model.zone_names, config.friction["zones"], config.friction["bounds"],
                                            config.friction.get("fixed"))
    else:
        parameters = parameters.ordered_as(model.zone_names, f"{where}: parameters")
    _check_identify(config, ident, len(parameters.free_names), list(parameters.free_names))
    multistart.start_points(ident["starts"], parameters.x0, parameters.lower, parameters.upper, int(ident["seed"]),
                            parameters.free_names, f"{where}:")
    profile.profiled_zones(ident["profile"], parameters.free_names, f"{where}:")
    check_options(ident, model_options, f"{where}:")
    memory.limit(config.solver.get("max_memory"), f"{where}: [solver]")
    if ident["model_error"] != "off" and config.solver["backend"] != "embedded":
        raise InputError(f"{where}: identify.model_error = {ident['model_error']!r} needs the embedded "
                         "backend (the estimate refines the embedded model)")
    data_file = data_paths(config.data, config.resolve)[0] if measurements is None else None
    given, frames, relative, specimens, files = measurements, [], {}, {}, []
    window = choose_window(config.data.get("strain_window"), config.data.get("strain_window_shape"), [])
    if measurements is None:
        sources = read_sources(config.data, config.resolve, where, model)
        measurements, frames, relative = sources.measurements, sources.frames, sources.relative
        specimens, window, files = sources.specimens, sources.window, sources.files
        if sources.plane:
            echo(sources.plane)
        for read in files:
            if read["coordinates"].startswith("deformed"):
                echo(f"{read['file']}: coordinates: {read['coordinates']}")
        for frame in frames:
            echo(f"{frame['file']}: {frame['line']}")
        if window.origin == "export header":
            echo(window.lines[0])
    window = window.for_fit(config.data["observables"])
    observations = observations_from(measurements, model, config.data["observables"], config.data["stages"],
                                     config.data.get("noise"), config.data.get("regions"), relative, specimens,
                                     config.data.get("reactions"))
    return Setup(model, observations, parameters, fingerprint(config, given_model, given), model_options,
                 data_file, tuple(frames), window, tuple(files), contact)


def _check_identify(config: Config, ident: dict, n_free: int, free: list[str]) -> None:
    """The [identify] keys that need the number of free zones: prior, loss, the method's options."""
    where, prior = config.where, ident["prior"]
    if prior is not None and not (isinstance(prior, (int, float)) and not isinstance(prior, bool)
                                  or isinstance(prior, list) and len(prior) == n_free
                                  and all(isinstance(v, (int, float)) for v in prior)):
        raise InputError(f"{where}: identify.prior must be a number or a list of {n_free} numbers (one per free "
                         f"zone {free}), got {prior!r}")
    if ident["loss"] not in ROBUST_WEIGHTS or ident["loss"] != "linear" and ident["method"] != "trf":
        raise InputError(f"{where}: identify.loss = {ident['loss']!r} must be one of {sorted(ROBUST_WEIGHTS)}"
                         " (a robust loss only with method = \"trf\")")
    try:
        check_method(ident["method"], dict(ident["options"]), ident["max_iterations"], ident["tol"], n_free)
    except InputError as exc:
        raise InputError(f"{where}: [identify] {exc}") from None


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


def identify(model: Model | dict, measurements: Measurements | str | Path, parameters: Parameters | dict, *,
             observables, stages, noise: dict | None = None, regions: dict | None = None,
             run_dir: str | Path | None = None, resume: bool = False, solver: dict | None = None, workers: int = 1,
             scheduler: str | None = None, progress=None, **options) -> IdentificationResult:
    """Identify the zone coefficients of ``model`` from ``measurements`` (the Python interface; the command line
    runs :func:`identify_config`, and both give the same result.json).

    Parameters
    ----------
    model : Model or dict
        A model object (e.g. from :func:`frictionid.builders.block.block_model_2d`) or a [model] table such as
        ``{"builder": "block2d", "mesh_size": 1.0}``; only a table can be refined (identify.model_error).
    measurements : Measurements, str or Path
        The measured values, or a measurement file (docs/data.md).
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
              "data": {"file": given.source or "(measurements given in memory)" if given else str(measurements),
                       "observables": list(observables), "stages": list(stages), "noise": dict(noise or {}),
                       "regions": dict(regions or {})},
              "solver": dict(solver or {}), "identify": options,
              "run": {"dir": str(run_dir or "(temporary)"), "workers": workers, "scheduler": scheduler}}
    config = config_from_dict(tables, need=("friction", "data", "run") + (("model",) if isinstance(model, dict)
                                                                          else ()), name="identify()")
    echo = progress or (lambda text: None)
    setup = prepare(config, None if isinstance(model, dict) else model, given, parameters, echo)
    if run_dir is not None:
        return identify_config(config, resume, echo=echo, setup=setup)
    with tempfile.TemporaryDirectory(prefix="frictionid-") as folder:
        result = identify_config(replace(config, run={**config.run, "dir": folder}), echo=echo, setup=setup,
                                 write_files=False)
    return replace(result, run_dir=None)


def identify_config(config: Config, resume: bool = False, echo=lambda text: None, on_prefit=None,
                    on_iteration=None, setup: Setup | None = None, write_files: bool = True) -> IdentificationResult:
    """Run (or resume) the identification a config describes; writes result.json and the run's files.

    ``echo(text)`` gets one line per phase (model, condensation, resolution, iterations, model error);
    ``on_prefit(Prefit)`` is called once before fitting with the resolution of the planned data (see
    :mod:`frictionid.prefit`; default: its summary goes to ``echo``), ``on_iteration(iteration, mu, objective,
    evaluator)`` after each iteration with all zones' coefficients mu; ``setup`` is :func:`prepare`'s
    (built here when not given); ``write_files=False`` keeps only the store (no result.json, plots, report).
    """
    run_dir = check_folder(config.resolve(config.run["dir"]), f"{config.where}: run.dir",
                           input_files(config), RUN_FILES if write_files else ())
    setup = setup or prepare(config, echo=echo)
    start = time.perf_counter()
    obs = setup.observations
    max_memory = config.solver.get("max_memory")
    chosen = control(setup.model_options, setup.model, obs, setup.parameters.full(setup.parameters.x0),
                     float(config.identify["refine_target"]), int(config.identify["refine_budget"]), max_memory,
                     echo, strain_window(setup.window, obs), config.solver["backend"])
    contact = setup.contact if chosen.model is setup.model else checked_contact(chosen.model, config.where, echo)
    setup = replace(setup, model=chosen.model, model_options=chosen.options, contact=contact,
                    discretisation=chosen.record)
    if config.solver["backend"] == "embedded":
        log.info(memory.check(setup.model, "model", max_memory, config.solver.get("factorisation", "auto")).line())
        if config.identify["model_error"] != "off":       # refused now rather than after the fit
            memory.check_growth(setup.model, 2, "model error: the model refined by 2", max_memory)
    try:                    # built before the store is opened: bad points leave no store behind
        condensed = time.perf_counter()
        backend = make_backend(config.solver["backend"], setup.model, obs.points, obs.quantities, obs.point_regions,
                               solver_options(config), f"{config.where}: [solver]", obs.reactions,
                               strain_window(setup.window, obs))
    except PointsOutside as exc:
        raise exc.named(obs.point_labels, obs.source) from None
    backend_s = time.perf_counter() - condensed
    echo(f"{config.solver['backend']} backend ready: {obs.n_obs:,} observations at {len(obs.points)} points "
         f"({backend_s:.1f} s{', condensed' if config.solver['backend'] == 'embedded' else ''})")
    executor = make_executor(backend, int(config.run["workers"]), config.run["scheduler"],
                             int(config.run["retries"]), f"{config.where}:")
    try:
        store = RunStore.open(run_dir, config.text, setup.fingerprint, resume)
    except BaseException:
        executor.close()
        raise
    if executor.parallel:
        echo(f"parallel solves: {executor.describe()}")
    evaluator = Evaluator(backend,
                          setup.observations, setup.parameters, store, config.identify["jacobian"],
                          float(config.identify["step"]), float(config.identify["tikhonov"]),
                          config.identify["prior"], float(config.identify["penalty"]), executor=executor)
    progress = _iteration_lines(echo, on_iteration)
    problem = _least_squares(evaluator, setup.parameters, config, store, progress)
    if on_prefit is None:
        def on_prefit(report):
            echo(prefit_summary(report.as_dict()))
    store.set_status("running")
    try:
        result = _finish(config, setup, evaluator, problem, store, run_dir, start, on_prefit, progress, write_files,
                         echo, backend_s)
    finally:
        evaluator.close()
    return IdentificationResult(result, run_dir if write_files else None)


def _iteration_lines(echo, on_iteration=None):
    """The optimiser's callback: one line per iteration with the objective, the step and the coefficients to
    ``echo``, then ``on_iteration``."""
    previous = {}

    def progress(iteration, mu, objective, evaluator):
        if on_iteration is not None:
            on_iteration(iteration, mu, objective, evaluator)
        step = "" if "mu" not in previous else f"  step={np.max(np.abs(mu - previous['mu'])):.2e}"
        previous["mu"] = np.array(mu)
        values = "  ".join(f"{name}={value:.4f}" for name, value in zip(evaluator.params.names, mu))
        echo(f"iter {iteration:3d}  J={objective:.6e}{step}  {values}  (solves {evaluator.n_forward} + "
             f"{evaluator.n_sensitivity} with sensitivities, {evaluator.n_replayed} replayed)")
    return progress


def _finish(config, setup, evaluator: Evaluator, problem: LeastSquares, store: RunStore, run_dir: Path,
            start: float, on_prefit, progress, write_files: bool = True, echo=lambda text: None,
            backend_s: float | None = None) -> dict:
    """Check the resolution, optimise, then write the result; an interruption or a solver failure still
    leaves result.json (with ``write_files``; the store keeps the result either way)."""
    try:
        factory = EmbeddedBackend if evaluator.backend.has_sensitivities else None
        report = prefit(evaluator, setup.model, float(config.identify["resolution"]),
                        int(config.identify["suggestions"]), factory)
        on_prefit(report)
        outcome, starts = _optimise_starts(problem, config, setup, evaluator, store, echo)
        error = None
        if config.identify["model_error"] != "off":
            echo(f"fit {outcome.status}; model error: the model refined by 2 at the start and the fitted point ...")
            error, outcome = _with_model_error(config, setup, evaluator, store, progress, outcome)
            echo(f"model error: RMS {error.summary['all']['rms']:.3g} noise levels, largest "
                 f"{error.summary['all']['max']:.3g} ({error.seconds:.1f} s)")
    except KeyboardInterrupt:
        _stopped(config, setup, evaluator, store, run_dir, "interrupted",
                 "stopped by the user; continue with --resume", time.perf_counter() - start, write_files)
        raise
    except SolverError as exc:
        _stopped(config, setup, evaluator, store, run_dir, "failed", str(exc), time.perf_counter() - start,
                 write_files)
        raise
    result = _result(config, setup, evaluator, problem, outcome, report, time.perf_counter() - start, error)
    held = refits.HeldRefits(evaluator, setup.parameters, store, config.identify,
                             lambda problem: _optimise(problem, config))
    held.check_bounds(result, echo)
    if starts:
        result["starts"] = starts
    zones = profile.profiled_zones(config.identify["profile"], setup.parameters.free_names, f"{config.where}:")
    if zones:
        echo(f"profiles of {', '.join(zones)}: {int(config.identify['profile_points'])} refits each ...")
        result["profiles"] = held.profiles(zones, result)
    result["timings"] = solve_timings(store, backend_s)
    store.put_result(result)
    store.set_status(result["status"])
    if write_files:
        write_outputs(run_dir, result, store, config.text, setup.data_file)
        if config.run["fields"]:
            export_fields(evaluator.backend, [result["parameters"][z]["value"] for z in setup.model.zone_names],
                          run_dir / "fields", echo)
    return result


def solve_timings(store: RunStore, backend_s: float | None = None) -> dict:
    """result.json's ``timings``: the backend's set-up time [s] (model condensed, or ccx checked) and, per kind
    of evaluation in the store ("forward", "forward+sensitivities", "held ..."), the count and the wall times [s]
    of its successful solves as measured where they ran (in a worker process with run.workers; replayed
    evaluations keep the time of the run that made them)."""
    walls: dict[str, list[float]] = {}
    for evaluation in store.evaluations():
        if evaluation.status == "ok":
            walls.setdefault(evaluation.kind, []).append(evaluation.wall_time)
    return {"backend_s": None if backend_s is None else float(backend_s),
            "solves": {kind: {"n": len(w), "median_s": float(np.median(w)), "min_s": float(np.min(w)),
                              "max_s": float(np.max(w)), "total_s": float(np.sum(w))}
                       for kind, w in walls.items()}}


def _optimise(problem: LeastSquares, config: Config) -> OptimiseResult:
    ident = config.identify
    return optimise(problem, ident["method"], max_iterations=int(ident["max_iterations"]), tol=float(ident["tol"]),
                    options=dict(ident["options"]))


def _optimise_starts(problem: LeastSquares, config: Config, setup, evaluator: Evaluator, store: RunStore,
                     echo) -> tuple[OptimiseResult, list[dict]]:
    """The fit from the configured start, or with identify.starts the fits from every start (side by side on a
    parallel executor) and the best of them, whose iterations are then stored as the run's; the list of starts
    for result.json ([] for one start)."""
    ident, params = config.identify, setup.parameters
    points = multistart.start_points(ident["starts"], params.x0, params.lower, params.upper, int(ident["seed"]),
                                     params.free_names)
    if len(points) == 1 and np.array_equal(points[0], params.x0):
        return _optimise(problem, config), []
    echo(f"{len(points)} starts ({evaluator.executor.describe()})")

    def optimise_from(k, x0):
        lines = _iteration_lines(lambda text: echo(f"start {k + 1}: {text}"))
        quiet = replace(problem, x0=x0, progress=lambda i, x, objective: lines(i, params.full(x), objective,
                                                                              evaluator))
        return _optimise(quiet, config)

    evaluator.executor.start()
    runs = multistart.run_starts(points, optimise_from, evaluator.executor.parallel)
    chosen = multistart.best(runs)
    for i, (x, objective) in enumerate(zip(chosen.outcome.history_x, chosen.outcome.history_objective)):
        store.record_iteration(i, x, objective)
    echo(f"best: start {chosen.index + 1} of {len(points)}, J={chosen.outcome.objective:.6e}")
    return chosen.outcome, multistart.summary(runs, chosen, params.full, params.names)


def _with_model_error(config, setup, evaluator: Evaluator, store: RunStore, progress, outcome: OptimiseResult):
    """The discretisation error along the fit, and with "include" the refit (:func:`~.discretisation.
    with_model_error`); the refit's iterations are stored after the fit's."""
    def refit(x0, offset):
        return _optimise(_least_squares(evaluator, setup.parameters, config, store, progress, offset, x0), config)

    try:
        return with_model_error(evaluator, setup.parameters, setup.model_options, setup.model, outcome,
                                config.identify["model_error"], refit, config.solver.get("max_memory"))
    except InputError as exc:       # after the fit: stored as a failed run, the fit kept (_stopped)
        raise SolverError(str(exc)) from None


def _stopped(config, setup, evaluator: Evaluator, store: RunStore, run_dir: Path, status: str, message: str,
             wall: float, write_files: bool = True) -> None:
    """result.json of a run that did not finish: the last stored iterate, the counts, the reason."""
    iterations = store.iterations()
    x = iterations[-1].x if iterations else setup.parameters.x0
    mu = setup.parameters.full(np.asarray(x))
    result = {"status": status, "message": message, "method": config.identify["method"],
              "jacobian": config.identify["jacobian"], "backend": config.solver["backend"],
              "parameters": {p.name: {"value": float(v), "initial": p.value, "fixed": not p.vary,
                                      **({"bounds": [p.min, p.max]} if p.vary else {})}
                             for p, v in zip(setup.parameters.items, mu)},
              "n_iterations": len(iterations) - 1 if iterations else 0, "n_forward_solves": evaluator.n_forward,
              "n_sensitivity_solves": evaluator.n_sensitivity, "n_replayed": evaluator.n_replayed,
              "wall_time_s": wall}
    store.set_status(status, message)
    store.put_result(result)
    if write_files:
        write_outputs(run_dir, result, store, config.text, setup.data_file)


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
            entry.update(value=float(outcome.x[k]), bounds=[p.min, p.max],
                         stderr=None if np.isnan(stderr) else float(stderr),
                         ci95=None if np.isnan(stderr) else [float(v) for v in unc.ci95[k]],
                         at_bound=bool(unc.at_bound[k]), identifiable=bool(unc.identifiable[k]))
            if why[k]:
                entry["why"] = why[k]
            if stats.systematic is not None:
                entry["stderr_systematic"] = float(stats.systematic[k])
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
        "model": {**setup.model_options, "contact": [entry.as_dict() for entry in setup.contact],
                  "discretisation": setup.discretisation},
        "data": data_section(setup.frames, obs, setup.window, setup.files),
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


def data_section(frames, obs, window=None, files=()) -> dict:
    """result.json's ``data``: the frame of each file that has one (given or fitted, with its residual), the
    reference points displacements are fitted relative to ([data] relative_to), the strain window of the fit
    (size, shape, origin: [data] strain_window or the exports' headers with their pixel sizes) and how each DIC
    export was read (``files``: format, stage, coordinates as written or converted from deformed positions,
    strain measure, rows, valid points, dropped rows by reason)."""
    minus = np.full(obs.n_obs, -1) if obs.minus_row is None else obs.minus_row
    n_quantities = max(len(obs.quantities), 1)
    return {"frames": [{k: v for k, v in f.items() if k != "line"} for f in frames],
            "relative_to": sorted({obs.point_labels[m // n_quantities] for m in minus[minus >= 0]}),
            **({} if window is None else {"strain_window": window.as_dict()}), "files": list(files)}


def strain_window(window, obs=None) -> StrainWindow | None:
    """The backend's window from a setup's choice (None: strains at the points), built for the rows ``obs``
    (:class:`~frictionid.inverse.observations.Observations`) fits: a point observes only the strains its file
    gives (a face's in-plane components), and only those need the window to span their gradient."""
    if window is None or window.size is None:
        return None
    if obs is None:
        return StrainWindow(window.size, window.shape)
    relative = () if obs.minus_row is None else obs.minus_row[obs.minus_row >= 0]
    return StrainWindow(window.size, window.shape, tuple(np.concatenate([obs.row, relative]).astype(int).tolist()))


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
    #: (n_free,) systematic standard error in the uncertainty (model error included), None otherwise
    systematic: np.ndarray | None = None


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
    model = getattr(evaluator.backend, "model", None)
    adequacy = assess(r, jac, obs.labels, obs.y, evaluator.model_values(x), obs.noise_known, inner=inner,
                      sigma=obs.sigma, regions=dict(zip(obs.point_labels, obs.point_regions)),
                      model_kind=getattr(model, "kind", None))
    shift = systematic = None
    if error is not None and error.signed is not None:
        shift = bias_shift(jac, np.sqrt(weights) * obs.weight * error.signed, inner)
        if error.before is not None:                   # "include": the error's effect is part of the interval
            systematic = systematic_error(shift, error.scale, error.before, x)
    unc = estimate(jac, r, x, params.lower, params.upper, obs.noise_known, resolution, params.free_names, adequacy,
                   shift, systematic)
    return FitStatistics(r, evaluator.model_values(x), weights, adequacy, unc, shift, systematic)


def point_misfit(obs, r: np.ndarray) -> list[dict]:
    """Per measurement point: its label, model coordinates [mm] and RMS weighted residual (noise units)."""
    index = {label: i for i, label in enumerate(obs.point_labels)}
    point = np.array([index.get(label.rpartition(":")[0], -1) for label in obs.labels], dtype=np.int64)
    seen = point >= 0                                   # the machine force ("force@2") belongs to no point
    count = np.bincount(point[seen], minlength=len(index))
    total = np.bincount(point[seen], weights=np.asarray(r, dtype=float)[seen] ** 2, minlength=len(index))
    return [{"point": label, "xyz": [float(v) for v in xyz], "rms": float(np.sqrt(total[i] / count[i]))}
            for i, (label, xyz) in enumerate(zip(obs.point_labels, obs.points)) if count[i]]


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
