"""3-D bodies meshed separately (non-matching interfaces), shared by the 3-D mortar tests: a stack of two
bodies (:func:`stack`) and reference test 1 as a user meshes it (:func:`write_nonmatching_block`).

Lower body [0, 2] x [0, 2] x [-1, 0], upper body [0, 2] x [0, 2] x [0, 1]; the upper bottom is split at x = 1
into zones A (x < 1) and B (x > 1), the lower top is "target". Both are 2-D meshes of their z = 0 / z = -1 face
extruded through the thickness (hexahedra with ``hexes``, else tetrahedra), so each side's in-plane pattern is
set separately:

- "grid n": n x n cells aligned with the axes;
- "free h": unstructured triangles of size h (quadrilaterals recombined with ``hexes``): no direction in common
  with the other side's cells.
"""

from __future__ import annotations

import gmsh
import numpy as np

from frictionid.builders.gmsh_mesh import gmsh_session
from frictionid.model import Mesh
from fixtures.user_block import generate
from helpers.meshes import generated, lowered

SIDE, THICKNESS = 2.0, 1.0
#: the upper body is meshed this far up [mm] and moved down after (gmsh's extrusion finds nodes by position)
_APART = 10.0


def _square_face(geo, z: float, pattern: str):
    """The plane surface [0, SIDE]^2 at height z, meshed per pattern."""
    kind, value = pattern.split()
    corners = [geo.addPoint(x, y, z) for x, y in ((0, 0), (SIDE, 0), (SIDE, SIDE), (0, SIDE))]
    lines = [geo.addLine(a, b) for a, b in zip(corners, corners[1:] + corners[:1])]
    surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    if kind == "grid":
        for line in lines:
            geo.mesh.setTransfiniteCurve(line, int(value) + 1)
        geo.mesh.setTransfiniteSurface(surface)
    else:
        for point in corners:
            geo.mesh.setSize([(0, point)], float(value))
    return [surface]


def stack(upper: str, lower: str, hexes: bool, order: int = 1, layers: int = 2):
    """The two bodies' mesh (see the module docstring); regions "lower", "upper"; boundaries A, B, target,
    upper_top, lower_bottom, lower_x0, upper_x0, lower_y0, upper_y0."""
    with gmsh_session("stack3d"):
        geo = gmsh.model.geo
        bodies = {}
        top = _square_face(geo, _APART, upper)
        base = _square_face(geo, -THICKNESS, lower)
        for name, faces, height in (("upper", top, THICKNESS), ("lower", base, THICKNESS)):
            out = geo.extrude([(2, f) for f in faces], 0, 0, height, numElements=[layers], recombine=hexes)
            bodies[name] = (faces, out)
        if hexes:
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        geo.synchronize()
        add = gmsh.model.addPhysicalGroup
        for name, (faces, out) in bodies.items():
            add(3, [t for d, t in out if d == 3], name=name)
            tops = [t for d, t in out if d == 2 and _on(2, t, 2, 0.0 if name == "lower" else _APART + THICKNESS)]
            add(2, tops, name="target" if name == "lower" else "upper_top")
            sides = [t for d, t in out if d == 2]
            add(2, [t for t in sides if _on(2, t, 0, 0.0)], name=f"{name}_x0")
            add(2, [t for t in sides if _on(2, t, 1, 0.0)], name=f"{name}_y0")
        add(2, base, name="lower_bottom")
        add(2, top, name="contact")
        mesh = generated(order)
    points = lowered(mesh, 2, _APART)
    boundaries = dict(mesh.boundaries)
    contact = boundaries.pop("contact")
    left = points[contact].mean(axis=1)[:, 0] < SIDE / 2
    boundaries.update(A=contact[left], B=contact[~left])
    return Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), boundaries)


def write_nonmatching_block(path, block_quarter: int = 4, plate_quarter: int = 3, outer: int = 3,
                            block_z: int = 6, plate_z: int = 3) -> None:
    """Reference test 1 as tests/fixtures/user_block/generate.py meshes it (transfinite hexahedra, each body
    fragmented on its own), but the block's footprint with ``block_quarter`` divisions per half side and the
    plate's with ``plate_quarter``: the interface nodes do not match (except on the quadrant borders' ends).
    The block, the contact side, carries the finer mesh, as the slave side of a mortar interface should."""
    with gmsh_session("user_block_nonmatching"):
        plate = generate._boxes([-20, -5, 0, 5, 20], -5, 0)
        block = generate._boxes([-5, 0, 5], 0, 10)
        gmsh.model.occ.synchronize()
        faces = gmsh.model.getBoundary([(3, v) for v in block], combined=False, oriented=False)
        in_block = {abs(c) for _, c in gmsh.model.getBoundary(faces, combined=False, oriented=False)}
        for _, curve in gmsh.model.getEntities(1):
            ends = [np.array(gmsh.model.getValue(0, abs(p), [])) for _, p in
                    gmsh.model.getBoundary([(1, curve)], oriented=False)]
            axis = int(np.argmax(np.abs(ends[1] - ends[0])))
            if axis == 2:
                n = block_z if curve in in_block else plate_z
            elif max(abs(ends[0][axis]), abs(ends[1][axis])) <= 5 + 1e-6:
                n = block_quarter if curve in in_block else plate_quarter
            else:
                n = outer
            gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface)
            gmsh.model.mesh.setRecombine(2, surface)
        for _, volume in gmsh.model.getEntities(3):
            gmsh.model.mesh.setTransfiniteVolume(volume)
        add = gmsh.model.addPhysicalGroup
        add(3, plate, name="plate")
        add(3, block, name="block")
        add(2, generate._faces_at(plate, 2, -5), name="plate_bottom")
        add(2, generate._faces_at(plate, 2, 0), name="plate_top")
        add(2, generate._faces_at(block, 2, 10), name="block_top")
        zones = {(-1, -1): "A", (1, -1): "B", (-1, 1): "C", (1, 1): "D"}
        for face in generate._faces_at(block, 2, 0):
            x, y, _ = gmsh.model.occ.getCenterOfMass(2, face)
            add(2, [face], name=zones[(int(np.sign(x)), int(np.sign(y)))])
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))


def _on(dim: int, tag: int, axis: int, value: float) -> bool:
    box = np.reshape(gmsh.model.getBoundingBox(dim, tag), (2, 3))
    return bool(np.allclose(box[:, axis], value, atol=1e-9))
