"""Plane convex polygons: signed area, counter-clockwise order and Sutherland-Hodgman clipping."""

from __future__ import annotations

import numpy as np


def signed_area(polygon: np.ndarray) -> float:
    """Signed area of a plane polygon (n, 2), positive when its vertices run counter-clockwise.

    >>> signed_area(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    0.5
    """
    points = np.asarray(polygon, dtype=float).tolist()
    return 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(points, points[1:] + points[:1]))


def counter_clockwise(polygon: np.ndarray) -> np.ndarray:
    """The polygon with its vertices in counter-clockwise order."""
    return polygon if signed_area(polygon) >= 0 else polygon[::-1]


def clip(subject: np.ndarray, window: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """The part (m, 2) of the convex polygon subject (n, 2) inside the convex polygon window (k, 2).

    Both counter-clockwise (Sutherland & Hodgman, CACM 17 (1974) 32-42). A subject vertex within ``tol`` [mm]
    of a window edge counts as inside, so that coincident edges do not leave slivers. Fewer than 3 vertices:
    no overlap.

    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> round(signed_area(clip(square + 0.5, square)), 12)
    0.25
    """
    out = np.asarray(subject, dtype=float).tolist()         # small polygons: plain floats beat numpy here
    corners = np.asarray(window, dtype=float).tolist()
    for (ax, ay), (bx, by) in zip(corners, corners[1:] + corners[:1]):
        if not out:
            break
        ex, ey = bx - ax, by - ay
        length = (ex * ex + ey * ey) ** 0.5
        # distance inside the edge's half-plane (left of a -> b)
        side = [(ex * (y - ay) - ey * (x - ax)) / length for x, y in out]
        if min(side) >= -tol:
            continue
        kept = []
        for i, (p, d) in enumerate(zip(out, side)):
            q, e = out[(i + 1) % len(out)], side[(i + 1) % len(out)]
            if d >= -tol:
                kept.append(p)
            if (d >= -tol) != (e >= -tol):
                # the edge's crossing; a vertex within tol outside the edge counts as inside, and then both lie
                # outside and the crossing is that vertex itself (unclamped, t would extrapolate off the segment)
                t = min(max(d / (d - e), 0.0), 1.0)
                kept.append([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])])
        out = kept
    return np.array(out) if len(out) >= 3 else np.zeros((0, 2))
