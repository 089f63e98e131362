"""The Measurements table: measured displacements and strains per point and stage, and its mapping onto (r, y)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from itertools import compress

import numpy as np

from ..errors import InputError

#: columns every measurement file has
REQUIRED = ("point", "x", "y", "z", "stage")
#: measured quantities in canonical order: displacements [mm], small-strain tensor components [-] (tensor shear)
QUANTITIES = ("ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz")
DISPLACEMENTS = QUANTITIES[:3]
STRAINS = QUANTITIES[3:]
UNITS = {**{q: "mm" for q in DISPLACEMENTS}, **{q: "-" for q in STRAINS}}
#: per-stage channels of a tightening test besides the machine force: name -> (what, unit in the file, factor
#: from the file's unit to the model's N mm / N); like ``force``, every row of a stage gives the same value
CHANNELS = {"torque": ("wrench torque", "N m", 1000.0), "clamp": ("clamp force (load cell)", "N", 1.0)}
#: a comment line a writer can put first so that the file states its units (docs/design.md, conventions)
UNITS_COMMENT = "units: x, y, z, ux, uy, uz [mm] (undeformed coordinates); strains [-], tensor shear; force [N]"
#: |z| / r below this counts as "in the x-y plane" when mapping onto an axisymmetric model
PLANE_TOL = 1e-9


def comment_text(line: str) -> str:
    """A comment line without its leading ``#`` marks and surrounding spaces (how comments are kept)."""
    return str(line).lstrip("# \t").rstrip()


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))


def _same_columns(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)


def _columns(columns: dict, n: int, what: str) -> dict:
    unknown = [q for q in columns if q not in QUANTITIES]
    if unknown:
        raise ValueError(f"{what}: {unknown} are not measured quantities {QUANTITIES}")
    arrays = {q: np.asarray(columns[q], dtype=float) for q in QUANTITIES if q in columns}
    if any(a.shape != (n,) for a in arrays.values()):
        raise ValueError(f"{what}: every column must have shape ({n},)")
    return arrays


