"""simulate: one forward solve with the [friction] values, written in the measurement CSV format."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .backends import check_backend, make_backend
from .builders.registry import build_model
from .config import Config
from .data.dic.window import choose as choose_window
from .data.measurements import Measurements, write_measurements
from .data.table import PLANE_TOL
from .data.sources import read_data
from .errors import InputError
from .model_checks import checked_contact, model_line
from .fem.locate import PointsOutside
from .data.table import CHANNELS
from .inverse.observations import default_quantities, split_observables
from .inverse.point_regions import region_of_points
from .inverse.reactions import FORCE, STAGE_OBSERVABLES, channel_reaction, check_reaction_keys
from .inverse.parameters import Parameters
from .paths import check_file, check_folder, input_files
from .fem.points import StrainWindow
from .report.vtu import export_fields



def simulate(config: Config, out: str | Path, echo=lambda text: None) -> Path:
    """Solve at the configured coefficients; one row per point of the data file and model stage.

    The `force` column is the machine force (see :func:`~frictionid.inverse.observations.machine_force`) where
    the model is driven by a prescribed displacement, empty otherwise; the `torque` [N m] and `clamp` [N] columns
    are written where :func:`~frictionid.inverse.observations.channel_reaction` finds their reaction (the torque
    of a turned boundary, ``[data] reactions``). With ``[run] fields`` (default true) the
    fields of the solve go to :func:`fields_folder` of ``out`` for ParaView (docs/results.md); ``echo(text)``
    gets a line about them.
    """
    with config.naming_keys():
        return _simulate(config, out, echo)


def _simulate(config: Config, out, echo) -> Path:
    inputs = input_files(config)
    out = check_file(out, inputs, "output file")
    if config.run.fields:
        check_folder(fields_folder(out), "output fields folder", inputs)
    check_backend(config.solver, None, f"{config.where}: [solver]")
    start = time.perf_counter()
    model = build_model(config.model_spec, f"{config.where}: [model]")
    echo(model_line(model, config.model.builder, time.perf_counter() - start))
    checked_contact(model, config.where, echo, config.solver.sliding)
    friction = config.friction
    mu = Parameters.from_config(model.zone_names, friction["zones"], (0.0, 1e6), friction.get("fixed"))
    source = read_data(config.data, config.resolve, f"{config.where}: [data]", model)
    labels = list(dict.fromkeys(source.points))
    first = {p: i for i, p in reversed(list(enumerate(source.points)))}
    xyz = np.array([source.coordinates[first[p]] for p in labels])
    if model.kind != "3d" and np.any(np.abs(xyz[:, 2]) > PLANE_TOL * max(1.0, float(np.abs(xyz).max()))):
        raise InputError(f"{source.source}: simulate on a {model.kind} model needs points with z = 0")
    quantities = split_observables(config.data.observables or default_quantities(model))[0]
    region_of = region_of_points(config.data.regions, labels, model.mesh.region_names)
    channels = {}
    check_reaction_keys(config.data.reactions, f"{config.where}: [data] reactions")
    for channel in STAGE_OBSERVABLES:
        try:
            channels[channel] = channel_reaction(model, channel, config.data.reactions,
                                                 f"{config.where}: [data] reactions")
        except InputError:      # e.g. loaded by a prescribed force: no machine force to report
            if channel in (config.data.reactions or {}):
                raise
    reactions = tuple(channels.values())
    choice = choose_window(config.data.strain_window, config.data.strain_window_shape, [])
    cells, window = np.ones((len(labels), len(quantities)), dtype=bool), None
    if choice.size is not None:
        echo(choice.lines[0])
        cells = windowed_cells(source, labels, quantities)
        window = StrainWindow(choice.size, choice.shape, tuple(np.flatnonzero(cells.ravel()).tolist()))
    try:
        backend = make_backend(model, xyz[:, :model.dim], quantities, [region_of[p] for p in labels],
                               config.solver, f"{config.where}: [solver]", reactions, window)
    except PointsOutside as exc:
        raise exc.named(labels, source.source) from None
    prediction = backend.predict(mu.full(mu.x0))
    check_sliding = getattr(backend, "check_sliding", None)
    if check_sliding is not None:
        check_sliding(mu.full(mu.x0))
    n_points, n_stages = len(labels), model.n_stages
    n_rows = n_points * len(quantities)
    values = prediction.values[:, :n_rows].reshape(n_stages, n_points, len(quantities)).copy()
    values[:, ~cells] = np.nan
    sums = dict(zip(channels, prediction.values[:, n_rows:].T))
    force = sums.get(FORCE, np.full(n_stages, np.nan))
    measurements = Measurements(
        points=tuple(labels) * n_stages, coordinates=np.tile(xyz, (n_stages, 1)),
        stage=np.repeat(np.arange(1, n_stages + 1), n_points), force=np.repeat(force, n_points),
        values={q: values[:, :, k].ravel() for k, q in enumerate(quantities)}, sigma={},
        comments=(f"frictionid simulate {config.path.name}: {model.kind} model, builder "
                  f"{config.model.builder!r}", "units: mm, N; strains dimensionless (tensor shear)",
                  "coefficients: " + ", ".join(f"{n}={v:g}" for n, v in zip(mu.names, mu.full(mu.x0))),
                  *(f"{c}: {CHANNELS[c][0]} [{CHANNELS[c][1]}], reaction {channels[c]}" for c in CHANNELS
                    if c in channels)),
        source=str(out), channels={c: np.repeat(sums[c] / CHANNELS[c][2], n_points) for c in CHANNELS if c in sums})
    out.parent.mkdir(parents=True, exist_ok=True)
    write_measurements(out, measurements)
    if config.run.fields:
        export_fields(backend, mu.full(mu.x0), fields_folder(out), echo)
    return Path(out)


def windowed_cells(source, labels, quantities) -> np.ndarray:
    """(points, quantities) bool: the cells ``simulate`` writes when a strain window is set. Every displacement;
    a strain where the data file gives it at that point (at any stage), or at every point when the file gives
    none of that strain: a DIC file gives a face's in-plane strains only, and only those can a window in the
    face's plane give."""
    cells = np.ones((len(labels), len(quantities)), dtype=bool)
    index = {p: i for i, p in enumerate(labels)}
    for k, q in enumerate(quantities):
        given = np.isfinite(np.asarray(source.values.get(q, []), dtype=float))
        if not q.startswith("e") or not given.any():
            continue
        cells[:, k] = False
        for point in np.asarray(source.points)[given]:
            cells[index[point], k] = True
    return cells


def fields_folder(out: str | Path) -> Path:
    """Where simulate writes the fields of a solve written to the CSV ``out``: ``measured.csv`` -> ``measured.fields``
    next to it."""
    out = Path(out)
    return out.with_name(f"{out.stem}.fields")
