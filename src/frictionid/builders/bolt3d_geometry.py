"""The 3-D bolt-nut tensile test in gmsh's OpenCASCADE kernel: helical bolt thread, hexagon nut with its window,
hexagon head, two plates; one fragment makes every touching face shared (a conforming interface).

Frame: y the bolt axis; the section half-plane at angle theta is spanned by y and e(theta) = (cos theta, 0,
-sin theta), so that the thread (teeth at y = z_k + P theta / 2 pi) is a right-hand helix. The bolt is its blank
(head, shank, threaded cylinder at the crest radius) minus one helical groove per turn, each a smooth loft of
:data:`SECTIONS` sections (BOLT.md: exact to < 1 um where a pipe sweep distorted the profile); no loft vertex lies
on the crest cylinder. The nut is its blank (hexagon, bore at the nut crest D1/2, 120 deg countersinks, the
window) overlapping the bolt: the fragment leaves the nut the space the bolt's grooves free, so its teeth are the
grooves' complement (load and free flanks on the bolt's, nut root on the bolt crest) and the load flanks are
shared faces. All functions here run inside a gmsh session (:func:`~frictionid.builders.gmsh_mesh.gmsh_session`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gmsh
import numpy as np

from .bolt_layout import BoltLayout
from .thread import SQRT3

#: loft sections per turn of a groove (BOLT.md)
SECTIONS = 16
#: points of the exact profile the spline through the groove's root passes (:func:`groove_section`)
ROOT_POINTS = 48


@dataclass(frozen=True)
class Window:
    """The nut's cut-out: the sector |theta - centre| <= width / 2 [deg] of the nut from its flats ``depth`` [mm]
    inwards, over the nut's whole height."""

    width: float
    depth: float
    centre: float = 0.0


def direction(theta) -> np.ndarray:
    """(..., 3) unit vector e(theta) of the section half-plane at angle theta [rad]."""
    theta = np.asarray(theta, dtype=float)
    return np.stack([np.cos(theta), np.zeros_like(theta), -np.sin(theta)], axis=-1)


def to_xyz(r, y, theta) -> np.ndarray:
    """(..., 3) [mm] of the section point (r, y) in the half-plane at theta [rad]."""
    return np.asarray(r, dtype=float)[..., None] * direction(theta) + np.multiply.outer(np.asarray(y, float),
                                                                                           [0.0, 1.0, 0.0])


