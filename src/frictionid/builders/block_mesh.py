"""The 3-D block test's geometry and its gmsh mesh: block and plate as transfinite hexahedra, graded towards the
footprint's edges, the quadrant borders and the interface (the model is :func:`frictionid.builders.block.
block_model`)."""

from __future__ import annotations

import logging
import math

import gmsh
import numpy as np

from ..errors import InputError
from ..model import Mesh
from .gmsh_mesh import gmsh_session, mesh_from_gmsh

logger = logging.getLogger(__name__)

#: 3-D geometry [mm]: block side and height, plate half-width and thickness
BLOCK_SIDE, BLOCK_HEIGHT, PLATE_HALF, PLATE_THICKNESS = 10.0, 10.0, 20.0, 5.0
#: growth ratio of the element sizes in the plate outside the block's footprint
PLATE_GROWTH = 1.2
#: zone names of the 3-D model by quadrant: A (x<0, y<0), B (x>0, y<0), C (x<0, y>0), D (x>0, y>0)
QUADRANT_ZONES = {(-1, -1): "A", (1, -1): "B", (-1, 1): "C", (1, 1): "D"}
_TOL = 1e-6  # [mm] geometric tolerance for classifying gmsh entities
#: default node grading of the 3-D block model towards the footprint's edges, quadrant borders and the interface
#: (with incompatible modes the most accurate strains at the default's cost: benchmarks/block_strains.py)
DEFAULT_GRADING = 4.0


