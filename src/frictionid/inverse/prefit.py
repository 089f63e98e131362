"""Pre-fit check: before fitting, which zones the planned data resolve, and which added points or stages would.

The weighted Jacobian of the planned observations at the start coefficients is taken from the evaluator (so
the identification reuses it, and a resumed run replays it from the store). When a zone is not resolved, the
observed quantities at candidate points spread over the visible surfaces of every region, and the observed
points at stages not used, are solved once with sensitivities and ranked by :func:`inverse.resolution.suggest`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..model import Model
from ..backends.base import BackendFactory
from .observations import DISPLACEMENTS, Observations
from .resolution import Addition, Resolution, resolution, suggest

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Prefit:
    """The resolution of the planned data and, where zones are unresolved, the suggested additions."""

    resolution: Resolution
    additions: tuple[Addition, ...]
    note: str = ""

    def as_dict(self) -> dict:
        names = self.resolution.names
        return {**self.resolution.as_dict(), "note": self.note,
                "suggestions": [{"observation": a.label,
                                 "stderr_after": {n: (float(v) if np.isfinite(v) else None)
                                                  for n, v in zip(names, a.stderr)}} for a in self.additions]}


def spread_points(points: np.ndarray, n_max: int) -> np.ndarray:
    """Indices of at most n_max points spread evenly (farthest-point sampling from the first point).

    >>> spread_points(np.array([[0.0], [0.1], [1.0], [2.0]]), 3).tolist()
    [0, 3, 2]
    """
    if len(points) <= n_max:
        return np.arange(len(points))
    chosen = [0]
    distance = np.linalg.norm(points - points[0], axis=1)
    for _ in range(n_max - 1):
        k = int(np.argmax(distance))
        chosen.append(k)
        distance = np.minimum(distance, np.linalg.norm(points - points[k], axis=1))
    return np.array(chosen)


def _hidden_surface(model: Model) -> tuple[np.ndarray, np.ndarray, float]:
    """(contact-side zone nodes, every hidden node, median zone facet edge [mm]): hidden are the zone nodes and
    the target nodes facing them (within half an edge); the rest of a target surface is in view."""
    zones = [z for i in model.interfaces for z in i.zones]
    if not zones:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), 0.0
    points, mesh = model.mesh.points, model.mesh
    facets = np.concatenate([mesh.boundary(z) for z in zones])
    edge = float(np.median(np.linalg.norm(points[facets[:, 1]] - points[facets[:, 0]], axis=1)))
    zone_nodes = np.unique(facets)
    targets = np.unique(np.concatenate([mesh.boundary_nodes(i.target) for i in model.interfaces]))
    facing = targets[cKDTree(points[zone_nodes]).query(points[targets])[0] <= edge / 2]
    return zone_nodes, np.union1d(zone_nodes, facing), edge


def candidate_points(model: Model, observed: np.ndarray, n_max: int = 120) -> tuple[np.ndarray, list[str]]:
    """(n, dim) points spread over the visible surfaces of every region, and the region of each.

    Contact surfaces (and the target surfaces facing them) are hidden and no candidates, unless an observed
    point already lies on one (a cut-out that shows the thread flanks).
    """
    names = list(model.mesh.regions)
    zone_nodes, hidden, edge = _hidden_surface(model)
    observed = np.asarray(observed, dtype=float)
    if len(zone_nodes) and len(observed) and \
            np.any(cKDTree(model.mesh.points[zone_nodes]).query(observed)[0] <= edge / 2):
        hidden = hidden[:0]
    points, owner = [], []
    for name in names:
        nodes = np.setdiff1d(model.mesh.surface_nodes(name), hidden)
        xyz = model.mesh.points[nodes]
        keep = spread_points(xyz, max(n_max // len(names), 1))
        points.append(xyz[keep])
        owner += [name] * len(keep)
    return np.concatenate(points), owner


def _point_rows(obs: Observations) -> np.ndarray:
    """(n_obs,) bool: observations of a quantity at a point (not a reaction row such as the machine force)."""
    return obs.point >= 0


def _sigma_of(obs: Observations, quantity: str) -> float | None:
    """Median standard deviation of the observed point quantities of the same kind (displacement or strain)."""
    at_points = _point_rows(obs)
    observed = obs.quantity[at_points]
    same = np.array([(q in DISPLACEMENTS) == (quantity in DISPLACEMENTS) for q in observed], dtype=bool)
    return float(np.median(obs.sigma[at_points][same])) if same.any() else None


def _derivatives_at(backend, backend_factory, model: Model, points, quantities, regions, mu) -> np.ndarray:
    """(n_stages, n_points * n_quantities, n_zones) derivatives at ``points``: from the fit's own backend where it
    gives them without condensing again (the embedded backend's point_sensitivities), else from a backend made for
    the points by ``backend_factory``."""
    at_points = getattr(backend, "point_sensitivities", None)
    derivatives = None if at_points is None else at_points(mu, points, quantities, regions)
    if derivatives is None:
        derivatives = backend_factory(model, points, quantities, regions).predict(mu, True).derivatives
    return derivatives


def _candidate_groups(backend, backend_factory, model: Model, obs: Observations, mu: np.ndarray,
                      free: np.ndarray, n_points: int):
    """(label, weighted rows) per candidate point and stage: surface points, and the observed points at
    stages not observed; quantities = the observed ones plus every displacement component."""
    quantities = tuple(dict.fromkeys(obs.quantities + DISPLACEMENTS[:model.dim]))
    sigma = np.array([_sigma_of(obs, q) or np.nan for q in quantities])
    quantities = tuple(q for q, s in zip(quantities, sigma) if np.isfinite(s))
    sigma = sigma[np.isfinite(sigma)]
    surface, owner = candidate_points(model, obs.points, n_points)
    points = np.concatenate([obs.points, surface])
    regions = list(obs.point_regions) + owner
    derivatives = _derivatives_at(backend, backend_factory, model, points, quantities, regions, mu)
    at_points = _point_rows(obs)
    n_q = len(quantities)
    observed = set(zip(obs.point[at_points], obs.stage[at_points]))
    groups = []
    for stage in range(model.n_stages):
        for p, xyz in enumerate(points):
            if p < len(obs.points) and (p, stage) in observed:
                continue
            rows = derivatives[stage, p * n_q:(p + 1) * n_q][:, free] / sigma[:, None]
            where = ", ".join(f"{v:.3f}" for v in xyz)
            label = obs.point_labels[p] if p < len(obs.point_labels) else str(p)
            name = f"observed point {label!r}" if p < len(obs.points) else f"({where}) in {regions[p]}"
            groups.append((f"{'+'.join(quantities)} at {name}, stage {stage + 1}", rows))
    return groups


def prefit(evaluator, model: Model, tolerance: float, max_additions: int = 5, backend_factory: BackendFactory | None = None,
           n_points: int = 120) -> Prefit:
    """The pre-fit resolution at the evaluator's start point, with suggestions for unresolved zones.

    ``backend_factory(model, points, quantities, regions)`` makes a backend with sensitivities for the
    candidate points; without one (or with ``max_additions`` = 0) no additions are proposed.
    """
    params, obs = evaluator.params, evaluator.obs
    jacobian = evaluator.jacobian(params.x0)[:obs.n_obs]
    found = resolution(jacobian, params.free_names, tolerance)
    if found.resolved.all():
        return Prefit(found, ())
    if backend_factory is None or max_additions <= 0:
        return Prefit(found, (), "no candidate observations were evaluated (backend without sensitivities "
                                 "or suggestions switched off)")
    groups = _candidate_groups(getattr(evaluator, "backend", None), backend_factory, model, obs,
                               params.full(params.x0), params.free, n_points)
    additions = tuple(suggest(jacobian, groups, tolerance, max_additions))
    note = "" if additions else "no candidate point or stage lowers the unresolved zones' standard errors"
    return Prefit(found, additions, note)
