"""Finite sliding: the contact coupling re-evaluated in the deformed configuration at every increment.

The bodies stay linear elastic (small strain); only the contact coupling follows the deformation. The model is
condensed once onto all dofs of its interface nodes (contact zones and targets), ``T`` the selection rows::

    u_I = u0_I(t) + S f_I + S_a alpha,      S = T K^g T^T     (fem/condense.py with B = T)

which does not depend on the coupling. A coupling builder maps deformed nodal coordinates to contact pairs
(frames, weights, gaps, B = Bhat T); for a coupling Bhat the operators of the small-sliding solver follow by
products only, ``W = Bhat S Bhat^T`` (:func:`coupled_operators`): no factorisation per increment.

Increment n (fixed point, docs/solver.md, finite sliding): the coupling B_n and the gap g_n are evaluated at the
configuration X + u_ref, first u_ref = u_{n-1} + (u_{n-1} - u_{n-2}); the increment is solved with

    g = g_n + B_N,n (u - u_ref),     ds = B_T,n (u - u_{n-1})     (slip increment in the current frame)

then u_ref = u_n and again, until the interface displacements change by at most :data:`FIXED_POINT_RTOL` of the
increment's largest interface displacement increment, or every pair moved by at most :data:`RECOUPLE_FRACTION`
of its facet since u_ref (then the coupling is also kept for the next increment while that holds).

Sensitivities: the path's direct differentiation with the coupling of each increment held, the previous
increment's displacements carried as interface forces ``f_I = Bhat^T lam``; then (:data:`PATH_SENSITIVITIES`
"consistent") the coupling's change with the displacements, dB/du du/dmu, added by a fixed point whose products
are forward differences of the increment in its coupling's configuration (:func:`_with_coupling_change`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace
from functools import partial

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, SolverError
from ..model import Model
from .condense import Affine, Condensed
from .facet_shapes import CORNERS
from .loadpath import LoadPathSolver
from .pairs import ContactPairs, relative_operator
from .space import Space

log = logging.getLogger(__name__)

#: re-coupling stops when the interface displacements move by at most this share of the increment's
#: largest interface displacement increment
FIXED_POINT_RTOL = 1e-4
MAX_PASSES = 12
#: an increment is also accepted, and its coupling kept for the next increments, while every pair's relative
#: tangential displacement since the configuration the coupling was evaluated at stays within this fraction of
#: the smallest facet edge at the pair (:func:`facet_lengths`); 0: re-couple every increment until the fixed
#: point converges to FIXED_POINT_RTOL
RECOUPLE_FRACTION = 1e-4
#: the sensitivities of the path: "consistent" (with the coupling's change with the displacements,
#: :func:`_with_coupling_change`) or "held" (each increment's coupling held, dB/du du/dmu left out)
PATH_SENSITIVITIES = "consistent"
#: the consistent sensitivities' fixed point stops when a pass changes them by at most this share of the largest
SENSITIVITY_RTOL = 1e-6
#: central differences of an increment in its coupling's configuration: the interface nodes moved by this at most
#: [mm] along the direction
COUPLING_STEP = 1e-6
#: gap [mm] given to a pair whose node the target no longer covers: it stays open
UNCOVERED_GAP = 1e12
#: the small-sliding check's 3-D triangle rule on the clipped pieces: degree 4, exact for a quadratic dual
#: function times a quadratic gap on a flat piece (6 points instead of the solver's 25); measured against degree
#: 10 by benchmarks/check_quadrature.py (docs/solver.md)
CHECK_DEGREE = 4

#: deformed nodal coordinates (n_nodes, dim) [mm] -> contact pairs in that configuration
CouplingBuilder = Callable[[np.ndarray], ContactPairs]


def interface_dofs(model: Model, n_components: int) -> np.ndarray:
    """Sorted dofs of every node on a contact zone or target of the model's interfaces."""
    names = [name for i in model.interfaces for name in (*i.zones, i.target)]
    nodes = np.unique(np.concatenate([model.mesh.boundary(n).ravel() for n in names])) if names else \
        np.zeros(0, int)
    return (n_components * nodes[:, None] + np.arange(n_components)).ravel()


