"""Observations: measured values mapped onto model points, quantities and stage ends, with weights."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data.table import DISPLACEMENTS
from ..errors import InputError
from ..model import Displacement, Model
from ..model.model import component_index, reaction_label

#: the observable for the measurement file's `force` column: the machine force of each stage [N]
FORCE = "force"


def _kind(quantity: str) -> str:
    return FORCE if quantity == FORCE else "u" if quantity in DISPLACEMENTS else "e"


def machine_force(model: Model) -> str:
    """Label ("boundary.axis") of the reaction sum the machine's load cell measures.

    It is the reaction of the one boundary component driven by a non-zero prescribed displacement (the block
    test: "block_top.y"), in the model's frame: positive when the machine pushes the body in +axis.

    Raises
    ------
    InputError
        When the model has no such component (e.g. it is loaded by a prescribed force, which is then known and
        not measured) or more than one.
    """
    driven = list(dict.fromkeys(
        reaction_label(load.boundary, component_index(load.component, model.dim, load.boundary))
        for load in model.loads if isinstance(load, Displacement) and any(v != 0 for v in load.values)))
    if len(driven) != 1:
        raise InputError(f"data.observables: 'force' needs a model driven by one prescribed displacement whose "
                         f"reaction the machine measures; this model drives {driven or 'none'}")
    return driven[0]


@dataclass(frozen=True)
class Observations:
    """The measured values an identification fits.

    Attributes
    ----------
    points : (n_points, dim) [mm] model coordinates of the measurement points
    point_regions : region name (or None) each point must lie in
    quantities : observed quantities, in the order of the backend's rows per point
    row : (n_obs,) backend row (point * n_quantities + quantity) of each observation
    stage : (n_obs,) 0-based stage of each observation
    y : (n_obs,) measured values; sigma : (n_obs,) standard deviations (from the file or data.noise)
    labels : "point:quantity@stage" per observation ("force@stage" for the machine force)
    noise_known : whether sigma is a stated noise level (then chi^2 / dof should be about 1)
    reactions : reaction sums the backend appends after the point rows (the machine force, if observed):
        row ``n_points * len(quantities) + k`` is ``reactions[k]``
    point_labels : the measurement file's label of each point; source : that file, for messages
    """

    points: np.ndarray
    point_regions: tuple
    quantities: tuple[str, ...]
    row: np.ndarray
    stage: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    labels: tuple[str, ...]
    noise_known: bool
    reactions: tuple[str, ...] = ()
    point_labels: tuple[str, ...] = ()
    source: str = ""

    @property
    def n_obs(self) -> int:
        return len(self.y)

    @property
    def weight(self) -> np.ndarray:
        return 1.0 / self.sigma

    def predicted(self, values: np.ndarray) -> np.ndarray:
        """(n_obs,) model values from backend rows at stage ends (n_stages, n_rows)."""
        return values[self.stage, self.row]

    def derivatives(self, derivatives: np.ndarray) -> np.ndarray:
        """(n_obs, n_zones) from (n_stages, n_rows, n_zones)."""
        return derivatives[self.stage, self.row]


def _coordinates(measurements, model: Model):
    if model.kind == "axisymmetric":
        from ..data.measurements import map_to_axisymmetric
        measurements = map_to_axisymmetric(measurements)
        return measurements, measurements.coordinates[:, :2]
    if model.kind == "plane_strain":
        if np.any(np.abs(measurements.coordinates[:, 2]) > 0):
            raise InputError(f"{measurements.source}: a plane-strain model needs points with z = 0")
        return measurements, measurements.coordinates[:, :2]
    return measurements, measurements.coordinates


def noise_of(quantity: str, noise: dict) -> float | None:
    """The stated noise of ``quantity`` from a data.noise table: its own key, else its kind's ("u", "e",
    "force"); None when neither is given.

    >>> noise_of("exy", {"u": 0.0005, "e": 1e-5}), noise_of("uz", {"uz": 0.001}), noise_of("ux", {})
    (1e-05, 0.001, None)
    """
    value = noise.get(quantity, noise.get(_kind(quantity)))
    if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0):
        raise InputError(f"data.noise.{quantity}: must be a positive number, got {value!r}")
    return None if value is None else float(value)


def _sigma(measurements, quantity: str, rows: np.ndarray, noise: dict) -> np.ndarray:
    given = measurements.sigma.get(quantity)
    sigma = np.full(len(rows), np.nan) if given is None else given[rows].astype(float)
    default = noise_of(quantity, noise)
    if default is not None:
        sigma = np.where(np.isnan(sigma), default, sigma)
    return sigma


def observations_from(measurements, model: Model, observables, stages, noise: dict | None = None,
                      regions: dict | None = None) -> Observations:
    """Select ``observables`` at ``stages`` (1-based, as in the file) and map them onto the model."""
    noise, regions = dict(noise or {}), dict(regions or {})
    for stage in stages:
        if not isinstance(stage, int) or not 1 <= stage <= model.n_stages:
            raise InputError(f"data.stages: stage {stage!r} is not one of the model's stages 1..{model.n_stages}")
    observe_force = FORCE in observables
    reactions = (machine_force(model),) if observe_force else ()
    observables = [q for q in observables if q != FORCE]
    wanted = list(observables)
    if model.kind == "axisymmetric" and "ux" in wanted and "uz" in measurements.quantities and "uz" not in wanted:
        wanted.append("uz")                                  # u_r = (ux x + uz z) / r needs both
    measurements = measurements.select(quantities=wanted, stages=list(stages))
    forces = _forces(measurements, stages, noise) if observe_force else []
    measurements, coordinates = _coordinates(measurements, model)
    labels_of = list(dict.fromkeys(measurements.points))
    point_index = {p: i for i, p in enumerate(labels_of)}
    first = {p: i for i, p in reversed(list(enumerate(measurements.points)))}
    points = np.array([coordinates[first[p]] for p in labels_of]).reshape(-1, coordinates.shape[1])
    quantities = tuple(observables)
    row, stage, y, sigma, labels = [], [], [], [], []
    for q_index, quantity in enumerate(quantities):
        values = measurements.values[quantity]
        present = np.flatnonzero(~np.isnan(values))
        sig = _sigma(measurements, quantity, present, noise)
        for i, s in zip(present, sig):
            p = point_index[measurements.points[i]]
            row.append(p * len(quantities) + q_index)
            stage.append(int(measurements.stage[i]) - 1)
            y.append(values[i])
            sigma.append(s)
            labels.append(f"{measurements.points[i]}:{quantity}@{measurements.stage[i]}")
    for stage_number, value, sig in forces:
        row.append(len(points) * len(quantities))
        stage.append(stage_number - 1)
        y.append(value)
        sigma.append(sig)
        labels.append(f"{FORCE}@{stage_number}")
    if not y:
        raise InputError(f"{measurements.source}: no measured values for {list(observables)} at stages {list(stages)}")
    sigma = np.array(sigma)
    noise_known = not np.any(np.isnan(sigma))
    kinds = {_kind(q) for q in quantities} | ({FORCE} if forces else set())
    if not noise_known and len(kinds) > 1:
        raise InputError("data: displacements and strains are observed together without standard deviations; "
                         "give sigma_<column> columns or data.noise (e.g. noise = { u = 0.0005, e = 1e-5, "
                         "force = 1.0 })")
    return Observations(points=points, point_regions=tuple(regions.get(p, regions.get("*")) for p in labels_of),
                        quantities=quantities, row=np.array(row), stage=np.array(stage), y=np.array(y),
                        sigma=np.where(np.isnan(sigma), 1.0, sigma), labels=tuple(labels), noise_known=noise_known,
                        reactions=reactions, point_labels=tuple(labels_of), source=str(measurements.source))


def _forces(measurements, stages, noise: dict) -> list[tuple[int, float, float]]:
    """(stage, machine force [N], sigma or nan) of each observed stage, from the file's `force` column."""
    sigma = noise.get(FORCE, np.nan)
    if not (isinstance(sigma, (int, float)) and not isinstance(sigma, bool) and (np.isnan(sigma) or sigma > 0)):
        raise InputError(f"data.noise.{FORCE}: must be a positive number, got {sigma!r}")
    out = []
    for stage in stages:
        value = measurements.stage_force(stage)
        if np.isnan(value):
            raise InputError(f"{measurements.source}: data.observables has 'force' but no row of stage {stage} "
                             "gives the machine force (column 'force')")
        out.append((int(stage), float(value), float(sigma)))
    return out
