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
    cell_of_edge = {}
    for cell in near:
        cycle = corners[cell]
        for a, b in zip(cycle, np.roll(cycle, -1)):
            cell_of_edge[(min(a, b), max(a, b))] = cell
    try:
        cells = np.array([cell_of_edge[(min(a, b), max(a, b))] for a, b in facets[:, :2].tolist()], dtype=int)
    except KeyError:
        raise InputError("mortar: a contact or target facet is not an edge of any cell") from None
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
    """Root of ``residual(x) -> (f, df)`` (vectorised) from start; NaN where it does not converge."""
    x = np.array(start, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(_NEWTON_STEPS):
            f, df = residual(x)
            step = f / df
            x = x - step
            if np.all(np.abs(step) < _NEWTON_TOL):
                return x
    return np.where(np.abs(step) < _NEWTON_TOL, x, np.nan)


def _chord_parameter(coords: np.ndarray, points: np.ndarray) -> np.ndarray:
    chord = coords[1] - coords[0]
    return 2 * (points - coords[0]) @ chord / (chord @ chord) - 1


def project_onto_slave(coords: np.ndarray, normals: np.ndarray, point: np.ndarray) -> float:
    """Slave parameter xi whose interpolated normal line passes through point (may lie outside [-1, 1])."""
    k = len(coords)

    def residual(xi):
        N, dN = shape_functions(xi, k)
        gap = point - N @ coords
        return _cross(gap, N @ normals), _cross(-(dN @ coords), N @ normals) + _cross(gap, dN @ normals)

    return float(_newton(residual, _chord_parameter(coords, point)))


def project_onto_master(coords: np.ndarray, points: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Master parameters eta (q,) where the lines through points (q, 2) along directions (q, 2) cut the facet."""
    k = len(coords)

    def residual(eta):
        N, dN = shape_functions(eta, k)
        return _cross(N @ coords - points, directions), _cross(dN @ coords, directions)

    return _newton(residual, _chord_parameter(coords, points))


def _segment(space, slave, s, dual, master, m, search_distance):
    """Mortar block (k_s, k_m) and gap integrals (k_s,) of slave facet s on master facet m, or None."""
    ends = [project_onto_slave(slave.coords[s], slave.normals[s], master.coords[m, c]) for c in (0, 1)]
    if np.isnan(ends).any():
        logger.debug("mortar: no projection of master facet %d onto slave facet %d", m, s)
        return None
    a, b = np.clip(min(ends), -1, 1), np.clip(max(ends), -1, 1)
    if b - a < _SLIVER:
        return None
    xi, w = _gauss(a, b)
    N, _ = shape_functions(xi, slave.n_facet_nodes)
    x, measure = _measure(space, slave.coords[s:s + 1], xi)
    normal = _unit(N @ slave.normals[s])
    eta = project_onto_master(master.coords[m], x[0], normal)
    if np.isnan(eta).any():
        logger.debug("mortar: slave facet %d does not project onto master facet %d", s, m)
        return None
    N_master, _ = shape_functions(eta, master.n_facet_nodes)
    gap = np.einsum("qd,qd->q", N_master @ master.coords[m] - x[0], normal)
    if np.max(np.abs(gap)) > search_distance:
        return None
    psi = (N @ dual[s].T) * (w * measure[0])[:, None]
    return psi.T @ N_master, psi.T @ gap


def _candidates(slave, master, search_distance):
    """For each slave facet, master facets that face it (chord normals opposed within
    :data:`~frictionid.fem.contact_map.FACING_DEG`) and whose bounding boxes are within search_distance."""
    low_s, high_s = slave.coords.min(axis=1), slave.coords.max(axis=1)
    low_m, high_m = master.coords.min(axis=1), master.coords.max(axis=1)
    near = np.all((low_m[None] <= high_s[:, None] + search_distance)
                  & (high_m[None] >= low_s[:, None] - search_distance), axis=2)
    facing = slave.chord_normal() @ master.chord_normal().T <= -np.cos(np.radians(FACING_DEG))
    return [np.flatnonzero(row) for row in near & facing]


def _integrate(space, slave, master, search_distance, n_zones):
    """Mortar matrix (n_nodes, n_nodes), gap integrals (n_nodes,), D split by zone (n_nodes, n_zones) and the
    largest angle [deg] between the chords of a slave node's facets and the reversed chords of the master facets
    they couple to (n_nodes,; NaN where none)."""
    n_nodes = space.mesh.n_nodes
    dual, integral = dual_coefficients(space, slave.coords)
    rows, cols, values = [np.zeros(0, int)], [np.zeros(0, int)], [np.zeros(0)]
    gap, facing = np.zeros(n_nodes), np.full(n_nodes, np.nan)
    slave_normal, master_normal = slave.chord_normal(), master.chord_normal()
    for s, candidates in enumerate(_candidates(slave, master, search_distance)):
        for m in candidates:
            block = _segment(space, slave, s, dual, master, m, search_distance)
            if block is None:
                continue
            angle = np.degrees(np.arccos(np.clip(-slave_normal[s] @ master_normal[m], -1.0, 1.0)))
            facing[slave.facets[s]] = np.fmax(facing[slave.facets[s]], angle)
            rows.append(np.repeat(slave.facets[s], master.n_facet_nodes))
            cols.append(np.tile(master.facets[m], slave.n_facet_nodes))
            values.append(block[0].ravel())
            np.add.at(gap, slave.facets[s], block[1])
    mortar = sp.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(n_nodes, n_nodes))
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
    rows = [mortar.getrow(i) for i in nodes]
    width = max([r.nnz for r in rows], default=1) or 1
    target_nodes = np.repeat(np.asarray(nodes)[:, None], width, axis=1)   # padding: weight 0 on the node itself
    target_weights = np.zeros((len(nodes), width))
    for p, (row, s) in enumerate(zip(rows, scale)):
        target_nodes[p, :row.nnz] = row.indices
        target_weights[p, :row.nnz] = row.data / s
    return target_nodes, target_weights


def mortar_pairs(space: Space, model: Model, interface_index: int, *, search_distance: float | None = None,
                 min_coverage: float = 0.5) -> ContactPairs:
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
