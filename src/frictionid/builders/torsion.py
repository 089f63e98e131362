"""Benchmarks of the "axisymmetric_twist" kind (x = r, y = axis): a shaft in torsion, a ring turned on a ring.

Meshes are structured (transfinite) triangles, linear or quadratic, one rectangle per body with its own nodes.
"""

from __future__ import annotations

import dataclasses

import gmsh
import numpy as np

from ..errors import InputError
from ..model import (ContactInterface, Material, Mesh, Model, Pressure, Rotation, Stage, SurfaceForce,
                     Support)
from .arguments import count, positive
from .gmsh_mesh import gmsh_session, mesh_from_gmsh

_SIDES = ("bottom", "outer", "top", "inner")


def _rectangle(name: str, r: tuple[float, float], y: tuple[float, float], size: float, splits=()) -> dict:
    """Add the rectangle r x y (its own points and lines) to the built-in geometry, transfinite with about
    ``size`` spacing (set on the geometry: constraints set on the model are lost at the next synchronize); the
    bottom and top lines are split at the radii ``splits``. Returns group name -> tags."""
    geo = gmsh.model.geo
    radii = [r[0], *splits, r[1]]
    bottom = [geo.addPoint(x, y[0], 0.0) for x in radii]
    top = [geo.addPoint(x, y[1], 0.0) for x in radii]
    lines = {"bottom": [geo.addLine(p, q) for p, q in zip(bottom[:-1], bottom[1:])],
             "outer": [geo.addLine(bottom[-1], top[-1])],
             "top": [geo.addLine(q, p) for p, q in zip(top[:-1], top[1:])][::-1],
             "inner": [geo.addLine(top[0], bottom[0])]}
    loop = geo.addCurveLoop(lines["bottom"] + lines["outer"] + lines["top"] + lines["inner"])
    surface = geo.addPlaneSurface([loop])
    n_y = int(np.ceil((y[1] - y[0]) / size - 1e-9)) + 1
    for side in ("outer", "inner"):
        geo.mesh.setTransfiniteCurve(lines[side][0], n_y)
    for k, (a, b) in enumerate(zip(radii[:-1], radii[1:])):
        n_r = int(np.ceil((b - a) / size - 1e-9)) + 1
        geo.mesh.setTransfiniteCurve(lines["bottom"][k], n_r)
        geo.mesh.setTransfiniteCurve(lines["top"][::-1][k], n_r)
    geo.mesh.setTransfiniteSurface(surface, cornerTags=[bottom[0], bottom[-1], top[-1], top[0]])
    geo.synchronize()
    groups = {name: (2, [surface])}
    groups.update({f"{name}_{side}": (1, lines[side]) for side in _SIDES})
    groups.update({f"{name}_bottom_{k}": (1, [line]) for k, line in enumerate(lines["bottom"])})
    return groups


def _mesh(rectangles: list[dict], order: int) -> Mesh:
    if order not in (1, 2):
        raise InputError(f"`order` must be 1 or 2, got {order!r}")
    for groups in rectangles:
        for name, (dim, tags) in groups.items():
            gmsh.model.addPhysicalGroup(dim, tags, name=name)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(order)
    return mesh_from_gmsh("torsion benchmark")


def shaft_model(radius: float = 5.0, length: float = 20.0, bore: float = 0.0, E: float = 200000.0,
                nu: float = 0.3, size: float = 1.0, order: int = 2, twist: float | None = 1e-3,
                force: float | None = None) -> Model:
    """A shaft bore <= r <= radius, 0 <= y <= length, in torsion (St-Venant: twist = T L / (G J)).

    "shaft_bottom" is held in y and t; "shaft_top" is turned by ``twist`` [rad] (a :class:`Rotation`, reaction
    "shaft_top.torque") or, with ``force`` [N] instead, loaded by a uniform circumferential traction totalling
    ``force`` (torque force * 2/3 (R^3 - r^3) / (R^2 - r^2)). Region "shaft"; boundaries "shaft_bottom", "_top",
    "_inner" (the axis for a solid shaft), "_outer". One stage, one increment.
    """
    radius, length = positive("radius", radius), positive("length", length)
    if not 0.0 <= bore < radius or (twist is None) == (force is None):
        raise InputError("need 0 <= bore < radius and exactly one of `twist`, `force`")
    with gmsh_session("shaft"):
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        mesh = _mesh([_rectangle("shaft", (bore, radius), (0.0, length), positive("size", size))], order)
    load = (Rotation("shaft_top", (twist,)) if force is None else SurfaceForce("shaft_top", "t", (force,)))
    return Model(mesh=mesh, kind="axisymmetric_twist", materials={"shaft": Material(E, nu, "shaft")},
                 supports=(Support("shaft_bottom", (1, 2)),), loads=(load,), stages=(Stage("load"),))