def selection(dofs: np.ndarray, n_dofs: int) -> sp.csr_matrix:
    """(len(dofs), n_dofs) rows picking ``dofs`` out of the dof vector."""
    return sp.csr_matrix((np.ones(len(dofs)), (np.arange(len(dofs)), dofs)), shape=(len(dofs), n_dofs))


def coupling_builder(space: Space, model: Model) -> CouplingBuilder:
    """The coupling builder of a model: :func:`mortar_builder`, the dual mortar of fem/mortar.py for plane-strain
    and axisymmetric models, of fem/mortar3d.py for 3-D ones. Nothing else in this module depends on the
    dimension."""
    if model.kind not in ("plane_strain", "axisymmetric", "3d"):
        raise InputError(f"[solver] sliding = 'finite' needs a plane-strain, axisymmetric or 3-D model, got kind "
                         f"{model.kind!r}; use sliding = 'small'")
    adjusted = [i.name for i in model.interfaces if i.adjust]
    if adjusted:
        raise InputError(f"[solver] sliding = 'finite': interface(s) {adjusted} set their initial gaps to zero "
                         "(adjust), which the re-coupling at the deformed positions does not; use sliding = 'small'")
    return mortar_builder(space, model)


def mortar_builder(space: Space, model: Model, degree: int | None = None) -> CouplingBuilder:
    """Coupling builder: dual mortar on every interface (fem/mortar.py in 2-D, fem/mortar3d.py in 3-D) at the
    given coordinates; ``degree``: the 3-D triangle rule's (default the solver's, mortar3d.DEGREE)."""
    if model.kind == "3d":
        from .mortar3d import DEGREE, mortar_pairs_3d
        pairs_of = partial(mortar_pairs_3d, degree=degree or DEGREE)
    else:
        from .mortar import mortar_pairs as pairs_of

    def build(points: np.ndarray) -> ContactPairs:
        deformed = replace(model, mesh=replace(model.mesh, points=points))
        # the set-up check ran at model build; at deformed positions the gaps are the solution's
        parts = [pairs_of(space, deformed, i, gap_check=False) for i in range(len(model.interfaces))]
        return ContactPairs.concatenate(parts, space.n_dofs, model.n_zones, space.dim)

    return build


def aligned(reference: ContactPairs, current: ContactPairs) -> ContactPairs:
    """``current`` with the pairs of ``reference`` in its order: a node the target no longer covers gets the
    reference frame, no target and the gap :data:`UNCOVERED_GAP` (it stays open); new nodes are left out."""
    dim, n_dofs = reference.dim, reference.B.shape[1]
    found = np.full(reference.n_pairs, -1)                  # index in current of each reference pair's node
    if current.n_pairs:
        order = np.argsort(current.nodes)
        at = np.minimum(np.searchsorted(current.nodes[order], reference.nodes), current.n_pairs - 1)
        found = np.where(current.nodes[order][at] == reference.nodes, order[at], -1)
    if len(current.nodes) > np.count_nonzero(found >= 0):
        log.info("finite sliding: %d newly covered contact nodes are not paired (the pairs are those of the "
                 "undeformed configuration)", len(current.nodes) - np.count_nonzero(found >= 0))
    lost = found < 0
    alone = relative_operator(reference.frames, reference.nodes, reference.nodes[:, None],
                              np.zeros((reference.n_pairs, 1)), n_dofs)
    source = np.where(lost, current.n_pairs + np.arange(reference.n_pairs), found)
    rows = (dim * source[:, None] + np.arange(dim)).ravel()
    take = lambda a, b: np.concatenate([a, b])[source]                       # noqa: E731
    return replace(reference, frames=take(current.frames, reference.frames), weight=take(current.weight,
                   reference.weight), gap=np.where(lost, UNCOVERED_GAP, take(current.gap, reference.gap)),
                   B=sp.vstack([current.B, alone]).tocsr()[rows])


