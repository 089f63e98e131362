"""Point location: the cell of a mesh holding each measurement point and its reference coordinates there, points
just outside their region moved onto it, and the error naming the points that lie too far outside."""

from __future__ import annotations

import logging
from typing import Mapping, Sequence

import numpy as np
from scipy.spatial import cKDTree
from skfem import ElementHex1, ElementQuad1, ElementTetP1, ElementTriP1
from skfem.refdom import RefHex, RefQuad, RefTet, RefTri

from ..errors import InputError
from .space import Space

logger = logging.getLogger(__name__)

#: a point belongs to a cell if its reference coordinates are inside up to this (dimensionless) margin
REFERENCE_TOL = 1e-8


#: a point outside its region (or the mesh) by at most this fraction of the nearest cell's size (its largest
#: coordinate extent) is read at the nearest point of that cell: measured points on a face carry round-off
SURFACE_TOL = 1e-3


#: cells (by nearest centre) searched for the region's point nearest to a point outside it
N_NEAREST = 32


#: Newton on the isoparametric map stops when the update is below this (reference units)
NEWTON_TOL = 1e-13


NEWTON_MAX_ITER = 30


#: linear element of each reference domain: the straight-sided geometry under a quadratic cell
LINEAR = {RefTri: ElementTriP1, RefQuad: ElementQuad1, RefTet: ElementTetP1, RefHex: ElementHex1}


#: bound of sum_k |N_k| (Lebesgue constant) over the reference cell for P2 / Q2 (tet P2: 2, hex Q2: 1.95)
LEBESGUE_BOUND = 2.0


def locate(space: Space, points, regions: Sequence[str | None] | None = None):
    """The cell holding each point and the point's reference coordinates in it.

    Parameters
    ----------
    space : Space
    points : (n, dim) [mm]
    regions : sequence of (str or None), optional
        As in :func:`~frictionid.fem.points.point_operator`.

    Returns
    -------
    cells : (n,) int
        Cell index (same numbering as ``space.mesh.cells``). A point on a face shared by several cells
        goes to the one it is deepest inside (ties: the lowest index). A point outside its region (or the
        mesh) by at most SURFACE_TOL of the cell size goes to the nearest cell, at its nearest point; the
        largest such distance is logged.
    reference : (dim, n)
        Reference coordinates of the scikit-fem element (unit simplex or unit square/cube).
    """
    points = checked_points(space, points)
    point_region = _point_regions(space.mesh, regions, len(points))
    nodes_xyz = cell_nodes(space)
    cells, located, found = _inside(space, nodes_xyz, points, point_region)
    missing = np.flatnonzero(~found)
    if missing.size:
        near, near_reference, distance, size = _nearest(space, nodes_xyz, points[missing], point_region[missing])
        far = ~(distance <= SURFACE_TOL * size)
        if far.any():
            raise PointsOutside(points, missing[far], point_region, space.mesh.region_names,
                                dict(zip(missing.tolist(), distance)))
        cells[missing], located[:, missing] = near, near_reference
        logger.info("%d point(s) outside their region by at most %.3g mm (allowed: %g of the cell size) are read "
                    "at its nearest point", missing.size, distance.max(), SURFACE_TOL)
    return cells, located


def _inside(space: Space, nodes_xyz: np.ndarray, points: np.ndarray, point_region: np.ndarray):
    """Cell (n,), reference coordinates (dim, n) and whether found (n,) of each point in a cell of its region
    (-1: any) up to REFERENCE_TOL; cells are found through a k-d tree of cell boxes (:func:`_candidate_pairs`)."""
    pair_point, pair_cell = _candidate_pairs(space, nodes_xyz, points)
    allowed = (point_region[pair_point] < 0) | (space.mesh.cell_region[pair_cell] == point_region[pair_point])
    pair_point, pair_cell = pair_point[allowed], pair_cell[allowed]
    reference, converged = _inverse_map(space, nodes_xyz[pair_cell], points[pair_point])
    margin = np.where(converged, _inside_margin(space, reference), -np.inf)
    hit = margin >= -REFERENCE_TOL
    order = np.lexsort((pair_cell[hit], -margin[hit], pair_point[hit]))
    best_point, first = np.unique(pair_point[hit][order], return_index=True)
    chosen = np.flatnonzero(hit)[order[first]]
    cells, located = np.full(len(points), -1, dtype=np.int64), np.empty((space.dim, len(points)))
    cells[best_point], located[:, best_point] = pair_cell[chosen], reference[:, chosen]
    return cells, located, cells >= 0


