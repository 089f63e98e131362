"""Cross-check: the same model, coefficients and points solved by the embedded backend and by CalculiX.

:func:`cross_check_config` runs both backends on a config's model (:func:`cross_check`, recorded as a
:class:`~frictionid.backends.comparison.CrossCheck`) and, given the noise, the coefficient shift of an
identification (:mod:`frictionid.inverse.shift`); :func:`frictionid.report.crosscheck.cross_check_table` writes
them as markdown.
"""

from __future__ import annotations

import time

import numpy as np

from .backends.calculix.backend import CalculixBackend, CalculixSettings
from .backends.comparison import CrossCheck
from .builders.registry import build_model
from .data.sources import read_data
from .errors import InputError
from .fem.locate import PointsOutside
from .fem.problem import Problem
from .inverse.observations import default_quantities, observations_from, split_observables
from .inverse.point_regions import region_of_points
from .inverse.reactions import FORCE, machine_force
from .inverse.parameters import Parameters
from .inverse.shift import CoefficientShift, coefficient_shift, observed_shift
from .model import Model

#: cells per region whose centroids are the default observation points
DEFAULT_CELLS_PER_REGION = 8


def default_points(model: Model) -> tuple[np.ndarray, list[str]]:
    """Centroids of up to :data:`DEFAULT_CELLS_PER_REGION` cells spread through each region, and their regions."""
    mesh, points, regions = model.mesh, [], []
    for name, cells in mesh.regions.items():
        chosen = cells[np.linspace(0, len(cells) - 1, min(DEFAULT_CELLS_PER_REGION, len(cells))).astype(int)]
        points.append(mesh.points[mesh.cells[chosen]].mean(axis=1))
        regions += [name] * len(chosen)
    return np.vstack(points), regions


def cross_check(model: Model, mu, points, quantities, regions, settings: CalculixSettings,
                name: str = "model") -> CrossCheck:
    """Solve once with each backend (timed) and collect what :func:`~frictionid.report.crosscheck.cross_check_table` compares."""
    mu = np.asarray(mu, dtype=float)
    start = time.perf_counter()
    problem = Problem.build(model, points=points, quantities=quantities, regions=regions)
    setup = time.perf_counter() - start
    start = time.perf_counter()
    solution = problem.solve(mu)
    time_embedded = time.perf_counter() - start
    ends = [solution.stage_end(s) for s in range(model.n_stages)]
    sensitivities = problem.solve(mu, sensitivities=True)
    ccx = CalculixBackend(model, points, quantities, regions, settings).solve(mu, full_field=False)
    return CrossCheck(
        name, model.mesh.n_nodes, mu, tuple(quantities), np.asarray(points), solution.observations[ends],
        ccx.observations, solution.reaction_labels, solution.reactions[ends], ccx.reactions, model.zone_names,
        solution.zone_normal_force[ends], ccx.zone_normal_force,
        np.linalg.norm(solution.zone_tangential_force[ends], axis=2), ccx.zone_tangential_force,
        time_embedded, ccx.wall_time, setup,
        (settings.contact_settings(model).normal_stiffness, settings.contact_settings(model).stick_slope),
        sensitivities.d_observations[ends], sensitivities.d_reactions[ends], settings.load_scale, model.kind)


def cross_check_config(config) -> tuple[CrossCheck, CoefficientShift | None, str]:
    """A cross-check from a config: [model], [friction] zones (the coefficients), [solver] (CalculiX options),
    and optionally [data] file / observables / regions for the points (default: :func:`default_points`).

    With [data] noise, also the coefficient shift of an identification. When the file has a column for every
    observable (the machine force included), the points and the shift's rows are exactly those an
    identification would fit (values present at [data] stages; the file's sigma columns, else [data] noise).
    Otherwise the shift counts every observable at every point and [data] stage (default: all), weighted by
    [data] noise. Returns (check, shift or None, a note saying why there is no shift).
    """
    model = build_model(config.model_spec, f"{config.where}: [model]")
    friction = config.friction
    mu = Parameters.from_config(model.zone_names, friction["zones"], (0.0, 1e6), friction.get("fixed"))
    data, noise = config.data, config.data.noise
    observables = tuple(data.observables or ())
    force = machine_force(model) if FORCE in observables else None
    quantities = split_observables(observables)[0] or default_quantities(model)
    source = read_data(data, config.resolve, f"{config.where}: [data]", model) if data.file else None
    observations = None
    if source is not None and noise and all(q in source.values for q in quantities) and \
            (force is None or not np.all(np.isnan(source.force))):
        stages = data.stages or range(1, model.n_stages + 1)
        observations = observations_from(source, model, data.with_values(observables=observables, stages=stages))
        points, regions, labels = observations.points, list(observations.point_regions), observations.point_labels
    elif source is not None:
        labels = list(dict.fromkeys(source.points))
        first = {p: i for i, p in reversed(list(enumerate(source.points)))}
        points = np.array([source.coordinates[first[p]][:model.dim] for p in labels])
        region_of = region_of_points(data.regions, labels, model.mesh.region_names)
        regions = [region_of[p] for p in labels]
    else:
        points, regions = default_points(model)
    settings = CalculixSettings.from_solver(config.solver)
    name = f"{config.path.name} (builder {config.model.builder!r})"
    try:
        check = cross_check(model, mu.full(mu.x0), points, quantities, regions, settings, name)
    except PointsOutside as exc:
        if source is None:             # cell centroids lie inside by construction
            raise
        raise exc.named(labels, source.source) from None
    if not noise:
        return check, None, ("Give [data] noise (e.g. noise = { u = 0.0005, e = 1e-5 }) to see what these "
                             "differences mean for an identified coefficient.")
    if observations is not None:
        return check, observed_shift(check, observations), ""
    try:
        return check, coefficient_shift(check, noise, data.stages, quantities, force), ""
    except InputError as exc:
        raise InputError(f"{config.path}: {exc}") from None
