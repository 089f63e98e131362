"""Cross-check: the same model, coefficients and points solved by the embedded backend and by CalculiX.

Besides the differences themselves, the table says what they mean for an identification: the coefficients a
fit with CalculiX would reach on data made by the embedded backend (or on measured data both fit equally well),
minus the embedded fit's, to first order in the differences (Gauss-Newton step from the embedded solution,
weighted by the stated noise):

    delta_mu = -(A^T A)^-1 A^T r,    A = W df_embedded/dmu,    r = W (f_calculix - f_embedded)

with the embedded backend's analytic sensitivities, so one ccx run replaces a finite-difference identification
with ccx (checked against such identifications in the README's CalculiX section).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...fem.points import PointsOutside
from ...fem.problem import Problem
from ...inverse.observations import FORCE, machine_force, noise_of
from ...inverse.resolution import predicted_stderr
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
    derivatives_embedded : (n_stages, n_rows, n_zones), reaction_derivatives_embedded : (n_stages, n_reac, n_zones)
        the embedded backend's sensitivities of observations and reactions at the stage ends
    load_scale : the CalculiX settings' load_scale (1: ccx at the loads as given)
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
    derivatives_embedded: np.ndarray
    reaction_derivatives_embedded: np.ndarray
    load_scale: float = 1.0


@dataclass(frozen=True)
class CoefficientShift:
    """What a cross-check's differences mean for an identification with a given observation set and noise.

    Attributes
    ----------
    stages : 1-based stages whose observations count; quantities : the counted quantities (and "force");
        n_rows : how many rows count
    noise : standard deviation of each counted quantity used as weight (nan: per row, from the data file)
    shift : (n_zones,) calculix fit - embedded fit, linearised; nan for a zone the rows do not resolve
    stderr : (n_zones,) the embedded fit's standard errors at that noise (inf: not resolved)
    rms : RMS of the weighted differences (in noise units)
    """

    stages: tuple[int, ...]
    quantities: tuple[str, ...]
    n_rows: int
    noise: dict
    shift: np.ndarray
    stderr: np.ndarray
    rms: float


def coefficient_shift(check: CrossCheck, noise: dict, stages=None,
                      quantities: tuple[str, ...] | None = None, force: str | None = None) -> CoefficientShift:
    """The linearised coefficient shift of :class:`CoefficientShift` from the rows of ``quantities`` (default:
    all of the cross-check's) at every point and ``stages`` (1-based; default all), plus the reaction labelled
    ``force`` (the machine force) when given.

    Raises
    ------
    InputError
        When a counted quantity has no stated noise in ``noise`` (data.noise) or a stage does not exist.
    """
    n_stages = len(check.embedded)
    stages = tuple(range(1, n_stages + 1)) if stages is None else tuple(stages)
    bad = [s for s in stages if not isinstance(s, int) or not 1 <= s <= n_stages]
    if bad:
        raise InputError(f"data.stages: {bad} not among the model's stages 1..{n_stages}")
    quantities = check.quantities if quantities is None else tuple(quantities)
    sigma = {q: noise_of(q, noise) for q in quantities + ((FORCE,) if force else ())}
    missing = [q for q, value in sigma.items() if value is None]
    if missing:
        raise InputError(f"data.noise: no standard deviation for {missing}; the coefficient shift weighs every "
                         "observation by its noise, e.g. noise = { u = 0.0005, e = 1e-5, force = 1.0 }")
    n_q, n_point_rows = len(check.quantities), check.embedded.shape[1]
    rows = [(p * n_q + check.quantities.index(q), sigma[q]) for p in range(len(check.points)) for q in quantities]
    if force:
        rows.append((n_point_rows + check.reaction_labels.index(force), sigma[FORCE]))
    column, weight = (np.array(v) for v in zip(*rows))
    stage = np.repeat(np.array(stages) - 1, len(rows))
    return _shift(check, stage, np.tile(column, len(stages)), np.tile(weight, len(stages)),
                  quantities + ((FORCE,) if force else ()), sigma)


def observed_shift(check: CrossCheck, observations) -> CoefficientShift:
    """The coefficient shift from exactly the rows and standard deviations an identification fits
    (:class:`~frictionid.inverse.observations.Observations` on the cross-check's points and quantities)."""
    n_point_rows = len(observations.points) * len(observations.quantities)
    if observations.quantities != check.quantities or n_point_rows != check.embedded.shape[1]:
        raise ValueError("the observations are not on the cross-check's points and quantities")
    reaction = [check.reaction_labels.index(label) for label in observations.reactions]
    column = np.array([row if row < n_point_rows else n_point_rows + reaction[row - n_point_rows]
                       for row in observations.row])
    n_q = len(observations.quantities)
    kinds = np.array([observations.quantities[row % n_q] if row < n_point_rows else FORCE for row in observations.row])
    noise = {}
    for q in dict.fromkeys(kinds):
        values = np.unique(observations.sigma[kinds == q])
        noise[str(q)] = float(values[0]) if len(values) == 1 else float("nan")      # nan: from the file, per row
    return _shift(check, observations.stage, column, observations.sigma, tuple(noise), noise)


def _shift(check: CrossCheck, stage: np.ndarray, column: np.ndarray, sigma: np.ndarray,
           quantities: tuple[str, ...], noise: dict) -> CoefficientShift:
    """Shift from rows (0-based stage, column of [point rows | reactions], sigma)."""
    embedded = np.concatenate([check.embedded, check.reactions_embedded], axis=1)
    calculix = np.concatenate([check.calculix, check.reactions_calculix], axis=1)
    derivatives = np.concatenate([check.derivatives_embedded, check.reaction_derivatives_embedded], axis=1)
    a = derivatives[stage, column] / sigma[:, None]
    r = (calculix[stage, column] - embedded[stage, column]) / sigma
    stderr = predicted_stderr(a.T @ a)
    seen = np.isfinite(stderr)
    shift = np.full(len(stderr), np.nan)
    if seen.any():
        shift[seen] = -np.linalg.lstsq(a[:, seen], r, rcond=None)[0]
    return CoefficientShift(tuple(int(s) + 1 for s in np.unique(stage)), quantities, len(r), noise, shift,
                            stderr, float(np.sqrt(np.mean(r ** 2))))


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
    sensitivities = problem.solve(mu, sensitivities=True)
    ccx = CalculixBackend(model, points, quantities, regions, settings).solve(mu, full_field=False)
    return CrossCheck(
        name, model.mesh.n_nodes, mu, tuple(quantities), np.asarray(points), solution.observations[ends],
        ccx.observations, solution.reaction_labels, solution.reactions[ends], ccx.reactions, model.zone_names,
        solution.zone_normal_force[ends], ccx.zone_normal_force,
        np.linalg.norm(solution.zone_tangential_force[ends], axis=2), ccx.zone_tangential_force,
        time_embedded, ccx.wall_time, setup,
        (settings.contact_settings(model).normal_stiffness, settings.contact_settings(model).stick_slope),
        sensitivities.d_observations[ends], sensitivities.d_reactions[ends], settings.load_scale)


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


def _shift_rows(check: CrossCheck, shift: CoefficientShift) -> list[str]:
    groups: dict[float, list[str]] = {}
    for q, value in shift.noise.items():
        groups.setdefault(value, []).append(q)
    noise = "; ".join(f"{', '.join(qs)} {value:g}" if np.isfinite(value) else f"{', '.join(qs)} as in the file"
                      for value, qs in groups.items())
    rows = [f"What the differences mean for an identification from these observations (linearised; stages "
            f"{list(shift.stages)}, {shift.n_rows} rows, weighted by the noise {noise}): a fit with CalculiX "
            "reaches each coefficient shifted from the embedded fit by", "",
            "| zone | mu | calculix - embedded | embedded fit's standard error | shift / standard error |",
            "|---|---|---|---|---|"]
    for zone, mu, delta, se in zip(check.zone_names, check.mu, shift.shift, shift.stderr):
        if np.isfinite(se):
            rows.append(f"| {zone} | {mu:g} | {delta:+.4f} | {se:.4f} | {delta / se:+.1f} |")
        else:
            rows.append(f"| {zone} | {mu:g} | not resolved | - | - |")
    return rows + ["", f"RMS of the differences: {shift.rms:.2f} noise levels."]


def cross_check_table(check: CrossCheck, shift: CoefficientShift | None = None, note: str = "") -> str:
    """Markdown tables: observation differences per stage, reactions and zone forces, time per forward solve,
    and (given ``shift``) the coefficient shift of an identification, else ``note``."""
    lines = [f"## {check.model_name}: {check.n_nodes} nodes, {len(check.points)} points "
             f"({', '.join(check.quantities)}), mu = {np.round(check.mu, 4).tolist()}",
             f"CalculiX penalty: normal {check.penalty[0]:.3g} N/mm^3, stick slope {check.penalty[1]:.3g} N/mm^3; "
             "differences are calculix - embedded; RMS / range uses the embedded values' range."]
    if check.load_scale != 1:
        lines.append(f"CalculiX solved at {check.load_scale:g} times the loads, its results divided by that "
                     "(the small-sliding limit, [solver] load_scale).")
    lines.append("")
    lines += _observation_rows(check) + [""] + _force_rows(check) + [""]
    lines += ["| backend | time per forward solve [s] |", "|---|---|",
              f"| embedded | {check.time_embedded:.3f} (+ {check.setup_embedded:.2f} s condensation once per geometry) |",
              f"| calculix | {check.time_calculix:.2f} |",
              f"| ratio calculix / embedded | {check.time_calculix / max(check.time_embedded, 1e-9):.0f} |"]
    if shift is not None:
        lines += [""] + _shift_rows(check, shift)
    elif note:
        lines += ["", note]
    return "\n".join(lines) + "\n"


def cross_check_config(config) -> tuple[CrossCheck, CoefficientShift | None, str]:
    """A cross-check from a config: [model], [friction] zones (the coefficients), [solver] (CalculiX options),
    and optionally [data] file / observables / regions for the points (default: :func:`default_points`).

    With [data] noise, also the coefficient shift of an identification. When the file has a column for every
    observable (the machine force included), the points and the shift's rows are exactly those an
    identification would fit (values present at [data] stages; the file's sigma columns, else [data] noise).
    Otherwise the shift counts every observable at every point and [data] stage (default: all), weighted by
    [data] noise. Returns (check, shift or None, a note saying why there is no shift).
    """
    from ...backends import solver_options
    from ...builders.registry import build_model
    from ...data.measurements import read_measurements
    from ...inverse.observations import observations_from
    from ...inverse.parameters import Parameters
    from ...simulation import DEFAULT_QUANTITIES

    model = build_model(config.model)
    friction = config.friction
    mu = Parameters.from_config(model.zone_names, friction["zones"], (0.0, 1e6), friction.get("fixed"))
    data, noise = config.data, config.data.get("noise")
    observables = tuple(data.get("observables") or ())
    force = machine_force(model) if FORCE in observables else None
    quantities = tuple(q for q in observables if q != FORCE) or tuple(DEFAULT_QUANTITIES[model.dim])
    source = read_measurements(config.resolve(data["file"])) if data.get("file") else None
    observations = None
    if source is not None and noise and all(q in source.values for q in quantities) and \
            (force is None or not np.all(np.isnan(source.force))):
        observations = observations_from(source, model, observables, data.get("stages")
                                         or list(range(1, model.n_stages + 1)), noise, data.get("regions"))
        points, regions, labels = observations.points, list(observations.point_regions), observations.point_labels
    elif source is not None:
        labels = list(dict.fromkeys(source.points))
        first = {p: i for i, p in reversed(list(enumerate(source.points)))}
        points = np.array([source.coordinates[first[p]][:model.dim] for p in labels])
        table = data.get("regions", {})
        regions = [table.get(p, table.get("*")) for p in labels]
    else:
        points, regions = default_points(model)
    settings = CalculixSettings.from_options(solver_options(config), f"{config.path}: [solver]")
    name = f"{config.path.name} (builder {config.model.get('builder')!r})"
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
        return check, coefficient_shift(check, noise, data.get("stages"), quantities, force), ""
    except InputError as exc:
        raise InputError(f"{config.path}: {exc}") from None
