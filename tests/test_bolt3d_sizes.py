"""The 3-D bolt at the defaults on a size other than the M20 and M6: the M36, whose knife edge (the nut's top
countersink meeting a load flank at about 2 deg, opposite the window: builders/bolt3d_knife.py) made gmsh's volume
mesher fail in the separate nut's bolt session. The M36 build takes minutes (docs/bolt-study.md), so all tests
here are slow (make check only)."""

import math

import gmsh
import numpy as np
import pytest
from skfem.quadrature import get_quadrature
from skfem.refdom import RefTet

from helpers import benchmark
from frictionid.builders.bolt import bolt_model, default_sizes
from frictionid.builders.bolt3d import JAW_ANGLE, WINDOW_CENTRE, window_of
from frictionid.builders.bolt3d_knife import knife_edges, tangency_lines
from frictionid.builders.bolt3d_mesh import Options3d, fragment_bodies
from frictionid.builders.bolt_layout import bolt_layout
from frictionid.builders.gmsh_mesh import gmsh_session
from frictionid.fem.interface import interface_pairs
from frictionid.fem.rigid import bodies
from frictionid.fem.space import Space

#: the stored CalculiX fixture's M6 (no window, two engaged pitches: the bearing face's countersink meets a free
#: flank in the nut's material, the top one meets none, the thread being relieved above the engaged length)
FIXTURE_M6 = dict(size="M6", length=24.0, engaged_length=2.0, thread_length=9.5, n_axial=2)


def _options(layout, size: str, cutout) -> Options3d:
    sizes = default_sizes(size, "3d")
    return Options3d(sizes["flank_size"], sizes["contact_size"], sizes["mesh_size"], window_of(layout, cutout),
                     math.radians(WINDOW_CENTRE), math.radians(JAW_ANGLE), sizes["root_size"], None, layout.y_thread)


def _layout(size="M20", length=None, engaged_length=None, thread_length=None, n_axial=3):
    return bolt_layout(size, length, engaged_length, None, 2, n_axial, None, thread_length)


def _normal(face: int, point) -> np.ndarray:
    """Unit normal of a face at the point of it closest to ``point``."""
    _, uv = gmsh.model.getClosestPoint(2, face, list(point))
    normal = np.asarray(gmsh.model.getNormal(face, list(uv)))
    return normal / np.linalg.norm(normal)


@pytest.mark.slow
def test_knife_edges_are_where_a_countersink_meets_a_flank_at_a_small_angle():
    """On the fixture's M6 the detected curves lie at the bearing face's tangency angle, and at each the cone and
    the flank beside it meet at under 3.5 deg (measured 2.80 and 3.09 deg at the two curves' middles, r = 2.83 and
    2.56 mm; the estimate cos 30 deg P / (2 pi r) gives 2.79 and 3.08); at the 3-D defaults of the M6 and the M20
    the tangency lines lie in the window: no knife edge."""
    layout = _layout(**FIXTURE_M6)
    with gmsh_session():
        fragment_bodies(layout, _options(layout, "M6", False), layout.y_bearing + FIXTURE_M6["engaged_length"])
        edges = knife_edges(layout, math.radians(WINDOW_CENTRE))
        assert edges
        for curve in edges:
            lo, hi = gmsh.model.getParametrizationBounds(1, curve)
            point = gmsh.model.getValue(1, curve, [(lo[0] + hi[0]) / 2])
            assert abs(point[1] - layout.y_bearing) < layout.size.P       # the bearing face's countersink
            faces = [abs(f) for f in gmsh.model.getAdjacencies(1, curve)[0]]
            cones = [f for f in faces if gmsh.model.getType(2, f) == "Cone"]
            flanks = [f for f in faces if gmsh.model.getType(2, f) != "Cone"]
            assert cones and flanks
            angles = [math.degrees(math.acos(min(1.0, abs(_normal(c, point) @ _normal(f, point)))))
                      for c in cones for f in flanks]
            assert min(angles) < 3.5, angles
    for size in ("M6", "M20"):
        layout = _layout(size)
        lines = tangency_lines(layout, math.radians(WINDOW_CENTRE))
        half = math.radians(window_of(layout, True).width) / 2
        assert all(abs(math.remainder(theta - math.radians(WINDOW_CENTRE), 2 * math.pi)) < half
                   for theta, _, _ in lines), size


