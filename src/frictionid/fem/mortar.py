"""Segment-based dual-Lagrange mortar coupling of non-matching 2-D contact interfaces (line and line3 facets).

The contact side of an interface (the union of its zones) is the slave side and carries the multipliers; the
target is the master side. With the element-wise dual basis ``psi_i = sum_k A_ik N_k``, ``A_e = D_e M_e^-1``
(``M_e`` the slave facet mass matrix, ``D_e`` its row sums) and every integral taken with the ring factor
``space.ring(x)`` (whole-ring areas in axisymmetry)::

    D_i  = int N_i ds                        (slave tributary area, the pair weight)
    M_ij = int psi_i N_j^master(P(x)) ds     (mortar matrix, integrated on the slave surface)
    w_i  = frame_i . (u_i - sum_j (M_ij / S_i) u_j^master),        S_i = sum_j M_ij
    gap_i = (1 / S_i) int psi_i g(x) ds,     g(x) = (x_master(P(x)) - x) . n_slave(x)

P projects a slave point onto the master surface along the interpolated averaged nodal normal ``n_slave`` of the
slave side (outward of the contact body). The pair frame normal is ``n_i = -n_slave,i``, the outward normal of
the target side, as in :mod:`frictionid.fem.pairs`; so ``g = gap + w_N`` with ``gap >= 0`` open and negative for
an interference. For a slave node whose support is fully covered by the master ``S_i = D_i`` (biorthogonality).

References: Popp, Gee & Wall, IJNME 79 (2009) 1354-1391 (2-D dual mortar, segment-based integration);
Wohlmuth, SIAM J. Numer. Anal. 38 (2000) 989-1012 (dual basis).
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..model import Model
from .contact_map import FACING_DEG, check_gaps, coefficient_columns, gap_tolerance
from .pairs import ContactPairs, relative_operator, tangent_frames
from .space import Space

logger = logging.getLogger(__name__)

#: Gauss points per integration interval (exact for straight facets of order <= 2, axisymmetric included)
N_GAUSS = 8
#: parameter of each facet node in meshio order (line: ends; line3: ends, then middle)
NODE_XI = {2: np.array([-1.0, 1.0]), 3: np.array([-1.0, 1.0, 0.0])}
_NEWTON_STEPS = 30
_NEWTON_TOL = 1e-10         # on the facet parameter; the error after such a step is ~1e-20
_SLIVER = 1e-12


def shape_functions(xi, n_facet_nodes: int):
    """Values and derivatives, each (..., n_facet_nodes), of line/line3 shape functions (meshio order) at xi."""
    xi = np.asarray(xi, dtype=float)
    if n_facet_nodes == 2:
        one = np.ones_like(xi)
        return np.stack([(1 - xi) / 2, (1 + xi) / 2], -1), np.stack([-one / 2, one / 2], -1)
    values = np.stack([xi * (xi - 1) / 2, xi * (xi + 1) / 2, 1 - xi**2], -1)
    return values, np.stack([xi - 0.5, xi + 0.5, -2 * xi], -1)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _facet_normals(coords, xi):
    """(n_facets, n_xi, 2) unit normals ``(t_y, -t_x)/|t|`` of facets (n_facets, k, 2) at parameters xi."""
    _, dN = shape_functions(xi, coords.shape[1])
    tangent = np.einsum("qk,fkd->fqd", dN, coords)
    return _unit(np.stack([tangent[..., 1], -tangent[..., 0]], -1))


def _oriented(mesh, facets: np.ndarray) -> np.ndarray:
    """Facets with their ends ordered so that ``(t_y, -t_x)`` points out of the adjacent cell."""
    n_corners = 3 if mesh.cell_type.startswith("triangle") else 4
    corners = mesh.cells[:, :n_corners]
    near = np.flatnonzero(np.isin(corners, facets[:, :2]).sum(axis=1) >= 2)
    ends = np.stack([corners[near], np.roll(corners[near], -1, axis=1)], -1).reshape(-1, 2)
    keys = np.sort(ends, axis=1) @ np.array([mesh.n_nodes, 1])
    order = np.argsort(keys, kind="stable")
    wanted = np.sort(facets[:, :2], axis=1) @ np.array([mesh.n_nodes, 1])
    found = np.searchsorted(keys[order], wanted, side="right") - 1       # the last cell of an edge, as before
    if np.any(found < 0) or np.any(keys[order][np.maximum(found, 0)] != wanted):
        raise InputError("mortar: a contact or target facet is not an edge of any cell")
    cells = near[order[found] // n_corners]
    centroid = mesh.points[corners[cells]].mean(axis=1)
    x0, x1 = mesh.points[facets[:, 0]], mesh.points[facets[:, 1]]
    chord = x1 - x0
    outward = np.einsum("fd,fd->f", (x0 + x1) / 2 - centroid, np.column_stack([chord[:, 1], -chord[:, 0]])) > 0
    out = facets.copy()
    out[~outward, 0], out[~outward, 1] = facets[~outward, 1], facets[~outward, 0]
    return out


class _Surface:
    """One side of an interface: oriented facets, their node coordinates and averaged nodal normals.

    Attributes: facets (n_facets, k) int, coords (n_facets, k, 2) [mm], normals (n_facets, k, 2) averaged unit
    outward normals at the facet nodes, zone (n_facets,) int, node_normal (n_nodes, 2) (zero off the surface).
    """

    def __init__(self, mesh, facets: np.ndarray, zone: np.ndarray):
        self.facets = _oriented(mesh, facets)
        self.zone = zone
        self.coords = mesh.points[self.facets]
        k = self.facets.shape[1]
        total = np.zeros((mesh.n_nodes, 2))
        np.add.at(total, self.facets, _facet_normals(self.coords, NODE_XI[k]))
        on = np.linalg.norm(total, axis=1) > 0
        total[on] = _unit(total[on])
        self.node_normal = total
        self.normals = total[self.facets]

    @property
    def n_facet_nodes(self) -> int:
        return self.facets.shape[1]

    def chord_length(self) -> np.ndarray:
        return np.linalg.norm(self.coords[:, 1] - self.coords[:, 0], axis=1)

    def chord_normal(self) -> np.ndarray:
        chord = self.coords[:, 1] - self.coords[:, 0]
        return _unit(np.column_stack([chord[:, 1], -chord[:, 0]]))


_LEGENDRE = np.polynomial.legendre.leggauss(N_GAUSS)     # computed once: a finite-sliding solve re-couples often


def _gauss(a: float = -1.0, b: float = 1.0):
    points, weights = _LEGENDRE
    return (a + b) / 2 + (b - a) / 2 * points, (b - a) / 2 * weights


def _measure(space: Space, coords: np.ndarray, xi: np.ndarray):
    """Positions (n_facets, q, 2) and measure ``|dx/dxi| ring(x)`` (n_facets, q) at parameters xi (q,)."""
    N, dN = shape_functions(xi, coords.shape[1])
    x = np.einsum("qk,fkd->fqd", N, coords)
    jacobian = np.linalg.norm(np.einsum("qk,fkd->fqd", dN, coords), axis=-1)
    return x, jacobian * space.ring(np.moveaxis(x, -1, 0))


def dual_coefficients(space: Space, coords: np.ndarray):
    """Dual basis coefficients A (n_facets, k, k) and nodal integrals ``int N_k`` (n_facets, k) per slave facet.

    ``psi_i = sum_k A[e, i, k] N_k`` satisfies ``int_e psi_i N_j = delta_ij int_e N_i`` (ring factor included).
    """
    xi, w = _gauss()
    N, _ = shape_functions(xi, coords.shape[1])
    _, measure = _measure(space, coords, xi)
    mass = np.einsum("q,fq,qk,ql->fkl", w, measure, N, N)
    integral = mass.sum(axis=2)
    return integral[:, :, None] * np.linalg.inv(mass), integral


def _newton(residual, start):
    """Roots of ``residual(x) -> (f, df)`` (elementwise, vectorised) from start; NaN where one does not converge.

    Each entry stops at the first step below :data:`_NEWTON_TOL` (later steps would change it by round-off).
    """
    x = np.array(start, dtype=float)
    active = np.ones(x.shape, dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(_NEWTON_STEPS):
            f, df = residual(x)
            step = f / df
            x = np.where(active, x - step, x)
            active &= ~(np.abs(step) < _NEWTON_TOL)
            if not active.any():
                return x
    return np.where(active, np.nan, x)


def _chord_parameter(coords: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Parameters (n, ...) of points (n, ..., 2) projected onto the chords of facets (n, k, 2)."""
    chord = coords[:, 1] - coords[:, 0]
    shape = (len(coords),) + (1,) * (points.ndim - 2) + (2,)
    along = np.sum((points - coords[:, 0].reshape(shape)) * chord.reshape(shape), axis=-1)
    return 2 * along / np.sum(chord * chord, axis=-1).reshape(shape[:-1]) - 1


