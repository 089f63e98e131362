"""Segment-based dual-Lagrange mortar coupling of non-matching 3-D contact interfaces (triangle, triangle6, quad and
quad9 facets).

The contact side of an interface (the union of its zones) is the slave side and carries the multipliers; the
target is the master side. Slave facet by slave facet (Puso & Laursen 2004; Popp, Gee & Wall 2010):

1. an auxiliary plane through the slave facet's centre, normal n0 its outward normal there;
2. the flat pieces of the slave facet and of each facing master facet nearby (the facet itself, a quadratic one
   split at its mid-side nodes into four, :data:`~frictionid.fem.facet_shapes.SUBFACETS`) projected onto it
   along n0, each master piece clipped by each slave piece (:func:`frictionid.fem.clipping.clip`);
3. the clipped polygon split into triangles, integrated with a degree-10 rule; each integration point projected
   back along n0 onto the slave facet (parameter xi) and the master facet (eta), its weight divided by
   ``|n_slave(xi) . n0|`` so that it measures slave surface area (exact on flat facets).

With the element-wise dual basis ``psi_i = sum_k A_ik N^_k`` (``A_e = D_e M_e^-1``, ``M_e`` the mass matrix of
the slave facet's basis N^, ``D_e`` its row sums) the pair quantities are those of :mod:`frictionid.fem.mortar`::

    D_i  = int N^_i dA                        (slave tributary area, the pair weight)
    M_ij = int psi_i N_j^master(eta) dA       (mortar matrix)
    w_i  = frame_i . (u^_i - sum_j (M_ij / S_i) u_j^master),        S_i = sum_j M_ij
    gap_i = (1 / S_i) int psi_i g dA,         g = (x_master(eta) - x_slave(xi)) . n(xi)

n(xi) is the interpolated averaged nodal normal of the slave side (outward of the contact body); the pair frame
normal is ``-n`` at the node. On 6-node triangles N^ is the transformed basis of dual quadratic mortar
(:func:`frictionid.fem.node_to_node.surface_transform`, corner areas positive) and u^ = P u the transformed slave
values; on the other facet types N^ = N, u^ = u. On curved quadratic facets the pieces' outlines are chords of
half edges (a second-order error in the facet size). The corner polygons alone would cover a thin curved facet of
a thread flank (55 um wide, mid-side nodes 20 um off its chords) by about half its area on matching meshes.

References: Puso & Laursen, CMAME 193 (2004) 601-629; Popp, Gee & Wall, IJNME 79 (2009) 1354-1391;
Popp, Gitterle, Gee & Wall, IJNME 83 (2010) 1428-1465 (3-D dual mortar, segment-based integration);
Popp, Wohlmuth, Gee & Wall, SIAM J. Sci. Comput. 34 (2012) B421-B446 (quadratic dual mortar).
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..errors import InputError
from ..model import Model
from ..model.mesh import CELL_FACETS
from .clipping import clip, counter_clockwise, signed_areas
from .contact_map import check_gaps, coefficient_columns, gap_tolerance
from .facet_shapes import CENTRE, CORNERS, NODE_PARAMETERS, SUBFACETS, facet_quadrature, geometry, \
    project_along, shape_functions, triangle_quadrature
from .node_to_node import TRI6_ALPHA, surface_transform
from .pairs import ContactPairs, tangent_frames
from .space import Space

logger = logging.getLogger(__name__)

#: clipped pieces smaller than this fraction of the slave facet's area are dropped
_SLIVER = 1e-12
#: the degree of the triangle rule on the clipped pieces: 10 (25 points) for the solver's coupling
DEGREE = 10


def local_transform(facet_type: str, alpha: float = TRI6_ALPHA) -> np.ndarray:
    """(k, k) T with N^ = T N on one facet: the triangle6 transformation of dual quadratic mortar, else I."""
    k = len(NODE_PARAMETERS[facet_type])
    T = np.eye(k)
    if facet_type == "triangle6":
        for corner, mids in ((0, (3, 5)), (1, (3, 4)), (2, (4, 5))):
            T[corner, list(mids)] = alpha
        T[3:, 3:] *= 1 - 2 * alpha
    return T


def _outward_sign(mesh, facets: np.ndarray) -> np.ndarray:
    """(n_facets,) +1 where a facet's parameter normal points out of its adjacent cell, else -1.

    Decided on the straight cell (its corners off the facet against the facet's corner plane: the sign of a valid
    cell's volume), then the parameter normal at the facet's centre against the corner plane's: a curved facet's
    centre may bulge further into a flat cell than the mean of the cell's corners lies above the facet's plane (a
    quarter of the cell's height: on a thread flank cells 26-35 um high under bulges of 7-9 um)."""
    n_corners = CORNERS[mesh.facet_type]
    cell_corners = mesh.cells[:, :4 if mesh.cell_type.startswith("tetra") else 8]
    on = np.zeros(mesh.n_nodes, bool)
    on[facets[:, :n_corners]] = True
    near = np.flatnonzero(on[cell_corners].sum(axis=1) >= n_corners)
    faces = np.vstack([np.sort(cell_corners[near][:, list(local)], axis=1) for local in CELL_FACETS[mesh.cell_type]])
    owner = np.tile(near, len(CELL_FACETS[mesh.cell_type]))
    _, same = np.unique(np.vstack([faces, np.sort(facets[:, :n_corners], axis=1)]), axis=0, return_inverse=True)
    cell_of = np.full(same.max(initial=-1) + 1, -1)
    cell_of[same[:len(faces)]] = owner
    cells = cell_of[same[len(faces):]]
    if np.any(cells < 0):
        raise InputError("mortar: a contact or target facet is not a face of any cell")
    _, _, normal = geometry_many(mesh.points[facets], mesh.facet_type, CENTRE[mesh.facet_type])
    corners = mesh.points[facets[:, :n_corners]]
    flat = np.cross(corners[:, 2] - corners[:, 0], corners[:, -1] - corners[:, 1]) if n_corners == 4 else \
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    off = ~(cell_corners[cells][:, :, None] == facets[:, None, :n_corners]).any(axis=2)
    inward = (mesh.points[cell_corners[cells]] * off[..., None]).sum(axis=1) / off.sum(axis=1, keepdims=True) \
        - corners.mean(axis=1)
    outward_flat = np.where(np.einsum("fd,fd->f", flat, inward) < 0, 1.0, -1.0)
    return outward_flat * np.where(np.einsum("fd,fd->f", normal, flat) < 0, -1.0, 1.0)


def geometry_many(coords: np.ndarray, facet_type: str, rs):
    """Positions, tangents and unit normals of many facets (n, k, 3) at one parameter rs (2,)."""
    N, dN = shape_functions(np.asarray(rs, float), facet_type)
    x = np.einsum("k,fkd->fd", N, coords)
    tangents = np.einsum("kp,fkd->fdp", dN, coords)
    normal = np.cross(tangents[..., 0], tangents[..., 1])
    with np.errstate(invalid="ignore"):
        return x, tangents, normal / np.linalg.norm(normal, axis=1, keepdims=True)


class _Side:
    """One side of an interface: facets (n, k), coords (n, k, 3) [mm], sign (n,) (+1: parameter normal outward),
    zone (n,), node_normal (n_nodes, 3) averaged unit outward normals (zero off the side; None without
    ``node_normals``: the master side's are not used)."""

    def __init__(self, mesh, facets: np.ndarray, zone: np.ndarray, node_normals: bool = True):
        self.facet_type = mesh.facet_type
        self.facets, self.zone = facets, zone
        self.coords = mesh.points[facets]
        self.sign = _outward_sign(mesh, facets)
        self.centre, _, normal = geometry_many(self.coords, self.facet_type, CENTRE[self.facet_type])
        if not np.all(np.isfinite(normal)):
            bad = int(np.flatnonzero(~np.isfinite(normal).all(axis=1))[0])
            raise InputError(f"mortar: facet with nodes {facets[bad].tolist()} has zero area")
        self.normal = self.sign[:, None] * normal
        corners = self.coords[:, :CORNERS[self.facet_type]]
        self.radius = np.linalg.norm(corners - self.centre[:, None], axis=2).max(axis=1)
        self.node_normal = self._node_normals(mesh, normal) if node_normals else None

    def _node_normals(self, mesh, normal: np.ndarray) -> np.ndarray:
        """(n_nodes, 3) averaged unit outward normals at the side's nodes, zero elsewhere."""
        facets = self.facets
        total = np.zeros((mesh.n_nodes, 3))
        for node, rs in enumerate(NODE_PARAMETERS[self.facet_type]):
            at_node = geometry_many(self.coords, self.facet_type, rs)[2]
            at_node = np.where(np.isfinite(at_node), at_node, normal)     # a 180-degree corner: no normal there
            np.add.at(total, facets[:, node], self.sign[:, None] * at_node)
        on = np.linalg.norm(total, axis=1) > 0
        total[on] /= np.linalg.norm(total[on], axis=1)[:, None]
        return total


def dual_coefficients(coords: np.ndarray, facet_type: str):
    """Dual coefficients A (n, k, k) and integrals ``int N^_k dA`` (n, k) of slave facets (n, k, 3).

    ``psi_i = sum_k A[e, i, k] N^_k`` satisfies ``int_e psi_i N^_j dA = delta_ij int_e N^_i dA``.
    """
    rs, w = facet_quadrature(facet_type)
    N, dN = shape_functions(rs, facet_type)
    N = N @ local_transform(facet_type).T
    tangents = np.einsum("qkp,fkd->fqdp", dN, coords)
    area = np.linalg.norm(np.cross(tangents[..., 0], tangents[..., 1]), axis=-1)       # (n, q)
    mass = np.einsum("q,fq,qk,ql->fkl", w, area, N, N)
    integral = mass.sum(axis=2)
    return integral[:, :, None] * np.linalg.inv(mass), integral


def _planes(normal: np.ndarray) -> np.ndarray:
    """(n, 2, 3) orthonormal in-plane axes e1, e2 with e1 x e2 = normal, of unit normals (n, 3)."""
    e1 = np.eye(3)[np.argmin(np.abs(normal), axis=1)]
    e1 = e1 - np.einsum("nd,nd->n", e1, normal)[:, None] * normal
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return np.stack([e1, np.cross(normal, e1)], axis=1)


def _candidates(slave: _Side, master: _Side, search_distance: float):
    """Slave and master facet (n,) of every pair whose projections onto the slave facet's plane can overlap
    (centres within the sum of the facets' radii in the plane), facing each other within search_distance across
    the slave facet; by slave facet."""
    tree = cKDTree(master.centre)
    found = tree.query_ball_point(slave.centre, slave.radius + master.radius.max() + search_distance)
    s = np.repeat(np.arange(len(found)), [len(f) for f in found])
    m = np.concatenate([np.asarray(f, dtype=int) for f in found]) if len(found) else np.zeros(0, int)
    offset = master.centre[m] - slave.centre[s]
    across = np.einsum("pd,pd->p", offset, slave.normal[s])
    along = np.linalg.norm(offset - across[:, None] * slave.normal[s], axis=1)
    near = (along <= (slave.radius[s] + master.radius[m]) * (1 + 1e-9)) \
        & (np.abs(across) <= search_distance + master.radius[m]) \
        & (np.einsum("pd,pd->p", master.normal[m], slave.normal[s]) < 0)
    return s[near], m[near]


def _clipped(slave: _Side, master: _Side, s: np.ndarray, m: np.ndarray, degree: int = DEGREE):
    """Integration points (q, 3) [mm] on the slave facets' planes, their weights (q,) [mm^2] and pair (q,) (an
    index into s, m; non-decreasing): the pieces of the master facets m's flat pieces (:data:`SUBFACETS`)
    projected onto the slave facets s's planes that the slave facets' projected flat pieces clip, each split into a
    fan of triangles (the triangle rule exact to ``degree`` on each). Pieces smaller than :data:`_SLIVER` of the
    slave facet are dropped."""
    x0, axes = slave.centre[s], _planes(slave.normal)[s]
    to_plane = lambda coords: np.einsum("pskd,ped->pske", coords - x0[:, None, None], axes)   # noqa: E731
    own, other = np.array(SUBFACETS[slave.facet_type]), np.array(SUBFACETS[master.facet_type])
    n_own, n_other = len(own), len(other)
    polygons = to_plane(slave.coords[s][:, own])                                  # (p, n_own, k, 2)
    windows = to_plane(master.coords[m][:, other])
    polygon = np.broadcast_to(polygons[:, :, None], (len(s), n_own, n_other, *polygons.shape[2:]))
    window = np.broadcast_to(windows[:, None], (len(s), n_own, n_other, *windows.shape[2:]))
    polygon = counter_clockwise(polygon.reshape(-1, *polygons.shape[2:]))
    window = counter_clockwise(window.reshape(-1, *windows.shape[2:]))
    parent = np.repeat(np.arange(len(s)), n_own * n_other)
    piece, count = clip(window, polygon, tol=1e-10 * slave.radius[s][parent])
    whole = np.abs(signed_areas(to_plane(slave.coords[s][:, None, :CORNERS[slave.facet_type]])[:, 0]))
    count = np.where(signed_areas(piece, count) < _SLIVER * whole[parent], 0, count)
    # fan: triangle t has the vertices 0, t + 1, t + 2 of the piece
    cut, t = np.nonzero(np.arange(piece.shape[1] - 2) < count[:, None] - 2)
    triangles = piece[cut[:, None], np.column_stack([np.zeros_like(t), t + 1, t + 2])]           # (n_tri, 3, 2)
    area = np.abs(signed_areas(triangles))
    pair = parent[cut]
    rule, weights = triangle_quadrature(degree)
    points = np.einsum("qa,tae->tqe", rule, triangles)
    plane = x0[pair][:, None] + np.einsum("tqe,ted->tqd", points, axes[pair])
    return plane.reshape(-1, 3), (area[:, None] * weights).ravel(), np.repeat(pair, len(weights))


def _integrate(slave: _Side, master: _Side, n_nodes: int, search_distance: float, n_zones: int,
               degree: int = DEGREE):
    """Mortar matrix (n_nodes, n_nodes), gap integrals (n_nodes,) and int N^_i split by zone (n_nodes, n_zones).

    Every candidate pair of slave and master facets at once. A pair is dropped where one of its points does not
    project onto the master facet or its gap exceeds search_distance."""
    dual, integral = dual_coefficients(slave.coords, slave.facet_type)
    s, m = _candidates(slave, master, search_distance)
    points, weight, pair = _clipped(slave, master, s, m, degree)
    s_q, m_q, n0 = s[pair], m[pair], slave.normal[s[pair]]
    xi = project_along(slave.coords[s_q], slave.facet_type, points, n0)
    eta = project_along(master.coords[m_q], master.facet_type, points, n0)
    x_slave, _, n_facet = geometry(slave.coords[s_q], np.nan_to_num(xi), slave.facet_type)
    N_slave, _ = shape_functions(np.nan_to_num(xi), slave.facet_type)
    N_master, _ = shape_functions(np.nan_to_num(eta), master.facet_type)
    normal = np.einsum("qk,qkd->qd", N_slave, slave.node_normal[slave.facets[s_q]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    gap = np.einsum("qd,qd->q", np.einsum("qk,qkd->qd", N_master, master.coords[m_q]) - x_slave, normal)
    bad = np.isnan(xi).any(axis=1) | np.isnan(eta).any(axis=1) | (np.abs(gap) > search_distance)
    dropped = np.zeros(len(s), bool)
    dropped[pair[bad]] = True
    if dropped.any():
        logger.debug("mortar: %d facet pairs not projected or too far", int(dropped.sum()))
    kept = ~dropped[pair]
    psi = np.einsum("qk,qik->qi", N_slave @ local_transform(slave.facet_type).T, dual[s_q])
    psi *= (weight / np.abs(np.einsum("qd,qd->q", n_facet, n0)) * kept)[:, None]
    gap_integral = np.bincount(slave.facets[s_q].ravel(), (psi * np.where(kept, gap, 0.0)[:, None]).ravel(),
                               minlength=n_nodes)
    # the points are grouped by pair: sum each pair's block over its own run of points
    used = np.unique(pair[kept])
    starts = np.searchsorted(pair, used)
    blocks = np.add.reduceat(psi[:, :, None] * N_master[:, None, :], starts, axis=0) if len(used) else \
        np.zeros((0, psi.shape[1], N_master.shape[1]))
    k_s, k_m = slave.facets.shape[1], master.facets.shape[1]
    rows = np.repeat(slave.facets[s[used]], k_m, axis=1)
    cols = np.tile(master.facets[m[used]], (1, k_s))
    mortar = sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(n_nodes, n_nodes))
    by_zone = np.zeros((n_nodes, n_zones))
    np.add.at(by_zone, (slave.facets, np.broadcast_to(slave.zone[:, None], slave.facets.shape)), integral)
    return mortar, gap_integral, by_zone


def _sides(model: Model, interface_index: int):
    """Slave (contact zones) and master (target) sides of an interface, and which of the model's coefficients each
    zone takes (:func:`~frictionid.fem.contact_map.coefficient_columns`)."""
    if not 0 <= interface_index < len(model.interfaces):
        raise InputError(f"mortar: interface_index {interface_index} is out of range; the model has "
                         f"{len(model.interfaces)} interface(s)")
    if model.kind != "3d":
        raise InputError(f"mortar3d: only 3-D models are supported, got kind {model.kind!r}")
    interface = model.interfaces[interface_index]
    mesh = model.mesh
    facets = [mesh.boundary(zone) for zone in interface.zones]
    zone = np.concatenate([np.full(len(f), z) for z, f in enumerate(facets)])
    slave = _Side(mesh, np.vstack(facets), zone)
    target = mesh.boundary(interface.target)
    if np.intersect1d(np.unique(target), slave.facets).size:
        raise InputError(f"interface {interface.name!r}: zones and target {interface.target!r} share nodes; "
                         "the two bodies must have separate nodes at the interface")
    master = _Side(mesh, target, np.zeros(len(target), dtype=int), node_normals=False)
    return slave, master, coefficient_columns(model, interface)


def _operator(frames: np.ndarray, rows: sp.csr_matrix, dim: int) -> sp.csr_matrix:
    """B = blockdiag(frames) (rows (x) I): ``w[dim*i+k] = frames[i, k] . sum_j rows[i, j] u_j``."""
    n = len(frames)
    rotate = sp.bsr_matrix((frames, np.arange(n), np.arange(n + 1)), shape=(dim * n, dim * n))
    return (rotate @ sp.kron(rows, sp.eye(dim), format="csr")).tocsr()


def mortar_pairs_3d(space: Space, model: Model, interface_index: int, *, search_distance: float | None = None,
                    min_coverage: float = 0.5, gap_check: bool = True, degree: int = DEGREE) -> ContactPairs:
    """Dual mortar contact pairs of one interface of a 3-D model (any of the supported facet types).

    Parameters
    ----------
    space : Space
    model : Model
    interface_index : int
        Index into ``model.interfaces``; its zones are the slave side, its target the master side.
    search_distance : float [mm], optional
        A slave facet is coupled to a facing master facet only where the normal gap over their overlap stays
        within this distance. Default: the interface's ``gap_tolerance`` where it states one (on a thin-walled
        part such as a thread tooth a second sheet of the target lies behind the contact side, e.g. the next
        turn's flank), else twice the largest facet radius of either side.
    min_coverage : float
        Slave nodes with ``S_i / D_i`` below this (the share of their support the master covers) are left out.
    gap_check : bool
        Refuse gaps beyond the interface's tolerance (the set-up check, as in 2-D); False for a coupling at
        deformed positions (finite sliding), whose gaps are the solution's.
    degree : int
        The triangle rule's degree on the clipped pieces (:data:`DEGREE` for the solver's coupling).

    Returns
    -------
    ContactPairs
        One pair per kept slave node, in increasing node order (see :mod:`frictionid.fem.mortar` for the
        treatment of partly covered nodes).

    Examples
    --------
    >>> pairs = mortar_pairs_3d(Space.build(model.mesh, "3d"), model, 0)  # doctest: +SKIP
    >>> pairs.weight.sum()   # interface area [mm^2]  # doctest: +SKIP
    """
    slave, master, columns = _sides(model, interface_index)
    if search_distance is None:
        search_distance = model.interfaces[interface_index].gap_tolerance
    if search_distance is None:
        search_distance = float(2 * max(slave.radius.max(), master.radius.max()))
    mesh = model.mesh
    mortar, gap_integral, by_zone = _integrate(slave, master, mesh.n_nodes, search_distance, len(columns),
                                               degree)
    weight_all = by_zone.sum(axis=1)
    covered = np.asarray(mortar.sum(axis=1)).ravel()
    nodes = np.unique(slave.facets)
    keep = ((weight_all[nodes] > 1e-12 * weight_all.max()) & (covered[nodes] > 0)
            & (covered[nodes] >= (min_coverage - 1e-9) * weight_all[nodes]))
    if not keep.all():
        logger.info("mortar: interface %d: %d of %d contact nodes left out (not covered by the target)",
                    interface_index, int((~keep).sum()), len(nodes))
    nodes = nodes[keep]
    if not len(nodes):
        interface = model.interfaces[interface_index]
        raise InputError(f"interface {interface.name!r}: no contact facet of zones {list(interface.zones)} faces "
                         f"the target {interface.target!r} within {search_distance:.3g} mm (mortar); check that "
                         "the two boundaries touch and their bodies lie on opposite sides")
    transform = surface_transform(mesh, slave.facets)
    slave_rows = sp.identity(mesh.n_nodes, format="csr")[nodes] if transform is None else transform[1][nodes]
    rows = slave_rows - sp.diags(1.0 / covered[nodes]) @ mortar[nodes]
    frames = tangent_frames(-slave.node_normal[nodes])
    zone_share = (by_zone[nodes] / weight_all[nodes, None]) @ columns
    gap = gap_integral[nodes] / covered[nodes]
    interface = model.interfaces[interface_index]
    if gap_check:
        check_gaps(interface, gap, mesh.points[nodes], gap_tolerance(mesh, interface), "mortar")
    return ContactPairs(
        nodes=nodes, position=np.array(mesh.points[nodes]), frames=frames, weight=weight_all[nodes],
        zone_share=zone_share, gap=gap,
        B=_operator(frames, sp.csr_matrix(rows), space.dim),
        interface=np.full(len(nodes), interface_index, dtype=np.int64))