@dataclass(frozen=True, eq=False)
class Measurements:
    """Measured values at points (undeformed coordinates, model frame) and stages of the load path.

    One row per (point, stage). Equality compares the content (every field except ``source``), with
    missing values (nan) equal to each other, so that reading back a written file gives an equal object.

    Attributes
    ----------
    points : (n,) point labels, one per row (a point measured at two stages has two rows)
    coordinates : (n, 3) [mm] undeformed x, y, z
    stage : (n,) int, 1-based stage of the model's load path
    force : (n,) [N] machine force of the row's stage, nan where not given
    values : quantity -> (n,) measured values (mm or -), nan for empty cells; only the columns of the file
    sigma : quantity -> (n,) standard deviations of ``values[quantity]``, nan where not given
    comments : the file's comment lines (units, provenance), kept without their leading ``#`` marks
    source : where the measurements came from (file path), for messages
    channels : name of :data:`CHANNELS` -> (n,) value of the row's stage in the file's unit (torque N m, clamp
        force N), nan where not given; only the columns of the file

    Examples
    --------
    >>> m = Measurements(points=("P1",), coordinates=[[9.0, 80.0, 0.0]], stage=[2], force=[20000.0],
    ...                  values={"uy": [0.012]})
    >>> m.quantities, m.stages
    (('uy',), (2,))
    """

    points: tuple[str, ...]
    coordinates: np.ndarray
    stage: np.ndarray
    force: np.ndarray
    values: dict[str, np.ndarray]
    sigma: dict[str, np.ndarray] = field(default_factory=dict)
    comments: tuple[str, ...] = ()
    source: str = ""
    channels: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self):
        n = len(self.points)
        stage = np.asarray(self.stage)
        set_ = object.__setattr__
        plain = isinstance(self.points, tuple) and set(map(type, self.points)) <= {str}   # 1e5 labels: ms
        set_(self, "points", self.points if plain else tuple(str(p) for p in self.points))
        set_(self, "coordinates", np.asarray(self.coordinates, dtype=float).reshape(n, 3))
        set_(self, "stage", stage.astype(int).reshape(n))
        set_(self, "force", np.asarray(self.force, dtype=float).reshape(n))
        set_(self, "values", _columns(self.values, n, "values"))
        set_(self, "sigma", _columns(self.sigma, n, "sigma"))
        set_(self, "comments", tuple(comment_text(c) for c in self.comments))
        if set(self.channels) - set(CHANNELS):
            raise ValueError(f"channels: {sorted(set(self.channels) - set(CHANNELS))} are not among {list(CHANNELS)}")
        set_(self, "channels", {c: np.asarray(self.channels[c], dtype=float).reshape(n)
                                for c in CHANNELS if c in self.channels})
        if not set(self.sigma) <= set(self.values):
            raise ValueError(f"sigma of {sorted(set(self.sigma) - set(self.values))} without values")

    def __eq__(self, other):
        if not isinstance(other, Measurements):
            return NotImplemented
        return (self.points == other.points and self.comments == other.comments
                and _same(self.coordinates, other.coordinates) and _same(self.stage, other.stage)
                and _same(self.force, other.force) and _same_columns(self.values, other.values)
                and _same_columns(self.sigma, other.sigma) and _same_columns(self.channels, other.channels))

    @property
    def n_rows(self) -> int:
        return len(self.points)

    def digest(self) -> str:
        """SHA-256 of the content (every field but ``source`` and ``comments``): equal measurements, equal digest."""
        h = hashlib.sha256("\n".join(self.points).encode())
        for array in (self.coordinates, self.stage.astype(np.int64), self.force):
            h.update(np.ascontiguousarray(array).tobytes())
        for kind, columns in (("v", self.values), ("s", self.sigma), ("c", self.channels)):
            for name in sorted(columns):
                h.update(f"{kind}:{name}".encode())
                h.update(np.ascontiguousarray(columns[name], dtype=float).tobytes())
        return h.hexdigest()

    @property
    def n_points(self) -> int:
        """Number of distinct point labels."""
        return len(set(self.points))

    @property
    def quantities(self) -> tuple[str, ...]:
        """The measured quantities present, in canonical order (ux, uy, uz, exx, ..., exz)."""
        return tuple(self.values)

    @property
    def stages(self) -> tuple[int, ...]:
        return tuple(int(s) for s in np.unique(self.stage))

    def stage_force(self, stage: int) -> float:
        """Machine force [N] of ``stage`` (nan if no row of that stage gives one)."""
        given = self.force[(self.stage == stage) & ~np.isnan(self.force)]
        return float(given[0]) if len(given) else float("nan")

    def select(self, quantities=None, stages=None) -> "Measurements":
        """The rows of ``stages`` and the columns ``quantities`` (None: all).

        Raises
        ------
        InputError
            A quantity that is not a column of these measurements, or a stage without rows; the message
            lists what exists.
        """
        names = self.quantities if quantities is None else self._known_quantities(quantities)
        rows = np.ones(self.n_rows, bool) if stages is None else np.isin(self.stage, self._known_stages(stages))
        return Measurements(
            points=self.points if rows.all() else tuple(compress(self.points, rows.tolist())),
            coordinates=self.coordinates[rows],
            stage=self.stage[rows], force=self.force[rows],
            values={q: self.values[q][rows] for q in names},
            sigma={q: self.sigma[q][rows] for q in names if q in self.sigma},
            comments=self.comments, source=self.source, channels={c: v[rows] for c, v in self.channels.items()})

    def _known_quantities(self, quantities) -> list[str]:
        quantities = [quantities] if isinstance(quantities, str) else list(quantities)
        for q in quantities:
            if q not in self.values:
                raise InputError(f"{self.source or 'measurements'}: no measured quantity {q!r}; "
                                 f"the measured quantities are {', '.join(self.quantities) or 'none'}")
        return quantities

    def _known_stages(self, stages) -> list[int]:
        stages = [stages] if np.isscalar(stages) else list(stages)
        for s in stages:
            if isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s not in self.stages:
                raise InputError(f"{self.source or 'measurements'}: no rows at stage {s!r}; "
                                 f"the stages measured are {', '.join(map(str, self.stages))}")
        return stages

    def observations(self) -> list[tuple[int, str, float, float]]:
        """(row, quantity, value, sigma) of every measured (non-missing) value, by row, then quantity.

        sigma is nan where the file gives no standard deviation.
        """
        found = []
        for row in range(self.n_rows):
            for q, column in self.values.items():
                if not np.isnan(column[row]):
                    sigma = self.sigma[q][row] if q in self.sigma else np.nan
                    found.append((row, q, float(column[row]), float(sigma)))
        return found

    def summary(self) -> str:
        """A few lines describing the measurements (what ``frictionid check-data`` prints)."""
        stages = ", ".join(f"{s} ({np.count_nonzero(self.stage == s)} rows, {_force(self.stage_force(s))})"
                           for s in self.stages)
        n_missing = sum(int(np.isnan(v).sum()) for v in self.values.values())
        sigmas = [f"sigma_{q} ({np.count_nonzero(~np.isnan(s))} given)" for q, s in self.sigma.items()]
        channels = [f"{c} [{CHANNELS[c][1]}] " + ", ".join(f"{s}: {_stage_value(v, self.stage == s)}"
                                                           for s in self.stages) for c, v in self.channels.items()]
        lines = [f"file: {self.source or '(not from a file)'}",
                 f"comments: {len(self.comments)} lines",
                 f"points: {self.n_points}, rows: {self.n_rows}",
                 f"stages: {stages or 'none'}",
                 f"{'quantity':<9}{'unit':<5}{'count':>6}{'missing':>8}{'min':>13}{'max':>13}{'mean':>13}",
                 *(_quantity_line(q, v) for q, v in self.values.items()),
                 *channels,
                 f"sigma columns: {', '.join(sigmas) or 'none'}",
                 f"missing cells: {n_missing} of {self.n_rows * len(self.values)}"]
        return "\n".join(lines)


