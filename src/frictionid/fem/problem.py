"""Problem: a model condensed once per geometry, solved for any vector of zone coefficients."""

from __future__ import annotations

import functools
import logging
import operator
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, SolverError
from ..model import Model, Rotation
from ..model.model import TORQUE
from .assembly import LoadChannels, load_channels, stiffness
from .condense import Condensed, condense
from .condense_implicit import IMPLICIT_ABOVE, condense_implicit, is_implicit
from .contact import free_tangents, held_normals
from .contact_krylov import KrylovSolver
from .interface import contact_pairs, model_space
from . import loadpath
from .loadpath import LoadPathSolver, contact_scale, stuck_inverses
from .pairs import ContactPairs
from .rigid import free_rigid_modes
from .solution import ExpandedRows, Solution
from .space import Space
from .threads import one_blas_thread

log = logging.getLogger(__name__)
#: values of [solver] sliding
SLIDING = ("small", "finite")
#: default of [solver] slip_tolerance: the small-sliding pairing's area-mean gap error over the closed contact,
#: relative to the normal deformation the contact resolves (:meth:`Problem.check_small_sliding`)
SLIP_TOLERANCE = 0.1
#: with twist or a helical interface (lead): the slip allowed, in local element lengths
TWIST_LENGTHS = 1.0
#: gap errors whose area mean is below this share of the interfaces' largest nodal displacement are round-off (a
#: uniform field)
ROUND_OFF = 1e-9
#: the deformed coupling measures a pair only where, undeformed, it finds the pair's own gap within this share of
#: the local element length (on a conforming interface exactly: a larger difference is another target facet)
MATCHED = 0.01