def coupled_operators(interface: Condensed, B_I: sp.csr_matrix) -> Condensed:
    """The condensed operators of the coupling ``w = B_I u_I`` (B_I on the interface dofs) from those of the
    interface dofs: products only, the factorisation is not touched."""
    B_I = sp.csr_matrix(B_I)

    def through(ops: Affine) -> Affine:
        return Affine(ops.channels, (B_I @ ops.on_lam.T).T, ops.on_alpha)

    gap = interface.gap_ops
    return replace(interface, gap_ops=Affine((B_I @ gap.channels.T).T, B_I @ (B_I @ gap.on_lam).T,
                                             B_I @ gap.on_alpha),
                   obs_ops=through(interface.obs_ops), reac_ops=through(interface.reac_ops),
                   equilibrium=through(interface.equilibrium))


class Coupling:
    """The coupling of one increment, evaluated at X + u_ref: pairs with their gap shifted so that
    ``g = gap + B_N u`` (= g(u_ref) + B_N (u - u_ref)), the composed operators and their load-path solver."""

    def __init__(self, problem, builder: CouplingBuilder, u_ref: np.ndarray):
        points = problem.model.mesh.points
        #: the displacements [mm] of the configuration the coupling was evaluated at
        self.u_ref = u_ref
        current = aligned(problem.pairs, builder(points + u_ref.reshape(points.shape)))
        #: pairs whose node the target does not cover in this configuration
        self.lost = frozenset(np.flatnonzero(current.gap >= UNCOVERED_GAP).tolist())
        self.B_I = current.B[:, problem.interface_dofs].tocsr()
        self.pairs = replace(current, gap=current.gap - (current.B @ u_ref)[::current.dim])
        self.condensed = coupled_operators(problem.condensed, self.B_I)
        self.solver = LoadPathSolver(self.condensed, self.pairs)


class _State:
    """The converged state of the last increment: displacements, multipliers, interface forces, accumulated
    slip, and the interface forces' sensitivities."""

    def __init__(self, n_dofs: int, pairs: ContactPairs, n_modes: int):
        self.u = np.zeros(n_dofs)
        self.du = np.zeros(n_dofs)           # displacement increment of the last increment [mm]
        self.x = np.zeros(pairs.n_pairs * pairs.dim + n_modes)
        self.contact = None
        self.slip = np.zeros((pairs.n_pairs, pairs.dim - 1))
        self.dx_I = None                     # (n_I + m, n_z) d(f_I, alpha)/dmu
        self.coupling = None                 # the coupling of the last increment
        self.n_couplings = 0                 # couplings built along the path


