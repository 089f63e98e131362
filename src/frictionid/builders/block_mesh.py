"""The 3-D block test's geometry and its gmsh mesh: block and plate as transfinite hexahedra, graded towards the
footprint's edges, the quadrant borders and the interface, optionally split further in bands of fixed width around
the footprint's edges and the interface (:class:`Bands`; the model is :func:`frictionid.builders.block.
block_model`)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

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


@dataclass(frozen=True)
class Bands:
    """Local refinement of the 3-D block's mesh: the element intervals (of the mesh the divisions, layers and
    grading give) whose middle lies within ``edge_band`` [mm] of the footprint's edges (x or y = +-5, inside the
    footprint and in the plate around it) are split into ``edge_splits`` equal parts in that coordinate, those
    within ``interface_band`` [mm] of the interface (z = 0, block and plate) into ``interface_splits`` parts in z.

    The bands keep their width as the splits grow, so their elements' size goes to 0 as 1 / splits: each split is
    a refinement direction whose error converges like the uniform one's (the discretisation control's splitting
    extrapolation). The mesh stays a tensor product, so an edge split adds lines across the whole plate, but only
    as many as the band has intervals. ``interior_splits`` splits the other intervals across the footprint, those
    outside the edge band (the footprint's interior, where the pull's lift-off front lies), into that many parts.
    """

    edge_splits: int = 1
    edge_band: float = 1.0
    interface_splits: int = 1
    interface_band: float = 1.0
    interior_splits: int = 1


@dataclass(frozen=True)
class Layout:
    """Node positions per axis piece before the grading: ``quarter`` the parameter s in [0, 1] of a footprint half
    side (0 at the quadrant border, 1 at the edge), ``block_z`` and ``plate_z`` of the block height and the plate
    thickness (0 at the interface), all mapped by :func:`_graded` afterwards; ``outer`` the distances |x| in
    [5, 20] of the plate outside the footprint, or None for gmsh's geometric progression of ``n_outer`` intervals
    (no band split there)."""

    quarter: np.ndarray
    block_z: np.ndarray
    plate_z: np.ndarray
    outer: np.ndarray | None
    n_outer: int
    grading: float

    def contact_length(self) -> float:
        """[mm] the shortest element edge on the contact (across the footprint, after the grading)."""
        return float(BLOCK_SIDE / 2 * np.min(np.diff(_graded(self.quarter, self.grading))))

    def n_nodes(self, order: int = 1) -> int:
        """The mesh's node count (block and plate have separate interface nodes)."""
        n_quarter, n_outer = len(self.quarter) - 1, self.n_outer if self.outer is None else len(self.outer) - 1
        plate, block = 2 * n_quarter + 2 * n_outer, 2 * n_quarter
        return int(sum((order * n + 1) ** 2 * (order * (len(z) - 1) + 1)
                       for n, z in ((plate, self.plate_z), (block, self.block_z))))


def _split(grid: np.ndarray, inside: np.ndarray, parts: int, others: int = 1) -> np.ndarray:
    """``grid`` (increasing) with each interval where ``inside`` (one flag per interval) split into ``parts``, the
    others into ``others``.

    >>> _split(np.array([0.0, 1.0, 3.0]), np.array([False, True]), 2).tolist()
    [0.0, 1.0, 2.0, 3.0]
    >>> _split(np.array([0.0, 1.0, 3.0]), np.array([False, True]), 1, others=2).tolist()
    [0.0, 0.5, 1.0, 3.0]
    """
    pieces = [grid[:1]]
    for a, b, flag in zip(grid[:-1], grid[1:], inside):
        n = parts if flag else others
        pieces.append(a + (b - a) * np.arange(1, n + 1) / n)
    return np.concatenate(pieces)


def layout(block_divisions: int, n_block_z: int, n_plate_z: int, grading: float = 1.0,
           bands: Bands = Bands()) -> Layout:
    """The node positions of :func:`block_mesh` per axis piece (:class:`Layout`)."""
    grading = checked_grading(grading)
    n_quarter = block_divisions // 2
    half = BLOCK_SIDE / 2

    def middles(grid, length, both_ends=True):        # the graded intervals' middles [mm] from the border / interface
        x = length * _graded(grid, grading, both_ends)
        return (x[:-1] + x[1:]) / 2

    quarter = np.linspace(0.0, 1.0, n_quarter + 1)
    quarter = _split(quarter, half - middles(quarter, half) < bands.edge_band, bands.edge_splits,
                     bands.interior_splits)
    z = {}
    for name, n, length in (("block", n_block_z, BLOCK_HEIGHT), ("plate", n_plate_z, PLATE_THICKNESS)):
        grid = np.linspace(0.0, 1.0, n + 1)
        z[name] = _split(grid, middles(grid, length, False) < bands.interface_band, bands.interface_splits)
    h = half * _graded(np.array([1.0 / n_quarter]), grading)[0]
    length = PLATE_HALF - half
    n_outer = max(1, math.ceil(math.log(1 + length * (PLATE_GROWTH - 1) / h) / math.log(PLATE_GROWTH)))
    outer = None
    if bands.edge_splits > 1:
        base = half + length * (PLATE_GROWTH ** np.arange(n_outer + 1) - 1) / (PLATE_GROWTH ** n_outer - 1)
        outer = _split(base, (base[:-1] + base[1:]) / 2 - half < bands.edge_band, bands.edge_splits)
    return Layout(quarter, z["block"], z["plate"], outer, n_outer, grading)


