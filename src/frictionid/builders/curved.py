"""Second-order tetrahedra with their mid-side nodes on the curved geometry wherever the cells stay valid.

gmsh places the mid-side nodes of a second-order mesh on the CAD surfaces (``Mesh.SecondOrderLinear = 0``); the
mid-side nodes of edges inside a volume stay on their edges' midpoints. That makes a coarse mesh of a cylinder a
cylinder, where straight-sided tetrahedra make it a polygon: the 3-D bolt's shank (mesh size 3 mm on a 3 mm
radius) lost 11 % of its cross-section and stretched 11 % more than a bar of its diameter. But gmsh also moves some
mid-side nodes far off their edge where a surface's parametrisation is poor (up to 0.62 mm on the lofted helical
flanks at the nut crest's corners), which inverts cells. :func:`curved_where_valid` keeps a mid-side node where gmsh
put it only when (a) its offset from the edge's midpoint is at most :data:`SAGITTA` times the edge's length (a
circular arc of up to about 120 deg per edge) and (b) every cell using it is valid: its Jacobian determinant is
positive everywhere in the cell and below :data:`DET_RANGE` [1] times the straight cell's, as certified by the
determinant's Bernstein coefficients (:func:`jacobian_bounds`). An invalid cell moves one of its curved mid-side
nodes per round towards the edge's midpoint, the one whose move raises its lower bound most, keeping half its
offset (after three halvings none): a node on a surface leaves it only as far as a cell using it needs.

Why positivity everywhere and no larger margin: the stiffness and the observation operators need det J > 0 at the
quadrature points (scikit-fem's order-4 rule, 11 points inside the cell) and the inverse map (facet bases, point
location) a one-to-one map of the whole cell; det J of a tetra10 is a cubic whose Bernstein coefficients bound it
from below and equal it at the corners (Johnen, Remacle & Geuzaine, J. Comput. Phys. 233 (2013) 359-372; gmsh's own
validity check). Where a curved face leaves det J small, it is small at a corner: on the M6 bolt meshes of
tests/test_curved_mesh.py and test_bolt3d_verification.py the lower bound goes down to 0.001 of the straight cell's
and every cell keeps at least 0.08 of it at the quadrature points. A bound of 0.02 at 15 sample points instead put
back all six mid-side nodes of 20 cells of the shank at mesh_size 2, 19 of them valid, and left the shank's section
3.3 % short of its cylinder (now 0.09 %).
"""

from __future__ import annotations

import itertools
import logging
import math

import numpy as np

log = logging.getLogger(__name__)

#: the edges of a tetra10 in meshio's (VTK's) node order: mid-side node 4 + k lies on corners EDGES[k]
EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
#: largest offset of a curved mid-side node from its edge's midpoint, in units of the edge's length
SAGITTA = 0.3
#: the determinant of the curved cell over the straight one's must stay within this open range in the whole cell
DET_RANGE = (0.0, 50.0)
#: det J is a cubic: its Bernstein basis of degree 3 on the tetrahedron, multi-indices (20, 4) and lattice points
_ALPHAS = np.array([a for a in itertools.product(range(4), repeat=4) if sum(a) == 3])
_LATTICE = _ALPHAS / 3.0


def _bernstein_from_values() -> np.ndarray:
    """(20, 20) maps a cubic's values at the lattice points to its Bernstein coefficients."""
    multinomial = np.array([math.factorial(3) / np.prod([math.factorial(k) for k in a]) for a in _ALPHAS])
    values = multinomial * np.prod(_LATTICE[:, None, :] ** _ALPHAS[None], axis=-1)
    return np.linalg.inv(values)


_TO_BERNSTEIN = _bernstein_from_values()


def _sample_points() -> np.ndarray:
    """(m, 4) barycentric coordinates: corners, edge midpoints, face centroids, the centroid."""
    eye = np.eye(4)
    edges = [(eye[a] + eye[b]) / 2 for a, b in EDGES]
    faces = [(1 - eye[k]) / 3 for k in range(4)]
    return np.vstack([eye, edges, faces, [np.full(4, 0.25)]])