def _reaction_sums(model: Model, prescribed: np.ndarray) -> tuple[sp.csr_matrix, tuple[str, ...]]:
    """Rows summing the reactions of each of :attr:`Model.reaction_entries`, labelled as
    :attr:`Model.reaction_labels` ('boundary.x'); the circumferential reactions of "axisymmetric_twist" are summed
    as moments about the axis, r F_t ('boundary.torque' [N mm])."""
    position = {int(d): i for i, d in enumerate(prescribed)}
    rows, cols, values = [], [], []
    for k, (boundary, c) in enumerate(model.reaction_entries):
        nodes = model.mesh.boundary_nodes(boundary)
        components = Rotation.components(model.kind) if c == TORQUE else (c,)
        dofs = np.concatenate([model.n_components * nodes + i for i in components])
        cols.append([position[int(d)] for d in dofs])
        rows.append(np.full(len(dofs), k))
        torque = c == TORQUE or (model.kind == "axisymmetric_twist" and c == 2)
        values.append(Rotation.unit(model.mesh.points[dofs // model.n_components], dofs % model.n_components,
                                    model.kind) if torque else np.ones(len(dofs)))
    labels = model.reaction_labels
    if not labels:
        return sp.csr_matrix((0, len(prescribed))), ()
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    return sp.csr_matrix((np.concatenate(values), (rows, cols)), shape=(len(labels), len(prescribed))), labels


def _contact_dofs(model: Model, B: sp.csr_matrix, n_components: int) -> np.ndarray:
    """The dofs of the nodes of every interface's zones (the contact sides) and of its target's facets that have a
    node the pairs' rows B touch (a mortar coupling's edge: not the rest of a larger target)."""
    mesh = model.mesh
    touched = np.zeros(mesh.n_nodes, dtype=bool)
    touched[np.asarray(B.indices) // n_components] = True
    parts = [np.zeros(0, dtype=int)]
    for interface in model.interfaces:
        parts += [mesh.boundary_nodes(zone) for zone in interface.zones]
        facets = mesh.boundary(interface.target)
        parts.append(facets[touched[facets].any(axis=1)].ravel())
    nodes = np.unique(np.concatenate(parts))
    return (n_components * nodes[:, None] + np.arange(n_components)).ravel()


def compressed(observe: sp.spmatrix | None) -> tuple[sp.csr_matrix | None, sp.csr_matrix | None]:
    """Observation rows as (rows to condense, expansion): the dofs the rows touch and the rows on those dofs,
    when there are fewer such dofs than rows, else (the rows, None).

    A full field of 1e5 points observes a few hundred cells: the condensation then carries their few thousand
    dofs instead of the 1e5 rows (its dense operators are rows x contact unknowns), and each solve expands the
    dofs' values to the rows with one sparse product: the same values up to round-off.
    """
    if observe is None:
        return None, None
    observe = sp.csr_matrix(observe)
    touched = np.zeros(observe.shape[1], dtype=bool)
    touched[observe.indices] = True                      # 14 million entries: 60 ms (np.unique, bincount: 0.3 s)
    kept = np.flatnonzero(touched)
    if len(kept) >= observe.shape[0]:
        return observe, None
    select = sp.csr_matrix((np.ones(len(kept)), (np.arange(len(kept)), kept)), shape=(len(kept), observe.shape[1]))
    # observe[:, kept] by renumbering the columns (the entries keep their order): 1e5 points' 14 million entries
    # in tens of ms instead of scipy's column indexing's half second
    column = np.zeros(observe.shape[1], dtype=observe.indices.dtype)
    column[kept] = np.arange(len(kept), dtype=observe.indices.dtype)
    return select, sp.csr_matrix((observe.data, column[observe.indices], observe.indptr),
                                 shape=(observe.shape[0], len(kept)))


class PointLabels(Sequence):
    """The labels ``P<i>.<quantity>`` of n points' observation rows, point-major, made when read: a full field's
    1e5 points x 6 quantities would otherwise build 600,000 strings that nothing reads.

    >>> labels = PointLabels(2, ("ux", "uy"))
    >>> len(labels), labels[1], labels[-1], labels[:3] == ("P0.ux", "P0.uy", "P1.ux")
    (4, 'P0.uy', 'P1.uy', True)
    """

    def __init__(self, n_points: int, quantities):
        self.n_points, self.quantities = int(n_points), tuple(quantities)

    def __len__(self) -> int:
        return self.n_points * len(self.quantities)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return tuple(self[i] for i in range(*index.indices(len(self))))
        index = operator.index(index)
        if index < 0:
            index += len(self)
        if not 0 <= index < len(self):
            raise IndexError(f"observation label {index} of {len(self)}")
        point, q = divmod(index, len(self.quantities))
        return f"P{point}.{self.quantities[q]}"

    def __eq__(self, other):
        if isinstance(other, PointLabels):
            return (self.n_points, self.quantities) == (other.n_points, other.quantities)
        return tuple(self) == other if isinstance(other, tuple) else NotImplemented

    def __hash__(self) -> int:
        return hash((self.n_points, self.quantities))

    def __repr__(self) -> str:
        return f"PointLabels({self.n_points}, {self.quantities})"


def sensitivity_zones(sensitivities, n_zones: int) -> np.ndarray | None:
    """The sorted indices of the zones a solve takes sensitivities to: None for False, every zone for True, else
    the listed indices (of ``n_zones``; none listed: None)."""
    if isinstance(sensitivities, (bool, np.bool_)) or sensitivities is None:
        return np.arange(n_zones) if sensitivities else None
    zones = np.unique(np.asarray(sensitivities, dtype=int).ravel())
    if zones.size and (zones[0] < 0 or zones[-1] >= n_zones):
        raise ValueError(f"sensitivities: zone indices {zones.tolist()} outside the model's {n_zones} zones")
    return zones if zones.size else None


def _widened(a: np.ndarray, zones: np.ndarray, n_zones: int) -> np.ndarray:
    """(..., n_zones) of (..., len(zones)): the columns at ``zones``, NaN elsewhere."""
    if len(zones) == n_zones:
        return a
    out = np.full(a.shape[:-1] + (n_zones,), np.nan)
    out[..., zones] = a
    return out


#: values of Problem.build's ``contact``; "auto" takes "implicit" above
#: :data:`frictionid.fem.condense_implicit.IMPLICIT_ABOVE` contact dofs
CONTACT_SOLVES = ("auto", "dense", "implicit")
#: how :meth:`Problem.solve` steps through each stage
INCREMENTS = ("fixed", "adaptive")
#: adaptive increments: the step doubles after an increment Newton solved in at most this many iterations, no cut,
#: that left every pair's state as it was and turned no slip direction by more than SETTLED_DIRECTION
EASY_NEWTON = 3
SETTLED_DIRECTION = 1e-3
#: adaptive increments: a step spans at most this many nominal increments of its stage
MAX_GROWTH = 8


class _AdaptiveSteps:
    """The (stage, amplitude) of each step of adaptive increments; :meth:`went` reports how the last one went."""

    def __init__(self, problem: "Problem"):
        self.ends = problem.channels.amplitudes
        self.counts = [stage.n_increments for stage in problem.model.stages]
        self.stage, self.done, self.step = 0, 0.0, 1.0 / self.counts[0]
        self.start = np.zeros(self.ends.shape[1])

    def __iter__(self):
        return self

    def __next__(self):
        if self.stage >= len(self.counts):
            raise StopIteration
        self.step = min(self.step, 1.0 - self.done)
        self.done += self.step
        if self.done >= 1.0 - 1e-12:                         # the stage's end exactly
            self.done = 1.0
        end = self.ends[self.stage]
        return self.stage, end.copy() if self.done == 1.0 else self.start + (end - self.start) * self.done

    def went(self, n_newton: int, n_cuts: int, settled: bool) -> None:
        nominal = 1.0 / self.counts[self.stage]
        if n_cuts:
            self.step /= 2
        elif n_newton <= EASY_NEWTON and settled:
            self.step = min(2 * self.step, MAX_GROWTH * nominal)
        if self.done == 1.0:
            self.start = self.ends[self.stage]
            self.stage += 1
            self.done = 0.0
            if self.stage < len(self.counts):                # a new stage may load another way: nominal again
                self.step = 1.0 / self.counts[self.stage]


@dataclass(frozen=True)
class Problem:
    """A model's condensed operators; :meth:`solve` runs the load path for given zone coefficients."""

    model: Model
    space: Space
    pairs: ContactPairs
    channels: LoadChannels
    condensed: Condensed
    observation_labels: Sequence[str]
    reaction_labels: tuple[str, ...]
    #: (n_obs, n_kept) observation rows on the kept dofs when the condensation observes those dofs instead of the
    #: rows (see :func:`compressed`); None: it observes the rows themselves
    expand: sp.csr_matrix | None = None
    #: "small" (pairs fixed in the undeformed configuration) or "finite" (fem/sliding.py: condensed on the
    #: interface dofs ``interface_dofs``, the coupling re-evaluated in the deformed configuration)
    sliding: str = "small"
    interface_dofs: np.ndarray | None = None

    def __repr__(self) -> str:
        return (f"Problem({self.model!r}, {self.pairs.n_pairs} contact pairs, "
                f"{len(self.observation_labels)} observations, {len(self.reaction_labels)} reactions)")

    @classmethod
    def build(cls, model: Model, observe: sp.spmatrix | None = None, observation_labels: tuple[str, ...] = (),
              points=None, quantities=("ux", "uy"), regions=None, compress: bool = True,
              window: float | None = None, factorisation: str = "auto", sliding: str = "small",
              contact: str = "auto") -> "Problem":
        """Assemble, discretise the interfaces and condense.

        Parameters
        ----------
        observe : (n_obs, n_dofs) sparse rows mapping the dof vector to observed values; none by default.
        points : (n, dim) [mm], optional
            Observation points instead of ``observe``: ``quantities`` (e.g. "ux", "eyy") at each point,
            labelled "P<i>.<quantity>", point-major; ``regions`` optionally names the region of each point
            (see :func:`frictionid.fem.points.point_operator`).
        window : float [mm], optional
            DIC strain window of the points' strains (:func:`frictionid.fem.points.point_operator`).
        compress : bool
            Condense the dofs the observation rows touch instead of the rows when they are fewer (see
            :func:`compressed`; a full field); False: always the rows.
        factorisation : "auto" | "cholmod" | "superlu" | "cholmod_solves" | "mumps"
            How the stiffness is factorised for the condensation (:func:`frictionid.fem.condense.condense`;
            [solver] factorisation); "auto": :func:`frictionid.fem.memory.automatic` (CHOLMOD, or MUMPS where
            CHOLMOD's estimate exceeds the default max_memory).
        sliding : "small" | "finite"
            Contact pairs fixed in the undeformed configuration, or re-coupled in the deformed configuration at
            every increment (:mod:`frictionid.fem.sliding`; plane strain, axisymmetric and 3-D, dual mortar on every
            interface).
        contact : "auto" | "dense" | "implicit"
            The contact compliance W formed densely (fem/condense.py, the load path's stuck inverses), or applied
            by the stiffness factor with the Newton systems solved by GMRES (fem/condense_implicit.py,
            fem/contact_krylov.py); "auto": implicit above :data:`IMPLICIT_ABOVE` contact dofs (small sliding; infinite for now:
            the implicit path is slower at every size measured).
        """
        space = model_space(model)
        if points is not None and observe is not None:
            raise InputError("observation: give either observe rows or points, not both")
        if points is not None:
            from .points import point_operator
            observe = point_operator(space, points, quantities, regions, model.materials, window)
            observation_labels = PointLabels(len(points), quantities)
        observe, expand = compressed(observe) if compress else (observe, None)
        if sliding not in SLIDING:
            raise InputError(f"[solver] sliding must be one of {', '.join(map(repr, SLIDING))}, got {sliding!r}")
        dofs = None
        if sliding == "finite":
            from .sliding import coupling_builder, interface_dofs, selection
            pairs = coupling_builder(space, model)(model.mesh.points)
            dofs = interface_dofs(model, space.n_components)
        else:
            pairs = contact_pairs(space, model)
        channels = load_channels(space, model)
        modes = free_rigid_modes(model.mesh, model.kind, channels.prescribed)
        sums, labels = _reaction_sums(model, channels.prescribed)
        observe = sp.csr_matrix((0, space.n_dofs)) if observe is None else sp.csr_matrix(observe)
        if observe.shape[1] != space.n_dofs:
            raise InputError(f"observation rows have {observe.shape[1]} columns, the model {space.n_dofs} dofs")
        n_rows = observe.shape[0] if expand is None else expand.shape[0]
        labels_obs = observation_labels if isinstance(observation_labels, PointLabels) else \
            tuple(observation_labels) or tuple(f"obs{i}" for i in range(n_rows))
        coupled = pairs.B if dofs is None else selection(dofs, space.n_dofs)
        if contact not in CONTACT_SOLVES:
            raise InputError(f"`contact` must be one of {', '.join(map(repr, CONTACT_SOLVES))}, got {contact!r}")
        implicit = contact == "implicit" or \
            (contact == "auto" and sliding == "small" and pairs.B.shape[0] > IMPLICIT_ABOVE)
        if implicit and sliding == "finite":
            raise InputError("`contact` 'implicit' takes small sliding only ([solver] sliding = \"small\")")
        # the small-sliding check reads the interfaces' displacements from the Schur factors where it can
        # (interface_displacement): the nodes a mortar coupling leaves out at its edges are eliminated last too
        extra = {} if implicit or sliding == "finite" else {"last": _contact_dofs(model, pairs.B,
                                                                                   space.n_components)}
        if factorisation == "auto":
            from .memory import automatic
            factorisation = automatic(model)
        condensed = (condense_implicit if implicit else condense)(
            stiffness(space, model), coupled, channels, modes, observe, sums, space.n_components,
            factorisation=factorisation, **extra)
        return cls(model, space, pairs, channels, condensed, labels_obs, labels, expand, sliding, dofs)

    def displacement(self, solution: Solution, increment=-1) -> np.ndarray:
        """(n_nodes, n_components) [mm] nodal displacements at an increment of a solution of this problem; for a
        list of increments (k, n_nodes, n_components), one solve with k right-hand sides."""
        many = np.ndim(increment) == 1
        index = np.atleast_1d(increment)
        u = self.condensed.displacement(*self._loads(solution, index))
        u = u.reshape(len(index), -1, self.space.n_components)
        return u if many else u[0]

    def point_sensitivities(self, solution: Solution, points, quantities: Sequence[str],
                            regions=None) -> np.ndarray | None:
        """(n_stages, n_points * n_quantities, n_zones) derivatives of ``quantities`` at ``points`` at each stage
        end of a solution with sensitivities (point-major, as :meth:`build`'s observation rows, regions as there;
        strains pointwise, no DIC window), from the condensation already made: the displacement field's
        sensitivity is the field of the contact unknowns' sensitivities (``solution.d_x``) under no load, one
        solve with the kept factor for all zones and stages (NaN for the zones the solve took none to). None
        where the solution has no ``d_x`` (solved without sensitivities, or with finite sliding).
        """
        if solution.d_x is None:
            return None
        from .points import point_operator

        ends = [solution.stage_end(s) for s in range(self.model.n_stages)]
        d_x = solution.d_x[ends]
        zones = np.flatnonzero(np.isfinite(d_x).all(axis=(0, 1)))          # those the solve took them to
        x = np.moveaxis(d_x[:, :, zones], 2, 1).reshape(len(ends) * len(zones), -1)   # (stage, zone) rows
        no_load = np.zeros((len(x), self.channels.amplitudes.shape[1]))
        du = self.condensed.displacement(self.pairs.B, self.channels.displacements, no_load, x)
        rows = point_operator(self.space, points, quantities, regions, self.model.materials) @ du.T
        return _widened(np.moveaxis(rows.reshape(rows.shape[0], len(ends), len(zones)), 1, 0), zones,
                        d_x.shape[2])

    def _loads(self, solution: Solution, index: np.ndarray) -> tuple:
        """(B, the channels' prescribed displacements, amplitudes, x) of the increments ``index`` of a solution:
        the arguments of :meth:`Condensed.displacement`."""
        if solution.interface_forces is not None:
            from .sliding import selection
            B, x = selection(self.interface_dofs, self.space.n_dofs), solution.interface_forces[index]
        else:
            B, x = self.pairs.B, solution.lam[index].reshape(len(index), -1)
        return B, self.channels.displacements, solution.amplitude[index], np.hstack([x, solution.alpha[index]])

    def interface_displacement(self, solution: Solution, increments) -> tuple[np.ndarray, bool]:
        """(k, n_nodes, n_components) [mm] displacements at the increments ``increments``, exact on the nodes of
        the interfaces' zones and targets, and whether they come without the field elsewhere: from the Schur
        complements' factors where the condensation eliminated those nodes' dofs last and kept them
        (:meth:`Condensed.displacement_at`; "mumps"), each other node then taking its nearest interface node's
        (:meth:`interface_field`); else the whole field (one solve with the stored factor: "cholmod" keeps its
        factor, "mumps" makes its factors of the interiors again)."""
        index = np.atleast_1d(increments)
        dofs = self._interface_sources[0]
        on = self.condensed.displacement_at(dofs, *self._loads(solution, index))
        if on is None:
            return self.displacement(solution, list(index)), False
        return self.interface_field(on).reshape(len(index), -1, self.space.n_components), True

    def interface_field(self, on: np.ndarray) -> np.ndarray:
        """(k, n_dofs) [mm] from the displacements ``on`` (k, n) of the interfaces' dofs
        (:func:`frictionid.fem.sliding.interface_dofs`): each other node takes its nearest interface node's, so
        that a cell next to an interface keeps its shape up to the strains, as the coupling's orientation of the
        facets (by the adjacent cells' corners) needs; exact on the interfaces only."""
        return np.atleast_2d(on)[:, self._interface_sources[1]]

    @functools.cached_property
    def _interface_sources(self) -> tuple[np.ndarray, np.ndarray]:
        """(the interfaces' dofs, (n_dofs,) the index among them each dof takes its value from in
        :meth:`interface_field`: its own, or the same component's of the nearest interface node)."""
        from scipy.spatial import cKDTree
        from .sliding import interface_dofs
        n = self.space.n_components
        dofs = interface_dofs(self.model, n)
        points = self.model.mesh.points
        if not len(dofs):
            return dofs, np.zeros(0, dtype=int)
        nodes = dofs[::n] // n
        nearest = cKDTree(points[nodes]).query(points)[1]                   # index among the interface nodes
        nearest[nodes] = np.arange(len(nodes))       # their own: the two sides' nodes coincide on an interface
        return dofs, (n * nearest[:, None] + np.arange(n)).ravel()

    def amplitudes(self) -> tuple[np.ndarray, np.ndarray]:
        """(stage of each nominal increment, (n_inc, n_channels) amplitude at its end)."""
        stages, amps, previous = [], [], np.zeros(self.channels.amplitudes.shape[1])
        for s, stage in enumerate(self.model.stages):
            end = self.channels.amplitudes[s]
            for k in range(1, stage.n_increments + 1):
                stages.append(s)
                amps.append(previous + (end - previous) * k / stage.n_increments)
            previous = end
        return np.array(stages), np.array(amps)

    def pair_length(self) -> np.ndarray:
        """(n_pairs,) [mm] size of the largest contact facet at each pair (corner-to-corner edge length)."""
        mesh = self.model.mesh
        length = np.zeros(mesh.n_nodes)
        for zone in (z for interface in self.model.interfaces for z in interface.zones):
            facets = mesh.boundary(zone)
            edge = np.linalg.norm(mesh.points[facets[:, 1]] - mesh.points[facets[:, 0]], axis=1)
            np.maximum.at(length, facets, np.repeat(edge[:, None], facets.shape[1], axis=1))
        return length[self.pairs.nodes]

    def check_small_sliding(self, solution: Solution, tolerance: float = SLIP_TOLERANCE) -> None:
        """Raise :class:`SolverError` where the fixed pairing's gap error exceeds ``tolerance`` of the normal
        deformation the contact resolves (docs/solver.md, "How far small sliding holds").

        The pairs are fixed in the undeformed configuration: a pair that slid by s keeps its partner instead of
        the target point it has slid to. At the increment of each stage with the largest slip the gap of the
        deformed configuration (:func:`frictionid.fem.sliding.pairing_gap_error`, the finite-sliding coupling at
        the solution's displacements) is compared with the pairing's (:meth:`gap_errors`); per interface, the
        area mean of that error over the closed pairs (and the open pairs the deformed configuration closes) is
        taken relative to the normal deformation the contact resolves: the range of the target's normal
        displacement across the closed pairs, or their largest initial interference if larger. Pairs the
        deformed coupling does not cover (slid off the target's end) are left out; a mean below
        :data:`ROUND_OFF` of the interfaces' largest nodal displacement is zero. Pairs that stay open along the
        whole path are not checked. The displacements come from :meth:`interface_displacement`: with "mumps"
        from the Schur complements' factors, no factor of the stiffness made again, where the condensation
        eliminated the interfaces' dofs last; off the interfaces each node then takes its nearest interface
        node's, which the coupling reads only to orient the facets (the adjacent cells' corners: the same side
        while the strains are small); with "cholmod" the whole field, from the factor the condensation kept.
        A pair the deformed coupling does not measure is held to one local element length of slip instead: where,
        undeformed, the coupling does not find the pair's own gap (within :data:`MATCHED` of the local element
        length: it projects onto another facet, as on a coarse helical thread whose flank is narrower than an
        element), or where a closed pair's error exceeds its tangential relative displacement,
        which bounds it (the slid-to point is at most that far from the partner on the target). With twist (no
        deformed coupling) or a helical interface (``lead``: its pairs' normals are the helicoid's, not the deformed
        coupling's facet normals) the slip (with twist: along t1) is limited to one local element length instead,
        whatever the tolerance.
        """
        if self.sliding == "finite" or self.pairs.n_pairs == 0:
            return
        if self.model.kind == "axisymmetric_twist" or any(i.lead for i in self.model.interfaces):
            return self._check_slip_lengths(solution, TWIST_LENGTHS)
        for found in self.gap_errors(solution, tolerance):
            if found["ratio"] > tolerance:
                inc, worst = found["increment"], found["worst"]
                stage = int(solution.stage[inc])
                raise SolverError(
                    f"small sliding: at interface {self.model.interfaces[found['interface']].name!r}, stage "
                    f"{stage + 1} ({self.model.stages[stage].name}), increment {inc + 1}, the fixed pairing's gap "
                    f"error averages {found['mean']:.3g} mm over the closed contact, {found['ratio']:.3g} of the normal "
                    f"deformation the contact resolves ({found['spread']:.3g} mm), beyond [solver] slip_tolerance = "
                    f"{tolerance:g}; largest {found['largest']:.3g} mm at contact node "
                    f"{int(self.pairs.nodes[worst])} (position {np.round(self.pairs.position[worst], 4).tolist()}, "
                    f"slip {found['slip']:.3g} mm); set [solver] sliding = \"finite\", reduce the imposed sliding, "
                    "or raise slip_tolerance (false: no check)")
            if found["unmeasured_slip"] > TWIST_LENGTHS:
                self._slip_too_long(found["increment"], found["unmeasured_worst"], found["unmeasured_slip"],
                                    TWIST_LENGTHS, "pairs the deformed coupling does not measure")

    def gap_errors(self, solution: Solution, tolerance: float = np.inf, builder=None) -> list[dict]:
        """The fixed pairing's gap error per interface at the increment of each stage with the largest slip
        (:meth:`check_small_sliding`): dicts with ``interface``, ``increment`` (0-based), ``mean`` [mm] (the area
        mean over the closed pairs), ``spread`` [mm] (the normal deformation: the range of the target's normal
        displacement across them, or their largest initial interference),
        ``ratio`` = mean / spread, ``worst`` (pair index), ``largest`` [mm], ``slip`` [mm] at the worst pair,
        ``uncovered`` (closed pairs the deformed coupling does not cover, left out), ``unmeasured`` (closed pairs it
        does not measure, :meth:`check_small_sliding`, left out of the mean), ``unmeasured_slip`` (their largest
        slip in local element lengths, 0 without them) and ``unmeasured_worst`` (its pair index); the search stops
        at the first ratio above ``tolerance``. ``builder``: the deformed coupling's builder (default the check's,
        :func:`frictionid.fem.sliding.check_builder`); its own undeformed coupling is then the gaps' reference, so
        that another quadrature's errors compare like with like."""
        from .sliding import UNCOVERED_GAP, aligned, check_builder, pairing_gap_error
        slip = np.linalg.norm(solution.slip, axis=2)                     # (n_inc, n_pairs)
        slip[:, np.all(solution.state == 0, axis=0)] = 0.0
        reference = self._coupled_gap if builder is None else \
            aligned(self.pairs, builder(self.model.mesh.points)).gap
        builder = builder or check_builder(self.space, self.model)
        checked = [int(rows[np.argmax(slip[rows].max(axis=1))])
                   for rows in (np.flatnonzero(solution.stage == stage) for stage in np.unique(solution.stage))]
        checked = [inc for inc in checked if slip[inc].max() > 0.0]
        if not checked:
            return []
        pairs, found = self.pairs, []
        length = self.pair_length()
        matched = (reference < UNCOVERED_GAP) & (np.abs(reference - pairs.gap) <= MATCHED * length)
        on_interfaces = self._interface_sources[0]
        for inc, u in zip(checked, self.interface_displacement(solution, checked)[0]):
            # the gap error's round-off scales with the displacements it is computed from, the interfaces' nodes'
            scale = np.abs(u.ravel()[on_interfaces]).max(initial=0.0)
            w_n = solution.w[inc, :, 0]
            error = pairing_gap_error(self, u.ravel(), w_n, builder, reference)
            # a pair the coupling does not cover (here or undeformed: the target's end) has no gap error to measure
            uncovered = ~np.isfinite(error)
            closed = solution.state[inc] != 0
            # a closed pair's error is at most its tangential relative displacement: beyond it (or unmatched), the
            # coupling measures another facet, and the pair is held to the slip rule instead
            bound = np.linalg.norm(solution.w[inc, :, 1:], axis=1) + ROUND_OFF * scale
            unmeasured = ~uncovered & (~matched | (closed & (np.abs(np.where(uncovered, 0.0, error)) > bound)))
            # an open pair counts where the deformed configuration closes it
            error = np.where(uncovered | unmeasured, 0.0, np.where(closed, np.abs(error),
                                                                   np.maximum(0.0, -(pairs.gap + w_n + error))))
            long_slip = np.where(unmeasured & closed, slip[inc] / length, 0.0)
            target_n = np.einsum("pi,pi->p", pairs.frames[:, 0, :], u[pairs.nodes]) - w_n
            for index in range(len(self.model.interfaces)):
                mine = pairs.interface == index
                if not np.any(mine & closed):
                    continue
                # the normal deformation the contact resolves: the range of its normal displacement (a force
                # fixes the pressure's mean), or an initial interference (which fixes it)
                spread = float(max(np.ptp(target_n[mine & closed]), -np.min(pairs.gap[mine & closed], initial=0.0)))
                if spread == 0.0:       # one closed pair, or the target moved as a whole: its normal displacement
                    spread = float(np.abs(target_n[mine & closed]).max())
                measured = mine & closed & ~unmeasured
                mean = (float(np.sum((pairs.weight * error)[mine]) / np.sum(pairs.weight[measured]))
                        if np.any(measured) else 0.0)
                if mean <= ROUND_OFF * scale:
                    mean = 0.0                                   # a uniform field's round-off, not an error
                worst = int(np.flatnonzero(mine)[np.argmax(error[mine])])
                ratio = 0.0 if mean == 0.0 else mean / spread if spread > 0.0 else np.inf
                found.append(dict(interface=index, increment=inc, mean=mean, spread=spread, ratio=ratio, worst=worst,
                                  largest=float(error[worst]), slip=float(slip[inc, worst]),
                                  uncovered=int(np.count_nonzero(uncovered & mine & closed)),
                                  unmeasured=int(np.count_nonzero(unmeasured & mine & closed)),
                                  unmeasured_slip=float(long_slip[mine].max()),
                                  unmeasured_worst=int(np.flatnonzero(mine)[np.argmax(long_slip[mine])])))
                if found[-1]["ratio"] > tolerance or found[-1]["unmeasured_slip"] > TWIST_LENGTHS:
                    return found
        return found

    def _check_slip_lengths(self, solution: Solution, limit: float) -> None:
        """The slip within ``limit`` local element lengths; with twist only along t1, in the (r, y) section
        (sliding around the axis keeps a ring pair's partners)."""
        slip = solution.slip[:, :, :1] if self.model.kind == "axisymmetric_twist" else solution.slip
        slip = np.linalg.norm(slip, axis=2)
        slip[:, np.all(solution.state == 0, axis=0)] = 0.0
        ratio = slip / self.pair_length()
        if ratio.size and ratio.max() > limit:
            inc, pair = np.unravel_index(np.argmax(ratio), ratio.shape)
            self._slip_too_long(int(inc), int(pair), float(ratio[inc, pair]), limit,
                                "a model with twist or a helical interface (lead)")

    def _slip_too_long(self, inc: int, pair: int, lengths: float, limit: float, where: str) -> None:
        """Raise: the slip of ``pair`` at increment ``inc`` is ``lengths`` local element lengths, beyond ``limit``,
        the small-sliding range of ``where``."""
        length = self.pair_length()[pair]
        raise SolverError(
            f"slip of {lengths * length:.3g} mm at contact node {int(self.pairs.nodes[pair])} "
            f"(position {np.round(self.pairs.position[pair], 4).tolist()}, increment {inc + 1}) exceeds "
            f"{limit:g} x the local element length {length:.3g} mm, the small-sliding range of {where}; reduce the "
            "imposed sliding, coarsen the contact mesh, or set [solver] slip_tolerance = false (no check)")

    def solve(self, mu, sensitivities: bool | Sequence[int] = False, max_slip: float | None = SLIP_TOLERANCE,
              increments: str = "fixed") -> Solution:
        """Run the load path for zone coefficients ``mu`` (array in zone order, or dict zone -> value).

        ``sensitivities``: False (none), True (to every zone's coefficient) or the indices of the zones to take
        them to (a fit's free zones): the other zones' columns of ``d_x``, ``d_observations`` and ``d_reactions``
        are NaN. Each zone's column costs a solve with the Jacobian per increment; with finite sliding every
        zone's are taken.

        ``max_slip``: the small-sliding check's tolerance ([solver] slip_tolerance; None: no check), see
        :meth:`check_small_sliding`. ``increments``: "fixed" (each stage's n_increments equal steps) or
        "adaptive" (each stage starts with its nominal step, doubles it after an increment Newton solved in at
        most :data:`EASY_NEWTON` iterations without a cut and without changing a pair's state or turning a slip
        direction by more than :data:`SETTLED_DIRECTION`, up to :data:`MAX_GROWTH` nominal steps, and halves it
        after a cut; the solution then has one row per step taken, every stage's end among them). With finite
        sliding the slip is not checked and the increments are fixed.
        """
        if increments not in INCREMENTS:
            raise InputError(f"`increments` must be one of {', '.join(map(repr, INCREMENTS))}, got {increments!r}")
        # one BLAS thread for the whole solve, its set-up and outputs included: the Newton steps' dense solves (a
        # few hundred to a few thousand unknowns) and the (observations x unknowns) products gain little from
        # threads on an idle machine and lose up to 60x to busy-waiting threads when the cores are shared with
        # another job or another solve (run.workers; benchmarks/blas_threads.py, benchmarks/cli_threads.py); its
        # factorisations of threads.LARGE rows or more take the process's threads back (fem/threads.py)
        zones = sensitivity_zones(sensitivities, self.model.n_zones)
        with one_blas_thread():
            return self._solve(self.model.coefficients(mu), zones, max_slip, increments == "adaptive")

    @functools.cached_property
    def _stuck_inverses(self):
        """The inverses of the stuck contact Jacobian the load path's solves correct (fem/updated_jacobian.py),
        made at the first solve and kept: they depend on the model only."""
        return stuck_inverses(self.condensed, self.pairs)

    @functools.cached_property
    def _krylov(self):
        """The Newton systems' iterative solver where W is applied, not stored (fem/contact_krylov.py), kept: its
        penalised factor serves the next solves."""
        pairs, c = self.pairs, self.condensed
        return KrylovSolver(c, contact_scale(c), free_tangents(pairs.B, c.free, pairs.dim),
                            held_normals(pairs.B, c.free, pairs.dim), pairs.dim)

    @functools.cached_property
    def _coupled_gap(self) -> np.ndarray:
        """(n_pairs,) [mm] the gap of the deformed-configuration coupling (fem/sliding.py) at the undeformed
        configuration, made at the first small-sliding check and kept: the reference of its gap errors."""
        from .sliding import aligned, check_builder
        return aligned(self.pairs, check_builder(self.space, self.model)(self.model.mesh.points)).gap

    def __getstate__(self):
        state = dict(self.__dict__)
        state.pop("_stuck_inverses", None)                 # made again where needed, not shipped
        state.pop("_krylov", None)
        state.pop("_interface_sources", None)
        return state

    def _solve(self, mu: np.ndarray, zones: np.ndarray | None, max_slip: float | None,
               adaptive: bool = False) -> Solution:
        """The load path at zone coefficients ``mu``, sensitivities to the zones ``zones`` (indices; None: none)."""
        if self.sliding == "finite":
            from .sliding import solve_finite
            return solve_finite(self, mu, zones is not None)
        sensitivities = zones is not None
        if is_implicit(self.condensed):
            solver = LoadPathSolver(self.condensed, self.pairs, linear=self._krylov, zones=zones)
        else:
            stuck = self._stuck_inverses if loadpath._LINEAR == "updated" else None
            solver = LoadPathSolver(self.condensed, self.pairs, stuck=stuck, zones=zones)
        path = solver.start()
        mu_pair = self.pairs.mu(mu)
        records, stages, amps = [], [], []
        schedule = _AdaptiveSteps(self) if adaptive else iter(zip(*self.amplitudes()))
        previous = np.zeros(self.channels.amplitudes.shape[1])
        direction = None
        for i, (stage, amp) in enumerate(schedule):
            where = f"stage {stage + 1} ({self.model.stages[stage].name}), increment {i + 1}"
            step = solver.step(path, previous, amp, mu_pair, sensitivities, where)
            records.append((path.x.copy(), step.state, None if path.S is None else path.S.copy(),
                            step.n_newton, step.n_cuts))
            log.debug("%s: %d Newton iterations, %d cuts", where, step.n_newton, step.n_cuts)
            if adaptive:
                settled = len(records) > 1 and np.array_equal(step.state, records[-2][1]) and \
                    np.max(np.abs(path.direction - direction), initial=0.0) <= SETTLED_DIRECTION
                schedule.went(step.n_newton, step.n_cuts, settled)
                direction = path.direction.copy()
            previous = amp
            stages.append(stage)
            amps.append(amp)
        solution = self._solution(mu, np.array(stages), np.array(amps), records, zones)
        if max_slip is not None:
            self.check_small_sliding(solution, max_slip)
        return solution

    def _solution(self, mu, stages, amps, records, zones: np.ndarray | None) -> Solution:
        c, pairs = self.condensed, self.pairs
        n_w = pairs.n_pairs * pairs.dim
        X = np.array([r[0] for r in records])
        outputs = {name: np.array([ops(a, x) for a, x in zip(amps, X)])
                   for name, ops in (("w", c.gap_ops), ("obs", c.obs_ops), ("reac", c.reac_ops))}
        d_obs = d_reac = S = None
        if zones is not None:
            S = np.array([r[2] for r in records])                               # (n_inc, n_x, n_taken)
            d_obs, d_reac, S = (_widened(a, zones, self.model.n_zones)          # (n_inc, n_obs, n_z), ...
                                for a in (c.obs_ops.full @ S, c.reac_ops.full @ S, S))
        if self.expand is not None:
            outputs["obs"] = ExpandedRows(outputs["obs"], self.expand)
            d_obs = None if d_obs is None else ExpandedRows(d_obs, self.expand)
        return Solution(
            mu=mu, zone_names=self.model.zone_names, observation_labels=self.observation_labels,
            reaction_labels=self.reaction_labels, stage=stages, amplitude=amps,
            lam=X[:, :n_w].reshape(len(X), pairs.n_pairs, pairs.dim), alpha=X[:, n_w:],
            w=outputs["w"].reshape(len(X), pairs.n_pairs, pairs.dim),
            state=np.array([r[1] for r in records]), observations=outputs["obs"], reactions=outputs["reac"],
            d_observations=d_obs, d_reactions=d_reac,
            n_newton=np.array([r[3] for r in records]), n_cuts=np.array([r[4] for r in records]), pairs=pairs,
            d_x=S)