def project_onto_slave(coords: np.ndarray, normals: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Slave parameters xi (n,) whose interpolated normal lines pass through points (n, 2), one per facet
    (coords, normals (n, k, 2)); they may lie outside [-1, 1]."""
    k = coords.shape[1]

    def residual(xi):
        N, dN = shape_functions(xi, k)
        gap = points - np.einsum("nk,nkd->nd", N, coords)
        normal, tangent = np.einsum("nk,nkd->nd", N, normals), np.einsum("nk,nkd->nd", dN, coords)
        return _cross(gap, normal), _cross(-tangent, normal) + _cross(gap, np.einsum("nk,nkd->nd", dN, normals))

    return _newton(residual, _chord_parameter(coords, points))


def project_onto_master(coords: np.ndarray, points: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Master parameters eta (n, q) where the lines through points (n, q, 2) along directions (n, q, 2) cut
    facet n (coords (n, k, 2))."""
    k = coords.shape[1]

    def residual(eta):
        N, dN = shape_functions(eta, k)
        x, tangent = np.einsum("nqk,nkd->nqd", N, coords), np.einsum("nqk,nkd->nqd", dN, coords)
        return _cross(x - points, directions), _cross(tangent, directions)

    return _newton(residual, _chord_parameter(coords, points))


def _segments(space, slave, dual, master, s, m, search_distance):
    """Mortar blocks (n, k_s, k_m) and gap integrals (n, k_s) of the candidate pairs (slave facet s[i], master
    facet m[i]) that couple, and a mask (len(s),) of those pairs."""
    ends = np.column_stack([project_onto_slave(slave.coords[s], slave.normals[s], master.coords[m, c])
                            for c in (0, 1)])
    projected = ~np.isnan(ends).any(axis=1)
    if not projected.all():
        logger.debug("mortar: %d master facets do not project onto their slave facets", int((~projected).sum()))
    with np.errstate(invalid="ignore"):
        a, b = np.clip(ends.min(axis=1), -1, 1), np.clip(ends.max(axis=1), -1, 1)
    kept = np.flatnonzero(projected & (b - a >= _SLIVER))
    s, m, a, b = s[kept], m[kept], a[kept], b[kept]
    points, weights = _LEGENDRE
    xi = (a + b)[:, None] / 2 + (b - a)[:, None] / 2 * points
    w = (b - a)[:, None] / 2 * weights
    N, dN = shape_functions(xi, slave.n_facet_nodes)
    x = np.einsum("nqk,nkd->nqd", N, slave.coords[s])
    measure = np.linalg.norm(np.einsum("nqk,nkd->nqd", dN, slave.coords[s]), axis=-1) * space.ring(
        np.moveaxis(x, -1, 0))
    normal = _unit(np.einsum("nqk,nkd->nqd", N, slave.normals[s]))
    eta = project_onto_master(master.coords[m], x, normal)
    found = ~np.isnan(eta).any(axis=1)
    if not found.all():
        logger.debug("mortar: %d slave facets do not project onto a master facet", int((~found).sum()))
    N_master, _ = shape_functions(np.nan_to_num(eta), master.n_facet_nodes)
    gap = np.einsum("nqd,nqd->nq", np.einsum("nqk,nkd->nqd", N_master, master.coords[m]) - x, normal)
    with np.errstate(invalid="ignore"):
        near = found & (np.max(np.abs(gap), axis=1) <= search_distance)
    psi = np.einsum("nqk,nik->nqi", N, dual[s]) * (w * measure)[..., None]
    coupled = np.zeros(len(ends), dtype=bool)
    coupled[kept[near]] = True
    return np.einsum("nqi,nqj->nij", psi[near], N_master[near]), np.einsum("nqi,nq->ni", psi[near], gap[near]), \
        coupled


def _candidates(slave, master, search_distance):
    """Candidate pairs (slave facets, master facets), slave-major: master facets that face the slave facet
    (chord normals opposed within :data:`~frictionid.fem.contact_map.FACING_DEG`) and whose bounding boxes are
    within search_distance."""
    low_s, high_s = slave.coords.min(axis=1), slave.coords.max(axis=1)
    low_m, high_m = master.coords.min(axis=1), master.coords.max(axis=1)
    near = np.all((low_m[None] <= high_s[:, None] + search_distance)
                  & (high_m[None] >= low_s[:, None] - search_distance), axis=2)
    facing = slave.chord_normal() @ master.chord_normal().T <= -np.cos(np.radians(FACING_DEG))
    return np.nonzero(near & facing)


def _integrate(space, slave, master, search_distance, n_zones):
    """Mortar matrix (n_nodes, n_nodes), gap integrals (n_nodes,), D split by zone (n_nodes, n_zones) and the
    largest angle [deg] between the chords of a slave node's facets and the reversed chords of the master facets
    they couple to (n_nodes,; NaN where none). All candidate pairs at once."""
    n_nodes = space.mesh.n_nodes
    dual, integral = dual_coefficients(space, slave.coords)
    s, m = _candidates(slave, master, search_distance)
    blocks, gap_integrals, coupled = _segments(space, slave, dual, master, s, m, search_distance)
    s, m = s[coupled], m[coupled]
    k_s, k_m = slave.n_facet_nodes, master.n_facet_nodes
    mortar = sp.csr_matrix((blocks.ravel(), (np.repeat(slave.facets[s], k_m, axis=1).ravel(),
                                             np.tile(master.facets[m], (1, k_s)).ravel())), shape=(n_nodes, n_nodes))
    gap = np.zeros(n_nodes)
    np.add.at(gap, slave.facets[s], gap_integrals)
    cosine = np.einsum("nd,nd->n", -slave.chord_normal()[s], master.chord_normal()[m])
    facing = np.full(n_nodes, np.nan)
    np.fmax.at(facing, slave.facets[s], np.repeat(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))[:, None],
                                                  k_s, axis=1))
    by_zone = np.zeros((n_nodes, n_zones))
    np.add.at(by_zone, (slave.facets, slave.zone[:, None]), integral)
    return mortar, gap, by_zone, facing


