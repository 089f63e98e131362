"""Many plane convex polygons at once: signed areas, counter-clockwise order and Sutherland-Hodgman clipping.

A batch of polygons is ``vertices (p, n, 2)`` with ``count (p,)``: polygon i is ``vertices[i, :count[i]]`` (the rest
is padding).
"""

from __future__ import annotations

import numpy as np


def signed_areas(vertices: np.ndarray, count: np.ndarray | None = None) -> np.ndarray:
    """Signed areas (p,) of plane polygons (p, n, 2) [count (p,) vertices each, default n], positive when their
    vertices run counter-clockwise.

    >>> signed_areas(np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]]))
    array([0.5])
    """
    vertices = np.asarray(vertices, dtype=float)
    n = vertices.shape[1]
    count = np.full(len(vertices), n) if count is None else np.asarray(count)
    following = _following(n, count)
    after = np.take_along_axis(vertices, following[..., None], axis=1)
    terms = vertices[..., 0] * after[..., 1] - after[..., 0] * vertices[..., 1]
    return 0.5 * np.where(np.arange(n) < count[:, None], terms, 0.0).sum(axis=1)


def counter_clockwise(vertices: np.ndarray) -> np.ndarray:
    """The polygons (p, n, 2) (all n vertices used) with their vertices in counter-clockwise order."""
    return np.where((signed_areas(vertices) >= 0)[:, None, None], vertices, vertices[:, ::-1])


def _following(n: int, count: np.ndarray) -> np.ndarray:
    """(p, n) index of the vertex after each vertex of polygons with count (p,) vertices (cyclic)."""
    index = np.arange(n) + 1
    return np.where(index < count[:, None], index, 0)


def clip(subject: np.ndarray, window: np.ndarray, tol: np.ndarray | float = 0.0):
    """The parts of the convex polygons subject (p, n, 2) inside the convex polygons window (p, k, 2).

    Both counter-clockwise, all their vertices used (Sutherland & Hodgman, CACM 17 (1974) 32-42). A subject
    vertex within ``tol`` [mm] (scalar or (p,)) of a window edge counts as inside, so that coincident edges do
    not leave slivers.

    Returns
    -------
    vertices (p, m, 2), count (p,)
        Polygon i is ``vertices[i, :count[i]]``, counter-clockwise, in the vertex order of clipping edge by edge;
        count 0 where fewer than 3 vertices are left (no overlap).

    >>> square = np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])
    >>> piece, count = clip(square + 0.5, square)
    >>> round(float(signed_areas(piece, count)[0]), 12)
    0.25
    """
    out = np.array(subject, dtype=float)
    window = np.asarray(window, dtype=float)
    n_polygons, k = len(out), window.shape[1]
    tol = np.broadcast_to(np.asarray(tol, dtype=float), (n_polygons,))[:, None]
    count = np.full(n_polygons, out.shape[1])
    for j in range(k):
        a, edge = window[:, j], window[:, (j + 1) % k] - window[:, j]
        length = np.sqrt(edge[:, 0] * edge[:, 0] + edge[:, 1] * edge[:, 1])[:, None]
        # distance inside the edge's half-plane (left of a -> b)
        side = (edge[:, 0, None] * (out[..., 1] - a[:, 1, None]) - edge[:, 1, None] * (out[..., 0] - a[:, 0, None])) \
            / length
        following = _following(out.shape[1], count)
        valid = np.arange(out.shape[1]) < count[:, None]
        inside = side >= -tol
        nxt, side_next = np.take_along_axis(out, following[..., None], axis=1), np.take_along_axis(side, following, 1)
        crosses = valid & (inside != np.take_along_axis(inside, following, axis=1))
        # a vertex within tol outside the edge counts as inside; then both lie outside and the crossing is that
        # vertex itself (unclamped, t would extrapolate off the segment)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.clip(side / (side - side_next), 0.0, 1.0)
        crossing = out + t[..., None] * (nxt - out)
        emit = np.stack([valid & inside, crosses], axis=2).reshape(n_polygons, 2 * out.shape[1])
        candidates = np.stack([out, crossing], axis=2).reshape(n_polygons, 2 * out.shape[1], 2)
        count = emit.sum(axis=1)
        position = np.cumsum(emit, axis=1) - 1
        rows, columns = np.nonzero(emit)
        out = np.zeros((n_polygons, max(int(count.max(initial=0)), 1), 2))
        out[rows, position[rows, columns]] = candidates[rows, columns]
    count = np.where(count >= 3, count, 0)
    return out, count
