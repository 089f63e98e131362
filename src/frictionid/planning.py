"""`frictionid design`: plan the measurement before building the rig.

From a config (the model, the expected coefficients as [friction] zones, the observed quantities, stages and
noise of [data], the planned points as [data] file, and the [design] table) it computes, at the expected
coefficients:

- the predicted standard error per zone of the planned points;
- a set of ``design.points`` points chosen from the planned points and candidates spread over the model
  (greedy A- or D-optimal, :func:`frictionid.inverse.design.select_points`) and its predicted standard errors;
- the finest zone partition each point set supports (:func:`frictionid.inverse.design.finest_partition`), as
  the ``[friction] merge`` table an identification can run with;
- a plot of each zone's weighted sensitivity over the candidates.

Candidates (``design.candidates``): "surface", nodes spread over the surfaces a camera can see (not the
contact surfaces), or "section", nodes spread over the whole model: for a plane-strain or axisymmetric model
the plane DIC sees on a specimen's face or cut-out. ``design.regions`` limits them to some regions.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .backends.embedded import EmbeddedBackend
from .builders.registry import build_model
from .config import Config
from .data.sources import read_data
from .data.table import CHANNELS, QUANTITIES, Measurements
from .errors import InputError
from .preparation import prepare
from .inverse.design import CRITERIA, finest_partition, information_of, select_points
from .inverse.observations import noise_of, split_observables
from .inverse.resolution import predicted_stderr, resolution
from .model import Model
from .paths import check_folder, input_files
from .inverse.prefit import candidate_points, spread_points

KINDS = ("surface", "section")
#: the files a design writes into its folder
DESIGN_FILES = ("design.json", "chosen_points.csv", "sensitivity.png")


@dataclass(frozen=True)
class Candidates:
    """Candidate points, their regions, and their weighted sensitivities (n, n_rows, n_free): the quantities
    at the observed stages of each point, each divided by its noise."""

    points: np.ndarray
    regions: tuple[str, ...]
    rows: np.ndarray


def candidate_locations(model: Model, kind: str, n_max: int, regions=None) -> tuple[np.ndarray, list[str]]:
    """(n, dim) points and their regions: spread over the visible surfaces ("surface") or the nodes ("section")."""
    names = list(regions) if regions else list(model.mesh.regions)
    unknown = [r for r in names if r not in model.mesh.regions]
    if unknown:
        raise InputError(f"design.regions: unknown region(s) {unknown}; the model's regions are "
                         f"{list(model.mesh.regions)}")
    if kind == "surface":
        points, owner = candidate_points(model, np.zeros((0, model.dim)), n_max * len(model.mesh.regions))
        keep = np.isin(owner, names)
        return points[keep], [o for o, k in zip(owner, keep) if k]
    points, owner = [], []
    for name in names:
        cells = model.mesh.cells[model.mesh.regions[name]]
        xyz = model.mesh.points[np.unique(cells)]
        if model.kind == "axisymmetric":          # on the axis a point has no radial direction to measure
            xyz = xyz[xyz[:, 0] > 1e-9 * np.ptp(model.mesh.points[:, 1])]
        chosen = spread_points(xyz, max(n_max // len(names), 1))
        points.append(xyz[chosen])
        owner += [name] * len(chosen)
    return np.concatenate(points), owner


def weighted_rows(backend: EmbeddedBackend, points, regions, quantities, stages, sigma, mu, free) -> np.ndarray:
    """(n_points, n_stages * n_q, n_free) sensitivities of ``quantities`` at the 1-based ``stages`` / sigma, from
    the planned points' backend (its condensation and its solve at ``mu``: no second condensation,
    :meth:`EmbeddedBackend.point_sensitivities`)."""
    derivatives = backend.point_sensitivities(mu, np.asarray(points), tuple(quantities), list(regions))
    n_q = len(quantities)
    per_stage = derivatives[[s - 1 for s in stages]][:, :len(points) * n_q][..., free]
    per_stage = per_stage / np.tile(np.asarray(sigma, dtype=float), len(points))[None, :, None]
    return per_stage.reshape(len(stages), len(points), n_q, -1).transpose(1, 0, 2, 3).reshape(
        len(points), len(stages) * n_q, -1)


def _zone_relations(model: Model, names) -> tuple[set, list]:
    """Pairs of the named zones (coefficients) that share a node, and each zone's interface (a coefficient zones of
    several interfaces share: their names joined by "+")."""
    zones_of: dict[str, list] = {}
    for i in model.interfaces:
        for zone, coefficient in zip(i.zones, i.coefficients):
            zones_of.setdefault(coefficient, []).append((zone, i.name))
    nodes = {c: {int(n) for zone, _ in zones_of[c] for n in model.mesh.boundary_nodes(zone)} for c in names}
    interface = {c: "+".join(dict.fromkeys(name for _, name in zones_of[c])) for c in names}
    neighbours = {frozenset((a, b)) for a in range(len(names)) for b in range(a + 1, len(names))
                  if nodes[names[a]] & nodes[names[b]]}
    return neighbours, [interface[z] for z in names]


def _summary(name: str, stderr, names, tolerance: float) -> str:
    cells = [f"{z} {s:.3g}" if np.isfinite(s) else f"{z} unseen" for z, s in zip(names, stderr)]
    resolved = [z for z, s in zip(names, stderr) if s <= tolerance]
    return (f"{name}: predicted standard errors {', '.join(cells)}; resolved (<= {tolerance:g}): "
            f"{', '.join(resolved) or 'none'}")


def _write_points(path: Path, points: np.ndarray, labels, stages, quantities) -> None:
    """The chosen points as a measurement-file template (values are placeholders; `simulate` fills them)."""
    rows = ["# points chosen by frictionid design (undeformed, mm); the values are placeholders",
            ",".join(["point", "x", "y", "z", "stage", *quantities])]
    xyz = np.column_stack([points, np.zeros((len(points), 3 - points.shape[1]))])
    for stage in stages:
        rows += [",".join([label, *(repr(float(v)) for v in p), str(stage), *("0.0" for _ in quantities)])
                 for label, p in zip(labels, xyz)]
    path.write_text("\n".join(rows) + "\n")


def _plot(path: Path, candidates: Candidates, names, chosen, planned: np.ndarray) -> None:
    """Each zone's weighted sensitivity at the candidates (log10, four decades below the largest), the chosen
    points circled red, the planned ones as black crosses."""
    from matplotlib.figure import Figure

    seen = np.log10(np.maximum(np.sqrt(np.einsum("pkz,pkz->pz", candidates.rows, candidates.rows)), 1e-300))
    top = float(np.max(seen))
    dim, n = candidates.points.shape[1], len(names)
    extent = np.ptp(candidates.points, axis=0)
    tall = float(extent[1] / max(extent[0], 1e-9)) if dim == 2 else 1.0
    width = float(np.clip(5.0 / tall, 1.6, 4.0)) if dim == 2 else 3.6
    fig = Figure(figsize=(width * n + 1.0, 5.5 if dim == 2 else 3.6), layout="constrained")
    for k, name in enumerate(names):
        ax = fig.add_subplot(1, n, k + 1, **({"projection": "3d"} if dim == 3 else {}))
        if dim == 2:
            ax.set_aspect("equal")
        dots = ax.scatter(*candidates.points.T, c=seen[:, k], s=5, cmap="viridis", vmin=top - 4.0, vmax=top)
        ax.scatter(*candidates.points[chosen].T, s=14, facecolors="none", edgecolors="r", linewidths=0.6)
        if len(planned):
            ax.scatter(*planned.T[:dim], marker="x", s=14, c="k", linewidths=0.8)
        ax.set_title(f"zone {name}", fontsize=9)
        ax.tick_params(labelsize=7)
    fig.colorbar(dots, ax=fig.axes, shrink=0.6, label="log10 |d(observation)/d mu| / noise")
    fig.savefig(path, dpi=110)


def design_config(config: Config, n_points: int | None = None, out: Path | None = None,
                  echo=lambda text: None) -> dict:
    """Run the design a config describes (module docstring); writes design.json, chosen_points.csv and
    sensitivity.png to ``out`` (default <run.dir>/design) and returns design.json's content."""
    where, table = config.where, config.design
    folder = check_folder(out if out is not None else config.resolve(config.run.dir) / "design",
                          "design --out" if out is not None else f"{where}: run.dir", input_files(config),
                          DESIGN_FILES)
    n_points = int(table.points if n_points is None else n_points)
    if table.candidates not in (None, *KINDS):
        raise InputError(f"{where}: design.candidates = {table.candidates!r} is not one of {list(KINDS)}")
    if table.criterion not in CRITERIA:
        raise InputError(f"{where}: design.criterion = {table.criterion!r} is not one of {list(CRITERIA)}")
    if int(table.n_candidates) < n_points:
        raise InputError(f"{where}: design.n_candidates = {table.n_candidates} is fewer than the "
                         f"{n_points} points to choose")
    with config.naming_keys():
        model = build_model(config.model_spec, f"{where}: [model]")
        setup = prepare(config, model, planned_measurements(config, model), echo=echo)
    params, obs = setup.parameters, setup.observations
    kind = table.candidates or ("surface" if model.dim == 3 else "section")
    quantities = split_observables(config.data.observables)[0]
    noise = config.data.noise or {}
    sigma = [noise_of(q, noise) for q in quantities]
    missing = [q for q, s in zip(quantities, sigma) if s is None]
    if missing:
        raise InputError(f"{where}: design needs the noise of every observed quantity; data.noise gives none for "
                         f"{missing} (e.g. noise = {{ u = 0.0005, e = 2e-5 }})")
    stages = [int(s) for s in config.data.stages]
    names, free, mu = params.free_names, params.free, params.full(params.x0)
    tolerance = float(table.tolerance or config.identify.resolution)

    backend = EmbeddedBackend(model, obs.points, obs.quantities, obs.point_regions, obs.reactions, keep=False)
    planned_jac = obs.derivatives(backend.predict(mu, True).derivatives)[:, free] / obs.sigma[:, None]
    planned = resolution(planned_jac, names, tolerance)
    echo(_summary(f"planned ({len(obs.points)} points)", planned.stderr, names, tolerance))

    points, regions = candidate_locations(model, kind, int(table.n_candidates), table.regions)
    points, regions = np.concatenate([obs.points, points]), list(obs.point_regions) + list(regions)
    rows = weighted_rows(backend, points, regions, quantities, stages, sigma, mu, free)
    candidates = Candidates(points, tuple(regions), rows)
    chosen = select_points(rows, n_points, table.criterion)
    chosen_info = information_of(rows, chosen)
    chosen_se = predicted_stderr(chosen_info)
    echo(_summary(f"chosen ({n_points} of {len(points)} {kind} candidates, {table.criterion}-optimal)",
                  chosen_se, names, tolerance))
    neighbours, interface_of = _zone_relations(model, names)
    partitions = {}
    for label, info in (("planned", planned_jac.T @ planned_jac), ("chosen", chosen_info)):
        partitions[label] = finest_partition(info, names, tolerance, neighbours, interface_of)
        echo(_partition_line(label, partitions[label]))

    folder.mkdir(parents=True, exist_ok=True)
    n_planned = len(obs.points)
    labels = [obs.point_labels[k] if k < n_planned else f"{regions[k]}-{i + 1}" for i, k in enumerate(chosen)]
    region_table = {**{obs.point_labels[k]: regions[k] for k in chosen if k < n_planned and regions[k]},
                    **{f"{regions[k]}-*": regions[k] for k in chosen if k >= n_planned}}
    _write_points(folder / "chosen_points.csv", points[chosen], labels, stages, quantities)
    _plot(folder / "sensitivity.png", candidates, names, chosen, obs.points)

    def clean(values):
        return {z: float(v) if np.isfinite(v) else None for z, v in zip(names, values)}

    result = {"coefficients": dict(zip(params.names, mu.tolist())), "quantities": list(quantities),
              "stages": stages, "noise": dict(zip(quantities, sigma)), "tolerance": tolerance,
              "planned": {"n_points": len(obs.points), "stderr": clean(planned.stderr),
                          "partition": partitions["planned"].as_dict()},
              "chosen": {"n_points": n_points, "candidates": kind, "n_candidates": len(points),
                         "criterion": table.criterion, "stderr": clean(chosen_se),
                         "points": {label: {"xyz": points[k].tolist(), "region": regions[k]}
                                    for label, k in zip(labels, chosen)},
                         "partition": partitions["chosen"].as_dict(), "regions": region_table},
              "files": ["chosen_points.csv", "sensitivity.png"]}
    (folder / "design.json").write_text(json.dumps(result, indent=2) + "\n")
    echo(f"written: {folder / 'design.json'}, chosen_points.csv (a points file for `frictionid simulate`, with "
         f"[data] regions = {_toml(region_table)}), sensitivity.png")
    return result