def _surfaces(model: Model, interface_index: int):
    """Slave (contact zones) and master (target) surfaces of an interface, and the model zone index per zone."""
    if not 0 <= interface_index < len(model.interfaces):
        raise InputError(f"mortar: interface_index {interface_index} is out of range; the model has "
                         f"{len(model.interfaces)} interface(s)")
    if model.kind == "3d" or model.mesh.facet_type not in ("line", "line3"):
        raise InputError(f"mortar: only 2-D models (line/line3 facets) are supported, got kind {model.kind!r}")
    interface = model.interfaces[interface_index]
    mesh = model.mesh
    facets = [mesh.boundary(zone) for zone in interface.zones]
    zone = np.concatenate([np.full(len(f), z) for z, f in enumerate(facets)])
    slave = _Surface(mesh, np.vstack(facets), zone)
    target = mesh.boundary(interface.target)
    master = _Surface(mesh, target, np.zeros(len(target), dtype=int))
    return slave, master, coefficient_columns(model, interface)


def _padded_rows(mortar: sp.csr_matrix, nodes: np.ndarray, scale: np.ndarray):
    """Target nodes and weights (n_pairs, m) of the mortar rows of nodes, divided by scale and padded with 0."""
    rows = mortar[np.asarray(nodes)]
    counts = np.diff(rows.indptr)
    width = max(int(counts.max(initial=0)), 1)
    target_nodes = np.repeat(np.asarray(nodes)[:, None], width, axis=1)   # padding: weight 0 on the node itself
    target_weights = np.zeros((len(nodes), width))
    row = np.repeat(np.arange(len(nodes)), counts)
    column = np.arange(rows.nnz) - np.repeat(rows.indptr[:-1], counts)
    target_nodes[row, column] = rows.indices
    target_weights[row, column] = rows.data / np.asarray(scale)[row]
    return target_nodes, target_weights