def region_at(space: Space, points, depth: float = 0.0) -> np.ndarray:
    """(n,) index into ``space.mesh.region_names`` of the region holding each point, -1 outside the mesh.

    ``depth`` [mm] > 0: also -1 for a point that is not inside its region by at least that much (the point
    moved by ``depth`` along either axis direction leaves the region or enters another one): used to choose
    points that lie in the same region of several meshes of one geometry (e.g. a finer mesh that made data).

    >>> region_at(space, [[0.0, 5.0], [0.0, -2.0], [99.0, 0.0]])   # doctest: +SKIP
    array([ 1,  0, -1])
    """
    points = checked_points(space, points)
    nodes_xyz = cell_nodes(space)
    anywhere = np.full(len(points), -1, dtype=np.int64)
    cells, _, found = _inside(space, nodes_xyz, points, anywhere)
    region = np.where(found, space.mesh.cell_region[np.maximum(cells, 0)], -1)
    if depth > 0:
        for axis in range(space.dim):
            for sign in (-1.0, 1.0):
                moved = points.copy()
                moved[:, axis] += sign * depth
                other, _, there = _inside(space, nodes_xyz, moved, anywhere)
                region = np.where(there & (space.mesh.cell_region[np.maximum(other, 0)] == region), region, -1)
    return region


def checked_points(space: Space, points) -> np.ndarray:
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != space.dim:
        raise InputError(f"point operator: `points` must have shape (n, {space.dim}) [mm], got {points.shape}")
    bad = np.flatnonzero(~np.isfinite(points).all(axis=1))
    if bad.size:
        raise InputError(f"point operator: point {bad[0]} has a non-finite coordinate {points[bad[0]].tolist()}")
    return points


def _point_regions(mesh, regions, n_points: int) -> np.ndarray:
    """(n,) index into mesh.region_names of each point's region, -1 for any cell."""
    if regions is None:
        return np.full(n_points, -1, dtype=np.int64)
    if isinstance(regions, str) or len(regions) != n_points:
        raise InputError(f"point operator: `regions` must be a sequence of {n_points} region names or None")
    index = {name: i for i, name in enumerate(mesh.region_names)}
    for i, name in enumerate(regions):
        if name is not None and name not in index:
            raise InputError(f"point operator: point {i} asks for region {name!r}; the mesh has "
                             f"{sorted(index) or 'no named regions'}")
    return np.array([-1 if name is None else index[name] for name in regions], dtype=np.int64)


def _nearest(space: Space, nodes_xyz: np.ndarray, targets: np.ndarray, target_region: np.ndarray):
    """The cell of each target's region (-1: any) holding the point nearest to it among the N_NEAREST cells with
    the nearest centres, that point's reference coordinates (dim, n), its distance [mm] and the cell's size [mm].
    """
    n = len(targets)
    cells, reference, distance = np.zeros(n, dtype=np.int64), np.zeros((space.dim, n)), np.full(n, np.inf)
    centres = nodes_xyz.mean(axis=1)
    for region in np.unique(target_region):
        allowed = np.arange(len(centres)) if region < 0 else np.flatnonzero(space.mesh.cell_region == region)
        which, k = np.flatnonzero(target_region == region), min(N_NEAREST, allowed.size)
        near = allowed[np.reshape(cKDTree(centres[allowed]).query(targets[which], k=k)[1], (len(which), k))]
        pair_point, pair_cell = np.repeat(which, k), near.ravel()
        ref, _ = _inverse_map(space, nodes_xyz[pair_cell], targets[pair_point])
        ref = _clamped(space, ref, _forward_map(space, nodes_xyz[pair_cell], ref, targets[pair_point])[1])
        phi, _ = reference_basis(space, ref)
        gap = np.linalg.norm(np.einsum("nk,nkd->nd", phi, nodes_xyz[pair_cell]) - targets[pair_point], axis=1)
        best = np.arange(len(which)) * k + gap.reshape(len(which), k).argmin(axis=1)
        cells[which], reference[:, which], distance[which] = pair_cell[best], ref[:, best], gap[best]
    return cells, reference, distance, np.ptp(nodes_xyz[cells], axis=1).max(axis=1)