def _volumes(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(n_cells,) [mm^3] volumes of quadratic tetrahedra (meshio order), det J integrated exactly (degree 3)."""
    X, W = get_quadrature(RefTet, 3)
    out = np.zeros(len(cells))
    x = points[cells]                                               # (n, 10, 3)
    edges = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))
    grad_l = np.array([[-1.0, -1.0, -1.0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    for xi, w in zip(X.T, W):
        lam = np.array([1 - xi.sum(), *xi])
        grads = [(4 * lam[i] - 1) * grad_l[i] for i in range(4)]
        grads += [4 * (lam[i] * grad_l[j] + lam[j] * grad_l[i]) for i, j in edges]
        jac = np.einsum("nka,kb->nab", x, np.array(grads))
        out += w * np.linalg.det(jac)
    return out


def _cad_volumes(layout, options, engaged_top) -> dict[str, float]:
    """[mm^3] each body's volume in the CAD (OCC's, of the fragment the mesh is made of)."""
    with gmsh_session():
        volumes = fragment_bodies(layout, options, engaged_top)
        return {body: sum(gmsh.model.occ.getMass(3, t) for t in tags) for body, tags in volumes.items()}


#: relative volume tolerance of the nut and the plates against their CAD (measured on the M36: 8.6e-6, 1.7e-6;
#: the knife edge's wedge of the bolt is 88 mm^3, 3.3e-4 of the bolt), and of the bolt's CAD against its exact
#: volume (benchmarks/bolt3d_volume.py; measured -2.0e-5 on the fixture's M6, -4.5e-5 on the M8, -4.7e-5 on the M36)
VOLUME_RTOL = 1e-4
#: the bolt's mesh is larger than its CAD by 8.3e-4 on the M36 (7.6e-4 on the M8, 8.0e-4 on the M10): its roots
#: are bridged where the elements are larger than the root (0.5 P across, 0.3 P deep). Above the nut, where the
#: roots are refined only up to a pitch above its top (M8: all of it, within 3e-5 of the CAD with the roots refined
#: to the bolt's end; M36: 150 of its 219 mm^3); on the M36 also along the thread, whose roots' size field samples
#: each turn's face 3.4 mm apart (+3.7 mm^3 per pitch). docs/bolt-study.md, "The bolt's mesh volume against its
#: CAD". Its volume is checked to lie between the CAD's and 1.5e-3 above it
BOLT_EXCESS = 1.5e-3


@pytest.mark.slow
def test_bolt_cad_is_its_exact_volume():
    """OCC's volume of the bolt's CAD (the fragment's bolt volumes: head, blank, the lofted grooves cut off at the
    thread's start) is the bolt's exact volume from the ISO profile (benchmarks/bolt3d_volume.py: the head's prism,
    the blank, 2 pi int r w(r) / P dr per mm of thread for the grooves) within VOLUME_RTOL, on the fixture's M6
    and the M8 at the defaults (measured -2.0e-5, -4.5e-5): the CAD is not what makes the bolt's mesh larger
    (BOLT_EXCESS). A root radius 1.2 times the ISO one in the grooves' section makes it -1.6e-3."""
    exact_volume = benchmark("bolt3d_volume").exact_volume
    for size, options in (("M6", FIXTURE_M6), ("M8", {"size": "M8"})):
        layout = _layout(**options)
        cad = _cad_volumes(layout, _options(layout, size, True), layout.y_bearing + layout.size.nut_m)
        assert cad["bolt"] == pytest.approx(exact_volume(layout), rel=VOLUME_RTOL), size


def check_mesh(mesh, layout, cad: dict[str, float]) -> None:
    """Every node in a cell, four bodies, every region one body, no cell of negative volume; each body's volume
    its CAD's (``cad``: [mm^3] by body), the bolt's CAD its exact volume and each plate's its annulus'."""
    assert np.array_equal(np.unique(mesh.cells), np.arange(mesh.n_nodes))
    label = bodies(mesh)
    assert label.max() + 1 == 4
    for name, cells in mesh.regions.items():
        assert np.unique(label[mesh.cells[cells]]).size == 1, name
    volume = _volumes(mesh.points, mesh.cells)
    assert np.all(volume > 0)
    assert cad["bolt"] == pytest.approx(benchmark("bolt3d_volume").exact_volume(layout), rel=VOLUME_RTOL)
    for body, cells in mesh.regions.items():
        if body == "bolt":
            assert 0 < volume[cells].sum() / cad[body] - 1 < BOLT_EXCESS
        else:
            assert volume[cells].sum() == pytest.approx(cad[body], rel=VOLUME_RTOL), body
    for body, (y0, y1) in (("plate1", layout.plate1), ("plate2", layout.plate2)):
        annulus = math.pi * (layout.r_outer ** 2 - layout.r_hole ** 2) * (y1 - y0)
        assert volume[mesh.regions[body]].sum() == pytest.approx(annulus, rel=VOLUME_RTOL), body


@pytest.mark.slow
def test_m36_meshes_at_the_3d_defaults():
    """The M36 at the defaults (nut meshed on its own, roots from the thread's start): :func:`check_mesh`; the
    thread's mortar pairs cover the nut's flanks (at least 98 % of the zones' area, as on the short model), head
    and nut bearing paired node to node at zero gap."""
    model = bolt_model(size="M36", model="3d")
    layout = bolt_layout("M36")
    check_mesh(model.mesh, layout, _cad_volumes(layout, _options(layout, "M36", True),
                                                layout.y_bearing + layout.size.nut_m))
    mesh = model.mesh

    space = Space.build(mesh, model.kind, model.element)
    thread = model.interfaces[0]
    pairs, how = interface_pairs(space, model, 0)
    assert how == "mortar" and pairs.n_pairs > 0 and np.all(pairs.gap == 0)
    from frictionid.fem.mortar3d import dual_coefficients
    zones = mesh.points[np.vstack([mesh.boundary(zone) for zone in thread.zones])]
    assert pairs.weight.sum() > 0.98 * dual_coefficients(zones, "triangle6")[1].sum()
    for i in (1, 2):
        pairs, how = interface_pairs(space, model, i)
        target = mesh.boundary_nodes(model.interfaces[i].target)
        assert how == "node-to-node" and pairs.n_pairs == len(target) and np.abs(pairs.gap).max() < 1e-9
