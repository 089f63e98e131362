"""Quadratic-tetrahedron mesh of the 3-D bolt-nut tensile test: the fragment of :mod:`.bolt3d_geometry` meshed
once (touching faces shared, so every interface is conforming), faces named by what they are, then each body
given its own copies of the nodes it shares with a body before it (node-to-node pairs at zero gap)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import gmsh
import numpy as np

from ..errors import InputError
from ..model import Mesh
from .bolt3d_geometry import Window, countersink, cylinder, direction, hexagon_prism, thread_grooves
from .bolt3d_knife import KNIFE_GROWTH, KNIFE_SIZE, knife_edges
from .bolt_layout import BoltLayout
from .curved import curved_where_valid
from .gmsh_mesh import gmsh_session, mesh_from_gmsh, use_size_fields
from .thread import NUT_ROOT_CLEARANCE, SQRT3

#: bodies in the order they keep their nodes (a later body copies the nodes it shares with an earlier one)
BODIES = ("bolt", "nut", "plate1", "plate2")
#: element size growth per mm of distance from the refined faces
SIZE_GROWTH = 0.3
#: growth per mm of the size away from the bolt's roots, which are meshed at ``root_size`` (inside the nut: left at
#: the sizes near them, a root face's triangles spanned the gap below the nut crest corner to corner and lay on the
#: nut crest's own triangles, and gmsh refused the overlapping facets)
ROOT_GROWTH = 2.5
#: a window reaching within this many pitches of the nut crest D1/2 is cut through to the bore
THROUGH = 0.1
_TOL = 2e-3  # [mm] distance under which a face point lies on an analytic surface (the lofts: < 1 um)
#: gmsh's 3-D algorithms tried in turn: Delaunay (its default), then Frontal, which meshed the short model without
#: window and jaws where Delaunay failed every time with "PLC Error: A segment and a facet intersect"
ALGORITHMS_3D = ((1, "Delaunay"), (4, "Frontal"))
#: normal angle [rad] of one of the head's flats (the others at + k 60 deg)
HEAD_ANGLE = math.pi / 2
#: with ``head_size``, the size grows to ``mesh_size`` over this many head heights k outside the head's box
HEAD_TRANSITION = 0.5

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Options3d:
    """What the 3-D mesh needs beyond the layout: sizes [mm], the window (None: no cut-out), the angle of the
    section that equals the axisymmetric one (the window's centre), the normal angle [rad] of the flat the jaws
    hold (the hexagons' flats are at this angle + k 60 deg), the size in the bolt's head (None: no own size) and
    the height y [mm] from which the bolt's roots are meshed at ``root_size`` (up to a pitch above the nut's top;
    None: from a pitch below the nut's bearing face)."""

    flank_size: float
    contact_size: float
    mesh_size: float
    window: Window | None
    theta_match: float
    jaw_angle: float
    root_size: float
    head_size: float | None = None
    root_start: float | None = None


def _bolt(layout: BoltLayout, theta_match: float) -> list[tuple[int, int]]:
    """The bolt blank minus the thread's grooves (:func:`thread_grooves`), their seams at theta_match + pi."""
    s, occ = layout.size, gmsh.model.occ
    head = hexagon_prism(s.head_s, -s.head_k, 0.0, HEAD_ANGLE)
    blank, _ = occ.fuse([(3, head)], [(3, cylinder(layout.r_shank, 0.0, layout.length))])
    bolt, _ = occ.cut(blank, thread_grooves(layout, theta_match + math.pi))
    return bolt


def _window(layout: BoltLayout, window: Window, y0: float, y1: float) -> list[tuple[int, int]]:
    """The window's tool: the sector |theta - centre| <= width / 2 outside r = s/2 - depth."""
    occ, s = gmsh.model.occ, layout.size
    far = 2 * s.nut_s
    half, centre = math.radians(window.width) / 2, math.radians(window.centre)
    angles = np.linspace(centre - half, centre + half, 5)
    corners = [np.array([0.0, y0, 0.0])] + [far * direction(a) + [0.0, y0, 0.0] for a in angles]
    points = [occ.addPoint(*c) for c in corners]
    lines = [occ.addLine(points[i], points[(i + 1) % len(points)]) for i in range(len(points))]
    face = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    wedge = [(d, t) for d, t in occ.extrude([(2, face)], 0.0, y1 - y0, 0.0) if d == 3]
    if s.nut_s / 2 - window.depth <= s.d1 / 2 + THROUGH * s.P:
        return wedge                                        # through to the bore: no sliver of the crest left
    tool, _ = occ.cut(wedge, [(3, cylinder(s.nut_s / 2 - window.depth, y0 - 1, y1 + 1))])
    return tool


def _nut(layout: BoltLayout, window: Window | None, jaw_angle: float, engaged_top: float) -> list[tuple[int, int]]:
    """Hexagon nut with its bore at the nut crest D1/2, the 120 deg countersinks, the relief above the engaged
    length (bore at the nut root) and the window."""
    s, occ = layout.size, gmsh.model.occ
    y0, y1 = layout.y_bearing, layout.y_top
    nut = hexagon_prism(s.nut_s, y0, y1, jaw_angle)
    tools = [(3, cylinder(s.d1 / 2, y0 - 1, y1 + 1)), (3, countersink(layout, y0, 1.0)),
             (3, countersink(layout, y1, -1.0))]
    if engaged_top < y1 - 1e-9:
        tools.append((3, cylinder(s.d / 2 + NUT_ROOT_CLEARANCE * s.H, engaged_top, y1 + 1)))
    if window is not None:
        tools += _window(layout, window, y0 - 1, y1 + 1)
    out, _ = occ.cut([(3, nut)], tools)
    return out


def _plates(layout: BoltLayout) -> tuple[list, list]:
    occ = gmsh.model.occ
    out = []
    for y0, y1 in (layout.plate1, layout.plate2):
        plate, _ = occ.cut([(3, cylinder(layout.r_outer, y0, y1))], [(3, cylinder(layout.r_hole, y0 - 1, y1 + 1))])
        out.append(plate)
    return out[0], out[1]


def fragment_bodies(layout: BoltLayout, options: Options3d, engaged_top: float) -> dict[str, list[int]]:
    """Volume tags of each body after the fragment; the bolt keeps the part of the nut blank it fills."""
    bolt = _bolt(layout, options.theta_match)
    nut = _nut(layout, options.window, options.jaw_angle, engaged_top)
    plate1, plate2 = _plates(layout)
    _, parts = gmsh.model.occ.fragment(bolt, nut + plate1 + plate2)
    gmsh.model.occ.synchronize()
    tags = [sorted({t for d, t in part if d == 3}) for part in parts]
    n_bolt, n_nut = len(bolt), len(nut)
    volumes = {"bolt": sorted({t for part in tags[:n_bolt] for t in part})}
    volumes["nut"] = sorted({t for part in tags[n_bolt:n_bolt + n_nut] for t in part} - set(volumes["bolt"]))
    volumes["plate1"] = sorted({t for part in tags[n_bolt + n_nut:n_bolt + n_nut + len(plate1)] for t in part})
    volumes["plate2"] = sorted({t for part in tags[n_bolt + n_nut + len(plate1):] for t in part})
    return volumes


def _faces(volumes) -> set[int]:
    return {abs(t) for _, t in gmsh.model.getBoundary([(3, v) for v in volumes], combined=False, oriented=False)}


def face_points(face: int, n: int = 3) -> np.ndarray:
    """(m, 3) [mm] points on a face: its parametric grid's inner points that lie inside the (trimmed) face."""
    lo, hi = (np.asarray(b) for b in gmsh.model.getParametrizationBounds(2, face))
    u = np.linspace(0, 1, n + 2)[1:-1]
    grid = np.array([[lo[0] + a * (hi[0] - lo[0]), lo[1] + b * (hi[1] - lo[1])] for a in u for b in u])
    inside = [gmsh.model.isInside(2, face, list(p), parametric=True) for p in grid]
    grid = grid[np.asarray(inside, dtype=bool)] if any(inside) else grid
    return np.reshape(gmsh.model.getValue(2, face, grid.ravel().tolist()), (-1, 3))


def _polar(points: np.ndarray, theta_match: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r, y, phi) of points: phi the angle from theta_match in [-pi, pi) (the turns' seam at +-pi)."""
    theta = np.arctan2(-points[:, 2], points[:, 0])
    phi = np.mod(theta - theta_match + math.pi, 2 * math.pi) - math.pi
    return np.hypot(points[:, 0], points[:, 2]), points[:, 1], phi


def flank_tooth(layout: BoltLayout, points: np.ndarray, theta_match: float, flank: str = "load") -> int | None:
    """Index k of the bolt tooth (centred at bolt_phase + k P at theta_match) whose helical ``flank`` ("load":
    below the tooth, "free": above) carries all the points (m, 3) [mm], else None."""
    s = layout.size
    r, y, phi = _polar(points, theta_match)
    apex = s.d / 2 + s.H / 8 - layout.shift
    sign = 1.0 if flank == "load" else -1.0
    k = (y - s.P * phi / (2 * math.pi) + sign * (apex - r) / SQRT3 - layout.bolt_phase) / s.P
    if np.ptp(np.round(k)) == 0 and np.all(np.abs(k - np.round(k)) * s.P < _TOL):
        return int(round(float(k[0])))
    return None


def classify_faces(layout: BoltLayout, options: Options3d, volumes: dict) -> dict[str, list[int]]:
    """Named faces: zones and thread_<i> (bolt load flanks shared with the nut, by turn from the bearing face),
    nut_contact, bolt_free (the free flanks facing the nut, touching it without contact), the bearing contacts, the
    plates' rims, the nut's jaw flats, the window's faces, bolt_root (the roots meshed at ``root_size``)."""
    faces = {body: _faces(tags) for body, tags in volumes.items()}
    thread = faces["bolt"] & faces["nut"]
    flanks: dict[int, list[tuple[int, float]]] = {}
    names: dict[str, list[int]] = {"nut_contact": [], "thread_shared": sorted(thread), "bolt_free": []}
    for face in sorted(thread):
        points = face_points(face)
        k = flank_tooth(layout, points, options.theta_match)
        if k is None and flank_tooth(layout, points, options.theta_match, "free") is not None:
            names["bolt_free"].append(face)
        if k is not None:
            flanks.setdefault(k, []).append((face, float(np.median(np.hypot(points[:, 0], points[:, 2])))))
    turns = sorted(flanks)
    sections = np.array_split(np.arange(len(turns)), min(len(layout.sections), len(turns)))
    for i, k in enumerate(turns):
        section = next(j for j, part in enumerate(sections) if i in part)
        for face, r in flanks[k]:
            radial = sum(split > r for split in layout.zone_splits)
            for name in (layout.zone_name(radial, section), f"thread_{i + 1}", "nut_contact"):
                names.setdefault(name, []).append(face)
    names["head_plate"] = names["plate2_head"] = sorted(faces["bolt"] & faces["plate2"])
    names["nut_plate"] = names["plate1_nut"] = sorted(faces["nut"] & faces["plate1"])
    for body in ("plate1", "plate2"):
        names[f"{body}_rim"] = [f for f in faces[body]
                                if np.allclose(np.hypot(*face_points(f)[:, [0, 2]].T), layout.r_outer, atol=_TOL)]
    names.update(_nut_faces(layout, options, faces))
    start = layout.y_bearing - layout.size.P if options.root_start is None else options.root_start
    names["bolt_root"] = [f for f in sorted(faces["bolt"] - thread) if _is_root(layout, face_points(f, 6), start)]
    return names


def _is_root(layout: BoltLayout, points: np.ndarray, start: float) -> bool:
    """Whether a face reaches a bolt thread root (below the nut crest D1/2) between the height ``start`` [mm] and a
    pitch above the nut's top: some of its points. (Above ``engaged_length`` too: the refinement around these roots
    also keeps the bolt crest apart from the relieved bore, H/16 away; without it gmsh's volume mesher met
    intersecting facets there.)"""
    r = np.hypot(points[:, 0], points[:, 2])
    s = layout.size
    root = (r < s.d1 / 2) & (r > s.d3 / 2 - layout.shift - _TOL)
    return bool(np.any(root & (points[:, 1] > start) & (points[:, 1] < layout.y_top + s.P)))


def _on_flats(points: np.ndarray, s: float, angle0: float, k=range(6)) -> bool:
    """Whether the points lie on one flat of the hexagon of width s [mm] whose flats' normals are at angle0 +
    k 60 deg."""
    normals = direction(angle0 + np.radians(60.0 * np.asarray(list(k))))
    return any(np.allclose(points @ n, s / 2, atol=_TOL) for n in normals)


def _nut_faces(layout: BoltLayout, options: Options3d, faces: dict) -> dict[str, list[int]]:
    """"nut_jaws" (the two flats whose normals are at jaw_angle and jaw_angle + pi), "nut_outer" and "head_side"
    (the six flats of nut and head, turned and held in tightening), "window_nut" and "window_bolt" (the faces
    inside the window's sector: the nut's cut, the bolt's thread within the nut height)."""
    s = layout.size
    out = {"nut_jaws": [], "nut_outer": [], "head_side": []}
    shared = set().union(*(faces[a] & faces[b] for a in faces for b in faces if a < b))
    for face in faces["nut"] - shared:
        points = face_points(face)
        if _on_flats(points, s.nut_s, options.jaw_angle, (0, 3)):
            out["nut_jaws"].append(face)
        if _on_flats(points, s.nut_s, options.jaw_angle):
            out["nut_outer"].append(face)
    for face in faces["bolt"] - shared:
        points = face_points(face)
        if np.all(points[:, 1] < _TOL) and _on_flats(points, s.head_s, HEAD_ANGLE):
            out["head_side"].append(face)
    if options.window is None:
        return out
    half = math.radians(options.window.width) / 2 + 1e-6
    centre = math.radians(options.window.centre)
    for body in ("nut", "bolt"):
        out[f"window_{body}"] = []
        for face in sorted(faces[body] - shared):
            r, y, phi = _polar(face_points(face), centre)
            inside = np.all(np.abs(phi) <= half) and np.all((y > layout.y_bearing) & (y < layout.y_top))
            if inside and (body == "nut" or np.all(r < s.nut_s / 2)):
                out[f"window_{body}"].append(face)
    return out


def distance_field(faces: list[int], size_min: float, size_max: float, growth: float = SIZE_GROWTH,
                   curves: bool = False) -> int:
    """Size ``size_min`` on the faces (``curves``: on the curves), growing by ``growth`` per mm up to
    ``size_max``."""
    field = gmsh.model.mesh.field
    near = field.add("Distance")
    field.setNumbers(near, "CurvesList" if curves else "SurfacesList", list(faces))
    field.setNumber(near, "Sampling", 100 if curves else 30)
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", near)
    for name, value in (("SizeMin", size_min), ("SizeMax", max(size_min, size_max)), ("DistMin", 0.0),
                        ("DistMax", max(size_max - size_min, 1e-9) / growth)):
        field.setNumber(threshold, name, value)
    return threshold


def head_field(layout: BoltLayout, size: float, size_max: float) -> int:
    """Size ``size`` in the box around the bolt's head (y from -k to the bearing face, |x|, |z| up to the
    hexagon's corner radius), growing linearly to ``size_max`` over HEAD_TRANSITION k outside it."""
    s, field = layout.size, gmsh.model.mesh.field
    box = field.add("Box")
    corner = s.head_s / SQRT3
    for name, value in (("VIn", size), ("VOut", max(size, size_max)), ("XMin", -corner), ("XMax", corner),
                        ("ZMin", -corner), ("ZMax", corner), ("YMin", -s.head_k), ("YMax", 0.0),
                        ("Thickness", HEAD_TRANSITION * s.head_k)):
        field.setNumber(box, name, value)
    return box


def separate_bodies(mesh: Mesh, owner: dict[str, str]) -> Mesh:
    """The mesh with every body (region) given its own nodes: a node of a region's cells that an earlier region
    in :data:`BODIES` order already uses is copied; the cells of the later region and the boundaries it owns
    (``owner``: boundary name -> region) take the copy. Boundaries not in ``owner`` keep the original nodes."""
    points, cells = list(mesh.points), mesh.cells.copy()
    used = np.zeros(mesh.n_nodes, dtype=bool)
    maps = {}
    for body in (name for name in BODIES if name in mesh.regions):
        body_cells = mesh.regions[body]
        nodes = np.unique(mesh.cells[body_cells])
        shared = nodes[used[nodes]]
        renumber = np.arange(mesh.n_nodes)
        renumber[shared] = len(points) + np.arange(len(shared))
        points.extend(mesh.points[shared])
        cells[body_cells] = renumber[mesh.cells[body_cells]]
        used[nodes] = True
        maps[body] = renumber
    boundaries = {name: maps[owner[name]][facets] if name in owner else facets
                  for name, facets in mesh.boundaries.items()}
    return Mesh(points=np.array(points), cell_type=mesh.cell_type, cells=cells, regions=dict(mesh.regions),
                boundaries=boundaries)


def body_of(name: str) -> str:
    """The body a named face belongs to: targets and nut faces to the nut or a plate, the rest to the bolt."""
    for prefix, body in (("nut_contact", "nut"), ("nut_", "nut"), ("window_nut", "nut"), ("plate1_", "plate1"),
                         ("plate2_", "plate2")):
        if name.startswith(prefix):
            return body
    return "bolt"


def curved_tetra10(source: str) -> Mesh:
    """The gmsh session's meshed model as quadratic tetrahedra (complete, mid-side nodes on the geometry), the
    mid-side nodes kept on the curved faces where the cells stay valid (:func:`curved_where_valid`)."""
    gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
    gmsh.option.setNumber("Mesh.SecondOrderLinear", 0)
    gmsh.model.mesh.setOrder(2)
    mesh = mesh_from_gmsh(source)
    points, _ = curved_where_valid(mesh.points, mesh.cells)
    return Mesh(points=points, cell_type=mesh.cell_type, cells=mesh.cells, regions=dict(mesh.regions),
                boundaries=dict(mesh.boundaries))


def mesh_with_fallback(make, read, source: str, algorithms=ALGORITHMS_3D, refinable: bool = False):
    """``read()`` of the volume mesh of the gmsh model that ``make()`` sets up in a fresh gmsh session, meshed by
    the first of ``algorithms`` ((Mesh.Algorithm3D, name) pairs) that succeeds: gmsh meshes without an error and
    ``read()`` accepts the mesh (an InputError from it, e.g. a face's nodes in no cell where gmsh left a volume
    unmeshed, counts as a failure). A failure is logged and the next attempt starts from a new session (after a
    failed Delaunay, Frontal in the same session, mesh cleared, returned no tetrahedra). With ``refinable``,
    ``make(knife)`` takes whether to refine the knife edges (:mod:`.bolt3d_knife`) and returns whether the model
    has any; if it has, the algorithms are then tried again with them refined (after the attempts without, so that
    a model one of them meshes keeps its mesh). InputError naming ``source`` when every attempt
    fails."""
    attempts = [(number, name, False) for number, name in algorithms]
    failures, decided = [], False
    while attempts:
        number, name, knife = attempts.pop(0)
        label = _label(name, knife)
        with gmsh_session(source):
            if refinable:
                if make(knife) and not decided:             # knife edges: the algorithms again, refined there
                    attempts += [(n, a, True) for n, a in algorithms]
                decided = True
            else:
                make()
            gmsh.option.setNumber("Mesh.Algorithm3D", number)
            try:
                gmsh.model.mesh.generate(3)
            except Exception as error:  # gmsh raises a bare Exception with its own message
                failure = str(error).strip()
            else:
                try:
                    mesh = read()
                except InputError as error:     # e.g. a face's nodes in no cell: gmsh left a volume unmeshed
                    failure = str(error).strip()
                else:
                    log.info("%s: meshed by gmsh's %s 3-D mesher", source, label)
                    return mesh
            failures.append(f"{label}: {failure}")
            following = f"; trying {_label(*attempts[0][1:])}" if attempts else ""
            log.warning("%s: gmsh's %s 3-D mesher failed (%s)%s", source, label, failure, following)
    raise InputError(f"{source}: gmsh could not mesh the volumes ({'; '.join(failures)}); other element sizes "
                     "(flank_size, contact_size, mesh_size, root_size) or nut_mesh may mesh")


def _label(name: str, knife: bool) -> str:
    return f"{name} (knife edges refined)" if knife else name


def bolt3d_mesh(layout: BoltLayout, options: Options3d, engaged_top: float) -> Mesh:
    """The tetra10 mesh of bolt, nut and plates with the named groups of :func:`frictionid.builders.bolt3d.
    bolt3d_model`, each body with its own nodes (conforming, node-to-node interfaces); mid-side nodes on the
    curved faces where the cells stay valid (:func:`frictionid.builders.curved.curved_where_valid`)."""
    source = f"3-D bolt model {layout.size.name}"

    def make(knife: bool) -> bool:
        volumes = fragment_bodies(layout, options, engaged_top)
        names = classify_faces(layout, options, volumes)
        root = min(options.flank_size, options.root_size)
        fields = [distance_field(names["thread_shared"], options.flank_size, options.mesh_size),
                  distance_field(names["head_plate"] + names["nut_plate"], options.contact_size, options.mesh_size),
                  distance_field(names.pop("bolt_root"), root, options.mesh_size, ROOT_GROWTH)]
        if options.head_size is not None:
            fields.append(head_field(layout, options.head_size, options.mesh_size))
        edges = knife_edges(layout, options.theta_match)
        if edges and knife:
            fields.append(distance_field(edges, KNIFE_SIZE * layout.size.P, options.mesh_size, KNIFE_GROWTH,
                                         curves=True))
        use_size_fields(*fields)
        gmsh.option.setNumber("Mesh.MeshSizeMax", options.mesh_size)
        for body, tags in volumes.items():
            gmsh.model.addPhysicalGroup(3, tags, name=body)
        for name, tags in names.items():
            if tags and name != "thread_shared":
                gmsh.model.addPhysicalGroup(2, tags, name=name)
        return bool(edges)

    mesh = mesh_with_fallback(make, lambda: curved_tetra10(source), source, refinable=True)
    return separate_bodies(mesh, {name: body_of(name) for name in mesh.boundaries})
