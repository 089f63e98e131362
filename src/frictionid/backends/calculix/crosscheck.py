"""Cross-check: the same model, coefficients and points solved by the embedded backend and by CalculiX."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ...fem.problem import Problem
from ...model import Model
from .backend import CalculixBackend, CalculixSettings

DISPLACEMENTS = ("ux", "uy", "uz")
#: cells per region whose centroids are the default observation points
DEFAULT_CELLS_PER_REGION = 8


@dataclass(frozen=True)
class CrossCheck:
    """Stage-end results of both backends on one model.

    Attributes
    ----------
    quantities : observed quantities (rows point-major); points : (n, dim) [mm]
    embedded, calculix : (n_stages, n_rows) observations
    reaction_labels : "boundary.x"; reactions_embedded, reactions_calculix : (n_stages, n_reac) [N]
    zone_names; normal_embedded, normal_calculix, tangential_embedded, tangential_calculix : (n_stages, n_zones) [N]
    time_embedded, time_calculix : [s] per forward solve; setup_embedded : [s] condensation (once per geometry)
    """

    model_name: str
    n_nodes: int
    mu: np.ndarray
    quantities: tuple[str, ...]
    points: np.ndarray
    embedded: np.ndarray
    calculix: np.ndarray
    reaction_labels: tuple[str, ...]
    reactions_embedded: np.ndarray
    reactions_calculix: np.ndarray
    zone_names: tuple[str, ...]
    normal_embedded: np.ndarray
    normal_calculix: np.ndarray
    tangential_embedded: np.ndarray
    tangential_calculix: np.ndarray
    time_embedded: float
    time_calculix: float
    setup_embedded: float
    penalty: tuple[float, float]


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
    """Solve once with each backend (timed) and collect what :func:`cross_check_table` compares."""
    mu = np.asarray(mu, dtype=float)
    start = time.perf_counter()
    problem = Problem.build(model, points=points, quantities=quantities, regions=regions)
    setup = time.perf_counter() - start
    start = time.perf_counter()
    solution = problem.solve(mu)
    time_embedded = time.perf_counter() - start
    ends = [solution.stage_end(s) for s in range(model.n_stages)]
    ccx = CalculixBackend(model, points, quantities, regions, settings).solve(mu, full_field=False)
    return CrossCheck(
        name, model.mesh.n_nodes, mu, tuple(quantities), np.asarray(points), solution.observations[ends],
        ccx.observations, solution.reaction_labels, solution.reactions[ends], ccx.reactions, model.zone_names,
        solution.zone_normal_force[ends], ccx.zone_normal_force,
        np.linalg.norm(solution.zone_tangential_force[ends], axis=2), ccx.zone_tangential_force,
        time_embedded, ccx.wall_time, setup,
        (settings.contact_settings(model).normal_stiffness, settings.contact_settings(model).stick_slope))


def _differences(reference: np.ndarray, other: np.ndarray) -> str:
    diff = other - reference
    rms = float(np.sqrt(np.mean(diff ** 2)))
    span = float(np.ptp(reference))
    relative = f"{100 * rms / span:.2f} %" if span > 0 else "-"
    return f"{np.abs(diff).max():.3e} | {rms:.3e} | {relative}"


def _observation_rows(check: CrossCheck) -> list[str]:
    n_q = len(check.quantities)
    groups = [("displacements [mm]", [k for k, q in enumerate(check.quantities) if q in DISPLACEMENTS]),
              ("strains", [k for k, q in enumerate(check.quantities) if q not in DISPLACEMENTS])]
    rows = ["| stage | quantities | max abs diff | RMS diff | RMS / range |", "|---|---|---|---|---|"]
    for stage in range(len(check.embedded)):
        a, b = check.embedded[stage].reshape(-1, n_q), check.calculix[stage].reshape(-1, n_q)
        for label, columns in groups:
            if columns:
                rows.append(f"| {stage + 1} | {label} | {_differences(a[:, columns], b[:, columns])} |")
    return rows


def _relative(a: float, b: float) -> str:
    """(b - a) / a: negative when calculix's value is smaller in size than the embedded one."""
    return f"{100 * (b - a) / a:+.2f} %" if abs(a) > 1e-9 * max(abs(b), 1.0) else "-"


def _force_rows(check: CrossCheck) -> list[str]:
    last = len(check.embedded) - 1
    rows = [f"| force at the end of stage {last + 1} [N] | embedded | calculix | difference |", "|---|---|---|---|"]
    for k, label in enumerate(check.reaction_labels):
        a, b = check.reactions_embedded[last, k], check.reactions_calculix[last, k]
        rows.append(f"| reaction {label} | {a:.4g} | {b:.4g} | {_relative(a, b)} |")
    for z, zone in enumerate(check.zone_names):
        for kind, emb, ccx in (("N", check.normal_embedded, check.normal_calculix),
                               ("abs(T)", check.tangential_embedded, check.tangential_calculix)):
            a, b = emb[last, z], ccx[last, z]
            rows.append(f"| zone {zone} {kind} (mu = {check.mu[z]:g}) | {a:.4g} | {b:.4g} | {_relative(a, b)} |")
    return rows


def cross_check_table(check: CrossCheck) -> str:
    """Markdown tables: observation differences per stage, reactions and zone forces, time per forward solve."""
    lines = [f"## {check.model_name}: {check.n_nodes} nodes, {len(check.points)} points "
             f"({', '.join(check.quantities)}), mu = {np.round(check.mu, 4).tolist()}",
             f"CalculiX penalty: normal {check.penalty[0]:.3g} N/mm^3, stick slope {check.penalty[1]:.3g} N/mm^3; "
             "differences are calculix - embedded; RMS / range uses the embedded values' range.", ""]
    lines += _observation_rows(check) + [""] + _force_rows(check) + [""]
    lines += ["| backend | time per forward solve [s] |", "|---|---|",
              f"| embedded | {check.time_embedded:.3f} (+ {check.setup_embedded:.2f} s condensation once per geometry) |",
              f"| calculix | {check.time_calculix:.2f} |",
              f"| ratio calculix / embedded | {check.time_calculix / max(check.time_embedded, 1e-9):.0f} |"]
    return "\n".join(lines) + "\n"


def cross_check_config(config) -> CrossCheck:
    """A cross-check from a config: [model], [friction] zones (the coefficients), [solver] (CalculiX options),
    and optionally [data] file / observables / regions for the points (default: :func:`default_points`)."""
    from ...backends import solver_options
    from ...builders.registry import build_model
    from ...data.measurements import read_measurements
    from ...inverse.parameters import Parameters
    from ...simulate import DEFAULT_QUANTITIES

    model = build_model(config.model)
    friction = config.friction
    mu = Parameters.from_config(model.zone_names, friction["zones"], (0.0, 1e6), friction.get("fixed"))
    quantities = tuple(config.data.get("observables") or DEFAULT_QUANTITIES[model.dim])
    if config.data.get("file"):
        source = read_measurements(config.resolve(config.data["file"]))
        labels = list(dict.fromkeys(source.points))
        first = {p: i for i, p in reversed(list(enumerate(source.points)))}
        points = np.array([source.coordinates[first[p]][:model.dim] for p in labels])
        table = config.data.get("regions", {})
        regions = [table.get(p, table.get("*")) for p in labels]
    else:
        points, regions = default_points(model)
    settings = CalculixSettings.from_options(solver_options(config), f"{config.path}: [solver]")
    name = f"{config.path.name} (builder {config.model.get('builder')!r})"
    return cross_check(model, mu.full(mu.x0), points, quantities, regions, settings, name)
