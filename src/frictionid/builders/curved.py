"""Second-order tetrahedra with their mid-side nodes on the curved geometry wherever the cells stay valid.

gmsh places the mid-side nodes of a second-order mesh on the CAD surfaces (``Mesh.SecondOrderLinear = 0``). That
makes a coarse mesh of a cylinder a cylinder, where straight-sided tetrahedra make it a polygon: the 3-D bolt's
shank (mesh size 3 mm on a 3 mm radius) lost 11 % of its cross-section and stretched 11 % more than a bar of its
diameter. But gmsh also moves some mid-side nodes far off their edge where a surface's parametrisation is poor (up to
0.62 mm on the lofted helical flanks at the nut crest's corners), which inverts cells. :func:`curved_where_valid`
keeps a mid-side node where gmsh put it only when (a) its offset from the edge's midpoint is at most
:data:`SAGITTA` times the edge's length (a circular arc of up to about 120 deg per edge) and (b) every cell using it
keeps its Jacobian determinant between :data:`DET_RANGE` times the straight cell's at the sample points (corners,
edge midpoints, face and cell centroids); the others are put back on their edge's midpoint.

Measured on the M6 bolt (34,635 nodes, mesh size 3 mm; docs/bolt-study.md): the shank's cross-section in the
mesh is 98.3 % of the circle's (straight-sided: 88.8 %), its stretch under 1,500 N 1.5 % above the bar's
F L / (E A) (straight-sided: 11 % above); 1,414 of 28,385 mid-side nodes put back.
"""

from __future__ import annotations

import logging

import numpy as np

log = logging.getLogger(__name__)

#: the edges of a tetra10 in meshio's (VTK's) node order: mid-side node 4 + k lies on corners EDGES[k]
EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
#: largest offset of a curved mid-side node from its edge's midpoint, in units of the edge's length
SAGITTA = 0.3
#: the determinant of the curved cell over the straight one's must stay within this range at the sample points
DET_RANGE = (0.02, 50.0)


def _sample_points() -> np.ndarray:
    """(m, 4) barycentric coordinates: corners, edge midpoints, face centroids, the centroid."""
    eye = np.eye(4)
    edges = [(eye[a] + eye[b]) / 2 for a, b in EDGES]
    faces = [(1 - eye[k]) / 3 for k in range(4)]
    return np.vstack([eye, edges, faces, [np.full(4, 0.25)]])


def determinant_ratios(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(n_cells, m) det J of each tetra10 at the sample points over the straight cell's (6 x its volume, signed)."""
    L = _sample_points()
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


def curved_where_valid(points: np.ndarray, cells: np.ndarray, max_rounds: int = 10) -> tuple[np.ndarray, int]:
    """(points with mid-side nodes straightened where the curved ones fail the module's rules, number of
    mid-side nodes straightened). ``cells`` (n, 10) tetra10 in meshio's order; the corners are never moved."""
    out = np.array(points, dtype=float)
    corners = np.stack([cells[:, [a, b]] for a, b in EDGES], axis=1)    # (n, 6, 2)
    mids = cells[:, 4:]                                                 # (n, 6)
    middle = 0.5 * (out[corners[..., 0]] + out[corners[..., 1]])
    length = np.linalg.norm(out[corners[..., 1]] - out[corners[..., 0]], axis=-1)
    far = np.linalg.norm(out[mids] - middle, axis=-1) > SAGITTA * length
    straightened = np.zeros(len(out), bool)

    def straighten(mask):
        nodes = mids[mask]
        out[nodes] = middle[mask]
        straightened[nodes] = True

    straighten(far)
    for _ in range(max_rounds):
        ratios = determinant_ratios(out, cells)
        bad = (ratios.min(axis=1) < DET_RANGE[0]) | (ratios.max(axis=1) > DET_RANGE[1])
        bad &= ~np.all(straightened[mids], axis=1)
        if not bad.any():
            break
        straighten(np.repeat(bad[:, None], 6, axis=1))
    n = int(straightened.sum())
    log.info("curved mid-side nodes: %d of %d put back on their edges", n, len(np.unique(mids)))
    return out, n