def _force(value: float) -> str:
    return "no force given" if np.isnan(value) else f"force {value:.6g} N"


def _stage_value(column: np.ndarray, rows: np.ndarray) -> str:
    given = column[rows & ~np.isnan(column)]
    return f"{given[0]:.6g}" if len(given) else "-"


def _quantity_line(q: str, column: np.ndarray) -> str:
    given = column[~np.isnan(column)]
    stats = [f"{v:>13.6g}" for v in (given.min(), given.max(), given.mean())] if len(given) else [f"{'-':>13}"] * 3
    return f"{q:<9}{UNITS[q]:<5}{len(given):>6}{len(column) - len(given):>8}" + "".join(stats)


def map_to_axisymmetric(measurements: Measurements) -> Measurements:
    """Measurements at 3-D points mapped onto an axisymmetric model (axis y, x = r; docs/design.md, conventions).

    - Coordinates: (x, y, z) -> (r, y, 0) with r = sqrt(x^2 + z^2).
    - Displacements: ``ux`` becomes u_r = (ux x + uz z) / r (sigma: independent errors propagated);
      the circumferential part is dropped; ``uy`` is unchanged; ``uz`` is consumed. A point on the axis
      (r = 0) with ux or uz, and a row that has one of ux, uz but not the other one u_r needs, are errors.
    - Strains: ``eyy`` (along the axis) is unchanged everywhere. ``exx``, ``ezz``, ``exy`` pass through as
      e_rr, e_theta, e_ry only at points in the x-y plane with x > 0 (|z| <= PLANE_TOL r); elsewhere they
      would need a tensor rotation, which is not done, so they are errors. ``eyz`` and ``exz`` have no
      axisymmetric counterpart (zero without torsion) and are errors.

    Errors concern measured (non-missing) values only. The result's columns follow the axisymmetric
    model's names: ux = u_r, exx = e_rr, ezz = e_theta, exy = e_ry; a comment line records the mapping.

    Raises
    ------
    InputError
        Naming the point, stage and column that cannot be mapped.

    Examples
    --------
    >>> m = Measurements(points=("P",), coordinates=[[3.0, 5.0, 4.0]], stage=[1], force=[float("nan")],
    ...                  values={"ux": [0.3], "uz": [0.4]})
    >>> a = map_to_axisymmetric(m)
    >>> a.coordinates[0].tolist(), round(float(a.values["ux"][0]), 12)
    ([5.0, 5.0, 0.0], 0.5)
    """
    m = measurements
    x, y, z = m.coordinates.T
    r = np.hypot(x, z)
    values, sigma = {}, {}
    if "ux" in m.values or "uz" in m.values:
        values["ux"], sigma["ux"] = _radial_displacement(m, r)
    for q in ("uy",) + STRAINS:
        if q in m.values:
            _check_strain_mappable(m, q, r)
            values[q] = m.values[q]
            if q in m.sigma:
                sigma[q] = m.sigma[q]
    if not (set(m.sigma) & {"ux", "uz"}):
        sigma.pop("ux", None)
    note = "mapped to axisymmetric (x = r, y = axis): ux = u_r, exx = e_rr, ezz = e_theta, exy = e_ry"
    return Measurements(points=m.points, coordinates=np.column_stack([r, y, np.zeros_like(r)]), stage=m.stage,
                        force=m.force, values=values, sigma=sigma, comments=m.comments + (note,), source=m.source,
                        channels=m.channels)


