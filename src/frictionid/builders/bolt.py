"""Reference test 2: the axisymmetric bolt-nut tensile test (ISO 4014 bolt, ISO 4032 nut, two plates) in gmsh.

Axis y, x = r [mm]. Layout (DESIGN.md, M20 numbers in brackets, other sizes scale with d): head y in [-k, 0]
(k = 12.5), bolt end y = l (6 d = 120), thread from l - b (74), nut top l - 3 P (112.5), nut bearing face
l - 3 P - m (94.5); plate 2 y in [0, d] and plate 1 y in [bearing - d, bearing], both with the ISO 273 medium
clearance hole (radius 11) and outer radius 2 d (40); hexagons as area-equivalent rings (15.75). The bolt profile
is moved radially inwards by |es|/2 (0.021) and the nut thread axially by |es|/(2 sqrt 3) (0.01212), so load
flanks touch exactly and free flanks are open (axial gap |es|/sqrt 3). Bolt and nut are separate gmsh surfaces;
each contact segment has the same uniform node spacing on both sides (node-to-node pairs at zero gap).
"""

from __future__ import annotations

import math
import string
from dataclasses import dataclass

import gmsh
import numpy as np

from ..errors import InputError
from ..model import ContactInterface, Material, Mesh, Model, Stage, Support, SurfaceForce
from .arcs import separate_quadratic_bodies
from .gmsh_mesh import gmsh_session, mesh_from_gmsh
from .thread import (SQRT3, Flank, ThreadSize, bolt_profile, engaged_flanks, first_tooth_window, nut_bore,
                     thread_size)

#: steel of bolt, nut and plates (DESIGN.md)
STEEL = Material(E=200000.0, nu=0.3, name="steel")
#: fixed friction coefficient of the head-plate and nut-plate contacts (DESIGN.md)
PLATE_MU = 0.15
#: element size growth per mm of distance from the refined curves
SIZE_GROWTH = 0.25
#: largest turn [rad] of a root arc per element
ARC_STEP = math.radians(15.0)
_TOL = 1e-9  # [mm] coordinates closer than this are the same point


# ------------------------------------------------------------------------------------------------ layout

@dataclass(frozen=True)
class BoltLayout:
    """The tensile test set-up of one size: heights and radii [mm], thread phases, engaged flanks.

    ``r_bearing`` is the outer radius of the nut's bearing face (the hexagon ring unless a bearing diameter is
    given, then chamfered at 30 deg up to the ring). ``flanks`` are the engaged load flanks numbered from the nut
    bearing face; ``zone_splits`` the radii [mm] splitting each flank's contact segment radially; ``sections``
    the flank indices (1-based) of each axial section, section 1 next to the bearing face.
    """

    size: ThreadSize
    length: float
    y_thread: float
    y_bearing: float
    y_top: float
    plate2: tuple[float, float]
    plate1: tuple[float, float]
    r_hole: float
    r_bearing: float
    r_outer: float
    r_shank: float
    shift: float
    bolt_phase: float
    nut_phase: float
    bore: np.ndarray
    flanks: tuple[Flank, ...]
    zone_splits: tuple[float, ...]
    sections: tuple[tuple[int, ...], ...]

    @property
    def n_radial(self) -> int:
        return len(self.zone_splits) + 1

    def zone_name(self, radial: int, section: int) -> str:
        """Zone letter of radial part ``radial`` (0 outermost) in axial section ``section`` (0 at the bearing)."""
        return string.ascii_uppercase[radial * len(self.sections) + section]

    @property
    def thread_zones(self) -> tuple[str, ...]:
        return tuple(self.zone_name(i, k) for i in range(self.n_radial) for k in range(len(self.sections)))


def _number(key: str, value, low: float = 0.0) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or not value > low:
        raise InputError(f"`{key}` must be a finite number > {low:g}, got {value!r}")
    return float(value)


