"""Plane convex polygons: signed area, counter-clockwise order and Sutherland-Hodgman clipping."""

from __future__ import annotations

import numpy as np


def signed_area(polygon: np.ndarray) -> float:
    """Signed area of a plane polygon (n, 2), positive when its vertices run counter-clockwise.

    >>> signed_area(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    0.5
    """
    x, y = polygon[:, 0], polygon[:, 1]
    return float(0.5 * (x @ np.roll(y, -1) - y @ np.roll(x, -1)))


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
    out = np.asarray(subject, dtype=float)
    for a, b in zip(window, np.roll(window, -1, axis=0)):
        if len(out) == 0:
            break
        edge = b - a
        length = np.hypot(*edge)
        # distance inside the edge's half-plane (left of a -> b)
        side = (edge[0] * (out[:, 1] - a[1]) - edge[1] * (out[:, 0] - a[0])) / length
        inside = side >= -tol
        if inside.all():
            continue
        kept = []
        for i in range(len(out)):
            j = (i + 1) % len(out)
            if inside[i]:
                kept.append(out[i])
            if inside[i] != inside[j]:
                t = side[i] / (side[i] - side[j])
                kept.append(out[i] + t * (out[j] - out[i]))
        out = np.array(kept).reshape(-1, 2)
    return out if len(out) >= 3 else np.zeros((0, 2))
