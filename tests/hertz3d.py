"""Hertz contact on two bodies meshed separately (non-matching interface), for the 3-D mortar's verification
(tests/test_mortar3d.py): a cylinder on a flat in a 3-D slab (:func:`hertz_model`) and a sphere on a flat
(:func:`sphere_model`, below).

Line contact: a slab of thickness T held in z on both faces (plane strain), half model (symmetry plane x = 0).
Cylinder radius R = 10 mm (axis along z through (0, R)), its quarter x in [0, R], y in [0, R], on a block
x in [0, 10], y in [-10, 0]; both steel (E = 210000 MPa, nu = 0.3). The cylinder's flat top y = R is moved down
by ``depth`` (a displacement: no body floats before contact closes). Reference (Johnson, Contact Mechanics
(1985), eq. 4.43-4.45): with P the force per mm of length (twice the half model's reaction over T),
a = sqrt(4 P R / (pi E*)), p0 = 2 P / (pi a), E* = E / (2 (1 - nu^2)).

The x-y sections are meshed by gmsh (quadrilaterals recombined, then extruded to hexahedra, or triangles
extruded to tetrahedra; order 1 or 2) with
size ``h`` within 1.6 A of the contact line on the cylinder, 0.7 h on the block, growing to 1 mm; the cylinder
has 1 layer through the thickness, the block 2. The contact zone is the cylinder's facets within 1.6 A of the
contact line, the target the block's top within 2.5 A.
"""

from __future__ import annotations

import gmsh
import numpy as np

from frictionid.builders.gmsh_mesh import gmsh_session
from frictionid.model import ContactInterface, Displacement, Material, Mesh, Model, Stage, Support
from helpers.meshes import generated, lowered

RADIUS, BLOCK, THICKNESS, A = 10.0, 10.0, 0.5, 1.0
STEEL = Material(210000.0, 0.3)
E_STAR = STEEL.E / (2 * (1 - STEEL.nu ** 2))
#: [mm] the top's displacement giving a close to A (measured: a = 1.03 at h = 0.05)
DEPTH = 0.2
_APART = 50.0                       # the cylinder is meshed this far up in y, then moved down


def hertz_reference(force: float) -> tuple[float, float]:
    """Hertz's half-width a [mm] and peak pressure p0 [MPa] at a force per mm of length [N/mm]."""
    a = np.sqrt(4 * force * RADIUS / (np.pi * E_STAR))
    return a, 2 * force / (np.pi * a)


def _arc_gap(x: float) -> float:
    """[mm] The curved body's initial gap to the flat at x [mm] from the axis, x^2 / (2 R): with x beyond the
    contact zone's last node, the geometry's gap tolerance (the set-up check's default, half a facet, is less)."""
    return x ** 2 / (2 * RADIUS)


def _size_field(h: float, point: int, near: float = A, far: float = 2.0) -> int:
    """Size h within 1.6 near [mm] of point, growing to far [mm] at 8 near."""
    field = gmsh.model.mesh.field
    distance = field.add("Distance")
    field.setNumbers(distance, "PointsList", [point])
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", distance)
    for key, value in (("SizeMin", h), ("SizeMax", far), ("DistMin", 1.6 * near), ("DistMax", 8.0 * near)):
        field.setNumber(threshold, key, value)
    return threshold


def _sections():
    """The cylinder's quarter section (meshed at y + _APART) and the block's; (surface, contact point) each."""
    geo = gmsh.model.geo
    y0 = _APART
    centre, bottom = geo.addPoint(0, y0 + RADIUS, 0), geo.addPoint(0, y0, 0)
    side = geo.addPoint(RADIUS, y0 + RADIUS, 0)
    arc = geo.addCircleArc(bottom, centre, side)
    cylinder = geo.addPlaneSurface([geo.addCurveLoop([arc, geo.addLine(side, centre), geo.addLine(centre, bottom)])])
    corners = [geo.addPoint(x, y, 0) for x, y in ((0, 0), (0, -BLOCK), (BLOCK, -BLOCK), (BLOCK, 0))]
    block = geo.addPlaneSurface([geo.addCurveLoop([geo.addLine(a, b) for a, b in
                                                   zip(corners, corners[1:] + corners[:1])])])
    return (cylinder, bottom), (block, corners[0])