def _where(m: Measurements, row: int) -> str:
    x, y, z = m.coordinates[row]
    return (f"{m.source or 'measurements'}: point {m.points[row]!r} (stage {m.stage[row]}, "
            f"x = {x:g}, y = {y:g}, z = {z:g} mm)")


def _radial_displacement(m: Measurements, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """u_r = (ux x + uz z) / r and its standard deviation, per row (nan where neither is measured)."""
    n = m.n_rows
    missing = np.full(n, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        weights = {"ux": m.coordinates[:, 0] / r, "uz": m.coordinates[:, 2] / r}
    u_r, var = np.zeros(n), np.zeros(n)
    measured = np.zeros(n, bool)
    for q in ("ux", "uz"):
        measured |= ~np.isnan(m.values.get(q, missing))
    for row in np.flatnonzero(measured):
        if r[row] == 0:
            raise InputError(f"{_where(m, row)}: ux, uz on the axis (r = 0) have no radial direction")
        for q, w in weights.items():
            if abs(w[row]) <= PLANE_TOL:
                continue
            value = m.values.get(q, missing)[row]
            if np.isnan(value):
                other = "uz" if q == "ux" else "ux"
                raise InputError(f"{_where(m, row)}: u_r = (ux x + uz z) / r needs {q}, which is missing "
                                 f"(only {other} is given)")
            u_r[row] += w[row] * value
            var[row] += (w[row] * m.sigma.get(q, missing)[row]) ** 2
    return np.where(measured, u_r, np.nan), np.where(measured, np.sqrt(var), np.nan)


def _check_strain_mappable(m: Measurements, q: str, r: np.ndarray) -> None:
    if q in ("uy", "eyy"):
        return
    x, z = m.coordinates[:, 0], m.coordinates[:, 2]
    in_plane = (x > 0) & (np.abs(z) <= PLANE_TOL * r)
    for row in np.flatnonzero(~np.isnan(m.values[q])):
        if q in ("eyz", "exz"):
            raise InputError(f"{_where(m, row)}: column {q!r} has no counterpart in an axisymmetric model "
                             f"(without torsion it is zero); leave it out or select other quantities")
        if not in_plane[row]:
            raise InputError(f"{_where(m, row)}: column {q!r} maps onto the axisymmetric model only at points "
                             f"in the x-y plane with x > 0 (strains are not rotated about the axis)")
