"""Axisymmetric gmsh mesh of a solid shaft inside a collar (hub or sleeve) with a conforming bore interface."""

from __future__ import annotations

import gmsh
import numpy as np

from ..model import Mesh
from .arcs import separate_quadratic_bodies
from .gmsh_mesh import gmsh_session, mesh_from_gmsh


def _vertical(r: float, ys) -> tuple[list[int], list[int]]:
    """(points, lines) of the polyline through (r, ys[k]), bottom up."""
    points = [gmsh.model.geo.addPoint(r, y, 0.0) for y in ys]
    return points, [gmsh.model.geo.addLine(p, q) for p, q in zip(points[:-1], points[1:])]


def _surfaces(shaft_radius, bore, outer, shaft_ys, zone_edges) -> dict[str, list[int]]:
    """Add shaft and collar to the built-in geometry; entity tags by group name (zones as "bore_k")."""
    geo = gmsh.model.geo
    shaft_points, shaft_lines = _vertical(shaft_radius, [shaft_ys[0], *zone_edges, shaft_ys[1]])
    bore_points, bore_lines = _vertical(bore, zone_edges)
    top_axis, bottom_axis = geo.addPoint(0.0, shaft_ys[1], 0.0), geo.addPoint(0.0, shaft_ys[0], 0.0)
    shaft_edges = [geo.addLine(shaft_points[-1], top_axis), geo.addLine(top_axis, bottom_axis),
                   geo.addLine(bottom_axis, shaft_points[0])]
    outer_bottom, outer_top = geo.addPoint(outer, zone_edges[0], 0.0), geo.addPoint(outer, zone_edges[-1], 0.0)
    collar_edges = [geo.addLine(bore_points[0], outer_bottom), geo.addLine(outer_bottom, outer_top),
                    geo.addLine(outer_top, bore_points[-1])]
    shaft = geo.addPlaneSurface([geo.addCurveLoop(shaft_lines + shaft_edges)])
    ring = geo.addPlaneSurface([geo.addCurveLoop(collar_edges + [-c for c in reversed(bore_lines)])])
    groups = dict(shaft=[shaft], collar=[ring], shaft_top=shaft_edges[:1], shaft_axis=shaft_edges[1:2],
                  shaft_bottom=shaft_edges[2:], shaft_surface=shaft_lines[1:-1], collar_bottom=collar_edges[:1],
                  collar_outer=collar_edges[1:2], collar_top=collar_edges[2:])
    groups.update({f"bore_{k}": [line] for k, line in enumerate(bore_lines)})
    return groups


def shaft_and_collar_mesh(shaft_radius: float, bore: float, outer: float, shaft_ys: tuple[float, float],
                          zone_edges, zones: list[str], collar: str, size: float, contact_size: float) -> Mesh:
    """Quadratic-triangle mesh of a shaft r <= shaft_radius, y in shaft_ys, and a collar bore <= r <= outer.

    The collar spans zone_edges[0] <= y <= zone_edges[-1]; its bore is split at zone_edges into the named
    zones (bottom up), and the shaft's outer line is split at the same heights with the same number of nodes
    per segment (spacing at most contact_size), so bore and shaft nodes pair at equal y with radial gap
    bore - shaft_radius. Regions "shaft" and collar; boundaries "shaft_bottom", "shaft_top", "shaft_axis",
    "shaft_surface" (the collar's span), the zones, and collar + "_bottom", "_top", "_outer".
    """
    zone_edges = np.asarray(zone_edges, dtype=float)
    with gmsh_session("shaft_and_collar"):
        separate_quadratic_bodies()
        groups = _surfaces(shaft_radius, bore, outer, shaft_ys, zone_edges)
        gmsh.model.geo.synchronize()
        for k, (y_a, y_b) in enumerate(zip(zone_edges[:-1], zone_edges[1:])):
            n_nodes = int(np.ceil((y_b - y_a) / contact_size - 1e-9)) + 1
            gmsh.model.mesh.setTransfiniteCurve(groups[f"bore_{k}"][0], n_nodes)
            gmsh.model.mesh.setTransfiniteCurve(groups["shaft_surface"][k], n_nodes)
        gmsh.model.mesh.setSize(gmsh.model.getEntities(0), size)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        names = {f"bore_{k}": zone for k, zone in enumerate(zones)}
        for key, tags in groups.items():
            name = names.get(key, key.replace("collar", collar))
            gmsh.model.addPhysicalGroup(2 if key in ("shaft", "collar") else 1, tags, name=name)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh("shaft_and_collar")
