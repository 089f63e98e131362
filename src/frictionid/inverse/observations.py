"""Observations: measured values mapped onto model points, quantities and stage ends, with weights."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data.table import CHANNELS, DISPLACEMENTS, PLANE_TOL
from ..errors import InputError
from ..fem.points import QUANTITIES
from ..model import Model
from ..options import DataSpec
from .point_regions import region_of_points
from .reactions import FORCE, STAGE_OBSERVABLES, channel_reaction


def _kind(quantity: str) -> str:
    return quantity if quantity in STAGE_OBSERVABLES else "u" if quantity in DISPLACEMENTS else "e"


def label_parts(label: str) -> tuple[str, str, str]:
    """(point, quantity, stage) of an observation label as :func:`observations_from` writes them: "point:quantity@
    stage", or "quantity@stage" for a per-stage observable (point ""; a specimen's "S1/force@2" keeps its
    prefix in the quantity). Code that has the :class:`Observations` reads its arrays; this reads result.json.

    >>> label_parts("F12:exx@2"), label_parts("force@3")
    (('F12', 'exx', '2'), ('', 'force', '3'))
    """
    body, _, stage = label.rpartition("@")
    point, _, quantity = body.rpartition(":")
    return point, quantity, stage


def split_observables(observables) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(point quantities, per-stage observables) of a ``[data] observables`` list, each in its given order: the
    quantities measured at points (displacements, strains) and the reaction sums of one value per stage
    (:data:`STAGE_OBSERVABLES`: force, torque, clamp).

    >>> split_observables(["ux", "torque", "exx", "force"])
    (('ux', 'exx'), ('torque', 'force'))
    """
    observables = tuple(observables)
    return (tuple(q for q in observables if q not in STAGE_OBSERVABLES),
            tuple(q for q in observables if q in STAGE_OBSERVABLES))


