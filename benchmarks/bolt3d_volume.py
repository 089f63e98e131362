"""The 3-D bolt's volume three ways: exact from its definition, OCC's mass of its CAD, and its tetra10 mesh; and
where along the axis the mesh's volume differs from the exact one.

Exact: the head's hexagonal prism, the blank cylinder at the crest radius and the helical grooves between the
thread's start and the bolt's end. Swept helically, an axial section keeps its volume (the map (r, y, theta) ->
(r, y + P theta / 2 pi, theta) has Jacobian one), and between two planes the grooves take, at each radius r, the
fraction w(r) / P of every angle's line on average, w(r) the groove's axial width in the section (ISO 68-1 with
the 6g shift: flanks, the root arc of radius H/6): 2 pi int r w(r) / P dr per mm of axis, by quadrature.

Mesh: the bolt session of ``nut_mesh = "separate"`` (bolt and plate 2, :mod:`frictionid.builders.bolt3d_separate`)
at the 3-D defaults, window, roots from the thread's start (as tests/test_bolt3d_sizes.py builds it), tetra10 with
gmsh's mid-side nodes and after :func:`frictionid.builders.curved.curved_where_valid`. The volume below a height c
is int x n_x + z n_z over the mesh's boundary below c, halved (the field (x, 0, z) / 2 has divergence one and no
flux through the plane y = c); binned by quadrature point, so a cut through large facets is off by up to about 1
mm^3 on the M8's shank (its 2.5 mm facets), and the differences between cuts on the thread (facets of P or less)
are the measure.

Run: .venv/bin/python benchmarks/bolt3d_volume.py SIZE|--stiffness [--roots-to-end] [--sampling N]
(``--roots-to-end``: the bolt's roots meshed at root_size up to the bolt's end instead of a pitch above the nut's
top; ``--sampling N``: gmsh's Distance fields on faces sample each face at N points per parametric direction
instead of the builder's 30; both patch the builder for this run). ``--stiffness`` instead solves the small M6 of
tests/test_bolt3d_verification.py (SMALL, mu 0.15) and prints the change of uy's section averages between its
STATIONS, their sum (the bolt's elongation) and uy at the ten points, as that test measures them.
"""

import contextlib
import math
import sys
from unittest import mock

import gmsh
import numpy as np
from scipy.integrate import quad
from skfem.quadrature import get_quadrature
from skfem.refdom import RefTri

import frictionid.builders.bolt3d_mesh as bolt3d_mesh
from frictionid.builders.bolt import default_sizes
from frictionid.builders.bolt3d import JAW_ANGLE, WINDOW_CENTRE, window_of
from frictionid.builders.bolt3d_separate import _bolt_session
from frictionid.builders.bolt_layout import bolt_layout
from frictionid.builders.curved import curved_where_valid
from frictionid.builders.gmsh_mesh import mesh_from_gmsh
from frictionid.builders.thread import SQRT3

#: corners of a tetra10's faces (meshio order) and the corner opposite each; the mid-side node of each edge
FACES = {(0, 1, 2): 3, (0, 1, 3): 2, (1, 2, 3): 0, (0, 2, 3): 1}
MID = {(0, 1): 4, (1, 2): 5, (0, 2): 6, (0, 3): 7, (1, 3): 8, (2, 3): 9}


def groove_width(layout, r: float) -> float:
    """Axial width [mm] of the bolt's groove at radius r [mm] in an axial section (ISO 68-1, 6g shift)."""
    s = layout.size
    apex, r_tangent = s.d / 2 + s.H / 8 - layout.shift, s.d1 / 2 - layout.shift
    if r >= r_tangent:
        return s.P - 2 * (apex - r) / SQRT3
    centre = r_tangent + s.root_radius / 2
    return 2 * math.sqrt(max(s.root_radius ** 2 - (r - centre) ** 2, 0.0))


def groove_per_length(layout) -> float:
    """[mm^3 / mm] the grooves' volume per mm of threaded length."""
    s = layout.size
    r_tangent, r_crest = s.d1 / 2 - layout.shift, s.d / 2 - layout.shift
    pieces = ((r_tangent - s.root_radius / 2, r_tangent), (r_tangent, r_crest))
    return 2 * math.pi / s.P * sum(quad(lambda r: r * groove_width(layout, r), a, b, epsabs=1e-13)[0]
                                   for a, b in pieces)


def exact_volume(layout, below: float = math.inf) -> float:
    """[mm^3] the bolt's volume below the height ``below`` [mm] (not at 0, the head's bearing face)."""
    s, top = layout.size, min(below, layout.length)
    head = SQRT3 / 2 * s.head_s ** 2 * s.head_k if below > 0 else 0.0
    return head + math.pi * layout.r_shank ** 2 * max(top, 0.0) - groove_per_length(layout) * max(
        0.0, top - layout.y_thread)


