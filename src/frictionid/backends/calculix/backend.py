"""CalculixBackend: the embedded backend's interface on top of ccx (one ccx run per forward solve)."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ...errors import InputError, SolverError
from ...fem.assembly import load_channels
from ...fem.interface import contact_pairs as embedded_pairs
from ...fem.points import point_operator
from ...fem.space import Space
from ...model import Model
from ...options import CalculixOptions, SolverOptions
from ..base import Prediction
from .deck import AXISYMMETRIC_SEGMENTS, ContactSettings, contact_pairs, set_name, write_deck, zone_columns
from .elements import calculix_cells, fill_dropped_nodes
from .parse import DatFile, read_dat, read_frd
from .runner import JOB, find_ccx, remove_work, run_ccx

log = logging.getLogger(__name__)
#: penalty slopes relative to E_min / h (softest Young's modulus over the contact element size), see README
PENALTY_FACTOR = 500.0
#: [N/mm^3] cap of the default slopes: steel sleeves in CAX6 did not converge at 1e8 and matched at 1e7
PENALTY_CAP = 1e7
#: what ccx prints when its increments are cut below the minimum (here: contact iterations that do not converge)
NOT_CONVERGED = "increment size smaller than minimum"
_PAIR_TYPES = {"surface-to-surface": "SURFACE TO SURFACE", "node-to-surface": "NODE TO SURFACE"}
_TIME_TOL = 1e-6


@dataclass(frozen=True)
class CalculixSettings(CalculixOptions):
    """Options of the CalculiX backend ([solver] keys of a config, :class:`~frictionid.options.CalculixOptions`).

    Attributes
    ----------
    ccx : executable name or path
    timeout : float [s] per ccx run
    keep_work : keep every work directory (failed ones are always kept)
    work_dir : folder for the work directories (default: the system's temporary folder)
    threads : OpenMP threads per ccx run
    contact : "surface-to-surface" | "node-to-surface"
    normal_stiffness, stick_slope : float [N/mm^3], optional
        Penalty slopes; default ``min(PENALTY_FACTOR * E_min / h, PENALTY_CAP)`` with E_min the softest
        material and h the median contact facet size.
    load_scale : float
        ccx solves with every force and prescribed displacement times this factor and the results are divided
        by it. ccx pairs contact on the deformed surfaces (finite sliding); a small factor such as 0.01 makes
        the slides negligible, so ccx solves the small-sliding problem the embedded solver solves. Exact only
        for a response proportional to the loads: the materials are linear elastic, and contact must start
        closed with zero gap (checked: InputError for initial gaps or interference). Default 1 (the loads
        as given).
    """

    @classmethod
    def from_solver(cls, solver: SolverOptions) -> "CalculixSettings":
        """The CalculiX keys of the [solver] options (config.py has checked them); the embedded backend's
        ``factorisation``, ``increments``, ``sliding`` and ``max_memory`` are not CalculiX's (its contact follows
        the deformation)."""
        return cls(**{f.name: getattr(solver, f.name) for f in fields(CalculixOptions)})

    def contact_settings(self, model: Model) -> ContactSettings:
        """Penalty slopes for a model: the given ones or ``min(PENALTY_FACTOR * E_min / h, PENALTY_CAP)``."""
        default = min(PENALTY_FACTOR * min(m.E for m in model.materials.values()) / contact_size(model), PENALTY_CAP)
        return ContactSettings(self.normal_stiffness or default, self.stick_slope or default,
                               _PAIR_TYPES[self.contact])


def _check_proportional(space: Space, model: Model) -> None:
    """InputError unless every contact pair starts closed with zero gap (load_scale needs a response
    proportional to the loads; an initial gap or interference does not scale with them)."""
    gaps = embedded_pairs(space, model).gap
    if gaps.size and np.abs(gaps).max() > 1e-9 * float(np.ptp(model.mesh.points, axis=0).max()):
        worst = float(gaps[np.argmax(np.abs(gaps))])
        raise InputError(f"[solver] load_scale: the model has initial contact gaps (up to {worst:.3g} mm; "
                         "negative: interference), which do not scale with the loads; load_scale needs a model "
                         "whose contact surfaces start touching with zero gap: leave it at 1")


def contact_size(model: Model) -> float:
    """Median corner-to-corner edge length [mm] of the contact facets (zones and targets)."""
    mesh = model.mesh
    names = [z for i in model.interfaces for z in (*i.zones, i.target)]
    if not names:
        return float(np.ptp(mesh.points, axis=0).max())
    facets = np.concatenate([mesh.boundary(n) for n in names])
    return float(np.median(np.linalg.norm(mesh.points[facets[:, 1]] - mesh.points[facets[:, 0]], axis=1)))


@dataclass(frozen=True)
class CalculixSolution:
    """Results of one ccx run at the end of each stage.

    Attributes
    ----------
    mu : (n_zones,) coefficients; zone_names, reaction_labels, observation_labels : column names
    observations : (n_stages, n_rows) point-major rows as the embedded backend's
    reactions : (n_stages, n_reac) [N] reaction sums, labels "boundary.x" as the embedded solver's
        (axisymmetric: whole ring)
    zone_normal_force : (n_stages, n_zones) [N] compressive normal force per zone (from *CONTACT PRINT CF;
        NaN with node-to-surface contact, which does not print it)
    zone_tangential_force : (n_stages, n_zones) [N] size of the tangential force per zone (NaN likewise)
    zone_force : (n_stages, n_zones, 3) [N] total contact force on each zone's (contact-side) surface in the
        global frame (NaN likewise; axisymmetric: whole ring, only its axial component is meaningful)
    displacement : (n_stages, n_nodes, dim) [mm] or None when the field was not read
    wall_time : float [s] of the ccx run
    """

    mu: np.ndarray
    zone_names: tuple[str, ...]
    observation_labels: tuple[str, ...]
    reaction_labels: tuple[str, ...]
    observations: np.ndarray
    reactions: np.ndarray
    zone_normal_force: np.ndarray
    zone_tangential_force: np.ndarray
    zone_force: np.ndarray
    displacement: np.ndarray | None
    wall_time: float


class CalculixBackend:
    """Forward solves by CalculiX on the exported model; observations through the embedded point operator.

    Parameters
    ----------
    model : Model
    points : (n, dim) [mm] observation points (may be empty); quantities, regions : as
        :class:`~frictionid.backends.embedded.EmbeddedBackend`
    settings : CalculixSettings
    reactions : labels of reaction sums ("boundary.axis") appended as rows after the point rows

    Raises
    ------
    InputError
        If ccx is not found (naming the setting and how to install it) or the settings are bad.
    """

    name = "calculix"
    has_sensitivities = False

    def __init__(self, model: Model, points=None, quantities=("ux", "uy"), regions=None,
                 settings: CalculixSettings | None = None, reactions: tuple[str, ...] = ()):
        self.model = model
        self.settings = settings or CalculixSettings()
        self.space = Space.build(model.mesh, model.kind, model.element)
        if self.settings.load_scale != 1:
            _check_proportional(self.space, model)
        self.executable = find_ccx(self.settings.ccx)
        points = np.zeros((0, model.dim)) if points is None else np.asarray(points, dtype=float)
        self.quantities = tuple(quantities)
        self.observe = point_operator(self.space, points, quantities, regions, model.materials) if len(points) \
            else sp.csr_matrix((0, self.space.n_dofs))
        self.observation_labels = tuple(f"P{i}.{q}" for i in range(len(points)) for q in self.quantities)
        channels = load_channels(self.space, model)
        self.forces, self.amplitudes = channels.forces, channels.amplitudes
        self.contact = self.settings.contact_settings(model)
        self.reaction_entries = list(model.reaction_entries)          # the embedded solver's order
        self.reaction_labels = model.reaction_labels
        unknown = [r for r in reactions if r not in self.reaction_labels]
        if unknown:
            raise InputError(f"model: no reaction {unknown}; the model's reactions are {list(self.reaction_labels)}")
        self._reaction_rows = [self.reaction_labels.index(r) for r in reactions]
        self._observed = self._observed_nodes()
        self._kept = np.unique(calculix_cells(model.mesh.points, model.mesh.cell_type, model.mesh.cells))

    def deck(self, mu) -> str:
        """The .inp text for zone coefficients ``mu`` (n_zones,), with print requests for the observation nodes."""
        return write_deck(self.model, self.model.coefficients(mu), self.contact, self.forces, self.amplitudes,
                          observed_nodes=self.observed_nodes(), load_scale=self.settings.load_scale)

    def observed_nodes(self) -> np.ndarray:
        """Nodes whose displacements the observation rows use (0-based)."""
        return self._observed

    def _observed_nodes(self) -> np.ndarray:
        nodes = np.unique(self.observe.tocoo().col // self.model.dim)
        cells = np.flatnonzero(np.isin(self.model.mesh.cells, nodes).any(axis=1))
        return np.unique(self.model.mesh.cells[cells]) if self.model.mesh.cell_type in ("quad9", "hexahedron27") \
            else nodes

    def predict(self, mu, sensitivities: bool = False) -> Prediction:
        """Observation rows at every stage end (no derivatives: use finite differences)."""
        if sensitivities:
            raise InputError("the calculix backend has no analytic sensitivities; use identify.jacobian = "
                             "'forward' or 'central'")
        solution = self.solve(mu, full_field=False)
        return Prediction(np.hstack([solution.observations, solution.reactions[:, self._reaction_rows]]), None)

    def solve(self, mu, full_field: bool = True) -> CalculixSolution:
        """One ccx run; ``full_field`` also reads the displacement field of every stage end from the .frd file."""
        mu = self.model.coefficients(mu)
        start = time.perf_counter()
        try:
            work = run_ccx(self.deck(mu), self.executable, self.settings.timeout, self.settings.work_dir,
                           self.settings.threads)
        except SolverError as exc:
            if NOT_CONVERGED not in str(exc):
                raise
            raise SolverError(f"{exc}. {self._penalty_hint()}") from None
        wall = time.perf_counter() - start
        try:
            solution = self._read(work, mu, full_field, wall)
        except SolverError as exc:
            raise SolverError(f"{exc}; work directory kept: {work}") from None
        if not self.settings.keep_work:
            remove_work(work)
        return solution

    def _penalty_hint(self) -> str:
        """What to change when ccx's contact iterations stop: the penalty slopes it ran with and how to set them."""
        contact = self.contact
        if self.settings.normal_stiffness or self.settings.stick_slope:
            origin = "as set in [solver]"
        else:
            origin = (f"the default min({PENALTY_FACTOR:g} E_min / h, {PENALTY_CAP:g}) with the contact facet size "
                      f"h = {contact_size(self.model):.3g} mm")
        return (f"ccx's contact iterations did not converge with the penalty slopes normal "
                f"{contact.normal_stiffness:.3g} / stick {contact.stick_slope:.3g} N/mm^3 ({origin}): set [solver] "
                "normal_stiffness and stick_slope lower, e.g. to half of these (docs/calculix.md, 'When ccx does not "
                "converge')")

    def _stage_times(self) -> np.ndarray:
        return np.arange(1, self.model.n_stages + 1, dtype=float)

    def _read(self, work: Path, mu: np.ndarray, full_field: bool, wall: float) -> CalculixSolution:
        dat = read_dat(work / f"{JOB}.dat")
        model, n_stages = self.model, self.model.n_stages
        u_obs = np.zeros((n_stages, model.mesh.n_nodes, model.dim))
        if self.observe.shape[0]:
            for s, t in enumerate(self._stage_times()):
                rows = _at_time(dat.nodal, ("displacements (vx,vy,vz)", "NOBS"), t)
                u_obs[s] = self._nodal(rows, self.observed_nodes())
        observations = np.array([self.observe @ u.ravel() for u in u_obs]).reshape(n_stages, -1)
        displacement = self._field(work) if full_field else None
        normal, tangential, force = self._zone_forces(dat)
        back = 1.0 / self.settings.load_scale          # results at the loads as given
        return CalculixSolution(mu, model.zone_names, self.observation_labels, self.reaction_labels,
                                back * observations, back * self._reactions(dat), back * normal, back * tangential,
                                back * force, None if displacement is None else back * displacement, wall)

    def _nodal(self, rows: dict, nodes: np.ndarray) -> np.ndarray:
        """(n_nodes, dim) displacements from {ccx node: values} for the required nodes; others zero."""
        out = np.zeros((self.model.mesh.n_nodes, self.model.dim))
        needed = np.intersect1d(nodes, self._kept)
        missing = [n for n in needed if n + 1 not in rows]
        if missing:
            raise SolverError(f"the .dat file has no displacement of node {missing[0] + 1} (incomplete output)")
        for n in needed:
            out[n] = rows[n + 1][:self.model.dim]
        return fill_dropped_nodes(self.model.mesh.cell_type, self.model.mesh.cells, out)

    def _reactions(self, dat: DatFile) -> np.ndarray:
        scale = AXISYMMETRIC_SEGMENTS if self.model.kind == "axisymmetric" else 1.0
        out = np.zeros((self.model.n_stages, len(self.reaction_entries)))
        for s, t in enumerate(self._stage_times()):
            for k, (boundary, c) in enumerate(self.reaction_entries):
                total = _at_time(dat.totals, ("total force (fx,fy,fz)", set_name(self.model, boundary)), t)
                out[s, k] = scale * total[c]
        return out

    def _zone_forces(self, dat: DatFile) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        shape = (self.model.n_stages, self.model.n_zones)
        if self.contact.pair_type != "SURFACE TO SURFACE":
            return np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape + (3,), np.nan)
        scale = AXISYMMETRIC_SEGMENTS if self.model.kind == "axisymmetric" else 1.0
        normal, tangential, force = np.zeros(shape), np.zeros(shape), np.zeros(shape + (3,))
        for z, pair in zip(zone_columns(self.model), contact_pairs(self.model)):     # zones sharing z: summed
            for s, t in enumerate(self._stage_times()):
                entry = _at_time(dat.contact, pair, t, required=False)
                # a zone out of contact prints nothing or zero area with NaN forces
                if entry and entry.get("area", 0.0) > 0:
                    normal[s, z] -= scale * entry["normal"]
                    tangential[s, z] += scale * entry["shear"]
                    force[s, z] += scale * entry["force"]
        return normal, tangential, force

    def _field(self, work: Path) -> np.ndarray:
        frd = read_frd(work / f"{JOB}.frd")
        model = self.model
        index = _node_index(frd, model)
        out = np.zeros((model.n_stages, model.mesh.n_nodes, model.dim))
        for s in range(model.n_stages):
            block = frd.last_of_step("DISP", s + 1)
            if abs(block.time - (s + 1)) > _TIME_TOL:
                raise SolverError(f"the .frd file's last displacement of step {s + 1} is at time {block.time:g}, "
                                  f"not at the step end {s + 1} (incomplete output)")
            values = np.zeros((model.mesh.n_nodes, model.dim))
            known = index(block.nodes)
            values[known[known >= 0]] = block.values[known >= 0, :model.dim]
            out[s] = fill_dropped_nodes(model.mesh.cell_type, model.mesh.cells, values)
        return out