def checked_grading(value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or not value >= 1:
        raise InputError(f"`grading` must be a finite number >= 1, got {value!r}")
    return float(value)


def set_order(order: int):
    """Second-order (complete) elements of the current gmsh model when ``order`` is 2."""
    if order == 2:
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        gmsh.model.mesh.setOrder(2)


def block_mesh(block_divisions: int, n_block_z: int, n_plate_z: int, order: int = 1,
               grading: float = 1.0) -> Mesh:
    """Hexahedral mesh of block and plate, built as 4 x 4 plate columns and 4 block quarters (all transfinite).

    The plate columns break at x, y = -20, -5, 0, 5, 20, so each block quarter stands on a plate column with
    the same edge divisions (and the same grading, see :func:`block_model`): the interface nodes coincide but
    belong to separate bodies.
    """
    with gmsh_session("block"):
        occ = gmsh.model.occ
        plate = _fragmented_boxes([-PLATE_HALF, -BLOCK_SIDE / 2, 0.0, BLOCK_SIDE / 2, PLATE_HALF],
                                  -PLATE_THICKNESS, 0.0)
        block = _fragmented_boxes([-BLOCK_SIDE / 2, 0.0, BLOCK_SIDE / 2], 0.0, BLOCK_HEIGHT)
        occ.synchronize()
        grading = checked_grading(grading)
        _set_transfinite_3d(block_divisions // 2, n_block_z, n_plate_z, grading)
        _add_groups_3d(plate, block)
        gmsh.model.mesh.generate(3)
        set_order(order)
        mesh = mesh_from_gmsh("block model")
    if grading != 1.0:
        mesh = Mesh(points=_grade_points(mesh.points, grading), cell_type=mesh.cell_type, cells=mesh.cells,
                    regions=dict(mesh.regions), boundaries=dict(mesh.boundaries))
    logger.info("block mesh: %d nodes, %d %s cells", mesh.n_nodes, mesh.n_cells, mesh.cell_type)
    return mesh


def _fragmented_boxes(breaks: list[float], z0: float, z1: float) -> list[int]:
    """Volume tags of the boxes between consecutive x and y breaks, fragmented so that they share faces."""
    boxes = [(3, gmsh.model.occ.addBox(x0, y0, z0, x1 - x0, y1 - y0, z1 - z0))
             for x0, x1 in zip(breaks, breaks[1:]) for y0, y1 in zip(breaks, breaks[1:])]
    pieces, _ = gmsh.model.occ.fragment(boxes[:1], boxes[1:])
    return [tag for dim, tag in pieces if dim == 3]


def _point(tag: int) -> np.ndarray:
    return np.asarray(gmsh.model.getValue(0, tag, []))


def _graded(s: np.ndarray, grading: float, both_ends: bool = True) -> np.ndarray:
    """Monotone map of [0, 1] onto itself with end points fixed and slope ratio ``grading`` (largest / smallest).

    ``both_ends``: slope ``1 - c cos(2 pi s)``, smallest at both ends, largest in the middle; otherwise
    ``1 - c cos(pi s)``, smallest at s = 0, largest at s = 1; ``c = (grading - 1) / (grading + 1)``.
    The slopes are smooth, so a graded side joins its graded neighbour without a jump in element size.
    """
    c = (grading - 1.0) / (grading + 1.0)
    k = 2.0 if both_ends else 1.0
    return s - c * np.sin(k * np.pi * s) / (k * np.pi)


def _grade_points(points: np.ndarray, grading: float) -> np.ndarray:
    """Node coordinates of the uniform mesh moved by :func:`_graded`: in x and y on every half side of the
    footprint (small at the footprint edges and the quadrant borders), in z in block and plate (small at z = 0).

    Each coordinate is mapped on its own by a function of that coordinate alone, so nodes that coincide stay
    coincident (the interface stays conforming) and planes of constant x, y or z stay planes.
    """
    if grading == 1.0:
        return points
    out = points.copy()
    half = BLOCK_SIDE / 2
    for axis in (0, 1):
        x = points[:, axis]
        inside = np.abs(x) <= half + _TOL
        sign = np.where(x < 0, -1.0, 1.0)
        s = np.clip(np.abs(x[inside]) / half, 0.0, 1.0)
        out[inside, axis] = sign[inside] * half * _graded(s, grading)
    z = points[:, 2]
    up = z > 0
    out[up, 2] = BLOCK_HEIGHT * _graded(z[up] / BLOCK_HEIGHT, grading, both_ends=False)
    out[~up, 2] = -PLATE_THICKNESS * _graded(-z[~up] / PLATE_THICKNESS, grading, both_ends=False)
    return out


def _set_transfinite_3d(n_quarter: int, n_block_z: int, n_plate_z: int, grading: float = 1.0):
    """Structured hexahedra everywhere: node counts per curve by its direction and place, then all entities.

    With ``grading`` the plate outside the footprint grows from the size the graded edge element will have.
    """
    h = BLOCK_SIDE / 2 * _graded(np.array([1.0 / n_quarter]), grading)[0]
    outer = PLATE_HALF - BLOCK_SIDE / 2
    n_outer = max(1, math.ceil(math.log(1 + outer * (PLATE_GROWTH - 1) / h) / math.log(PLATE_GROWTH)))
    for _, curve in gmsh.model.getEntities(1):
        start, end = (_point(abs(p)) for _, p in gmsh.model.getBoundary([(1, curve)], oriented=False))
        axis = int(np.argmax(np.abs(end - start)))
        if axis == 2:
            n = n_block_z if start[2] + end[2] > 0 else n_plate_z
            gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
        elif max(abs(start[axis]), abs(end[axis])) <= BLOCK_SIDE / 2 + _TOL:
            gmsh.model.mesh.setTransfiniteCurve(curve, n_quarter + 1)
        else:   # outside the footprint: small elements next to the block, growing outwards
            growth = PLATE_GROWTH if abs(start[axis]) < abs(end[axis]) else 1 / PLATE_GROWTH
            gmsh.model.mesh.setTransfiniteCurve(curve, n_outer + 1, "Progression", growth)
    for _, surface in gmsh.model.getEntities(2):
        gmsh.model.mesh.setTransfiniteSurface(surface)
        gmsh.model.mesh.setRecombine(2, surface)
    for _, volume in gmsh.model.getEntities(3):
        gmsh.model.mesh.setTransfiniteVolume(volume)


def _faces_at(volumes: list[int], axis: int, value: float) -> list[int]:
    """Faces of the given volumes lying in the plane ``x[axis] = value``."""
    faces = {abs(t) for _, t in gmsh.model.getBoundary([(3, v) for v in volumes], combined=False, oriented=False)}
    out = []
    for face in sorted(faces):
        box = np.reshape(gmsh.model.getBoundingBox(2, face), (2, 3))
        if abs(box[0, axis] - value) < _TOL and abs(box[1, axis] - value) < _TOL:
            out.append(face)
    return out


def _add_groups_3d(plate: list[int], block: list[int]):
    add = gmsh.model.addPhysicalGroup
    add(3, plate, name="plate")
    add(3, block, name="block")
    add(2, _faces_at(plate, 2, -PLATE_THICKNESS), name="plate_bottom")
    add(2, _faces_at(plate, 2, 0.0), name="plate_top")
    add(2, _faces_at(block, 2, BLOCK_HEIGHT), name="block_top")
    for face in _faces_at(block, 2, 0.0):
        centre = gmsh.model.occ.getCenterOfMass(2, face)
        add(2, [face], name=QUADRANT_ZONES[(int(np.sign(centre[0])), int(np.sign(centre[1])))])
