"""gmsh half-discs whose contact arcs carry nodes at prescribed abscissae (conforming cylinder-on-cylinder contact)."""

from __future__ import annotations

from dataclasses import dataclass

import gmsh
import numpy as np

from ..errors import InputError
from ..model import Mesh
from .gmsh_mesh import distance_size_field, gmsh_session, mesh_from_gmsh, use_size_fields

#: growth of the element size per mm of distance from the contact arcs (neighbouring sizes differ by about 15 %)
SIZE_GROWTH = 0.15


def contact_abscissae(half_width: float, spacing: float) -> np.ndarray:
    """(2 n + 1,) abscissae [mm] evenly spaced on [-half_width, half_width], 0 included, spacing at most ``spacing``.

    >>> contact_abscissae(1.0, 0.5)
    array([-1. , -0.5,  0. ,  0.5,  1. ])
    """
    n = max(1, int(np.ceil(half_width / spacing - 1e-9)))
    return np.linspace(-half_width, half_width, 2 * n + 1)


def arc_height(x, centre_y: float, radius: float, facing: int):
    """y [mm] of the circle (centre (0, centre_y), radius) at abscissa x: its top (facing +1) or bottom (-1) half."""
    x = np.asarray(x, dtype=float)
    return centre_y + facing * np.sqrt(radius ** 2 - x ** 2)


@dataclass(frozen=True)
class HalfDisc:
    """gmsh entities of a half-disc: contact arcs (one element each, increasing x), flat face halves, surfaces.

    ``facing`` +1: the half above the centre (contact on top), -1: the half below the centre.
    """

    centre_y: float
    radius: float
    facing: int
    xs: np.ndarray
    arcs: tuple[int, ...]
    flat_left: int
    flat_right: int
    axis: int | None
    surfaces: tuple[int, ...]

    @property
    def left_arcs(self) -> tuple[int, ...]:
        """Contact arcs with x <= 0."""
        return self.arcs[: len(self.arcs) // 2]

    @property
    def right_arcs(self) -> tuple[int, ...]:
        """Contact arcs with x >= 0."""
        return self.arcs[len(self.arcs) // 2:]


def _loop(curves: list[int], facing: int) -> int:
    """Curve loop, counter-clockwise whichever half it bounds (curves are listed clockwise for facing +1)."""
    if facing > 0:
        curves = [-c for c in reversed(curves)]
    return gmsh.model.geo.addCurveLoop(curves)


def add_half_disc(centre_y: float, radius: float, facing: int, xs: np.ndarray, split: bool = False) -> HalfDisc:
    """Add a half-disc to the gmsh built-in geometry; the contact arcs join the circle's points at ``xs``.

    Parameters
    ----------
    centre_y : float [mm]
        The centre is (0, centre_y); the flat face lies on y = centre_y, from x = -radius to radius.
    radius : float [mm]
    facing : +1 | -1
        +1 keeps the half above the centre, -1 the half below.
    xs : (2 n + 1,) [mm]
        Increasing abscissae of the contact-arc ends, symmetric about 0 (see :func:`contact_abscissae`).
    split : bool
        Also add the axis x = 0 from the centre to the circle, splitting the body into two quarter-discs.
    """
    if not np.max(np.abs(xs)) < radius:
        raise InputError(f"the refined contact arc (|x| <= {np.max(np.abs(xs))}) must be narrower than "
                         f"the cylinder radius {radius}")
    geo = gmsh.model.geo
    centre = geo.addPoint(0.0, centre_y, 0.0)
    points = [geo.addPoint(x, y, 0.0) for x, y in zip(xs, arc_height(xs, centre_y, radius, facing))]
    arcs = [geo.addCircleArc(p, centre, q) for p, q in zip(points[:-1], points[1:])]
    left, right = geo.addPoint(-radius, centre_y, 0.0), geo.addPoint(radius, centre_y, 0.0)
    outer_right, outer_left = geo.addCircleArc(points[-1], centre, right), geo.addCircleArc(left, centre, points[0])
    flat_right, flat_left = geo.addLine(right, centre), geo.addLine(centre, left)
    n = len(arcs) // 2
    if split:
        axis = geo.addLine(centre, points[n])
        loops = [_loop(arcs[n:] + [outer_right, flat_right, axis], facing),
                 _loop(arcs[:n] + [-axis, flat_left, outer_left], facing)]
    else:
        axis = None
        loops = [_loop(arcs + [outer_right, flat_right, flat_left, outer_left], facing)]
    surfaces = tuple(geo.addPlaneSurface([loop]) for loop in loops)
    return HalfDisc(centre_y, radius, facing, np.asarray(xs, float), tuple(arcs), flat_left, flat_right, axis,
                    surfaces)


def one_element_per_arc(*discs: HalfDisc):
    """Make every contact arc a single element (call after synchronising the geometry)."""
    for disc in discs:
        for arc in disc.arcs:
            gmsh.model.mesh.setTransfiniteCurve(arc, 2)


def refine_near_arcs(contact_size: float, size: float, *discs: HalfDisc):
    """Element size contact_size on the contact arcs, growing by :data:`SIZE_GROWTH` per mm up to size."""
    use_size_fields(distance_size_field([a for d in discs for a in d.arcs], contact_size, size,
                                        max(size - contact_size, 0.0) / SIZE_GROWTH + 1e-12, sampling=10))
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)


def place_arc_midnodes(*discs: HalfDisc):
    """Move the mid-node of each quadratic contact arc onto the circle at the mean abscissa of its ends.

    gmsh puts it at the mean angle, which differs between circles of different radii; at the mean abscissa
    the mid-nodes of two facing circles pair up exactly, like the end nodes.
    """
    for disc in discs:
        for arc, x0, x1 in zip(disc.arcs, disc.xs[:-1], disc.xs[1:]):
            tags, _, _ = gmsh.model.mesh.getNodes(1, arc, includeBoundary=False)
            if len(tags) != 1:
                raise InputError(f"contact arc {arc} has {len(tags)} inner nodes, expected the one mid-node "
                                 "of a single quadratic element")
            x = 0.5 * (x0 + x1)
            gmsh.model.mesh.setNode(int(tags[0]), [x, float(arc_height(x, disc.centre_y, disc.radius,
                                                                        disc.facing)), 0.0], [])


def separate_quadratic_bodies():
    """Options for the current gmsh session: quadratic triangles; coincident points of two bodies stay apart."""
    gmsh.option.setNumber("Geometry.AutoCoherence", 0)
    gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)