def groove_section(layout: BoltLayout, z: float) -> list[tuple]:
    """Closed outline [(kind, points)] in (r, y) [mm] of the bolt groove between the tooth centred at z and the
    next one: free flank of tooth z, root arc, load flank of the next tooth (vertices at the zone splits), closed
    outside the crest at r_out = crest + H/16. ``kind`` "line" (two points) or "spline" (interpolated points).

    The flanks below the lowest zone split (at most d2/2) and the root arc between them are one spline through
    :data:`ROOT_POINTS` points of the exact profile: the nut's crest cylinder D1/2 cuts the flanks only
    |es|/(2 sqrt 3) above their tangent points, and an edge there would leave a helical face 0.02 mm wide, too
    thin to mesh. (Two splines joined at the root's bottom met a PLC error in gmsh's volume mesher.)"""
    s, shift = layout.size, layout.shift
    P, R = s.P, s.root_radius
    apex, r_root = s.d / 2 + s.H / 8 - shift, s.d1 / 2 - shift
    r_out = s.d / 2 - shift + s.H / 16
    r_joint = min([s.d2 / 2, *layout.zone_splits])
    free = lambda r: z + (apex - r) / SQRT3            # noqa: E731  free flank of the tooth at z
    load = lambda r: z + P - (apex - r) / SQRT3        # noqa: E731  load flank of the next tooth
    centre = np.array([r_root + R / 2, z + P / 2])
    start, end = (np.array([r_root, f(r_root)]) - centre for f in (free, load))
    a0, a1 = math.atan2(start[1], start[0]), math.atan2(end[1], end[0])
    angles = np.linspace(a0, a1 - 2 * math.pi if a1 > a0 else a1, ROOT_POINTS // 2 + 1)    # through the bottom
    arc = centre + R * np.column_stack([np.cos(angles), np.sin(angles)])
    n_flank = ROOT_POINTS // 4
    lower = np.linspace(r_joint, r_root, n_flank, endpoint=False)
    pieces = [("line", [(r_out, free(r_out)), (r_joint, free(r_joint))]),
              ("spline", [(r, free(r)) for r in lower] + [tuple(p) for p in arc] + [(r, load(r)) for r in lower[::-1]])]
    radii = [r_joint, *sorted(r for r in layout.zone_splits if r > r_joint + 1e-9), r_out]
    pieces += [("line", [(a, load(a)), (b, load(b))]) for a, b in zip(radii[:-1], radii[1:])]
    pieces.append(("line", [(r_out, load(r_out)), (r_out, free(r_out))]))
    return pieces


def _wire(pieces, theta: float, dy: float) -> int:
    """An OCC wire of a section outline placed in the half-plane at theta, moved by dy along the axis."""
    occ = gmsh.model.occ
    points: dict = {}

    def point(p):
        key = (round(p[0], 10), round(p[1], 10))
        if key not in points:
            points[key] = occ.addPoint(*to_xyz(p[0], p[1] + dy, theta))
        return points[key]

    curves = []
    for kind, pts in pieces:
        tags = [point(p) for p in pts]
        curves.append(occ.addLine(*tags) if kind == "line" else occ.addSpline(tags))
    return occ.addWire(curves)


def groove(layout: BoltLayout, z: float, theta0: float) -> int:
    """Volume tag of one turn of the helical groove whose section at theta0 is :func:`groove_section` (z)."""
    P = layout.size.P
    pieces = groove_section(layout, z)
    wires = [_wire(pieces, theta0 + 2 * math.pi * j / SECTIONS, P * j / SECTIONS) for j in range(SECTIONS + 1)]
    out = gmsh.model.occ.addThruSections(wires, makeSolid=True, makeRuled=False)
    return next(tag for dim, tag in out if dim == 3)


def thread_grooves(layout: BoltLayout, theta0: float) -> list[tuple[int, int]]:
    """The bolt thread's helical grooves, one :func:`groove` turn per pitch with its seam at theta0, cut off below
    the plane y = ``layout.y_thread``: the thread starts at that plane at every angle, as the axisymmetric
    profile (:func:`frictionid.builders.thread.bolt_profile` from y_thread) does at every phase of its teeth, so
    that the helix's section at any angle is the ring model at that phase. Whole turns instead would leave the
    lowest part turn uncut at some angles and reach below y_thread at others (M6: 2.2 mm^3 more steel over the
    first pitch, docs/bolt-study.md). The turns reach the bolt's end."""
    s, occ = layout.size, gmsh.model.occ
    P, reach = s.P, 15 * s.P / 32                      # a groove's half width at r_out about its centre line
    # groove k: its centre line at bolt_phase + k P at the seam, rising by P over the turn
    first = math.floor((layout.y_thread - reach - layout.bolt_phase) / P) - 1
    last = math.ceil((layout.length + reach - layout.bolt_phase) / P)
    grooves, crossing = [], []
    for k in range(first, last + 1):
        low, high = layout.bolt_phase + k * P - reach, layout.bolt_phase + (k + 1) * P + reach
        if high <= layout.y_thread or low >= layout.length:
            continue
        tag = (3, groove(layout, layout.bolt_phase + (k - 0.5) * P, theta0))
        (crossing if low < layout.y_thread else grooves).append(tag)
    if crossing:
        r_far = s.d / 2 + s.H
        above = cylinder(r_far, layout.y_thread, layout.length + 2 * P)
        cut, _ = occ.intersect(crossing, [(3, above)])
        grooves += [(d, t) for d, t in cut if d == 3]
    return grooves


def hexagon_prism(s: float, y0: float, y1: float, angle0: float) -> int:
    """Volume tag of a hexagonal prism, width across flats s [mm], y in [y0, y1]; flat normals at angle0 +
    k 60 deg in the (x, z) plane (angle from +x towards -z, as theta)."""
    occ = gmsh.model.occ
    R = s / SQRT3
    corners = [to_xyz(R, y0, angle0 + math.radians(30 + 60 * k)) for k in range(6)]
    points = [occ.addPoint(*c) for c in corners]
    lines = [occ.addLine(points[k], points[(k + 1) % 6]) for k in range(6)]
    face = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    out = occ.extrude([(2, face)], 0.0, y1 - y0, 0.0)
    return next(tag for dim, tag in out if dim == 3)


def cylinder(r: float, y0: float, y1: float) -> int:
    return gmsh.model.occ.addCylinder(0.0, y0, 0.0, 0.0, y1 - y0, 0.0, r)


def countersink(layout: BoltLayout, y_face: float, sign: float) -> int:
    """Volume tag of the 120 deg cone removed at a nut face (diameter da at the face, narrowing into the nut)."""
    s = layout.size
    depth = (s.da / 2 - s.d1 / 2) / SQRT3 + 0.2
    r_tip = s.da / 2 - depth * SQRT3
    occ = gmsh.model.occ
    y_far = y_face + sign * depth
    # a cone from a bit outside the face (r = da/2 + 0.5 sqrt 3) to depth, so the face is cut cleanly
    y_out = y_face - sign * 0.5
    return occ.addCone(0.0, y_out, 0.0, 0.0, y_far - y_out, 0.0, s.da / 2 + 0.5 * SQRT3, max(r_tip, 0.0))
