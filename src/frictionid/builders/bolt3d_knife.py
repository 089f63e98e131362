"""Knife edges of the 3-D bolt model and the element size along them.

A 120 deg countersink has the slope of a thread flank in every axial section: the one at the nut's top that of
the load flanks, the one at its bearing face that of the free flanks. In the section at one angle phi* per
countersink the cone and a flank coincide, and on either side of it they are parallel at the axial offset
P (phi - phi*) / 2 pi. So the fragment's cone and flank meet along the radial line at phi* at a dihedral angle of
only about cos 30 deg P / (2 pi r) (M36: 1.9 deg): the piece of the bolt's tooth (or of the nut's) between them
is a wedge that closes to nothing there. Where the nut has material at phi* (not in the window), gmsh's surface
triangles of the two faces, at the flank's size, cross inside that wedge (their chords sag by more than the
wedge is thick), and the 3-D mesher fails ("PLC Error: A segment and a facet intersect", or a volume left
unmeshed). Meshing the edge at KNIFE_SIZE pitches, growing away from it, keeps the two faces' triangles apart.
Where phi* lies in the window (the default M6, M20), the nut has no material there and there is no such edge.
The builder refines the knife edges only after gmsh's algorithms failed without (:func:`.bolt3d_mesh.
mesh_with_fallback`), so that a model that meshed before keeps its mesh (the stored fixtures' M6 without window
has one and meshes by Frontal; with the refinement Delaunay still reported overlapping facets there).
"""

from __future__ import annotations

import math

import gmsh
import numpy as np

from .bolt_layout import BoltLayout
from .thread import SQRT3

#: element size on a knife edge, in pitches
KNIFE_SIZE = 0.06
#: growth of the size per mm of distance from a knife edge
KNIFE_GROWTH = 0.5
_TOL = 2e-3  # [mm] distance under which a curve point lies on the tangency line


def tangency_lines(layout: BoltLayout, theta_match: float) -> list[tuple[float, float, float]]:
    """(theta*, y_face, sign) [rad, mm] of each countersink: the angle theta* of the radial line along which the
    cone at the nut face y_face coincides with a bolt flank (load flank at the top, free flank at the bearing
    face), sign +1 where the cone narrows upwards into the nut (bearing face), -1 at the top."""
    s = layout.size
    apex = s.d / 2 + s.H / 8 - layout.shift
    lines = []
    # cone y = y_face + sign (da/2 - r)/sqrt 3; flank y = phase + k P + P phi / 2 pi - sign (apex - r)/sqrt 3
    for y_face, sign in ((layout.y_bearing, 1.0), (layout.y_top, -1.0)):
        offset = y_face + sign * (s.da / 2 - apex) / SQRT3 - layout.bolt_phase
        phi = 2 * math.pi * ((offset / s.P) % 1.0)
        lines.append((theta_match + phi, y_face, sign))
    return lines


def on_line(layout: BoltLayout, points: np.ndarray, line: tuple[float, float, float]) -> np.ndarray:
    """Whether each of the points (m, 3) [mm] lies on the tangency line ``line`` (:func:`tangency_lines`): on the
    cone, in the section at theta* to within the angle over which the flank moves by the tolerance (the lofted
    flank's own tangency moves by 0.02 deg on the M36)."""
    theta, y_face, sign = line
    s = layout.size
    r = np.hypot(points[:, 0], points[:, 2])
    phi = np.mod(np.arctan2(-points[:, 2], points[:, 0]) - theta + math.pi, 2 * math.pi) - math.pi
    y_cone = y_face + sign * (s.da / 2 - r) / SQRT3
    return (np.abs(s.P * phi / (2 * math.pi)) < _TOL) & (np.abs(points[:, 1] - y_cone) < _TOL)


def knife_edges(layout: BoltLayout, theta_match: float) -> list[int]:
    """Tags of the curves of the current gmsh model that lie on a tangency line (:func:`tangency_lines`)."""
    lines = tangency_lines(layout, theta_match)
    s = layout.size
    span = (s.da / 2 - s.d3 / 2) / SQRT3 + _TOL         # the cone's extent in y from the face, down to the root
    edges = []
    for _, curve in gmsh.model.getEntities(1):
        box = gmsh.model.getBoundingBox(1, curve)
        if not any(box[1] > y - span and box[4] < y + span for _, y, _ in lines):
            continue
        lo, hi = gmsh.model.getParametrizationBounds(1, curve)
        u = np.linspace(lo[0], hi[0], 5)
        points = np.reshape(gmsh.model.getValue(1, curve, u.tolist()), (-1, 3))
        if any(np.all(on_line(layout, points, line)) for line in lines):
            edges.append(curve)
    return edges