def cylinders_mesh(R_upper: float, R_lower: float, half_width: float, contact_size: float, size: float) -> Mesh:
    """Upper half-disc (centre (0, R_upper), split by its axis) touching a lower one (centre (0, -R_lower)) at 0.

    Both contact arcs (|x| <= half_width) have nodes at the same abscissae, spacing at most contact_size.
    Regions "upper", "lower". Boundaries: "left", "right" (upper contact arc, x < 0 / x > 0), "lower_contact",
    "upper_flat" (halves "upper_flat_left", "upper_flat_right"), "upper_axis" (x = 0), "lower_flat".
    """
    xs = contact_abscissae(half_width, contact_size)
    with gmsh_session("cylinders"):
        separate_quadratic_bodies()
        upper = add_half_disc(R_upper, R_upper, -1, xs, split=True)
        lower = add_half_disc(-R_lower, R_lower, +1, xs)
        gmsh.model.geo.synchronize()
        one_element_per_arc(upper, lower)
        refine_near_arcs(min(contact_size, size), size, upper, lower)
        groups = {"upper": upper.surfaces, "lower": lower.surfaces, "left": upper.left_arcs,
                  "right": upper.right_arcs, "lower_contact": lower.arcs,
                  "upper_flat": [upper.flat_left, upper.flat_right], "upper_flat_left": [upper.flat_left],
                  "upper_flat_right": [upper.flat_right], "upper_axis": [upper.axis],
                  "lower_flat": [lower.flat_left, lower.flat_right]}
        for name, tags in groups.items():
            gmsh.model.addPhysicalGroup(2 if name in ("upper", "lower") else 1, list(tags), name=name)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        place_arc_midnodes(upper, lower)
        return mesh_from_gmsh("cylinders")
