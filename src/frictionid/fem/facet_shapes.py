"""Shape functions, quadrature and point projection of 3-D contact facets (triangle, triangle6, quad, quad9).

Facets are in meshio order: corners first (counter-clockwise seen from the side their parameter normal
``dx/dr x dx/ds`` points to), then the mid-side nodes of edges 0-1, 1-2, ..., then (quad9) the centre.
Parameters: triangles (r, s) in {r, s >= 0, r + s <= 1}; quadrilaterals (r, s) in [-1, 1]^2.
"""

from __future__ import annotations

import numpy as np
from skfem.quadrature import get_quadrature
from skfem.refdom import RefTri

#: number of corners of each facet type
CORNERS = {"triangle": 3, "triangle6": 3, "quad": 4, "quad9": 4}
#: the flat pieces (local node lists) a facet stands for in a plane clipping: a quadratic facet is split at its
#: mid-side nodes into four, so that the pieces' outlines follow its curved edges (chords of half the edge)
SUBFACETS = {"triangle": ((0, 1, 2),), "quad": ((0, 1, 2, 3),),
             "triangle6": ((0, 3, 5), (3, 1, 4), (5, 4, 2), (3, 4, 5)),
             "quad9": ((0, 4, 8, 7), (4, 1, 5, 8), (8, 5, 2, 6), (7, 8, 6, 3))}
#: parameters (n_facet_nodes, 2) of each facet type's nodes
NODE_PARAMETERS = {
    "triangle": np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
    "triangle6": np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]]),
    "quad": np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]),
    "quad9": np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0],
                       [0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, 0.0]]),
}
#: parameter of each facet type's centre
CENTRE = {"triangle": (1 / 3, 1 / 3), "triangle6": (1 / 3, 1 / 3), "quad": (0.0, 0.0), "quad9": (0.0, 0.0)}
_NEWTON_STEPS = 30
_NEWTON_TOL = 1e-12


def _line3(x):
    """1-D quadratic Lagrange functions at -1, 1, 0 and their derivatives, each (..., 3)."""
    return (np.stack([x * (x - 1) / 2, x * (x + 1) / 2, 1 - x * x], -1),
            np.stack([x - 0.5, x + 0.5, -2 * x], -1))


def shape_functions(rs, facet_type: str):
    """Values (..., k) and derivatives (..., k, 2) of the shape functions of facet_type at parameters rs (..., 2)."""
    rs = np.asarray(rs, dtype=float)
    r, s = rs[..., 0], rs[..., 1]
    one, zero = np.ones_like(r), np.zeros_like(r)
    if facet_type == "triangle":
        N = np.stack([1 - r - s, r, s], -1)
        dN = np.stack([np.stack([-one, -one], -1), np.stack([one, zero], -1), np.stack([zero, one], -1)], -2)
        return N, dN
    if facet_type == "triangle6":
        return _triangle6(r, s)
    nodes = NODE_PARAMETERS[facet_type]
    if facet_type == "quad":
        N = (1 + r[..., None] * nodes[:, 0]) * (1 + s[..., None] * nodes[:, 1]) / 4
        dN = np.stack([nodes[:, 0] * (1 + s[..., None] * nodes[:, 1]) / 4,
                       nodes[:, 1] * (1 + r[..., None] * nodes[:, 0]) / 4], -1)
        return N, dN
    index = {-1.0: 0, 1.0: 1, 0.0: 2}
    (lr, dlr), (ls, dls) = _line3(r), _line3(s)
    i = [index[a] for a in nodes[:, 0]]
    j = [index[b] for b in nodes[:, 1]]
    N = lr[..., i] * ls[..., j]
    return N, np.stack([dlr[..., i] * ls[..., j], lr[..., i] * dls[..., j]], -1)


def _triangle6(r, s):
    """The 6-node triangle's shape functions (..., 6) and derivatives (..., 6, 2) at (r, s), written in place (the
    mortar's projections evaluate them at about 10^5 points per Newton step)."""
    t = 1 - r - s
    N = np.empty(r.shape + (6,))
    dN = np.empty(r.shape + (6, 2))
    N[..., 0], N[..., 1], N[..., 2] = t * (2 * t - 1), r * (2 * r - 1), s * (2 * s - 1)
    N[..., 3], N[..., 4], N[..., 5] = 4 * t * r, 4 * r * s, 4 * s * t
    d0 = 1 - 4 * t
    dN[..., 0, 0] = dN[..., 0, 1] = d0
    dN[..., 1, 0], dN[..., 1, 1] = 4 * r - 1, 0.0
    dN[..., 2, 0], dN[..., 2, 1] = 0.0, 4 * s - 1
    dN[..., 3, 0], dN[..., 3, 1] = 4 * (t - r), -4 * r
    dN[..., 4, 0], dN[..., 4, 1] = 4 * s, 4 * r
    dN[..., 5, 0], dN[..., 5, 1] = -4 * s, 4 * (t - s)
    return N, dN