def mortar_pairs(space: Space, model: Model, interface_index: int, *, search_distance: float | None = None,
                 min_coverage: float = 0.5, gap_check: bool = True) -> ContactPairs:
    """Dual mortar contact pairs of one interface of a 2-D model (plane strain or axisymmetric).

    Parameters
    ----------
    space : Space
        The model's space (its ``ring`` gives the axisymmetric measure).
    model : Model
    interface_index : int
        Index into ``model.interfaces``; its zones are the slave side, its target the master side.
    search_distance : float [mm], optional
        A slave facet is coupled to a facing master facet only if the normal gap stays within this distance over
        their overlap. Default: the longest facet chord of either side.
    min_coverage : float
        Slave nodes with ``S_i / D_i`` below this (share of their support the master covers; 1 = fully covered)
        are left out, as are nodes of zero weight (line3 corner nodes on the axis, r = 0).
    gap_check : bool
        Refuse gaps beyond the interface's tolerance (the set-up check, :func:`~frictionid.fem.contact_map.
        check_gaps`); False for a coupling at deformed positions (finite sliding), whose gaps are the solution's.

    Returns
    -------
    ContactPairs
        One pair per kept slave node, in increasing node order. Partly covered nodes keep ``weight = D_i`` and
        rows scaled by ``S_i``: rigid translations are exact for them, linear fields only for fully covered nodes.

    Examples
    --------
    >>> pairs = mortar_pairs(Space.build(model.mesh, model.kind), model, 0)  # doctest: +SKIP
    >>> pairs.weight.sum()  # interface length [mm] (plane strain) or area [mm^2] (axisymmetric)  # doctest: +SKIP
    """
    slave, master, columns = _surfaces(model, interface_index)
    if search_distance is None:
        search_distance = float(max(slave.chord_length().max(), master.chord_length().max()))
    mortar, gap_integral, by_zone, facing = _integrate(space, slave, master, search_distance, len(columns))
    weight_all = by_zone.sum(axis=1)
    covered = np.asarray(mortar.sum(axis=1)).ravel()
    nodes = np.unique(slave.facets)
    keep = ((weight_all[nodes] > 1e-12 * weight_all.max()) & (covered[nodes] > 0)
            & (covered[nodes] >= (min_coverage - 1e-9) * weight_all[nodes]))
    if not keep.any():
        raise InputError(f"[[model.interfaces]] {model.interfaces[interface_index].name!r}: none of its "
                         f"{len(nodes)} contact nodes (mortar) has a target facet facing it (normals opposed within "
                         f"{FACING_DEG:g} deg) within {search_distance:.3g} mm; check that the target "
                         f"{model.interfaces[interface_index].target!r} is the surface the zones face")
    if not keep.all():
        logger.info("mortar: interface %d: %d of %d contact nodes left out (not covered by the target)",
                    interface_index, int((~keep).sum()), len(nodes))
    nodes = nodes[keep]
    frames = tangent_frames(-slave.node_normal[nodes])
    target_nodes, target_weights = _padded_rows(mortar, nodes, covered[nodes])
    gap = gap_integral[nodes] / covered[nodes]
    interface = model.interfaces[interface_index]
    if gap_check:
        check_gaps(interface, gap, model.mesh.points[nodes], gap_tolerance(model.mesh, interface), "mortar")
    return ContactPairs(
        nodes=nodes,
        position=np.array(model.mesh.points[nodes]),
        frames=frames,
        weight=weight_all[nodes],
        zone_share=(by_zone[nodes] / weight_all[nodes, None]) @ columns,
        gap=gap,
        B=relative_operator(frames, nodes, target_nodes, target_weights, space.n_dofs),
        interface=np.full(len(nodes), interface_index, dtype=np.int64),
        facing=facing[nodes],
    )