def planned_measurements(config: Config, model: Model) -> Measurements:
    """The planned points of ``[data] file`` at every ``[data] stages`` with placeholder values (zeros) of every
    observable: a plan needs where the points are, not what they measured. A CSV whose header has point, x, y, z
    is read as a points file (other columns, stage included, are not used); any other file as identify reads it."""
    files = config.data.file
    path = config.resolve(files) if isinstance(files, str) else None
    if path is not None and _points_header(path) is not None:
        labels, xyz = read_points(path)
    else:
        measured = read_data(config.data, config.resolve, f"{config.where}: [data]", model)
        first = dict(zip(reversed(measured.points), range(len(measured.points) - 1, -1, -1)))
        labels, xyz = list(first), measured.coordinates[list(first.values())]
    stages = [int(s) for s in config.data.stages]
    n = len(labels)
    observed = config.data.observables
    zeros = np.zeros(n * len(stages))
    return Measurements(points=tuple(labels) * len(stages), coordinates=np.tile(xyz, (len(stages), 1)),
                        stage=np.repeat(stages, n), force=zeros.copy(),
                        values={q: zeros.copy() for q in observed if q in QUANTITIES},
                        channels={c: zeros.copy() for c in observed if c in CHANNELS},
                        source=str(path or config.data.file))