def default_quantities(model: Model) -> tuple[str, ...]:
    """The point quantities a model of its kind gives (:data:`frictionid.fem.points.QUANTITIES`) but plane
    strain's ezz, zero by definition: what ``frictionid simulate`` writes and the cross-check compares when
    ``[data] observables`` names none (an axisymmetric model's ezz is its hoop strain, u_r / r)."""
    return tuple(q for q in QUANTITIES[model.kind] if not (q == "ezz" and model.kind == "plane_strain"))


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
    labels : "point:quantity@stage" per observation ("force@stage" for the machine force, "torque@stage",
        "clamp@stage" for the channels of a tightening test)
    noise_known : whether sigma is a stated noise level (then chi^2 / dof should be about 1)
    reactions : reaction sums the backend appends after the point rows (the machine force, torque and clamp
        force, those observed, in that order): row ``n_points * len(quantities) + k`` is ``reactions[k]``;
        y and sigma of those rows are in the model's units (N mm, N)
    point_labels : the measurement file's label of each point; source : that file, for messages
    minus_row : (n_obs,) backend row subtracted from ``row``'s value (-1: none): a displacement measured relative
        to a reference point's ([data] relative_to) is predicted as the difference of the two points' values
    channels : the per-stage observable of each reaction row ("force", "torque", "clamp"; default "force")

    Per observation, from the rows (the labels are for people and files; code reads these): ``point`` (index
    into ``points``, -1 for a per-stage observable), ``quantity`` (the quantity or the per-stage observable),
    ``kind`` ("u", "e", or the per-stage observable).
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
    minus_row: np.ndarray | None = None
    channels: tuple[str, ...] = ()

    @property
    def n_obs(self) -> int:
        return len(self.y)

    @property
    def n_point_rows(self) -> int:
        """Backend rows of the points (the reaction rows follow)."""
        return len(self.points) * len(self.quantities)

    @property
    def point(self) -> np.ndarray:
        """(n_obs,) index into ``points`` of each observation; -1 for a per-stage observable."""
        row = np.asarray(self.row, dtype=np.int64)
        return np.where(row < self.n_point_rows, row // max(len(self.quantities), 1), -1)

    @property
    def quantity(self) -> np.ndarray:
        """(n_obs,) the quantity ("ux", "exx", ...) or per-stage observable ("force", ...) of each observation."""
        channels = self.channels or (FORCE,) * len(self.reactions)
        names = np.array(list(self.quantities) + list(channels) or [""], dtype=object)
        row = np.asarray(self.row, dtype=np.int64)
        at = np.where(row < self.n_point_rows, row % max(len(self.quantities), 1),
                      len(self.quantities) + row - self.n_point_rows)
        return names[at]

    @property
    def kind(self) -> np.ndarray:
        """(n_obs,) "u" (a displacement), "e" (a strain) or the per-stage observable of each observation."""
        return np.array([_kind(q) for q in self.quantity], dtype=object)

    @property
    def weight(self) -> np.ndarray:
        return 1.0 / self.sigma

    def predicted(self, values: np.ndarray) -> np.ndarray:
        """(n_obs,) model values from backend rows at stage ends (n_stages, n_rows)."""
        return self._relative(values[self.stage, self.row], values)

    def derivatives(self, derivatives: np.ndarray) -> np.ndarray:
        """(n_obs, n_zones) from (n_stages, n_rows, n_zones)."""
        return self._relative(derivatives[self.stage, self.row], derivatives)

    def _relative(self, at_rows: np.ndarray, values: np.ndarray) -> np.ndarray:
        if self.minus_row is None or not np.any(self.minus_row >= 0):
            return at_rows
        relative = self.minus_row >= 0
        out = at_rows.copy()
        out[relative] -= values[self.stage[relative], self.minus_row[relative]]
        return out


def _coordinates(measurements, model: Model):
    if model.kind == "axisymmetric":
        from ..data.measurements import map_to_axisymmetric
        measurements = map_to_axisymmetric(measurements)
        return measurements, measurements.coordinates[:, :2]
    if model.kind == "axisymmetric_twist":
        # no mapping of points off the x-y plane yet: there uz is u_t only at z = 0, x >= 0
        size = max(1.0, float(np.abs(measurements.coordinates).max(initial=0.0)))
        off = (np.abs(measurements.coordinates[:, 2]) > PLANE_TOL * size) | (measurements.coordinates[:, 0] < 0)
        if np.any(off):
            raise InputError(f"{measurements.source}: an axisymmetric model with twist needs points on the x-y plane "
                             f"at x >= 0 (z = 0), where uz is the circumferential displacement; {int(off.sum())} "
                             "point(s) are not")
        return measurements, measurements.coordinates[:, :2]
    if model.kind == "plane_strain":
        # a frame turned about z by a fitted or typed angle leaves round-off in z
        size = max(1.0, float(np.abs(measurements.coordinates).max(initial=0.0)))
        if np.any(np.abs(measurements.coordinates[:, 2]) > PLANE_TOL * size):
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


def observations_from(measurements, model: Model, data: DataSpec, relative: dict | None = None,
                      specimens: dict | None = None) -> Observations:
    """Select ``data.observables`` at ``data.stages`` (1-based, as in the file) and map them onto the model.

    ``data.regions`` (the ``[data] regions`` table) is resolved by :func:`region_of_points` against every point
    of the file (also those of stages not fitted); ``data.noise`` weights the rows the file gives no sigma.
    ``relative`` (point label -> reference label, from ``[data] relative_to``): that point's displacements are
    fitted as its displacement minus the reference's at the same stage, in the data and in the model (the
    reference's own displacements are then not fitted). ``specimens`` (point label -> specimen): each specimen's
    machine force is an observation of its own (of the same model reaction: specimens share the model and its
    load path). The per-stage observables ``torque`` and ``clamp`` (columns of that name, file units N m and N;
    noise in the same units) are reaction sums of the model too, found by :func:`channel_reaction` from
    ``data.reactions`` (the ``[data] reactions`` table)."""
    observables, stages, reactions = data.observables, data.stages, data.reactions
    noise, regions, relative = dict(data.noise or {}), dict(data.regions or {}), dict(relative or {})
    for stage in stages:
        if not isinstance(stage, int) or not 1 <= stage <= model.n_stages:
            raise InputError(f"data.stages: stage {stage!r} is not one of the model's stages 1..{model.n_stages}")
    channels = [c for c in STAGE_OBSERVABLES if c in observables]
    reactions = tuple(channel_reaction(model, c, reactions) for c in channels)
    observables = list(split_observables(observables)[0])
    wanted = list(observables)
    if model.kind == "axisymmetric" and "ux" in wanted and "uz" in measurements.quantities and "uz" not in wanted:
        wanted.append("uz")                                  # u_r = (ux x + uz z) / r needs both
    all_labels = measurements.points
    measurements = measurements.select(quantities=wanted, stages=list(stages))
    forces = [(k, *f) for k, c in enumerate(channels) for f in _forces(measurements, stages, noise,
                                                                       dict(specimens or {}), c)]
    measurements, coordinates = _coordinates(measurements, model)
    labels_of = list(dict.fromkeys(measurements.points))
    region_of = region_of_points(regions, all_labels, model.mesh.region_names)
    point_index = dict(zip(labels_of, range(len(labels_of))))
    n_rows = len(measurements.points)
    first = dict(zip(reversed(measurements.points), range(n_rows - 1, -1, -1)))       # each label's first row
    points = coordinates[[first[p] for p in labels_of]].reshape(-1, coordinates.shape[1])
    quantities = tuple(observables)
    row, stage, y, sigma, labels, minus = [], [], [], [], [], []
    at = {(p, int(s)): i for i, (p, s) in enumerate(zip(measurements.points, measurements.stage))} if relative \
        else {}
    point_of = np.fromiter(map(point_index.__getitem__, measurements.points), dtype=np.int64, count=n_rows)
    names, at_stage = measurements.points, [f"@{s}" for s in measurements.stage.tolist()]   # labels' parts per row
    for q_index, quantity in enumerate(quantities):
        values = measurements.values[quantity]
        present = np.flatnonzero(~np.isnan(values))
        sig = _sigma(measurements, quantity, present, noise)
        if not (relative and quantity in DISPLACEMENTS):      # whole columns at once (a full field: 1e5 values)
            row.extend((point_of[present] * len(quantities) + q_index).tolist())
            stage.extend((measurements.stage[present].astype(np.int64) - 1).tolist())
            y.extend(values[present].tolist())
            minus.extend([-1] * len(present))
            sigma.extend(sig.tolist())
            suffix = f":{quantity}"                           # "<point>:<quantity>@<stage>"
            labels.extend(names[i] + suffix + at_stage[i] for i in present.tolist())
            continue
        for i, s in zip(present, sig):
            label, reference = measurements.points[i], relative.get(measurements.points[i])
            if reference is None:
                pass
            elif reference == label:
                continue                            # its displacement relative to itself: zero, nothing to fit
            p = point_index[label]
            row.append(p * len(quantities) + q_index)
            stage.append(int(measurements.stage[i]) - 1)
            y.append(values[i] - (0.0 if reference is None else
                                  _reference_value(measurements, at, reference, quantity, i)))
            minus.append(-1 if reference is None else point_index[reference] * len(quantities) + q_index)
            sigma.append(s)
            labels.append(f"{label}:{quantity}@{measurements.stage[i]}")
    for k, specimen, stage_number, value, sig in forces:
        minus.append(-1)
        row.append(len(points) * len(quantities) + k)
        stage.append(stage_number - 1)
        y.append(value)
        sigma.append(sig)
        labels.append(f"{'' if specimen is None else specimen + '/'}{channels[k]}@{stage_number}")
    if not y:
        raise InputError(f"{measurements.source}: no measured values for {list(observables)} at stages {list(stages)}")
    sigma = np.array(sigma)
    noise_known = not np.any(np.isnan(sigma))
    kinds = {_kind(q) for q in quantities} | set(channels)
    observations = Observations(
        points=points, point_regions=tuple(map(region_of.__getitem__, labels_of)), quantities=quantities,
        row=np.array(row), stage=np.array(stage), y=np.array(y), sigma=np.where(np.isnan(sigma), 1.0, sigma),
        labels=tuple(labels), noise_known=noise_known, reactions=reactions, point_labels=tuple(labels_of),
        source=str(measurements.source), minus_row=np.array(minus, dtype=np.int64) if relative else None,
        channels=tuple(channels))
    if not noise_known and len(kinds) > 1:
        raise InputError(_unweighted(observations.quantity, sigma))
    return observations


#: what a data.noise key of each kind of observable is, for messages
_NOISE_EXAMPLES = {"u": ("u = 0.0005", "mm"), "e": ("e = 1e-5", "strain"), FORCE: ("force = 1.0", "N"),
                   "torque": ("torque = 0.1", "N m"), "clamp": ("clamp = 10.0", "N")}


def _unweighted(quantities, sigma: np.ndarray) -> str:
    """The message for observables of different kinds (units) fitted together where some have no stated noise
    (``quantities``, ``sigma``: per observation): it names those."""
    missing = list(dict.fromkeys(q for q, s in zip(quantities, sigma) if np.isnan(s)))
    given = list(dict.fromkeys(q for q, s in zip(quantities, sigma) if not np.isnan(s)))
    keys = list(dict.fromkeys(_kind(q) for q in missing))
    what = (f"{', '.join(missing)} {'is' if len(missing) == 1 else 'are'} observed with {', '.join(given)} but "
            "without a standard deviation" if given else
            f"{', '.join(missing)} are observed together without standard deviations")
    example = ", ".join(_NOISE_EXAMPLES[k][0] for k in keys)
    units = ", ".join(f"{k} in {_NOISE_EXAMPLES[k][1]}" for k in keys)
    return (f"data.noise: {what}; quantities of different units are weighted by their noise: give e.g. "
            f"noise = {{ {example} }} ({units}) or sigma_<column> columns")


def _reference_value(measurements, at: dict, reference: str, quantity: str, i: int) -> float:
    """The reference point's measured ``quantity`` at row ``i``'s stage (relative_to)."""
    stage = int(measurements.stage[i])
    j = at.get((reference, stage))
    value = np.nan if j is None else measurements.values[quantity][j]
    if np.isnan(value):
        raise InputError(f"{measurements.source}: data.relative_to: point {measurements.points[i]!r} is measured "
                         f"relative to {reference!r}, which has no {quantity} at stage {stage}")
    return float(value)


def _forces(measurements, stages, noise: dict, specimens: dict,
            channel: str = FORCE) -> list[tuple[str | None, int, float, float]]:
    """(specimen or None, stage, value, sigma or nan) of each specimen and observed stage, from the files'
    ``channel`` column (`force` [N], or `torque` [N m] / `clamp` [N], returned in the model's N mm / N); the
    views of one specimen must agree."""
    sigma = noise.get(channel, np.nan)
    if not (isinstance(sigma, (int, float)) and not isinstance(sigma, bool) and (np.isnan(sigma) or sigma > 0)):
        raise InputError(f"data.noise.{channel}: must be a positive number, got {sigma!r}")
    what, unit, scale = ("machine force", "N", 1.0) if channel == FORCE else CHANNELS[channel]
    column = measurements.force if channel == FORCE else measurements.channels.get(channel)
    if column is None:
        raise InputError(f"{measurements.source}: data.observables has {channel!r} but the data have no column "
                         f"{channel!r} ({what} [{unit}] of each stage)")
    of = np.array([specimens.get(p, "") for p in measurements.points])
    out = []
    for specimen in dict.fromkeys(of.tolist()):
        for stage in stages:
            rows = (of == specimen) & (measurements.stage == stage)
            given = np.unique(column[rows & ~np.isnan(column)])
            whose = f"specimen {specimen!r}: " if specimen else ""
            if not len(given):
                source = "column 'force', or a file's force" if channel == FORCE else f"column {channel!r}"
                raise InputError(f"{measurements.source}: {whose}data.observables has {channel!r} but no row of stage "
                                 f"{stage} gives the {what} ({source})")
            if len(given) > 1:
                raise InputError(f"{measurements.source}: {whose}stage {stage} has the {what}s "
                                 f"{', '.join(f'{f:g}' for f in given)} {unit} from different files; the views of one "
                                 "stage share one value (several specimens: give each file its specimen)")
            out.append((specimen or None, int(stage), scale * float(given[0]), scale * float(sigma)))
    return out