def facet_quadrature(facet_type: str):
    """Points (q, 2) and weights (q,) on the reference facet, exact for polynomials of degree 10 (triangles) or
    11 in each parameter (quadrilaterals)."""
    if CORNERS[facet_type] == 3:
        points, weights = get_quadrature(RefTri, 10)
        return points.T, weights
    x, w = np.polynomial.legendre.leggauss(6)
    return np.column_stack([np.repeat(x, 6), np.tile(x, 6)]), np.repeat(w, 6) * np.tile(w, 6)


def triangle_quadrature(degree: int = 10):
    """Points (q, 3) as barycentric weights and weights (q,) summing to 1 on a triangle, exact to ``degree``."""
    points, weights = get_quadrature(RefTri, degree)
    return np.column_stack([1 - points[0] - points[1], points[0], points[1]]), 2 * weights


def geometry(coords: np.ndarray, rs, facet_type: str):
    """Positions (q, 3), tangents (q, 3, 2) and unit parameter normals (q, 3) at parameters rs (q, 2) of one
    facet (coords (k, 3)) or of one facet per point (coords (q, k, 3))."""
    N, dN = shape_functions(rs, facet_type)
    if coords.ndim == 2:
        x, tangents = N @ coords, np.einsum("qkp,kd->qdp", dN, coords)
    else:
        x, tangents = np.einsum("qk,qkd->qd", N, coords), np.einsum("qkp,qkd->qdp", dN, coords)
    normal = np.cross(tangents[..., 0], tangents[..., 1])
    return x, tangents, normal / np.linalg.norm(normal, axis=-1, keepdims=True)


def project_along(coords: np.ndarray, facet_type: str, points: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Parameters (q, 2) where the lines through points (q, 3) along direction (3,) or each point's direction (q, 3)
    cut the facet (coords (k, 3)) or each point's facet (coords (q, k, 3)).

    Newton on x(r, s) - t direction = point, each point until its own step is below 1e-12; NaN where it does not
    converge (the line misses a curved facet's extension). The parameters may lie outside the reference facet
    (the caller decides).
    """
    n = len(points)
    coords = np.broadcast_to(coords, (n, *np.shape(coords)[-2:]))
    direction = np.broadcast_to(direction, (n, 3))
    rs, t = np.tile(CENTRE[facet_type], (n, 1)), np.zeros(n)
    converged = np.zeros(n, bool)
    active = np.arange(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(_NEWTON_STEPS):
            every = len(active) == n                     # then no copies of the points' facets
            at = slice(None) if every else active
            N, dN = shape_functions(rs[at], facet_type)
            on = coords if every else coords[active]
            residual = np.matmul(N[:, None, :], on)[:, 0] - t[at, None] * direction[at] - points[at]
            tangents = np.matmul(np.swapaxes(dN, 1, 2), on)                     # (q, 2, 3)
            step = _solve3(tangents[:, 0], tangents[:, 1], -direction[at], -residual)
            rs[at] += step[:, :2]
            t[at] += step[:, 2]
            done = np.abs(step[:, :2]).max(axis=1) < _NEWTON_TOL
            converged[active[done]] = True
            active = active[~done]
            if not len(active):
                break
    return np.where(converged[:, None], rs, np.nan)


def _solve3(a: np.ndarray, b: np.ndarray, c: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solutions (q, 3) of [a b c] x = rhs, the columns a, b, c (q, 3) each (Cramer's rule; NaN or inf where
    singular)."""
    def det(u, v, w):
        return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])

    # components as contiguous rows (the same operations in the same order as on the columns: the same bits)
    a, b, c, rhs = (np.ascontiguousarray(np.transpose(x)) for x in (a, b, c, rhs))
    return np.column_stack([det(rhs, b, c), det(a, rhs, c), det(a, b, rhs)]) / det(a, b, c)[:, None]