def _shape(xi):
    """Values and derivatives of the triangle6 shape functions (corners, then edges 01, 12, 20) at xi (2,)."""
    l0, l1, l2 = 1 - xi[0] - xi[1], xi[0], xi[1]
    values = [l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0]
    d1 = [1 - 4 * l0, 4 * l1 - 1, 0.0, 4 * (l0 - l1), 4 * l2, -4 * l2]
    d2 = [1 - 4 * l0, 0.0, 4 * l2 - 1, -4 * l1, 4 * l1, 4 * (l0 - l2)]
    return np.array(values), np.array(d1), np.array(d2)


def boundary(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(facets (m, 6) triangle6 of the cells' boundary, the corner (m,) opposite each in its cell)."""
    seen: dict = {}
    for face in FACES:
        for i, key in enumerate(map(tuple, np.sort(cells[:, list(face)], axis=1))):
            seen.setdefault(key, []).append((i, face))
    rows, opposite = [], []
    for (i, (a, b, c)), *others in seen.values():
        if not others:
            cell = cells[i]
            rows.append([cell[a], cell[b], cell[c], cell[MID[a, b]], cell[MID[b, c]], cell[MID[a, c]]])
            opposite.append(cell[FACES[a, b, c]])
    return np.array(rows), np.array(opposite)


def volume_below(points: np.ndarray, facets: np.ndarray, opposite: np.ndarray, heights) -> np.ndarray:
    """[mm^3] the mesh's volume below each height [mm] (see the module docstring), degree-8 rule on the facets."""
    x = points[facets]
    outward = np.sign(np.einsum("ij,ij->i", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]),
                                x[:, :3].mean(axis=1) - points[opposite]))
    X, W = get_quadrature(RefTri, 8)
    y, flux = [], []
    for xi, w in zip(X.T, W):
        N, d1, d2 = _shape(xi)
        p = np.einsum("k,mkd->md", N, x)
        n = np.cross(np.einsum("k,mkd->md", d1, x), np.einsum("k,mkd->md", d2, x)) * outward[:, None]
        y.append(p[:, 1])
        flux.append(w * (p[:, 0] * n[:, 0] + p[:, 2] * n[:, 2]) / 2)
    y, flux = np.concatenate(y), np.concatenate(flux)
    order = np.argsort(y)
    cumulative = np.concatenate([[0.0], np.cumsum(flux[order])])
    return cumulative[np.searchsorted(y[order], heights)]


def bolt_mesh(size: str):
    """(layout, OCC's volume of the bolt [mm^3], the bolt session's tetra10 mesh with gmsh's mid-side nodes)."""
    layout = bolt_layout(size)
    sizes = default_sizes(size, "3d")
    options = bolt3d_mesh.Options3d(sizes["flank_size"], sizes["contact_size"], sizes["mesh_size"],
                                    window_of(layout, True), math.radians(WINDOW_CENTRE), math.radians(JAW_ANGLE),
                                    sizes["root_size"], None, layout.y_thread)
    cad = []

    def read():
        bolt = next(t for _, t in gmsh.model.getPhysicalGroups(3) if gmsh.model.getPhysicalName(3, t) == "bolt")
        cad.append(sum(gmsh.model.occ.getMass(3, v) for v in gmsh.model.getEntitiesForPhysicalGroup(3, bolt)))
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        gmsh.option.setNumber("Mesh.SecondOrderLinear", 0)
        gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh(size)

    top = layout.y_bearing + layout.size.nut_m
    mesh = bolt3d_mesh.mesh_with_fallback(lambda knife: _bolt_session(layout, options, top, knife), read, size,
                                          refinable=True)
    return layout, cad[-1], mesh


def _roots_to_end(layout, points, start):
    """The builder's root rule (bolt3d_mesh._is_root) without its upper end: roots up to the bolt's end."""
    r = np.hypot(points[:, 0], points[:, 2])
    root = (r < layout.size.d1 / 2) & (r > layout.size.d3 / 2 - layout.shift - bolt3d_mesh._TOL)
    return bool(np.any(root & (points[:, 1] > start)))


def _sampled(n: int):
    """gmsh's field option setter with the faces' Distance sampling (the builder's 30) replaced by n."""
    set_number = gmsh.model.mesh.field.setNumber
    return lambda field, option, value: set_number(field, option, n if (option, value) == ("Sampling", 30) else value)