def facet_lengths(problem) -> np.ndarray:
    """(n_pairs,) [mm] the shortest corner-to-corner facet edge at each pair: of the contact facets at its node and
    of the target facets of its interface that share a node with the undeformed coupling."""
    mesh, pairs = problem.model.mesh, problem.pairs
    n_corners = 2 if mesh.points.shape[1] == 2 else CORNERS[mesh.facet_type]

    def shortest_edges(facets):
        corners = mesh.points[facets[:, :n_corners]]
        return np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=2).min(axis=1)

    length = np.full(pairs.n_pairs, np.inf)
    at_node = np.full(mesh.n_nodes, np.inf)
    coupled = np.zeros(mesh.n_nodes, bool)
    coupled[np.unique(pairs.B.indices) // pairs.dim] = True
    for index, interface in enumerate(problem.model.interfaces):
        for zone in interface.zones:
            facets = mesh.boundary(zone)
            np.minimum.at(at_node, facets, np.repeat(shortest_edges(facets)[:, None], facets.shape[1], axis=1))
        target = mesh.boundary(interface.target)
        near = target[coupled[target].any(axis=1)]
        mine = pairs.interface == index
        length[mine] = np.minimum(at_node[pairs.nodes[mine]], shortest_edges(near).min(initial=np.inf))
    return length


def _moved(coupling: Coupling, u: np.ndarray, lengths: np.ndarray) -> float:
    """The largest relative displacement of a pair since the coupling's configuration, in facet lengths."""
    pairs = coupling.pairs
    w = (pairs.B @ (u - coupling.u_ref)).reshape(-1, pairs.dim)
    return float(np.max(np.linalg.norm(w, axis=1) / lengths, initial=0.0))


def _increment(problem, builder, state: _State, start, end, mu_pair, sensitivities, where, lengths):
    """Solve one nominal increment by fixed-point re-coupling, the first coupling at the configuration the last
    increment's displacement increment extrapolates to (or the last increment's coupling, kept while the pairs
    slide by at most :data:`RECOUPLE_FRACTION` of their facets since it); (coupling, path, u, (Newton iterations,
    cuts, passes))."""
    T = selection(problem.interface_dofs, len(state.u))
    u_ref, dofs = state.u + state.du, problem.interface_dofs
    keep = RECOUPLE_FRACTION > 0 and state.coupling is not None
    coupling = state.coupling if keep and _moved(state.coupling, u_ref, lengths) <= RECOUPLE_FRACTION else None
    n_newton = n_cuts = 0
    lost = []                            # per pass: the pairs the target does not cover
    for n_pass in range(1, MAX_PASSES + 1):
        if coupling is None:
            coupling = Coupling(problem, builder, u_ref)
            state.n_couplings += 1
        lost.append(coupling.lost)
        solver, pairs = coupling.solver, coupling.pairs
        path = solver.start()
        path.x, path.state = state.x.copy(), state.contact
        path.w_T = (pairs.B @ state.u).reshape(-1, pairs.dim)[:, 1:]
        if sensitivities and state.dx_I is not None:
            du = coupling.B_I @ (problem.condensed.gap_ops.full @ state.dx_I)
            path.dw_T = du.reshape(pairs.n_pairs, pairs.dim, -1)[:, 1:, :]
        step = solver.step(path, start, end, mu_pair, sensitivities, where)
        n_newton, n_cuts = n_newton + step.n_newton, n_cuts + step.n_cuts
        u = _displacement(problem, T, end, _interface_x(coupling, path.x))
        change = np.max(np.abs(u[dofs] - coupling.u_ref[dofs]), initial=0.0)
        scale = np.max(np.abs(u[dofs] - state.u[dofs]), initial=0.0)
        if change <= FIXED_POINT_RTOL * scale or (
                RECOUPLE_FRACTION > 0 and _moved(coupling, u, lengths) <= RECOUPLE_FRACTION):
            return coupling, path, u, (n_newton, n_cuts, n_pass)
        u_ref, coupling = u, None
    toggled = sorted(frozenset().union(*lost) - frozenset.intersection(*lost))
    cause = "" if not toggled else (
        f"; contact node(s) {problem.pairs.nodes[toggled].tolist()} (first at "
        f"{np.round(problem.pairs.position[toggled[0]], 4).tolist()}) move on and off the end of the target: extend "
        "the target surface over the whole slide")
    raise SolverError(f"finite sliding did not converge in {where}: the re-coupled interface displacements "
                      f"still moved {change:.3g} mm after {MAX_PASSES} passes" + cause)


def _displacement(problem, T: sp.csr_matrix, amplitude: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(n_dofs,) [mm] for interface forces and alpha ``x``: the interface dofs' from the Schur complements' kept
    factors where the condensation has them ("mumps": :meth:`Condensed.displacement_at`, no interior solve), the
    other nodes' their nearest interface node's (:meth:`Problem.interface_field`: the coupling reads only the
    interface nodes' positions, and the adjacent cells' corners to orient the facets); else the whole field."""
    c, dofs = problem.condensed, problem.interface_dofs
    on = c.displacement_at(dofs, T, problem.channels.displacements, amplitude, x)
    if on is None:
        return c.displacement(T, problem.channels.displacements, amplitude, x)
    return problem.interface_field(on)[0]


def _with_coupling_change(problem, builder, state: _State, coupling: Coupling, start, end, mu_pair, where,
                          held: np.ndarray, y: np.ndarray) -> np.ndarray:
    """d(f_I, alpha)/dmu (n_I + m, n_z) of the increment with the coupling's change with the displacements.

    The increment's solution y = (f_I, alpha) depends on mu directly and through the previous increment (``held``:
    that derivative with the coupling held) and on the configuration c its coupling is evaluated at, c = u(y) at
    the fixed point: ``s = held + dy/dc U s``, U = du_I/dy. Solved by fixed-point passes, each product
    ``dy/dc v`` by a forward difference: the increment solved, from the previous increment's state as the
    increment itself, with a coupling at ``c + h v`` (the interface nodes moved by at most
    :data:`COUPLING_STEP`), against its solution y at c.
    """
    dofs, dim = problem.interface_dofs, coupling.pairs.dim
    U = problem.condensed.gap_ops.full
    s = held
    for _ in range(MAX_PASSES):
        v = U @ s
        new = held.copy()
        for z in np.flatnonzero(np.abs(v).max(axis=0) > 0):
            h = COUPLING_STEP / np.abs(v[:, z]).max()
            u = coupling.u_ref.copy()
            u[dofs] += h * v[:, z]
            moved = Coupling(problem, builder, u)
            path = moved.solver.start()
            path.x, path.state = state.x.copy(), state.contact
            path.w_T = (moved.pairs.B @ state.u).reshape(-1, dim)[:, 1:]
            moved.solver.step(path, start, end, mu_pair, False, where)
            new[:, z] += (_interface_x(moved, path.x) - y) / h
        change, s = np.abs(new - s).max(), new
        if change <= SENSITIVITY_RTOL * np.abs(s).max():
            return s
    log.warning("finite sliding, %s: the sensitivities with the coupling's change still moved by %.2g of the largest "
                "after %d passes", where, change / max(np.abs(s).max(), 1e-300), MAX_PASSES)
    return s


def _interface_x(coupling: Coupling, x: np.ndarray) -> np.ndarray:
    """(f_I, alpha) of x = (lam, alpha): interface forces f_I = Bhat^T lam."""
    n_w = coupling.B_I.shape[0]
    return np.concatenate([coupling.B_I.T @ x[:n_w], x[n_w:]])


def solve_finite(problem, mu: np.ndarray, sensitivities: bool):
    """Run the load path of ``problem`` (condensed on its interface dofs) with finite sliding.

    Returns a :class:`~frictionid.fem.solution.Solution` whose ``lam`` are in the frames of each increment,
    ``w`` the change of the normal gap since the undeformed configuration and the accumulated slip,
    ``interface_forces`` the contact forces on the interface dofs.
    """
    from .solution import ExpandedRows, Solution

    if problem.pairs.n_pairs == 0:
        raise SolverError("finite sliding: the model has no contact pairs")
    builder = coupling_builder(problem.space, problem.model)
    ref, c = problem.pairs, problem.condensed
    state = _State(problem.space.n_dofs, ref, c.n_modes)
    stages, amps = problem.amplitudes()
    mu_pair, rec = ref.mu(mu), {k: [] for k in ("lam", "alpha", "w", "state", "obs", "reac", "d_obs", "d_reac",
                                                 "n_newton", "n_cuts", "f_I")}
    previous = np.zeros(amps.shape[1])
    n_w = ref.n_pairs * ref.dim
    lengths = facet_lengths(problem)
    for i, (stage, amp) in enumerate(zip(stages, amps)):
        where = f"stage {stage + 1} ({problem.model.stages[stage].name}), increment {i + 1}"
        coupling, path, u, (n_newton, n_cuts, n_pass) = _increment(problem, builder, state, previous, amp, mu_pair,
                                                                   sensitivities, where, lengths)
        log.debug("%s: %d re-coupling passes, %d Newton iterations", where, n_pass, n_newton)
        w_new, w_old = coupling.pairs.B @ u, coupling.pairs.B @ state.u
        state.slip = state.slip + (w_new - w_old).reshape(-1, ref.dim)[:, 1:]
        gap = coupling.pairs.gap + w_new[::ref.dim]
        x_I = _interface_x(coupling, path.x)
        ops = coupling.condensed
        for key, value in (("lam", path.x[:n_w].reshape(-1, ref.dim)), ("alpha", path.x[n_w:]),
                           ("w", np.column_stack([gap - ref.gap, state.slip])), ("state", path.state),
                           ("obs", ops.obs_ops(amp, path.x)), ("reac", ops.reac_ops(amp, path.x)),
                           ("n_newton", n_newton), ("n_cuts", n_cuts), ("f_I", x_I[:len(problem.interface_dofs)])):
            rec[key].append(value)
        if sensitivities:
            state.dx_I = np.vstack([coupling.B_I.T @ path.S[:n_w], path.S[n_w:]])
            if PATH_SENSITIVITIES == "consistent":
                state.dx_I = _with_coupling_change(problem, builder, state, coupling, previous, amp, mu_pair, where,
                                                   state.dx_I, x_I)
            rec["d_obs"].append(c.obs_ops.full @ state.dx_I)
            rec["d_reac"].append(c.reac_ops.full @ state.dx_I)
        state.u, state.du, state.x, state.contact, state.coupling = u, u - state.u, path.x, path.state, coupling
        previous = amp
    log.debug("finite sliding: %d couplings built for %d increments", state.n_couplings, len(stages))
    out = {k: np.array(v) for k, v in rec.items()}
    d_obs = out["d_obs"] if sensitivities else None
    d_reac = out["d_reac"] if sensitivities else None
    if problem.expand is not None:
        out["obs"] = ExpandedRows(out["obs"], problem.expand)
        d_obs = None if d_obs is None else ExpandedRows(d_obs, problem.expand)
    return Solution(
        mu=mu, zone_names=problem.model.zone_names, observation_labels=problem.observation_labels,
        reaction_labels=problem.reaction_labels, stage=stages, amplitude=amps, lam=out["lam"],
        alpha=out["alpha"], w=out["w"], state=out["state"], observations=out["obs"], reactions=out["reac"],
        d_observations=d_obs, d_reactions=d_reac, n_newton=out["n_newton"], n_cuts=out["n_cuts"], pairs=ref,
        interface_forces=out["f_I"])


def check_builder(space: Space, model: Model) -> CouplingBuilder:
    """The small-sliding check's coupling (:func:`pairing_gap_error`): :func:`mortar_builder` with the 3-D
    triangle rule of degree :data:`CHECK_DEGREE`."""
    return mortar_builder(space, model, CHECK_DEGREE)


def pairing_gap_error(problem, u: np.ndarray, w_normal: np.ndarray, builder: CouplingBuilder | None = None,
                      reference: np.ndarray | None = None) -> np.ndarray:
    """(n_pairs,) [mm] what the small-sliding pairing gets wrong in the normal gap at displacements ``u``.

    The change of the gap of the deformed configuration (the dual mortar coupling of :func:`check_builder` at
    ``X + u``, the pairs of ``problem`` in their order) since the undeformed one (``reference``, that coupling's
    gap at X: computed if not given) minus the fixed pairing's change ``w_normal`` (the pairs' normal relative
    displacements at ``u``): so a difference of the two discretisations in the undeformed configuration (node-to-
    node against mortar) is not counted. On a flat target that deforms uniformly a translated pair keeps its gap
    and the error is zero; otherwise it is about ``s . grad(u_n of the target)`` plus ``s^2 / (2 R)`` on a target
    of radius R, for a slip s. A pair the target no longer covers gets ``inf``.
    """
    builder = builder or check_builder(problem.space, problem.model)
    points = problem.model.mesh.points
    if reference is None:
        reference = aligned(problem.pairs, builder(points)).gap
    current = aligned(problem.pairs, builder(points + u.reshape(points.shape)))
    error = current.gap - reference - w_normal
    return np.where((current.gap >= UNCOVERED_GAP) | (reference >= UNCOVERED_GAP), np.inf, error)