def determinant_ratios(points: np.ndarray, cells: np.ndarray, barycentric: np.ndarray | None = None) -> np.ndarray:
    """(n_cells, m) det J of each tetra10 over the straight cell's (6 x its volume, signed) at ``barycentric``
    (m, 4) points, by default the corners, edge midpoints, face and cell centroids."""
    L = _sample_points() if barycentric is None else np.asarray(barycentric, dtype=float)
    dL = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # dL_i / dxi
    dN = np.empty((len(L), 10, 3))
    for i in range(4):
        dN[:, i] = (4 * L[:, i] - 1)[:, None] * dL[i]
    for k, (a, b) in enumerate(EDGES):
        dN[:, 4 + k] = 4 * (L[:, b, None] * dL[a] + L[:, a, None] * dL[b])
    x = points[cells]                                             # (n, 10, 3)
    J = np.einsum("nid,mie->nmde", x, dN)                         # dx_d / dxi_e
    straight = np.linalg.det(x[:, 1:4] - x[:, :1])                # (n,)
    return np.linalg.det(J) / straight[:, None]


def jacobian_bounds(points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n_cells,) lower and upper bounds of det J over the straight cell's in the whole of each tetra10: its smallest
    and largest Bernstein coefficients (equal to det J at the corners, within the coefficients' hull elsewhere)."""
    coefficients = determinant_ratios(points, cells, _LATTICE) @ _TO_BERNSTEIN.T
    return coefficients.min(axis=1), coefficients.max(axis=1)


def _invalid(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(n_cells,) bool: det J / straight leaves DET_RANGE somewhere in the cell."""
    lower, upper = jacobian_bounds(points, cells)
    return (lower <= DET_RANGE[0]) | (upper >= DET_RANGE[1])


def _most_helpful(out, cells, trial, movable) -> np.ndarray:
    """(n,) for each cell, the index 0-5 of the movable mid-side node whose move to ``trial`` (n, 6, 3) raises the
    cell's lower bound most (-1 where none is movable)."""
    gain = np.full(movable.shape, -np.inf)
    for k in range(6):
        if not movable[:, k].any():
            continue
        x = out[cells[movable[:, k]]]
        x[:, 4 + k] = trial[movable[:, k], k]
        gain[movable[:, k], k] = jacobian_bounds(x.reshape(-1, 3), np.arange(x.shape[0] * 10).reshape(-1, 10))[0]
    return np.where(movable.any(axis=1), gain.argmax(axis=1), -1)


def curved_where_valid(points: np.ndarray, cells: np.ndarray, max_rounds: int = 60) -> tuple[np.ndarray, int]:
    """(points with mid-side nodes moved towards their edges' midpoints where the curved ones fail the module's
    rules, number of mid-side nodes moved). ``cells`` (n, 10) tetra10 in meshio's order; the corners are never
    moved. A rejected cell's chosen node keeps half its offset each round, and none below 1/8 of it."""
    out = np.array(points, dtype=float)
    corners = np.stack([cells[:, [a, b]] for a, b in EDGES], axis=1)    # (n, 6, 2)
    mids = cells[:, 4:]                                                 # (n, 6)
    middle = np.zeros_like(out)
    middle[mids] = 0.5 * (out[corners[..., 0]] + out[corners[..., 1]])
    offset = out - middle
    length = np.zeros(len(out))
    length[mids] = np.linalg.norm(out[corners[..., 1]] - out[corners[..., 0]], axis=-1)
    curved = np.zeros(len(out), bool)
    curved[mids] = np.linalg.norm(offset[mids], axis=-1) > 1e-12 * length[mids]
    kept = np.where(curved, 1.0, 0.0)
    kept[np.linalg.norm(offset, axis=-1) > SAGITTA * length] = 0.0
    out = middle + kept[:, None] * offset
    out[~curved] = points[~curved]
    for _ in range(max_rounds):
        bad = np.flatnonzero(_invalid(out, cells))
        nodes = mids[bad]
        movable = kept[nodes] > 0
        if not bad.size or not movable.any():
            break
        smaller = np.where(kept[nodes] > 0.125, kept[nodes] / 2, 0.0)
        choice = _most_helpful(out, cells[bad], middle[nodes] + smaller[..., None] * offset[nodes], movable)
        chosen = choice >= 0
        node = nodes[chosen, choice[chosen]]
        kept[node] = smaller[chosen, choice[chosen]]
        out[node] = middle[node] + kept[node, None] * offset[node]
    bad = _invalid(out, cells)
    if bad.any():                       # not reached in max_rounds: every mid-side node of those cells goes back
        out[mids[bad]] = middle[mids[bad]]
    n = int(np.count_nonzero(np.any(out != points, axis=1)))
    log.info("curved mid-side nodes: %d of %d moved towards their edges", n, int(curved.sum()))
    return out, n
