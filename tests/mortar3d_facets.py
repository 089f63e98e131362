"""The 3-D mortar coupling integrated slave facet by slave facet, in Python loops, and the scalar polygon clipping
it uses: the reference the vectorised builder (frictionid.fem.mortar3d._integrate, all candidate facet pairs at
once) is tested against (tests/test_mortar3d.py). This is the builder as it was before it was vectorised."""

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from frictionid.fem.facet_shapes import (CORNERS, SUBFACETS, geometry, project_along, shape_functions,
                                        triangle_quadrature)
from frictionid.fem.mortar3d import _SLIVER, DEGREE, dual_coefficients, local_transform


def signed_area(polygon):
    points = np.asarray(polygon, dtype=float).tolist()
    return 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(points, points[1:] + points[:1]))


def counter_clockwise(polygon):
    return polygon if signed_area(polygon) >= 0 else polygon[::-1]


def clip(subject, window, tol=0.0):
    """Sutherland-Hodgman, one convex polygon (n, 2) by another (k, 2), both counter-clockwise."""
    out = np.asarray(subject, dtype=float).tolist()
    corners = np.asarray(window, dtype=float).tolist()
    for (ax, ay), (bx, by) in zip(corners, corners[1:] + corners[:1]):
        if not out:
            break
        ex, ey = bx - ax, by - ay
        length = (ex * ex + ey * ey) ** 0.5
        side = [(ex * (y - ay) - ey * (x - ax)) / length for x, y in out]
        if min(side) >= -tol:
            continue
        kept = []
        for i, (p, d) in enumerate(zip(out, side)):
            q, e = out[(i + 1) % len(out)], side[(i + 1) % len(out)]
            if d >= -tol:
                kept.append(p)
            if (d >= -tol) != (e >= -tol):
                t = min(max(d / (d - e), 0.0), 1.0)
                kept.append([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])])
        out = kept
    return np.array(out) if len(out) >= 3 else np.zeros((0, 2))


def _plane(normal):
    e1 = np.eye(3)[np.argmin(np.abs(normal))]
    e1 = e1 - (e1 @ normal) * normal
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(normal, e1)])


def _pieces(polygon):
    points, weights = [], []
    for i in range(1, len(polygon) - 1):
        triangle = polygon[[0, i, i + 1]]
        rule, rule_weights = triangle_quadrature(DEGREE)
        points.append(rule @ triangle)
        weights.append(rule_weights * abs(signed_area(triangle)))
    return np.concatenate(points), np.concatenate(weights)


def _clipped(slave, s, master, candidates):
    x0, axes = slave.centre[s], _plane(slave.normal[s])
    whole = signed_area(counter_clockwise((slave.coords[s, :CORNERS[slave.facet_type]] - x0) @ axes.T))
    points, weights, owners = [np.zeros((0, 2))], [np.zeros(0)], [np.zeros(0, int)]
    for m in candidates:
        for own in SUBFACETS[slave.facet_type]:
            polygon = counter_clockwise((slave.coords[s, list(own)] - x0) @ axes.T)
            for other in SUBFACETS[master.facet_type]:
                window = (master.coords[m, list(other)] - x0) @ axes.T
                piece = clip(counter_clockwise(window), polygon, tol=1e-10 * slave.radius[s])
                if len(piece) == 0 or signed_area(piece) < _SLIVER * whole:
                    continue
                plane_points, weight = _pieces(piece)
                points.append(plane_points)
                weights.append(weight)
                owners.append(np.full(len(weight), m))
    return x0 + np.concatenate(points) @ axes, np.concatenate(weights), np.concatenate(owners)


def _facet_blocks(slave, s, dual, master, candidates, search_distance):
    points, weight, owner = _clipped(slave, s, master, candidates)
    n0 = slave.normal[s]
    xi = project_along(slave.coords[s], slave.facet_type, points, n0)
    eta = project_along(master.coords[owner], master.facet_type, points, n0)
    x_slave, _, n_facet = geometry(slave.coords[s], np.nan_to_num(xi), slave.facet_type)
    N_slave, _ = shape_functions(np.nan_to_num(xi), slave.facet_type)
    N_master, _ = shape_functions(np.nan_to_num(eta), master.facet_type)
    normal = N_slave @ slave.node_normal[slave.facets[s]]
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    gap = np.einsum("qd,qd->q", np.einsum("qk,qkd->qd", N_master, master.coords[owner]) - x_slave, normal)
    facets, local = np.unique(owner, return_inverse=True)
    bad = np.isnan(xi).any(axis=1) | np.isnan(eta).any(axis=1) | (np.abs(gap) > search_distance)
    kept = ~np.isin(local, np.unique(local[bad]))
    psi = N_slave @ local_transform(slave.facet_type).T @ dual[s].T
    psi *= (weight / np.abs(n_facet @ n0) * kept)[:, None]
    blocks = np.zeros((len(facets), psi.shape[1], N_master.shape[1]))
    np.add.at(blocks, local, psi[:, :, None] * N_master[:, None, :])
    used = np.isin(np.arange(len(facets)), local[kept])
    return facets[used], blocks[used], psi.T @ np.where(kept, gap, 0.0)


def candidates(slave, master, search_distance):
    """For each slave facet, the facing master facets whose projections can overlap it."""
    tree = cKDTree(master.centre)
    reach = slave.radius + master.radius.max() + search_distance
    out = []
    for s, found in enumerate(tree.query_ball_point(slave.centre, reach)):
        found = np.asarray(found, dtype=int)
        offset = master.centre[found] - slave.centre[s]
        across = offset @ slave.normal[s]
        along = np.linalg.norm(offset - across[:, None] * slave.normal[s], axis=1)
        near = (along <= (slave.radius[s] + master.radius[found]) * (1 + 1e-9)) \
            & (np.abs(across) <= search_distance + master.radius[found])
        out.append(found[near & (master.normal[found] @ slave.normal[s] < 0)])
    return out


def integrate(slave, master, n_nodes, search_distance, n_zones):
    """Mortar matrix (n_nodes, n_nodes), gap integrals (n_nodes,) and int N^_i split by zone (n_nodes, n_zones)."""
    dual, integral = dual_coefficients(slave.coords, slave.facet_type)
    rows, cols, values = [np.zeros(0, int)], [np.zeros(0, int)], [np.zeros(0)]
    gap = np.zeros(n_nodes)
    k_s, k_m = slave.facets.shape[1], master.facets.shape[1]
    for s, found in enumerate(candidates(slave, master, search_distance)):
        facets, blocks, gap_integral = _facet_blocks(slave, s, dual, master, found, search_distance)
        rows.append(np.tile(np.repeat(slave.facets[s], k_m), len(facets)))
        cols.append(np.tile(master.facets[facets], (1, k_s)).ravel())
        values.append(blocks.ravel())
        np.add.at(gap, slave.facets[s], gap_integral)
    mortar = sp.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(n_nodes, n_nodes))
    by_zone = np.zeros((n_nodes, n_zones))
    np.add.at(by_zone, (slave.facets, np.broadcast_to(slave.zone[:, None], slave.facets.shape)), integral)
    return mortar, gap, by_zone