def _count(key: str, value, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise InputError(f"`{key}` must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


def bolt_layout(size: str = "M20", length: float | None = None, engaged_length: float | None = None,
                clearance: float | None = None, n_radial: int = 2, n_axial: int = 3,
                bearing_diameter: float | str | None = None) -> BoltLayout:
    """The set-up geometry of a size (see the module docstring); options as in :func:`bolt_model`.

    >>> layout = bolt_layout("M20")
    >>> layout.y_bearing, layout.y_top, len(layout.flanks)
    (94.5, 112.5, 7)
    """
    s = thread_size(size)
    length = 6 * s.d if length is None else _number("length", length)
    m = s.nut_m
    engaged = m if engaged_length is None else _number("engaged_length", engaged_length)
    if engaged > m + _TOL:
        raise InputError(f"`engaged_length` = {engaged:g} mm is longer than the nut: expected at most the "
                         f"{s.name} nut height m = {m:g} mm (ISO 4032)")
    if clearance is not None and not (isinstance(clearance, (int, float)) and 0 <= clearance < s.H / 4):
        raise InputError(f"`clearance` must be a number of mm in [0, H/4 = {s.H / 4:.3g}) (the 6g flank clearance "
                         f"|es|, {-s.es:g} for {s.name}), got {clearance!r}")
    shift = -s.es / 2 if clearance is None else float(clearance) / 2
    y_top = length - 3 * s.P
    y_bearing = y_top - m
    y_thread = length - s.thread_length(length)
    if y_thread > y_bearing - s.P or y_bearing - s.d < s.d + s.P:
        raise InputError(f"`length` = {length:g} mm is too short for {s.name}: the plates ({s.d:g} mm thick) "
                         f"would not fit between head and nut; expected at least {2 * s.d + m + 4 * s.P:g} mm")
    nut_phase = _nut_phase(s, y_bearing, y_top, shift)
    bolt_phase = nut_phase + s.P / 2 - shift / SQRT3
    bore = nut_bore(s, y_bearing, y_top, nut_phase, engaged)
    flanks = tuple(engaged_flanks(s, bore, nut_phase, bolt_phase, shift, y_thread, length))
    if not flanks:
        raise InputError(f"`engaged_length` = {engaged:g} mm leaves no complete load flank engaged; expected at "
                         f"least about {2 * s.P:g} mm (two pitches)")
    n_radial, n_axial = _count("n_radial", n_radial, 1, 4), _count("n_axial", n_axial, 1, len(flanks))
    if n_radial * n_axial > 26:
        raise InputError(f"`n_radial` x `n_axial` = {n_radial * n_axial} zones: at most 26 (letters A-Z)")
    splits = _zone_splits(s, shift, n_radial)
    sections = tuple(tuple(int(i) + 1 for i in part) for part in np.array_split(np.arange(len(flanks)), n_axial))
    return BoltLayout(s, length, y_thread, y_bearing, y_top, (0.0, s.d), (y_bearing - s.d, y_bearing),
                      s.hole / 2, _bearing_radius(s, bearing_diameter), 2 * s.d, s.d / 2 - shift, shift, bolt_phase, nut_phase, bore, flanks,
                      splits, sections)


def _bearing_radius(s: ThreadSize, diameter) -> float:
    """Outer radius [mm] of the nut bearing face: the ring (None), ISO 4032 dw ("dw") or a diameter."""
    if diameter is None:
        return s.hex_radius
    value = s.nut_dw if diameter == "dw" else diameter
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not s.hole < value <= 2 * s.hex_radius:
        raise InputError(f"`bearing_diameter` must be \"dw\" or a number of mm in ({s.hole:g}, "
                         f"{2 * s.hex_radius:.4g}] (clearance hole to hexagon ring), got {diameter!r}")
    return float(value) / 2


def _nut_phase(s: ThreadSize, y_bearing: float, y_top: float, shift: float) -> float:
    """Nut tooth phase [mm]: bolt teeth centred in the nut (bolt tooth at mid-height), the nut moved up by
    shift / sqrt(3); moved down into :func:`first_tooth_window` when the countersink would cut a load flank
    part-way (M20 keeps the centred phase)."""
    phase = (y_bearing + y_top) / 2 + shift / SQRT3
    z_min, z_max = first_tooth_window(s, y_bearing, shift)
    first = phase + math.ceil((z_min - phase) / s.P - 1e-12) * s.P
    return phase if first <= z_max else phase - (first - (z_min + z_max) / 2)


def _zone_splits(s: ThreadSize, shift: float, n_radial: int) -> tuple[float, ...]:
    """Radii [mm] splitting a full contact segment (d1/2 to d/2 - shift), outermost first: d2/2 for 2 parts,
    else equal radial parts."""
    if n_radial == 2:
        return (s.d2 / 2,)
    return tuple(float(r) for r in np.linspace(s.d1 / 2, s.d / 2 - shift, n_radial + 1)[1:-1][::-1])


# ------------------------------------------------------------------------------------------------- gmsh

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
    field = gmsh.model.mesh.field
    distance = field.add("Distance")
    field.setNumbers(distance, "CurvesList", curves)
    field.setNumber(distance, "Sampling", 20)
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", distance)
    field.setNumber(threshold, "SizeMin", size_min)
    field.setNumber(threshold, "SizeMax", size_max)
    field.setNumber(threshold, "DistMin", 0.0)
    field.setNumber(threshold, "DistMax", max(size_max - size_min, 0.0) / SIZE_GROWTH + 1e-12)
    return threshold


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
        minimum = gmsh.model.mesh.field.add("Min")
        gmsh.model.mesh.field.setNumbers(minimum, "FieldsList", fields)
        gmsh.model.mesh.field.setAsBackgroundMesh(minimum)
        for option in ("Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature", "Mesh.MeshSizeExtendFromBoundary"):
            gmsh.option.setNumber(option, 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
        for name, tag in surfaces.items():
            gmsh.model.addPhysicalGroup(2, [tag], name=name)
        for name, tags in labels.items():
            gmsh.model.addPhysicalGroup(1, tags, name=name)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh(f"bolt model {s.name}")


# ------------------------------------------------------------------------------------------------ model

def _forces(forces) -> tuple[float, ...]:
    if isinstance(forces, (int, float)) and not isinstance(forces, bool):
        forces = (forces,)
    if not isinstance(forces, (list, tuple)) or not forces:
        raise InputError(f"`forces` must be a list of machine forces [N], one per stage, got {forces!r}")
    return tuple(_number(f"forces[{i}]", f) for i, f in enumerate(forces))


def bolt_model(size: str = "M20", forces=(10000.0, 30000.0), n_increments: int = 3, flank_size: float = 0.1,
               contact_size: float | None = None, mesh_size: float | None = None, n_radial: int = 2,
               n_axial: int = 3, length: float | None = None, engaged_length: float | None = None,
               clearance: float | None = None, bearing_diameter: float | str | None = None) -> Model:
    """The axisymmetric bolt-nut tensile test (DESIGN.md, reference test 2) for a coarse M size.

    Parameters
    ----------
    size : str
        "M6" ... "M36" (tables in :mod:`frictionid.builders.thread`); "M20" is the DESIGN.md set-up.
    forces : sequence of float [N]
        Machine force at the end of each stage (e.g. the measured force of each DIC stage), applied in +y on
        plate 1's outer rim (whole ring); plate 2's outer rim is held.
    n_increments : int
        Increments per stage.
    flank_size : float [mm]
        Element size on the engaged thread (node spacing on the contact flanks, both sides).
    contact_size : float [mm], optional
        Node spacing on the head-plate and nut-plate contacts; default d / 40 (0.5 for M20).
    mesh_size : float [mm], optional
        Largest element size; default d / 8.
    n_radial, n_axial : int
        Thread zones: each engaged load flank split radially into n_radial parts (2: at the pitch diameter),
        the flanks grouped axially into n_axial sections (as equal counts as possible, extra flanks near the
        bearing face). Zone letters run over sections first: outer parts A, B, C, inner parts D, E, F.
    length : float [mm], optional
        Nominal bolt length l (bolt end at y = l); default 6 d.
    engaged_length : float [mm], optional
        Threaded length of the nut bore from the bearing face (at most the nut height m); above it the bore is
        relieved to the thread root. Default m.
    clearance : float [mm], optional
        Flank clearance |es| of the 6g bolt; default ISO 965-1 (0.042 for M20).
    bearing_diameter : "dw" or float [mm], optional
        Outer diameter of the nut's bearing face on plate 1; "dw" takes ISO 4032 dw (27.7 for M20). The ring
        beyond it is chamfered at 30 deg (both nut faces). Default: the whole ring face (DESIGN.md).

    Returns
    -------
    Model
        Axisymmetric, regions "bolt", "nut", "plate1", "plate2" (steel). Interfaces: "thread" (zones on the
        bolt load flanks, target "nut_contact"), "head" (zone "head_plate", target "plate2_head") and
        "nut_bearing" (zone "nut_plate", target "plate1_nut"). Further boundaries: "thread_<i>" (bolt contact
        segment of engaged flank i, from the bearing face), "nut_thread_<i>", "bolt_load", "bolt_free",
        "nut_load", "nut_free", "nut_outer", "plate1_rim" (loaded), "plate2_rim" (held).
    """
    layout = bolt_layout(size, length, engaged_length, clearance, n_radial, n_axial, bearing_diameter)
    d = layout.size.d
    flank_size = _number("flank_size", flank_size)
    contact_size = d / 40 if contact_size is None else _number("contact_size", contact_size)
    mesh_size = d / 8 if mesh_size is None else _number("mesh_size", mesh_size)
    if flank_size > layout.size.P / 4:
        raise InputError(f"`flank_size` = {flank_size:g} mm is too coarse for {layout.size.name}: expected at most "
                         f"P/4 = {layout.size.P / 4:g} mm (a flank is about 0.6 P long)")
    forces = _forces(forces)
    n_increments = _count("n_increments", n_increments, 1, 1000)
    mesh = bolt_mesh(layout, flank_size, contact_size, max(mesh_size, flank_size))
    interfaces = (ContactInterface("thread", layout.thread_zones, "nut_contact", "node-to-node"),
                  ContactInterface("head", ("head_plate",), "plate2_head", "node-to-node"),
                  ContactInterface("nut_bearing", ("nut_plate",), "plate1_nut", "node-to-node"))
    return Model(mesh=mesh, kind="axisymmetric",
                 materials={name: STEEL for name in ("bolt", "nut", "plate1", "plate2")},
                 supports=(Support("plate2_rim", (0, 1)),),
                 loads=(SurfaceForce("plate1_rim", 1, forces),),
                 stages=tuple(Stage(f"F{i + 1}", n_increments) for i in range(len(forces))),
                 interfaces=interfaces)


def fixed_friction() -> dict[str, float]:
    """Coefficients of the zones that identification holds fixed: head-plate and nut-plate, 0.15 (DESIGN.md)."""
    return {"head_plate": PLATE_MU, "nut_plate": PLATE_MU}


def measurement_points(layout: BoltLayout, points=None, flanks=(1, 2), n_per_flank: int = 5) -> np.ndarray:
    """(n, 2) (r, y) [mm] measurement points on the bolt load flanks.

    Default: ``n_per_flank`` points at 1/(n+1) ... n/(n+1) of the straight part of each listed engaged flank
    (1 = next to the nut bearing face), root tangent to crest corner: 10 points at 1/6 ... 5/6 on flanks 1, 2.
    Given ``points`` are checked to lie on the straight part of an engaged bolt load flank (to 1e-3 mm).
    The points lie on the bolt-nut interface: observe them in region "bolt" (config: regions = { "*" = "bolt" }).
    """
    if points is None:
        n_per_flank = _count("n_per_flank", n_per_flank, 1, 100)
        fractions = np.arange(1, n_per_flank + 1) / (n_per_flank + 1)
        for i in flanks:
            if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 1 <= i <= len(layout.flanks):
                raise InputError(f"`flanks`: {i!r} is not an engaged flank; expected 1 ... {len(layout.flanks)}")
        return np.vstack([layout.flanks[i - 1].along(fractions) for i in flanks])
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2:
        raise InputError(f"`points` must be (r, y) pairs [mm], shape (n, 2), got shape {points.shape}")
    for i, point in enumerate(points):
        if min(_flank_distance(f, point) for f in layout.flanks) > 1e-3:
            raise InputError(f"`points`[{i}] = {point.tolist()} is not on an engaged bolt load flank; expected a "
                             f"point on the straight part of one of the {len(layout.flanks)} flanks, e.g. "
                             f"{np.round(layout.flanks[0].along(0.5), 4).tolist()}")
    return points


def _flank_distance(flank: Flank, point: np.ndarray) -> float:
    """Distance [mm] of a point from the straight part of a bolt load flank."""
    a, b = (np.asarray(p) for p in flank.straight)
    t = np.clip(np.dot(point - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(point - (a + t * (b - a))))