def hertz_mesh(h: float, order: int = 2, hexes: bool = True) -> Mesh:
    """The two bodies' mesh; regions "upper", "lower"; boundaries "contact", "target", "top", "bottom", "x0",
    "z0", "z1" (both bodies' where it applies)."""
    with gmsh_session("hertz3d"):
        geo = gmsh.model.geo
        (cylinder, near_upper), (block, near_lower) = _sections()
        extruded = {name: geo.extrude([(2, face)], 0, 0, THICKNESS, numElements=[layers], recombine=hexes)
                    for name, face, layers in (("upper", cylinder, 1), ("lower", block, 2))}
        geo.synchronize()
        fields = [_size_field(h, near_upper), _size_field(0.7 * h, near_lower)]
        minimum = gmsh.model.mesh.field.add("Min")
        gmsh.model.mesh.field.setNumbers(minimum, "FieldsList", fields)
        gmsh.model.mesh.field.setAsBackgroundMesh(minimum)
        for key in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
            gmsh.option.setNumber(key, 0)
        gmsh.option.setNumber("Mesh.RecombineAll", int(hexes))
        add = gmsh.model.addPhysicalGroup
        groups = {name: [] for name in ("top", "bottom", "x0", "z1", "curved", "block_top")}
        for name, out in extruded.items():
            add(3, [t for d, t in out if d == 3], name=name)
            for face in (t for d, t in out if d == 2):
                box = np.reshape(gmsh.model.getBoundingBox(2, face), (2, 3))
                if np.allclose(box[:, 2], THICKNESS, atol=1e-7):
                    groups["z1"].append(face)
                elif np.allclose(box[:, 0], 0.0, atol=1e-7):
                    groups["x0"].append(face)
                elif name == "upper" and np.allclose(box[:, 1], _APART + RADIUS, atol=1e-7):
                    groups["top"].append(face)
                elif name == "upper" and box[0, 1] < _APART + 1e-7:
                    groups["curved"].append(face)
                elif name == "lower" and np.allclose(box[:, 1], -BLOCK, atol=1e-7):
                    groups["bottom"].append(face)
                elif name == "lower" and np.allclose(box[:, 1], 0.0, atol=1e-7):
                    groups["block_top"].append(face)
        groups["z0"] = [cylinder, block]
        for name, tags in groups.items():
            add(2, tags, name=name)
        mesh = generated(order)
    points = lowered(mesh, 1, _APART)
    boundaries = dict(mesh.boundaries)
    curved, block_top = boundaries.pop("curved"), boundaries.pop("block_top")
    boundaries.update(contact=curved[points[curved].mean(axis=1)[:, 0] < 1.6 * A],
                      target=block_top[points[block_top].mean(axis=1)[:, 0] < 2.5 * A])
    return Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), boundaries)


def hertz_model(h: float, order: int = 2, depth: float = DEPTH, n_increments: int = 2,
                hexes: bool = True) -> Model:
    """The half slab at contact size h [mm], the cylinder's top moved down by depth [mm]."""
    return Model(hertz_mesh(h, order, hexes), "3d", {"upper": STEEL, "lower": STEEL},
                 supports=(Support("bottom", (0, 1, 2)), Support("x0", (0,)), Support("z0", (2,)),
                           Support("z1", (2,))),
                 loads=(Displacement("top", "y", (-depth,)),), stages=(Stage("press", n_increments),),
                 interfaces=(ContactInterface("hertz", ("contact",), "target", "mortar",
                                              gap_tolerance=_arc_gap(2 * A)),))


# ------------------------------------------------------------------------------ point contact: a sphere on a flat

SPHERE_A, SPHERE_SIDE = 0.5, 5.0


def sphere_reference(force: float) -> tuple[float, float]:
    """Hertz's contact radius a [mm] and peak pressure p0 [MPa] of the sphere at a total force [N] (whole
    sphere): a = (3 P R / (4 E*))^(1/3), p0 = 3 P / (2 pi a^2) (Johnson (1985), eq. 4.22-4.23)."""
    a = (3 * force * RADIUS / (4 * E_STAR)) ** (1 / 3)
    return a, 3 * force / (2 * np.pi * a ** 2)


