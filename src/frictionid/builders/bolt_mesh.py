"""gmsh mesh of the bolt-nut tensile test: bolt, nut and the two plates as separate quadratic-triangle bodies,
each contact segment with the same uniform node spacing on both sides (node-to-node pairs at zero gap)."""

from __future__ import annotations

import math

import gmsh
import numpy as np

from ..model import Mesh
from .arcs import separate_quadratic_bodies
from .bolt_layout import BoltLayout
from .gmsh_mesh import distance_size_field, gmsh_session, mesh_from_gmsh, use_size_fields
from .thread import SQRT3, Flank, bolt_profile

#: element size growth per mm of distance from the refined curves
SIZE_GROWTH = 0.25
#: largest turn [rad] of a root arc per element
ARC_STEP = math.radians(15.0)
_TOL = 1e-9  # [mm] coordinates closer than this are the same point


class _Outline:
    """A closed outline of one body in the gmsh built-in kernel, drawn curve by curve; labels per curve."""

    def __init__(self, start, labels: dict[str, list[int]]):
        self.start, self.current, self.labels = tuple(start), tuple(start), labels
        self.points: dict[tuple[float, float], int] = {}
        self.curves: list[int] = []
        self.area = 0.0                                  # twice the signed area enclosed so far (shoelace)

    def _point(self, p) -> int:
        key = (round(float(p[0]), 9), round(float(p[1]), 9))
        if key not in self.points:
            self.points[key] = gmsh.model.geo.addPoint(float(p[0]), float(p[1]), 0.0)
        return self.points[key]

    def to(self, end, *labels: str, centre=None) -> int | None:
        """Draw a line (or an arc about ``centre``) from the current point to ``end``; its tag or None if empty."""
        end = (float(end[0]), float(end[1]))
        if math.dist(self.current, end) < _TOL:
            return None
        a, b = self._point(self.current), self._point(end)
        tag = gmsh.model.geo.addLine(a, b) if centre is None else \
            gmsh.model.geo.addCircleArc(a, gmsh.model.geo.addPoint(*centre, 0.0), b)
        self.curves.append(tag)
        self.area += self.current[0] * end[1] - end[0] * self.current[1]
        for label in labels:
            self.labels.setdefault(label, []).append(tag)
        self.current = end
        return tag

    def close(self, *labels: str) -> int:
        """Draw back to the start and add the plane surface, counter-clockwise (cells with det J > 0)."""
        self.to(self.start, *labels)
        curves = self.curves if self.area > 0 else [-c for c in reversed(self.curves)]
        return gmsh.model.geo.addPlaneSurface([gmsh.model.geo.addCurveLoop(curves)])


def _flank_pieces(layout: BoltLayout, flank: Flank, r_from: float, r_to: float):
    """[(r_a, r_b, labels)] pieces of a flank line between two radii, split at the contact ends and zone radii."""
    lo, hi = flank.r_contact
    cuts = sorted({r_from, r_to, *[r for r in (lo, hi, *layout.zone_splits) if r_from < r < r_to]})
    section = next(k for k, part in enumerate(layout.sections) if flank.index in part)
    pieces = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        inside = lo - _TOL <= a and b <= hi + _TOL
        radial = sum(r > (a + b) / 2 for r in layout.zone_splits)
        pieces.append((a, b, (layout.zone_name(radial, section), f"thread_{flank.index}") if inside else ()))
    return pieces if r_from <= r_to else [(b, a, labels) for a, b, labels in reversed(pieces)]


def _draw_flank(outline: _Outline, layout: BoltLayout, flank: Flank, r_from: float, r_to: float, side: str,
                transfinite: dict[int, int], flank_size: float):
    for a, b, labels in _flank_pieces(layout, flank, r_from, r_to):
        names = [f"{side}_load", "engaged_region"]
        if labels:
            names += [f"{side}_contact", *(labels if side == "bolt" else [f"nut_thread_{flank.index}"])]
        tag = outline.to(flank.point(b), *names)
        if labels and tag is not None:
            transfinite[tag] = math.ceil(abs(b - a) / math.cos(math.pi / 6) / flank_size - 1e-9) + 1


def _arc_nodes(segment, size: float) -> int:
    """Nodes on a root arc: spacing at most ``size`` [mm] and at most :data:`ARC_STEP` of turn per element
    (coarser quadratic triangles on the tight root came out inverted at their corners)."""
    a, b = np.subtract(segment.a, segment.centre), np.subtract(segment.b, segment.centre)
    angle = abs(math.atan2(a[0] * b[1] - a[1] * b[0], float(np.dot(a, b))))
    return max(math.ceil(angle / ARC_STEP - 1e-9), math.ceil(angle * np.linalg.norm(a) / size - 1e-9), 1) + 1


def _draw_bolt(layout: BoltLayout, labels, transfinite, flank_size: float, n_head: int) -> int:
    s, flanks = layout.size, {round(f.z_bolt, 6): f for f in layout.flanks}
    r_head = s.head_radius
    o = _Outline((0.0, -s.head_k), labels)
    o.to((r_head, -s.head_k), "head_bottom")
    o.to((r_head, 0.0), "head_side")
    transfinite[o.to((layout.r_hole, 0.0), "head_plate")] = n_head
    o.to((layout.r_shank, 0.0), "head_free")
    o.to((layout.r_shank, layout.y_thread), "shank")
    for segment in bolt_profile(s, layout.y_thread, layout.length, layout.bolt_phase, layout.shift):
        o.to(segment.a, "thread_start")
        z = layout.bolt_phase + segment.tooth * s.P
        flank = flanks.get(round(z, 6)) if segment.role == "load" else None
        near = layout.y_bearing - s.P / 2 < (segment.a[1] + segment.b[1]) / 2 < layout.y_top + s.P / 2
        if flank is None:
            tag = o.to(segment.b, f"bolt_{segment.role}", "bolt_thread", *(("engaged_region",) if near else ()),
                       centre=segment.centre)
            if segment.centre is not None and tag is not None:
                transfinite[tag] = _arc_nodes(segment, flank_size if near else max(flank_size, s.P / 8))
        else:
            _draw_flank(o, layout, flank, segment.a[0], segment.b[0], "bolt", transfinite, flank_size)
    o.to((0.0, layout.length), "bolt_end")
    return o.close("bolt_axis")