def turned_rings_model(inner: float = 6.0, outer: float = 10.0, height: float = 4.0, E: float = 200000.0,
                       nu: float = 0.3, pressure: float = 50.0, angle: float = 2e-3, size: float = 0.5,
                       order: int = 2, n_turn: int = 4, lead: float = 0.0, cone_deg: float = 0.0) -> Model:
    """A ring pressed axially on a ring of the same section and turned about the axis (x = r, y = axis).

    Rings inner <= r <= outer: "lower" at -height <= y <= 0, "upper" at 0 <= y <= height, with coincident
    nodes on y = 0. Contact: the upper ring's bottom split at the mean radius into zones "inside" and
    "outside", target "lower_top". "lower_bottom" is held in y and t. Stage "press": ``pressure`` [MPa] on
    "upper_top" (N = pressure pi (outer^2 - inner^2)); stage "turn": pressure held, "upper_top" turned by
    ``angle`` [rad] (n_turn increments; reaction "upper_top.torque").

    One material and a uniform axial stress: both rings expand radially alike, so the contact pressure is
    uniform and the gross-slip torque is mu N r_eff, r_eff = 2/3 (R^3 - r^3) / (R^2 - r^2).

    ``lead`` [mm per turn]: the face is a helicoid of that lead (a square thread; the interface's
    :attr:`~frictionid.model.ContactInterface.lead`): turning the upper ring screws it along the axis.

    ``cone_deg`` [deg]: the face is a cone rising outwards at that angle, y = (r - inner) tan(cone_deg) (a thread
    flank's 30 deg without its helix): every node is moved by :func:`cone_shift`, which leaves the held bottom and
    the pressed top flat. The pressure is then not uniform and the slip is in the section too.
    """
    inner, outer, height = positive("inner", inner), positive("outer", outer), positive("height", height)
    if not inner < outer:
        raise InputError(f"need inner < outer, got {inner}, {outer}")
    size, middle = positive("size", size), 0.5 * (inner + outer)
    with gmsh_session("turned_rings"):
        gmsh.option.setNumber("Geometry.AutoCoherence", 0)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        lower = _rectangle("lower", (inner, outer), (-height, 0.0), size, splits=(middle,))
        upper = _rectangle("upper", (inner, outer), (0.0, height), size, splits=(middle,))
        upper["inside"], upper["outside"] = upper.pop("upper_bottom_0"), upper.pop("upper_bottom_1")
        mesh = _mesh([lower, upper], order)
    if cone_deg:
        if not 0.0 < cone_deg < 60.0:
            raise InputError(f"`cone_deg` must lie in (0, 60) deg, got {cone_deg!r}")
        mesh = dataclasses.replace(mesh, points=cone_shift(mesh.points, inner, height, cone_deg))
    pressure = positive("pressure", pressure)
    return Model(mesh=mesh, kind="axisymmetric_twist",
                 materials={"lower": Material(E, nu, "lower"), "upper": Material(E, nu, "upper")},
                 supports=(Support("lower_bottom", (1, 2)),),
                 loads=(Pressure("upper_top", (pressure, pressure)), Rotation("upper_top", (0.0, angle))),
                 stages=(Stage("press", 1), Stage("turn", count("n_turn", n_turn))),
                 interfaces=(ContactInterface("face", ("inside", "outside"), "lower_top", "node-to-node", lead),))


def cone_shift(points: np.ndarray, inner: float, height: float, cone_deg: float) -> np.ndarray:
    """(n, 2 or 3) points (r, y[, z] with r = x, or 3-D with r = sqrt(x^2 + z^2)) moved along y by
    (r - inner) tan(cone_deg) (1 - |y| / height): the plane y = 0 becomes the cone, y = -height and y = height stay.

    >>> cone_shift(np.array([[10.0, 0.0], [10.0, 4.0], [8.0, -2.0]]), 6.0, 4.0, 45.0).round(12).tolist()
    [[10.0, 4.0], [10.0, 4.0], [8.0, -1.0]]
    """
    points = np.array(points, dtype=float)
    r = np.hypot(points[:, 0], points[:, 2]) if points.shape[1] == 3 else points[:, 0]
    points[:, 1] += (r - inner) * np.tan(np.radians(cone_deg)) * (1.0 - np.abs(points[:, 1]) / height)
    return points


def effective_radius(inner: float, outer: float) -> float:
    """Friction radius of a uniformly pressed annulus: 2/3 (R^3 - r^3) / (R^2 - r^2) [mm].

    >>> round(effective_radius(6.0, 10.0), 4)
    8.1667
    """
    return 2.0 / 3.0 * (outer ** 3 - inner ** 3) / (outer ** 2 - inner ** 2)