def stiffness() -> None:
    """Print the elongation and the ten points' uy of tests/test_bolt3d_verification.py's SMALL model."""
    from bolt3d import layout_of, ten_points
    from bolt3d_vs_axisymmetric import elongation_points

    import _tests  # noqa: F401  (tests/ importable)
    from test_bolt3d_verification import MU, SMALL, STATIONS

    from frictionid.builders.bolt import bolt_model
    from frictionid.fem.problem import Problem
    layout, model = layout_of(SMALL), bolt_model(**SMALL)
    points, weights = elongation_points(layout, 3, STATIONS)
    ten = ten_points(layout)
    problem = Problem.build(model, points=np.vstack([points, ten]), quantities=("uy",),
                            regions=["bolt"] * (len(points) + len(ten)), factorisation="mumps")
    uy = 1000 * np.asarray(problem.solve(np.full(len(model.zone_names), MU)).observations[-1])
    changes = np.diff(uy[:len(points)].reshape(-1, len(weights)) @ weights)
    print(f"SMALL: {model.mesh.n_nodes} nodes; uy's changes between {STATIONS} [um]: {np.round(changes, 5)}, "
          f"elongation {changes.sum():.5f}")
    print(f"uy at the ten points [um]: {np.round(uy[len(points):], 5)}")


def main(argv) -> None:
    to_end = "--roots-to-end" in argv
    sampling = int(argv[argv.index("--sampling") + 1]) if "--sampling" in argv else None
    with mock.patch.object(bolt3d_mesh, "_is_root", _roots_to_end) if to_end else contextlib.nullcontext(), \
            mock.patch.object(gmsh.model.mesh.field, "setNumber", _sampled(sampling)) if sampling else \
            contextlib.nullcontext():
        if argv[0] == "--stiffness":
            return stiffness()
        size = argv[0]
        layout, cad, mesh = bolt_mesh(size)
    s, exact = layout.size, exact_volume(layout)
    cells = mesh.cells[mesh.regions["bolt"]]
    corners = mesh.points[cells[:, :4]]
    linear = np.linalg.det(corners[:, 1:] - corners[:, :1]).sum() / 6
    variant = (" roots to the end" if to_end else "") + (f" sampling {sampling}" if sampling else "")
    print(f"{size}{variant}: {mesh.n_nodes} nodes, {len(cells)} bolt cells")
    print(f"exact {exact:.4f} mm^3, OCC {cad:.4f} ({cad / exact - 1:+.2e}), linear mesh {linear / exact - 1:+.2e}")
    facets, opposite = boundary(cells)
    _root_facets(mesh.points, facets, layout)
    heights = np.array([layout.y_thread + s.P / 3, layout.y_bearing - s.P, layout.y_top + s.P, layout.length + 1])
    parts = ("head, shank, thread's start", "thread below the nut", "nut, a pitch either side", "above the nut")
    curved, moved = curved_where_valid(mesh.points, mesh.cells)
    print(f"curved_where_valid moved {moved} mid-side nodes")
    for name, points in (("gmsh's mid-side nodes", mesh.points), ("curved_where_valid", curved)):
        below = volume_below(points, facets, opposite, heights)
        print(f"{name}: {below[-1]:.4f} mm^3, against OCC {below[-1] / cad - 1:+.2e}, exact "
              f"{below[-1] / exact - 1:+.2e}")
        excess = np.diff(below - [exact_volume(layout, c) for c in heights], prepend=0.0)
        for part, (a, b), e in zip(parts, zip([-s.head_k, *heights[:-1]], heights), excess):
            print(f"  {part:28s} y {a:8.3f} to {b:8.3f}: mesh - exact {e:+.4f} mm^3 ({e / (b - a) * s.P:+.4f} per "
                  "pitch)")


def _root_facets(points: np.ndarray, facets: np.ndarray, layout) -> None:
    """Print the boundary facets below the root's tangent radius d1/2 on the thread below the nut: their number
    and longest edges (root_size is 0.12 P, the root's radius 0.144 P)."""
    s, x = layout.size, points[facets[:, :3]]
    below = np.hypot(x[..., 0], x[..., 2]) < s.d1 / 2 - layout.shift - 1e-3
    free = (x[..., 1] > layout.y_thread + s.P) & (x[..., 1] < layout.y_bearing - s.P)
    edges = np.linalg.norm(x[:, [1, 2, 0]] - x, axis=2).max(axis=1)[np.all(below & free, axis=1)]
    print(f"root facets on the thread below the nut: {len(edges)}, longest edges median "
          f"{np.median(edges) / s.P:.3f} P, largest {edges.max() / s.P:.3f} P")


if __name__ == "__main__":
    main(sys.argv[1:])
