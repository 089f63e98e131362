"""An identification's set-up, built and validated before anything runs: the model, the measurements mapped
to observations, the parameters, the [identify] options that need the model, and the fingerprint of everything
that determines forward results (a resumed run must match it)."""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .backends import check_backend
from .builders.registry import build_model
from .config import Config
from .data.dic.window import choose as choose_window
from .data.measurements import Measurements
from .data.sources import data_digest, data_paths, read_sources
from .errors import InputError
from .fem import memory
from .fem.points import StrainWindow
from .inverse import multistart, profile
from .inverse.discretisation import ESTIMATING, check_options
from .inverse.evaluator import JACOBIANS
from .inverse.least_squares import ROBUST_WEIGHTS
from .inverse.observations import observations_from
from .inverse.optimisers import check_method
from .inverse.parameters import Parameters
from .model import Model
from .model_checks import checked_contact, model_line
from .options import IdentifyOptions, ModelSpec
from .run.executor import check_scheduler


@dataclass(frozen=True)
class Setup:
    """Everything an identification needs, built and validated before anything runs; ``model_options`` is the
    [model] the model was built from (None for a model given as an object), ``data_file`` the measurement
    file (None for measurements given as an object)."""

    model: object
    observations: object
    parameters: Parameters
    fingerprint: str
    model_options: ModelSpec | None
    data_file: Path | None = None
    frames: tuple = ()
    #: the fit's DIC strain window (:class:`~frictionid.data.dic.window.WindowChoice`), None: none
    window: object = None
    #: how each DIC export was read (format, coordinates, strain measure, points): result.json's ``data.files``
    files: tuple = ()
    #: the contact map checked at model build (:func:`~frictionid.fem.interface.contact_setup`)
    contact: tuple = ()
    #: what the discretisation control did (:mod:`~frictionid.inverse.discretisation_control`): result.json's
    #: ``model.discretisation``
    discretisation: dict | None = None
    #: the error the control predicts for the fitted model, per observation
    #: (:class:`~frictionid.inverse.remaining_error.RemainingError`; None when it did not run)
    remaining_error: object = None


def fingerprint(config: Config, model: Model | None = None, measurements: Measurements | None = None) -> str:
    """Hash of everything that determines forward results: model (its [model] table, or the model's own
    fingerprint when given as an object), data (file bytes, or the content of given measurements),
    observables, solver."""
    data = {k: v for k, v in config.data.table().items() if k != "file"}
    content = {"model": config.model.table() if model is None else model.fingerprint(), "data": data,
               "data_bytes": data_digest(config.data, config.resolve)
               if measurements is None else measurements.digest(),
               "solver": config.solver.table(), "fixed": config.friction.get("fixed", {}),
               "jacobian": config.identify.jacobian, "step": config.identify.step}
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
    if ident.jacobian not in JACOBIANS:
        raise InputError(f"{where}: identify.jacobian = {ident.jacobian!r} is not one of {list(JACOBIANS)}")
    check_backend(config.solver, ident.jacobian, f"{where}: [solver]", ident.step)
    check_scheduler(config.run.scheduler, f"{where}:")
    given_model, model_options = model, config.model_spec if model is None else None
    if model is None:
        start = time.perf_counter()
        model = build_model(model_options, f"{where}: [model]")
        echo(model_line(model, config.model.builder, time.perf_counter() - start))
    contact = checked_contact(model, where, echo, config.solver.sliding)
    if parameters is None:
        parameters = Parameters.from_config(model.zone_names, config.friction["zones"], config.friction["bounds"],
                                            config.friction.get("fixed"))
    else:
        parameters = parameters.ordered_as(model.zone_names, f"{where}: parameters")
    _check_identify(config, ident, len(parameters.free_names), list(parameters.free_names))
    multistart.start_points(ident.starts, parameters.x0, parameters.lower, parameters.upper, ident.seed,
                            parameters.free_names, f"{where}:")
    profile.profiled_zones(ident.profile, parameters.free_names, f"{where}:")
    check_options(ident, model_options, f"{where}:")
    memory.limit(config.solver.max_memory, f"{where}: [solver]")
    if ident.model_error in ESTIMATING and config.solver.backend != "embedded":
        raise InputError(f"{where}: identify.model_error = {ident.model_error!r} needs the embedded "
                         "backend (the estimate refines the embedded model)")
    data_file = data_paths(config.data, config.resolve)[0] if measurements is None else None
    given, frames, relative, specimens, files = measurements, [], {}, {}, []
    window = choose_window(config.data.strain_window, config.data.strain_window_shape, [])
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
    window = window.for_fit(config.data.observables)
    observations = observations_from(measurements, model, config.data, relative, specimens)
    return Setup(model, observations, parameters, fingerprint(config, given_model, given), model_options,
                 data_file, tuple(frames), window, tuple(files), contact)


def _check_identify(config: Config, ident: IdentifyOptions, n_free: int, free: list[str]) -> None:
    """The [identify] keys that need the number of free zones: prior, loss, the method's options."""
    where, prior = config.where, ident.prior
    if prior is not None and not (isinstance(prior, (int, float)) and not isinstance(prior, bool)
                                  or isinstance(prior, list) and len(prior) == n_free
                                  and all(isinstance(v, (int, float)) for v in prior)):
        raise InputError(f"{where}: identify.prior must be a number or a list of {n_free} numbers (one per free "
                         f"zone {free}), got {prior!r}")
    if ident.loss not in ROBUST_WEIGHTS or ident.loss != "linear" and ident.method != "trf":
        raise InputError(f"{where}: identify.loss = {ident.loss!r} must be one of {sorted(ROBUST_WEIGHTS)}"
                         " (a robust loss only with method = \"trf\")")
    try:
        check_method(ident.method, dict(ident.options), ident.max_iterations, ident.tol, n_free)
    except InputError as exc:
        raise InputError(f"{where}: [identify] {exc}") from None


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