def _nut_role(layout: BoltLayout, a, b) -> tuple[str, Flank | None]:
    """Role of a bore segment by position: engaged or other load flank, free flank, or "bore" (crest, root, cone)."""
    s = layout.size
    apex = s.d / 2 - 7 * s.H / 8
    for sign, role in ((1.0, "load"), (-1.0, "free")):
        z = [p[1] - sign * (p[0] - apex) / SQRT3 for p in (a, b)]
        k = (z[0] - layout.nut_phase) / s.P
        if abs(z[0] - z[1]) < _TOL and abs(k - round(k)) < 1e-9 and abs(a[0] - b[0]) > _TOL:
            flank = next((f for f in layout.flanks if abs(f.z_nut - z[0]) < 1e-6), None) if role == "load" else None
            return role, flank
    return "bore", None


def _draw_nut(layout: BoltLayout, labels, transfinite, flank_size: float, n_nut: int) -> int:
    s, r_b = layout.size, layout.r_bearing
    chamfer = (s.hex_radius - r_b) / SQRT3
    o = _Outline((s.hex_radius, layout.y_bearing + chamfer), labels)
    o.to((r_b, layout.y_bearing), "nut_chamfer")
    transfinite[o.to((layout.r_hole, layout.y_bearing), "nut_plate")] = n_nut
    for a, b in zip(layout.bore[:-1], layout.bore[1:]):
        o.to(a, "nut_bearing_free")
        role, flank = _nut_role(layout, a, b)
        if flank is None:
            o.to(b, f"nut_{role}", "nut_thread", "engaged_region")
        else:
            _draw_flank(o, layout, flank, a[0], b[0], "nut", transfinite, flank_size)
    o.to((r_b, layout.y_top), "nut_top")
    o.to((s.hex_radius, layout.y_top - chamfer), "nut_chamfer")
    return o.close("nut_outer")


def _draw_plates(layout: BoltLayout, labels, transfinite, n_head: int, n_nut: int) -> tuple[int, int]:
    s, r_hole, r_out = layout.size, layout.r_hole, layout.r_outer
    (y0, y1), (y2, y3) = layout.plate2, layout.plate1
    p2 = _Outline((r_hole, y0), labels)
    transfinite[p2.to((s.head_radius, y0), "plate2_head")] = n_head
    p2.to((r_out, y0), "plate2_bottom")
    p2.to((r_out, y1), "plate2_rim")
    p2.to((r_hole, y1), "plate2_top")
    p1 = _Outline((r_hole, y2), labels)
    p1.to((r_out, y2), "plate1_bottom")
    p1.to((r_out, y3), "plate1_rim")
    p1.to((layout.r_bearing, y3), "plate1_top")
    transfinite[p1.to((r_hole, y3), "plate1_nut")] = n_nut
    return p2.close("plate2_hole"), p1.close("plate1_hole")


def _size_field(curves: list[int], size_min: float, size_max: float) -> int:
    """Size ``size_min`` on the curves, growing by :data:`SIZE_GROWTH` per mm up to ``size_max``."""
    return distance_size_field(curves, size_min, size_max, max(size_max - size_min, 0.0) / SIZE_GROWTH + 1e-12)


def bolt_mesh(layout: BoltLayout, flank_size: float, contact_size: float, mesh_size: float) -> Mesh:
    """Quadratic-triangle ("triangle6") mesh of bolt, nut and plates with the named groups of :func:`bolt_model`."""
    s = layout.size
    n_head = math.ceil((s.head_radius - layout.r_hole) / contact_size - 1e-9) + 1
    n_nut = math.ceil((layout.r_bearing - layout.r_hole) / contact_size - 1e-9) + 1
    with gmsh_session("bolt"):
        separate_quadratic_bodies()
        labels, transfinite = {}, {}
        surfaces = {"bolt": _draw_bolt(layout, labels, transfinite, flank_size, n_head),
                    "nut": _draw_nut(layout, labels, transfinite, flank_size, n_nut)}
        surfaces["plate2"], surfaces["plate1"] = _draw_plates(layout, labels, transfinite, n_head, n_nut)
        gmsh.model.geo.synchronize()
        for tag, n in transfinite.items():
            gmsh.model.mesh.setTransfiniteCurve(tag, n)
        thread_size = max(flank_size, s.P / 8)
        fields = [_size_field(labels["engaged_region"], flank_size, mesh_size),
                  _size_field(labels["bolt_thread"] + labels["bolt_load"], thread_size, mesh_size),
                  _size_field([*labels["head_plate"], *labels["nut_plate"]], contact_size, mesh_size)]
        use_size_fields(*fields)
        gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
        for name, tag in surfaces.items():
            gmsh.model.addPhysicalGroup(2, [tag], name=name)
        for name, tags in labels.items():
            gmsh.model.addPhysicalGroup(1, tags, name=name)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh(f"bolt model {s.name}")