def _points_header(path: Path) -> list[str] | None:
    """The header of a CSV naming point, x, y and z (None: another file, or none at all)."""
    try:
        with path.open() as handle:
            for line in handle:
                if line.strip() and not line.lstrip().startswith("#"):
                    names = [n.strip() for n in line.split(",")]
                    return names if {"point", "x", "y", "z"} <= set(names) else None
    except (OSError, UnicodeDecodeError):
        return None
    return None


def read_points(path: Path) -> tuple[list[str], np.ndarray]:
    """Point labels and (n, 3) coordinates [mm] of a points file: ``#`` comments, a header with point, x, y, z
    (other columns are not read), one row per point (a point repeated, e.g. once per stage, must repeat its
    coordinates). Errors name the file, the line and the column."""
    header, rows = None, {}
    with path.open() as handle:
        for number, line in enumerate(handle, start=1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            fields = [f.strip() for f in line.rstrip("\n").split(",")]
            if header is None:
                header = fields
                continue
            if len(fields) != len(header):
                raise InputError(f"{path}:{number}: {len(fields)} fields, but the header has {len(header)}")
            cells = dict(zip(header, fields))
            xyz = []
            for axis in "xyz":
                try:
                    xyz.append(float(cells[axis]))
                except ValueError:
                    raise InputError(f"{path}:{number}: column {axis!r}: {cells[axis]!r} is not a number") from None
                if not np.isfinite(xyz[-1]):
                    raise InputError(f"{path}:{number}: column {axis!r}: {cells[axis]!r} is not a finite number")
            label = cells["point"]
            if label in rows and rows[label] != xyz:
                raise InputError(f"{path}:{number}: point {label!r} again with other coordinates {xyz} (first "
                                 f"{rows[label]})")
            rows[label] = xyz
    if not rows:
        raise InputError(f"{path}: no points (a header point,x,y,z and one row per point)")
    return list(rows), np.array(list(rows.values()))


def _partition_line(label: str, p) -> str:
    groups = ", ".join(f"{p.name(g)} {s:.3g}" + ("" if ok else " (not resolved)")
                       for g, s, ok in zip(p.groups, p.stderr, p.resolved))
    if not p.resolved.all():
        return f"the {label} points resolve no partition of these zones; the coarsest tried: {groups}"
    if not p.merge_table():
        return f"the {label} points resolve every zone on its own: {groups}"
    return (f"finest partition the {label} points resolve: {groups}; identify it with "
            f"[friction] merge = {_toml(p.merge_table())}")


def _toml(table: dict) -> str:
    return "{ " + ", ".join(f"{json.dumps(k)} = {json.dumps(v)}" for k, v in table.items()) + " }"