def _clamped(space: Space, reference: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
    """Reference coordinates (dim, n) moved into the reference element.

    A point outside is first projected onto the plane of the face it is farthest outside of in the metric
    J^T J of the map (jacobian (n, dim, dim)), which is the nearest point of that face in physical space for an
    affine cell, and then clipped into the element (near an edge or corner).
    """
    dim, n = reference.shape
    faces = [(np.eye(dim)[i], 0.0, -1.0) for i in range(dim)]          # (normal a, offset b, side): side a.X >= b
    faces += [(np.ones(dim), 1.0, 1.0)] if _is_simplex(space) else [(np.eye(dim)[i], 1.0, 1.0) for i in range(dim)]
    violation = np.stack([side * (a @ reference - b) for a, b, side in faces])        # > 0: outside that face
    worst = violation.argmax(axis=0)
    normal = np.stack([faces[j][0] for j in worst])                                     # (n, dim)
    metric_inv_normal = np.linalg.solve(np.einsum("nka,nkb->nab", jacobian, jacobian), normal[..., None])[..., 0]
    excess = np.array([faces[j][2] for j in worst]) * violation[worst, np.arange(n)]
    step = (excess / np.einsum("nd,nd->n", normal, metric_inv_normal))[:, None] * metric_inv_normal
    reference = np.where(violation.max(axis=0) > 0, reference - step.T, reference)
    if not _is_simplex(space):
        return np.clip(reference, 0.0, 1.0)
    reference = np.maximum(reference, 0.0)
    total = reference.sum(axis=0)
    return np.where(total > 1.0, reference / np.where(total > 1.0, total, 1.0), reference)


class PointsOutside(InputError):
    """Observation points that lie in no cell of their region; :meth:`named` restates it with the points' labels.

    Attributes: missing (indices of the points), points (n, dim) [mm], and where each one was looked for.
    """

    def __init__(self, points, missing, point_region, region_names, distance: Mapping | None = None):
        self.missing, self.points, self.distance = missing, points, dict(distance or {})
        self.where = ["the mesh" if point_region[i] < 0 else f"region {region_names[point_region[i]]!r}"
                      for i in range(len(points))]
        super().__init__(f"point operator: {self._listed(lambda i: f'point {i}')}")

    def _by(self, i) -> str:
        distance = self.distance.get(int(i), np.inf)
        return f" by {distance:.3g} mm" if np.isfinite(distance) else ""

    def _listed(self, name) -> str:
        listed = "; ".join(f"{name(i)} at {np.round(self.points[i], 6).tolist()} [mm] is outside {self.where[i]}"
                           f"{self._by(i)}" for i in self.missing[:5])
        return listed + (f" (and {self.missing.size - 5} more points)" if self.missing.size > 5 else "")

    def named(self, labels, source: str) -> InputError:
        """The same error naming the points by their labels and the file they came from."""
        return InputError(f"{source}: {self._listed(lambda i: f'point {labels[i]!r}')}; a point must lie inside "
                          f"the region data.regions names for it (or the model), or outside it by at most "
                          f"{SURFACE_TOL:g} of the nearest cell's size")


def cell_nodes(space: Space) -> np.ndarray:
    """(n_cells, n_local, dim) [mm] node coordinates of each cell in the element's local dof order."""
    nodes = space.node_of[space.scalar.element_dofs]
    return space.mesh.points[nodes.T]


def _candidate_pairs(space: Space, nodes_xyz: np.ndarray, points: np.ndarray):
    """(point, cell) pairs whose (widened) cell bounding box holds the point.

    Cells are grouped by size (factors of two) so that each group's ball search finds few cells per point
    even on meshes graded from 0.1 mm to several mm.
    """
    low, high = _bounding_boxes(space, nodes_xyz)
    centre, radius = (low + high) / 2, np.linalg.norm(high - low, axis=1) / 2
    smallest = max(radius.min(), 1e-12 * radius.max())   # a collapsed cell must not break the grouping
    size_class = np.floor(np.log2(np.maximum(radius, smallest) / smallest)).astype(np.int64)
    point_tree = cKDTree(points)
    pair_point, pair_cell = [], []
    for group in np.unique(size_class):
        cells = np.flatnonzero(size_class == group)
        close = point_tree.sparse_distance_matrix(cKDTree(centre[cells]), radius[cells].max(),
                                                  output_type="ndarray")
        pair_point.append(close["i"].astype(np.int64))
        pair_cell.append(cells[close["j"]])
    pair_point, pair_cell = np.concatenate(pair_point), np.concatenate(pair_cell)
    inside = np.all((points[pair_point] >= low[pair_cell]) & (points[pair_point] <= high[pair_cell]), axis=1)
    return pair_point[inside], pair_cell[inside]


def _bounding_boxes(space: Space, nodes_xyz: np.ndarray):
    """Boxes (n_cells, dim) [mm] low, high that hold each whole cell, curved ones included.

    A quadratic cell departs from its straight-sided (corner) geometry by at most LEBESGUE_BOUND times the
    largest offset of a node from that geometry; the straight-sided cell lies in its corners' box.
    """
    element = space.scalar.elem
    linear = LINEAR[element.refdom]()
    n_corners = linear.doflocs.shape[0]
    corner_weights = np.stack([linear.lbasis(element.doflocs.T, j)[0] for j in range(n_corners)], axis=1)
    straight = np.einsum("kj,cjd->ckd", corner_weights, nodes_xyz[:, :n_corners])
    offset = np.linalg.norm(nodes_xyz - straight, axis=2).max(axis=1)
    corners = nodes_xyz[:, :n_corners]
    low, high = corners.min(axis=1), corners.max(axis=1)
    pad = LEBESGUE_BOUND * offset + 2 * REFERENCE_TOL * (high - low).max(axis=1)
    return low - pad[:, None], high + pad[:, None]


def reference_basis(space: Space, reference: np.ndarray):
    """Shape functions (n, n_local) and their reference gradients (n, n_local, dim) at reference points."""
    element = space.scalar.elem
    values, grads = zip(*(element.lbasis(reference, k) for k in range(space.scalar.Nbfun)))
    return np.stack(values, axis=1), np.stack(grads, axis=1).transpose(2, 1, 0)


def _inverse_map(space: Space, cell_xyz: np.ndarray, targets: np.ndarray):
    """Reference coordinates (dim, n) of each target in its cell by Newton, and whether Newton converged.

    cell_xyz (n, n_local, dim) [mm], targets (n, dim) [mm]. Iterates are kept in a box around the reference
    element so that cells that do not hold their target cannot run away; those are rejected afterwards.
    """
    # coordinates relative to each cell's first node keep the round-off at the cell's scale, not the model's
    origin = cell_xyz[:, 0, :]
    cell_xyz, targets = cell_xyz - origin[:, None, :], targets - origin
    centroid = space.scalar.elem.refdom.p.mean(axis=1)
    reference = np.repeat(centroid[:, None], len(targets), axis=1)
    size = np.ptp(cell_xyz, axis=1).max(axis=1)
    residual = np.empty_like(targets)
    stale = np.ones(len(targets), dtype=bool)          # reference moved since its residual was computed
    active = np.arange(len(targets))
    for iteration in range(1 if _is_affine(space) else NEWTON_MAX_ITER):
        r, jacobian = _forward_map(space, cell_xyz[active], reference[:, active], targets[active])
        residual[active], stale[active] = r, False
        if iteration:
            # at its point to round-off (the next step would be below NEWTON_TOL): done without that step, which
            # saves an affine cell (a parallelepiped, most of a structured mesh) its confirming step
            moving = np.linalg.norm(r, axis=1) > NEWTON_TOL * size[active]
            active, r, jacobian = active[moving], r[moving], jacobian[moving]
            if not active.size:
                break
        jacobian[np.abs(np.linalg.det(jacobian)) < 1e-300] = np.eye(space.dim)
        step = np.linalg.solve(jacobian, r[..., None])[..., 0].T
        unclipped = reference[:, active] + step
        reference[:, active] = np.clip(unclipped, -1.0, 2.0)
        stale[active] = True
        # a target still thrown out of the box after two steps is far outside this cell: stop following it
        far_out = (iteration >= 2) & np.any(unclipped != reference[:, active], axis=0)
        active = active[(np.abs(step).max(axis=0) >= NEWTON_TOL) & ~far_out]
        if not active.size:
            break
    if stale.any():
        residual[stale] = _forward_map(space, cell_xyz[stale], reference[:, stale], targets[stale])[0]
    converged = np.linalg.norm(residual, axis=1) <= 1e-9 * size
    return reference, converged


def _forward_map(space: Space, cell_xyz, reference, targets):
    """Residual targets - x(X) (n, dim) [mm] and Jacobian dx/dX (n, dim, dim) of the isoparametric map."""
    phi, dphi = reference_basis(space, reference)
    x = np.einsum("nk,nkd->nd", phi, cell_xyz)
    jacobian = np.einsum("nka,nkb->nab", cell_xyz, dphi)
    return targets - x, jacobian


def _is_simplex(space: Space) -> bool:
    return space.scalar.elem.refdom not in (RefQuad, RefHex)


def _is_affine(space: Space) -> bool:
    """Linear simplices map affinely: one Newton step from anywhere is exact."""
    return _is_simplex(space) and space.scalar.elem.maxdeg == 1


def _inside_margin(space: Space, reference: np.ndarray) -> np.ndarray:
    """(n,) signed distance-like margin to the reference element's boundary, negative outside."""
    if _is_simplex(space):
        return np.minimum(reference.min(axis=0), 1.0 - reference.sum(axis=0))
    return np.minimum(reference, 1.0 - reference).min(axis=0)
