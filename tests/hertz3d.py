"""Hertz line contact of a cylinder on a flat in 3-D, the two bodies meshed separately (non-matching interface,
in-plane and through the thickness): a slab of thickness T held in z on both faces (plane strain), half model
(symmetry plane x = 0), for the 3-D mortar's verification (tests/test_mortar3d.py).

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

from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh
from frictionid.model import ContactInterface, Displacement, Material, Mesh, Model, Stage, Support

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


def _size_field(h: float, point: int) -> int:
    field = gmsh.model.mesh.field
    distance = field.add("Distance")
    field.setNumbers(distance, "PointsList", [point])
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", distance)
    for key, value in (("SizeMin", h), ("SizeMax", 2.0), ("DistMin", 1.6 * A), ("DistMax", 8.0)):
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
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
            gmsh.model.mesh.setOrder(2)
        mesh = mesh_from_gmsh()
    points = np.array(mesh.points)
    points[np.unique(mesh.cells[mesh.regions["upper"]]), 1] -= _APART
    boundaries = dict(mesh.boundaries)
    curved, block_top = boundaries.pop("curved"), boundaries.pop("block_top")
    boundaries.update(contact=curved[points[curved].mean(axis=1)[:, 0] < 1.6 * A],
                      target=block_top[points[block_top].mean(axis=1)[:, 0] < 2.5 * A])
    return Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), boundaries)


def hertz_model(h: float, order: int = 2, depth: float = DEPTH, n_increments: int = 2, hexes: bool = True) -> Model:
    """The half slab at contact size h [mm], the cylinder's top moved down by depth [mm]."""
    return Model(hertz_mesh(h, order, hexes), "3d", {"upper": STEEL, "lower": STEEL},
                 supports=(Support("bottom", (0, 1, 2)), Support("x0", (0,)), Support("z0", (2,)),
                           Support("z1", (2,))),
                 loads=(Displacement("top", "y", (-depth,)),), stages=(Stage("press", n_increments),),
                 interfaces=(ContactInterface("hertz", ("contact",), "target", "mortar"),))