def _classify(volume: int, z_low: float, z_high: float, upper: bool, groups: dict) -> None:
    """Faces of a box-like volume into groups by their bounding boxes (gmsh pads them, hence 1e-5)."""
    for _, face in gmsh.model.getBoundary([(3, volume)], oriented=False):
        box = np.reshape(gmsh.model.getBoundingBox(2, face), (2, 3))
        if np.allclose(box[:, 0], 0.0, atol=1e-5):
            groups["x0"].append(face)
        elif np.allclose(box[:, 1], 0.0, atol=1e-5):
            groups["y0"].append(face)
        elif np.allclose(box[:, 2], z_high, atol=1e-5):
            groups["top" if upper else "block_top"].append(face)
        elif not upper and np.allclose(box[:, 2], z_low, atol=1e-5):
            groups["bottom"].append(face)
        elif upper and box[0, 2] < z_low + 1e-5:
            groups["curved"].append(face)


def sphere_mesh(h: float, order: int = 2) -> Mesh:
    """Quarter sphere cap (R, centre (0, 0, R), cut to [0, 5]^2 x [0, 5]) on a block [0, 5]^2 x [-5, 0], meshed
    separately with tetrahedra of size h (cap) and 0.8 h (block) within 1.6 a of the axis, growing to 1 mm;
    contact: the cap's facets within 1.6 a of the axis; target: the block top's within 2 a."""
    with gmsh_session("hertz3d_sphere"):
        occ = gmsh.model.occ
        ball = occ.addSphere(0, 0, _APART + RADIUS, RADIUS)
        box = occ.addBox(0, 0, _APART, SPHERE_SIDE, SPHERE_SIDE, SPHERE_SIDE)
        upper = occ.intersect([(3, ball)], [(3, box)])[0][0][1]
        lower = occ.addBox(0, 0, -SPHERE_SIDE, SPHERE_SIDE, SPHERE_SIDE, SPHERE_SIDE)
        near = [occ.addPoint(0, 0, _APART), occ.addPoint(0, 0, 0)]
        occ.synchronize()
        fields = [_size_field(h, near[0], SPHERE_A, 1.0), _size_field(0.8 * h, near[1], SPHERE_A, 1.0)]
        minimum = gmsh.model.mesh.field.add("Min")
        gmsh.model.mesh.field.setNumbers(minimum, "FieldsList", fields)
        gmsh.model.mesh.field.setAsBackgroundMesh(minimum)
        for key in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
            gmsh.option.setNumber(key, 0)
        groups = {name: [] for name in ("top", "bottom", "x0", "y0", "curved", "block_top")}
        _classify(upper, _APART, _APART + SPHERE_SIDE, True, groups)
        _classify(lower, -SPHERE_SIDE, 0.0, False, groups)
        add = gmsh.model.addPhysicalGroup
        add(3, [upper], name="upper")
        add(3, [lower], name="lower")
        for name, tags in groups.items():
            add(2, tags, name=name)
        mesh = generated(order)
    points = lowered(mesh, 2, _APART)
    boundaries = dict(mesh.boundaries)
    curved, block_top = boundaries.pop("curved"), boundaries.pop("block_top")
    r_curved = np.linalg.norm(points[curved].mean(axis=1)[:, :2], axis=1)
    r_block = np.linalg.norm(points[block_top].mean(axis=1)[:, :2], axis=1)
    boundaries.update(contact=curved[r_curved < 1.6 * SPHERE_A], target=block_top[r_block < 2 * SPHERE_A])
    return Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), boundaries)


def sphere_model(h: float, order: int = 2, n_increments: int = 2) -> Model:
    """The quarter sphere on the block at contact size h [mm], the cap's top moved down by a^2 / R."""
    return Model(sphere_mesh(h, order), "3d", {"upper": STEEL, "lower": STEEL},
                 supports=(Support("bottom", (2,)), Support("x0", (0,)), Support("y0", (1,))),
                 loads=(Displacement("top", "z", (-SPHERE_A ** 2 / RADIUS,)),),
                 stages=(Stage("press", n_increments),),
                 interfaces=(ContactInterface("hertz", ("contact",), "target", "mortar",
                                              gap_tolerance=_arc_gap(2 * SPHERE_A)),))