def block_mesh(block_divisions: int, n_block_z: int, n_plate_z: int, order: int = 1,
               grading: float = 1.0, bands: Bands = Bands()) -> Mesh:
    """Hexahedral mesh of block and plate, built as 4 x 4 plate columns and 4 block quarters (all transfinite).

    The plate columns break at x, y = -20, -5, 0, 5, 20, so each block quarter stands on a plate column with
    the same edge divisions (and the same grading and bands, see :func:`block_model`): the interface nodes
    coincide but belong to separate bodies. gmsh meshes uniform intervals; the nodes are then moved to the
    :func:`layout`'s positions, each coordinate by a function of itself alone (planes stay planes).
    """
    with gmsh_session("block"):
        occ = gmsh.model.occ
        plate = _fragmented_boxes([-PLATE_HALF, -BLOCK_SIDE / 2, 0.0, BLOCK_SIDE / 2, PLATE_HALF],
                                  -PLATE_THICKNESS, 0.0)
        block = _fragmented_boxes([-BLOCK_SIDE / 2, 0.0, BLOCK_SIDE / 2], 0.0, BLOCK_HEIGHT)
        occ.synchronize()
        places = layout(block_divisions, n_block_z, n_plate_z, grading, bands)
        _set_transfinite_3d(places)
        _add_groups_3d(plate, block)
        gmsh.model.mesh.generate(3)
        set_order(order)
        mesh = mesh_from_gmsh("block model")
    moved = _place_points(mesh.points, places)
    if moved is not mesh.points:
        mesh = Mesh(points=moved, cell_type=mesh.cell_type, cells=mesh.cells,
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


def _uniform(grid: np.ndarray) -> bool:
    """Whether ``grid`` on [0, 1] has equal intervals (no band split)."""
    return bool(np.allclose(np.diff(grid), 1.0 / (len(grid) - 1), rtol=0.0, atol=1e-15))


def _unsplit(t: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """The uniform parameter ``t`` of gmsh's nodes (len(grid) - 1 equal intervals) at ``grid``'s positions."""
    if _uniform(grid):
        return t                                           # no band split: unchanged
    return np.interp(t, np.linspace(0.0, 1.0, len(grid)), grid)


def _place_points(points: np.ndarray, places: Layout) -> np.ndarray:
    """Node coordinates of gmsh's uniform mesh moved to the :class:`Layout`: in x and y on every half side of the
    footprint (split in the bands, then graded by :func:`_graded`: small at the footprint edges and the quadrant
    borders) and outside it where the bands split it, in z in block and plate (small at z = 0).

    Each coordinate is mapped on its own by a function of that coordinate alone, so nodes that coincide stay
    coincident (the interface stays conforming) and planes of constant x, y or z stay planes.
    """
    grading, half = places.grading, BLOCK_SIDE / 2
    if grading == 1.0 and places.outer is None and all(map(_uniform, (places.quarter, places.block_z,
                                                                      places.plate_z))):
        return points
    out = points.copy()
    for axis in (0, 1):
        x = points[:, axis]
        inside = np.abs(x) <= half + _TOL
        sign = np.where(x < 0, -1.0, 1.0)
        s = _unsplit(np.clip(np.abs(x[inside]) / half, 0.0, 1.0), places.quarter)
        out[inside, axis] = sign[inside] * half * _graded(s, grading)
        if places.outer is not None:
            uniform = np.linspace(half, PLATE_HALF, len(places.outer))
            out[~inside, axis] = sign[~inside] * np.interp(np.abs(x[~inside]), uniform, places.outer)
    z = points[:, 2]
    up = z > 0
    out[up, 2] = BLOCK_HEIGHT * _graded(_unsplit(z[up] / BLOCK_HEIGHT, places.block_z), grading, both_ends=False)
    out[~up, 2] = -PLATE_THICKNESS * _graded(_unsplit(-z[~up] / PLATE_THICKNESS, places.plate_z), grading,
                                             both_ends=False)
    return out


def _set_transfinite_3d(places: Layout):
    """Structured hexahedra everywhere: node counts per curve by its direction and place, then all entities.

    Without an edge band split the plate outside the footprint grows geometrically (gmsh's progression) from the
    size the graded edge element will have; with one it is uniform here and :func:`_place_points` moves it.
    """
    for _, curve in gmsh.model.getEntities(1):
        start, end = (_point(abs(p)) for _, p in gmsh.model.getBoundary([(1, curve)], oriented=False))
        axis = int(np.argmax(np.abs(end - start)))
        if axis == 2:
            z = places.block_z if start[2] + end[2] > 0 else places.plate_z
            gmsh.model.mesh.setTransfiniteCurve(curve, len(z))
        elif max(abs(start[axis]), abs(end[axis])) <= BLOCK_SIDE / 2 + _TOL:
            gmsh.model.mesh.setTransfiniteCurve(curve, len(places.quarter))
        elif places.outer is not None:
            gmsh.model.mesh.setTransfiniteCurve(curve, len(places.outer))
        else:   # outside the footprint: small elements next to the block, growing outwards
            growth = PLATE_GROWTH if abs(start[axis]) < abs(end[axis]) else 1 / PLATE_GROWTH
            gmsh.model.mesh.setTransfiniteCurve(curve, places.n_outer + 1, "Progression", growth)
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
