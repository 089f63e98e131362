"""The 2-D mortar coupling integrated segment by segment, in Python loops: the reference the vectorised builder
(frictionid.fem.mortar._integrate, all candidate pairs at once) is tested against (tests/test_mortar.py)."""

import numpy as np
import scipy.sparse as sp

from frictionid.fem.contact_map import FACING_DEG
from frictionid.fem.mortar import _cross, _gauss, _measure, _unit, dual_coefficients, shape_functions

_STEPS, _TOL, _SLIVER = 30, 1e-10, 1e-12


def _newton(residual, start):
    x = np.array(start, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(_STEPS):
            f, df = residual(x)
            step = f / df
            x = x - step
            if np.all(np.abs(step) < _TOL):
                return x
    return np.where(np.abs(step) < _TOL, x, np.nan)


def _chord_parameter(coords, points):
    chord = coords[1] - coords[0]
    return 2 * (points - coords[0]) @ chord / (chord @ chord) - 1


def _onto_slave(coords, normals, point):
    k = len(coords)

    def residual(xi):
        N, dN = shape_functions(xi, k)
        gap = point - N @ coords
        return _cross(gap, N @ normals), _cross(-(dN @ coords), N @ normals) + _cross(gap, dN @ normals)

    return float(_newton(residual, _chord_parameter(coords, point)))


def _onto_master(coords, points, directions):
    k = len(coords)

    def residual(eta):
        N, dN = shape_functions(eta, k)
        return _cross(N @ coords - points, directions), _cross(dN @ coords, directions)

    return _newton(residual, _chord_parameter(coords, points))


def _segment(space, slave, s, dual, master, m, search_distance):
    ends = [_onto_slave(slave.coords[s], slave.normals[s], master.coords[m, c]) for c in (0, 1)]
    if np.isnan(ends).any():
        return None
    a, b = np.clip(min(ends), -1, 1), np.clip(max(ends), -1, 1)
    if b - a < _SLIVER:
        return None
    xi, w = _gauss(a, b)
    N, _ = shape_functions(xi, slave.n_facet_nodes)
    x, measure = _measure(space, slave.coords[s:s + 1], xi)
    normal = _unit(N @ slave.normals[s])
    eta = _onto_master(master.coords[m], x[0], normal)
    if np.isnan(eta).any():
        return None
    N_master, _ = shape_functions(eta, master.n_facet_nodes)
    gap = np.einsum("qd,qd->q", N_master @ master.coords[m] - x[0], normal)
    if np.max(np.abs(gap)) > search_distance:
        return None
    psi = (N @ dual[s].T) * (w * measure[0])[:, None]
    return psi.T @ N_master, psi.T @ gap


def integrate(space, slave, master, search_distance, n_zones):
    """The same four results as frictionid.fem.mortar._integrate, one (slave, master) segment at a time."""
    n_nodes = space.mesh.n_nodes
    dual, integral = dual_coefficients(space, slave.coords)
    low_s, high_s = slave.coords.min(axis=1), slave.coords.max(axis=1)
    low_m, high_m = master.coords.min(axis=1), master.coords.max(axis=1)
    near = np.all((low_m[None] <= high_s[:, None] + search_distance)
                  & (high_m[None] >= low_s[:, None] - search_distance), axis=2)
    facing_pairs = slave.chord_normal() @ master.chord_normal().T <= -np.cos(np.radians(FACING_DEG))
    rows, cols, values = [np.zeros(0, int)], [np.zeros(0, int)], [np.zeros(0)]
    gap, facing = np.zeros(n_nodes), np.full(n_nodes, np.nan)
    slave_normal, master_normal = slave.chord_normal(), master.chord_normal()
    for s, candidates in enumerate(np.flatnonzero(row) for row in near & facing_pairs):
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


def padded_rows(mortar, nodes, scale):
    """frictionid.fem.mortar._padded_rows, row by row."""
    rows = [mortar.getrow(i) for i in nodes]
    width = max([r.nnz for r in rows], default=1) or 1
    target_nodes = np.repeat(np.asarray(nodes)[:, None], width, axis=1)
    target_weights = np.zeros((len(nodes), width))
    for p, (row, s) in enumerate(zip(rows, scale)):
        target_nodes[p, :row.nnz] = row.indices
        target_weights[p, :row.nnz] = row.data / s
    return target_nodes, target_weights