def _node_index(frd, model: Model):
    """Function mapping .frd node numbers to 0-based model nodes (-1: not a model node).

    Numbers above the model's count (2-D elements expanded to 3-D) are matched by position on the mid-plane.
    """
    n = model.mesh.n_nodes
    extra = frd.nodes > n
    if not extra.any():
        return lambda numbers: np.where(numbers <= n, numbers - 1, -1)
    from scipy.spatial import cKDTree

    points = np.asarray(model.mesh.points)
    xyz = frd.coordinates[:, :points.shape[1]]
    distance, nearest = cKDTree(points).query(xyz)
    on_plane = np.abs(frd.coordinates[:, 2]) < 1e-9 * max(np.ptp(points), 1.0) if points.shape[1] == 2 \
        else np.ones(len(xyz), bool)
    size = 1e-6 * max(np.ptp(points), 1.0)
    lookup = dict(zip(frd.nodes.tolist(), np.where((distance < size) & on_plane, nearest, -1).tolist()))
    return lambda numbers: np.array([lookup.get(int(k), -1) for k in numbers], dtype=np.int64)


def _at_time(table: dict, key, time: float, required: bool = True):
    """The entry of ``table[key]`` printed at total time ``time`` (a stage end)."""
    entries = table.get(key, {})
    for t, value in entries.items():
        if abs(t - time) <= _TIME_TOL * max(1.0, time):
            return value
    if not required:
        return None
    raise SolverError(f"the .dat file has no {key[0]} for {key[1]} at time {time:g} (incomplete output)")
