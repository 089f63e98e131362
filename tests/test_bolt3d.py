"""The 3-D bolt-nut model (builder "bolt", model = "3d"): the helical thread measured on the mesh against ISO 68-1
(lead, flank angle, pitch diameter of the 6g bolt), the conforming node pairing of the thread, the contact zones'
areas against the helicoid's, the window and the jaws, bad input.

The meshed model is a short one (two engaged pitches, the bolt threaded from a pitch below the nut, coarse); its
CAD and mesh take minutes on a shared machine, so the tests that need it are marked slow."""

import logging
import math
from dataclasses import replace

import gmsh
import numpy as np
import pytest

from frictionid.builders.bolt import bolt_model
from frictionid.builders.bolt3d import WINDOW_CENTRE, WINDOW_WIDTH, measurement_points_3d
from frictionid.builders.bolt3d_geometry import _wire, cylinder, groove_section, thread_grooves
from frictionid.builders import bolt3d_mesh
from frictionid.builders.bolt3d_mesh import mesh_with_fallback
from frictionid.builders.bolt_layout import bolt_layout
from frictionid.builders.gmsh_mesh import gmsh_session, use_size_fields
from frictionid.builders.registry import build_model
from frictionid.errors import InputError
from frictionid.fem.rigid import bodies
from frictionid.fem.space import Space
from frictionid.fem.node_to_node import node_to_node_pairs
from frictionid.options import ModelSpec

#: the short model: M20, threads engaged over two pitches, bolt threaded from 1.2 pitches below the nut, the nut
#: meshed with the bolt (node-to-node thread), the roots around the nut at R/2
SHORT = dict(size="M20", model="3d", engaged_length=5.0, thread_length=30.5, n_axial=2, flank_size=0.625,
             forces=(10000.0,), n_increments=2, nut_mesh="conforming", root_refinement="engaged",
             root_size=bolt_layout("M20").size.root_radius / 2)
SQRT3 = math.sqrt(3.0)


@pytest.fixture(scope="module")
def model():
    return bolt_model(**SHORT)


@pytest.fixture(scope="module")
def pairs(model):
    """The thread's node-to-node pairs (interface 0), made once for the tests that read them."""
    return node_to_node_pairs(Space.build(model.mesh, model.kind, model.element), model, 0)


@pytest.fixture(scope="module")
def layout():
    return bolt_layout("M20", engaged_length=5.0, n_axial=2, thread_length=30.5)


def _polar(points):
    """(r, y, phi) with phi the angle from the window's centre in [-pi, pi)."""
    theta = np.arctan2(-points[:, 2], points[:, 0])
    phi = np.mod(theta - math.radians(WINDOW_CENTRE) + math.pi, 2 * math.pi) - math.pi
    return np.hypot(points[:, 0], points[:, 2]), points[:, 1], phi


def test_groove_section_is_the_iso_profile(layout):
    """The loft's section: flanks at 30 deg to the radial direction, the root spline on the exact arc (radius H/6)
    and on the flank lines to 1e-9, the groove P - 2 (r_apex - r) / sqrt 3 wide."""
    s, z = layout.size, 100.0
    apex = s.d / 2 + s.H / 8 - layout.shift
    pieces = groove_section(layout, z)
    lines = [np.array(p) for kind, p in pieces if kind == "line"]
    for a, b in lines[:-1]:
        assert math.degrees(math.atan2(abs(b[1] - a[1]), abs(b[0] - a[0]))) == pytest.approx(30.0, abs=1e-9)
    root = np.vstack([p for kind, p in pieces if kind == "spline"])
    centre = np.array([s.d1 / 2 - layout.shift + s.root_radius / 2, z + s.P / 2])
    on_arc = np.abs(np.linalg.norm(root - centre, axis=1) - s.root_radius) < 1e-9
    on_free = np.abs(root[:, 1] - (z + (apex - root[:, 0]) / SQRT3)) < 1e-9
    on_load = np.abs(root[:, 1] - (z + s.P - (apex - root[:, 0]) / SQRT3)) < 1e-9
    assert np.all(on_arc | on_free | on_load) and on_arc.sum() > 10
    assert root[:, 0].min() == pytest.approx(s.d3 / 2 - layout.shift, abs=1e-6)


def test_helix_starts_at_the_thread_plane_as_the_rings_do():
    """The helical thread starts at the plane y = y_thread at every angle, as the axisymmetric profile does at every
    phase of its teeth, so that each section of the helix is the ring model at that phase: a rod cut by the
    builder's grooves keeps the shank's whole section over the pitch below the plane, and over the first pitch above
    it holds the rings' volume per pitch (the shank minus the groove's volume of revolution, Pappus), as it does a
    pitch further up. Whole groove turns (the lowest at most half a pitch below the plane at its seam) left 24.74
    mm^3 there on this M6 against 22.54 (a pitch further up: 22.54)."""
    layout = bolt_layout("M6", length=24.0, n_axial=2, thread_length=9.5)
    P, y0, r = layout.size.P, layout.y_thread, layout.r_shank
    with gmsh_session("thread start"):
        occ = gmsh.model.occ
        grooves = [g for g in thread_grooves(layout, math.pi) if occ.getBoundingBox(*g)[1] < y0 + 3 * P]
        rod, _ = occ.cut([(3, cylinder(r, 0.0, y0 + 3 * P))], grooves)
        slabs = []
        for y in (y0 - P, y0, y0 + P):
            piece, _ = occ.intersect(rod, [(3, cylinder(2 * r, y, y + P))], removeObject=False)
            occ.synchronize()
            slabs.append(sum(occ.getMass(3, tag) for dim, tag in piece if dim == 3))
        ring = occ.addPlaneSurface([_wire(groove_section(layout, 0.0), 0.0, 0.0)])
        inside, _ = occ.intersect([(2, ring)], [(2, occ.addRectangle(0.0, -P, 0.0, r, 3 * P))])
        occ.synchronize()
        groove = sum(2 * math.pi * occ.getCenterOfMass(2, tag)[0] * occ.getMass(2, tag) for _, tag in inside)
    assert slabs[0] == pytest.approx(math.pi * r ** 2 * P, rel=1e-6)
    assert slabs[1] == pytest.approx(slabs[2], rel=1e-6)
    # the loft through SECTIONS sections per turn holds 1.5e-4 less than the ring (0.0033 mm^3 per pitch)
    assert slabs[1] == pytest.approx(math.pi * r ** 2 * P - groove, rel=5e-4)


@pytest.mark.parametrize("options, message", [
    ({"model": "2d"}, "`model`"),
    ({"model": "3d", "cutout": {"width": 200}}, "`cutout.width`"),
    ({"model": "3d", "cutout": {"depth": 9.0}}, "`cutout.depth`"),
    ({"model": "3d", "cutout": {"widht": 30}}, "did you mean 'width'"),
    ({"model": "3d", "jaws": "yes"}, "`jaws`"),
    ({"model": "3d", "load": "torque"}, "`load`"),
    ({"model": "3d", "load": "tightening", "jaws": True}, "`jaws` = true holds the nut"),
    ({"model": "3d", "load": "tightening", "torques": [40.0]}, "`torques`"),
    ({"model": "3d", "load": "tightening", "angles": [-1.0]}, "angles"),
    ({"model": "3d", "flank_size": 3.0}, "`flank_size`"),
    ({"model": "3d", "head_size": 0.0}, "`head_size`"),
    ({"model": "3d", "nut_mesh": "apart"}, "`nut_mesh`"),
    ({"model": "3d", "root_refinement": "nut"}, "`root_refinement`"),
    ({"model": "3d", "load": "tightening", "nut_mesh": "separate"}, "`nut_mesh` = \"separate\""),
    ({"thread_length": 10.0}, "`thread_length`"),
])
def test_bad_options_name_the_key(options, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        build_model(ModelSpec.from_table({"builder": "bolt", **options}))


class _Meshed(Exception):
    """Raised by the mesher's stand-in: the options the 3-D builder meshes with, and which mesher."""


def _meshing(monkeypatch) -> None:
    from frictionid.builders import bolt3d

    for name in ("bolt3d_mesh", "separate_mesh"):
        monkeypatch.setattr(bolt3d, name, lambda layout, options, top, name=name: (_ for _ in ()).throw(
            _Meshed(name, options)))


def _meshed_with(**options) -> tuple[str, "bolt3d_mesh.Options3d"]:
    with pytest.raises(_Meshed) as meshed:
        bolt_model(model="3d", **options)
    return meshed.value.args


def test_3d_defaults_separate_nut_in_tension_conforming_in_tightening_roots_from_the_thread(monkeypatch):
    """The 3-D defaults (docs/models.md): flanks 0.75 P, bearings 1.5 P, largest 2 P, roots 0.12 P (M20: 1.875,
    3.75, 5.0, 0.3 mm) refined from the thread's start; the nut meshed on its own in tension and with the bolt in
    tightening; an explicit choice wins."""
    _meshing(monkeypatch)
    layout = bolt_layout("M20")
    mesher, options = _meshed_with()
    assert mesher == "separate_mesh"
    assert (options.flank_size, options.contact_size, options.mesh_size, options.root_size) == (1.875, 3.75, 5.0, 0.3)
    assert options.root_start == layout.y_thread
    assert _meshed_with(load="tightening")[0] == "bolt3d_mesh"
    assert _meshed_with(nut_mesh="conforming")[0] == "bolt3d_mesh"
    assert _meshed_with(root_refinement="engaged")[1].root_start is None
    assert _meshed_with(size="M6")[1].root_size == pytest.approx(0.12)


def test_root_refinement_thread_reaches_the_thread_start_engaged_the_nut_only():
    """The faces meshed at ``root_size`` (:func:`bolt3d_mesh.classify_faces`' "bolt_root") on an M6 threaded 12 mm
    (from y 12; the nut's bearing face at 15.8, P 1): with "thread" (root_start at the thread's start) they reach
    down to the thread's start, with "engaged" (None) only to about a pitch below the nut (measured 13.8, a face
    reaching the range with some of its points); both up to a pitch above the nut's top."""
    layout = bolt_layout("M6", length=24.0, thread_length=12.0)
    lowest, highest = {}, {}
    with gmsh_session("roots"):
        options = bolt3d_mesh.Options3d(0.75, 1.5, 2.0, None, 0.0, math.pi / 2, 0.12)
        volumes = bolt3d_mesh.fragment_bodies(layout, options, layout.y_top)
        for start in (layout.y_thread, None):
            names = bolt3d_mesh.classify_faces(layout, replace(options, root_start=start), volumes)
            y = np.concatenate([bolt3d_mesh.face_points(f, 6)[:, 1] for f in names["bolt_root"]])
            lowest[start], highest[start] = y.min(), y.max()
    P = layout.size.P
    assert lowest[layout.y_thread] < layout.y_thread + P / 4
    assert layout.y_bearing - 3 * P < lowest[None] < layout.y_bearing
    assert highest[None] == highest[layout.y_thread] > layout.y_top


def test_measurement_points_are_the_axisymmetric_ones_in_the_window(layout):
    """P1-P5 of flanks 1 and 2 lie in the window's centre section, at the axisymmetric model's (r, y)."""
    from frictionid.builders.bolt import measurement_points
    points = measurement_points_3d(layout)
    r, y, phi = _polar(points)
    section = measurement_points(layout)
    np.testing.assert_allclose(np.column_stack([r, y]), section, atol=1e-12)
    np.testing.assert_allclose(phi, 0.0, atol=1e-12)


@pytest.mark.slow
def test_bodies_have_their_own_nodes(model):
    """Four bodies (no node shared across the conforming interfaces), every region one body."""
    label = bodies(model.mesh)
    assert label.max() + 1 == 4
    for name, cells in model.mesh.regions.items():
        assert np.unique(label[model.mesh.cells[cells]]).size == 1, name


@pytest.mark.slow
def test_thread_pairs_are_coincident_nodes_of_bolt_and_nut(model, pairs):
    """Every contact node of the thread faces a nut node at its place (zero gap to round-off), on the nut."""
    label = bodies(model.mesh)
    bolt, nut = (label[model.mesh.cells[model.mesh.regions[n][0]][0]] for n in ("bolt", "nut"))
    assert np.all(label[pairs.nodes] == bolt)
    target = model.mesh.boundary_nodes("nut_contact")
    assert np.all(label[target] == nut) and len(target) == len(pairs.nodes)
    assert np.abs(pairs.gap).max() < 1e-9
    _, _, phi = _polar(model.mesh.points[pairs.nodes])
    assert np.all(np.abs(phi) >= math.radians(WINDOW_WIDTH) / 2 - 1e-6), "a thread pair inside the window"


@pytest.mark.slow
def test_helix_on_the_mesh_is_iso_68_1(model, layout):
    """Bolt flank nodes fitted by y = c_k + L phi / 2 pi +- t r: lead L = P, flank half-angle atan(t) = 30 deg,
    and the radius where the tooth is P/2 thick is the 6g pitch diameter d2 + es (ISO 965-1), to 5 um (es is
    -42 um). Fitted on the facets' vertices, which gmsh places on the CAD faces: the quadratic tets are
    straight-sided, so mid-side nodes lie on chords of the helicoid (1.25 mm edges on r = 9 mm: 22 um inside)."""
    s = layout.size
    fits = {}
    for name in ("nut_contact_bolt", "bolt_free"):
        boundary = "bolt_free" if name == "bolt_free" else None
        faces = [boundary] if boundary else model.interfaces[0].zones
        nodes = np.unique(np.concatenate([model.mesh.boundary(face)[:, :3] for face in faces]))   # vertices
        r, y, phi = _polar(model.mesh.points[nodes])
        eta = y - s.P * phi / (2 * math.pi)
        tooth = np.round((eta - layout.bolt_phase) / s.P).astype(int)
        teeth = np.unique(tooth)
        columns = [tooth == k for k in teeth] + [phi / (2 * math.pi), r]
        coefficients, *_ = np.linalg.lstsq(np.column_stack(columns).astype(float), y, rcond=None)
        residual = y - np.column_stack(columns).astype(float) @ coefficients
        assert np.abs(residual).max() < 1e-2
        fits[name] = dict(zip(teeth, coefficients[:-2])), coefficients[-2], coefficients[-1]
    (load_c, load_lead, load_t), (free_c, free_lead, free_t) = fits["nut_contact_bolt"], fits["bolt_free"]
    for lead, t in ((load_lead, load_t), (free_lead, -free_t)):
        assert lead == pytest.approx(s.P, abs=2e-3)
        assert math.degrees(math.atan(t)) == pytest.approx(30.0, abs=0.05)
    k = next(k for k in load_c if k - 1 in free_c)          # tooth k - 1: free flank above it, load flank below k
    # thickness of tooth k - 1 at r: load flank of tooth k - 1 is load_c[k] - P (same helix), free flank free_c
    d2 = 2 * ((free_c[k - 1] - (load_c[k] - s.P)) - s.P / 2) / (load_t - free_t)
    assert d2 == pytest.approx(s.d2 + s.es, abs=5e-3)


@pytest.mark.slow
def test_zone_areas_are_the_helicoid_areas(model, layout, pairs):
    """The tributary areas of the thread pairs per radial part (outer: A, B; inner: C, D) against the helicoid's
    area integrated over the exact engaged region (nut crest D1/2 to bolt crest, above the countersink, below the
    engaged length, outside the window), to 1 %."""
    s = layout.size
    zones = model.interfaces[0].zones
    area = (pairs.weight[:, None] * pairs.zone_share[:, [model.zone_names.index(z) for z in zones]]).sum(axis=0)
    outer = sum(a for z, a in zip(zones, area) if z in "AB")
    inner = sum(a for z, a in zip(zones, area) if z in "CD")
    expected = [_helicoid_area(layout, s.d2 / 2, s.d / 2 - layout.shift),
                _helicoid_area(layout, s.d1 / 2, s.d2 / 2)]
    np.testing.assert_allclose([outer, inner], expected, rtol=0.01)


def _helicoid_area(layout, r0: float, r1: float, n: int = 400) -> float:
    """Area [mm^2] of the bolt load flanks between radii r0 and r1 where the nut's threaded bore faces them."""
    s = layout.size
    apex = s.d / 2 + s.H / 8 - layout.shift
    r = r0 + (np.arange(n) + 0.5) / n * (r1 - r0)
    phi = -math.pi + (np.arange(8 * n) + 0.5) / (8 * n) * 2 * math.pi
    R, PHI = np.meshgrid(r, phi, indexing="ij")
    t, lead = 1 / SQRT3, s.P
    element = np.sqrt(R ** 2 * (1 + t ** 2) + (lead / (2 * math.pi)) ** 2) * (r1 - r0) / n * 2 * math.pi / (8 * n)
    total = 0.0
    for k in range(-50, 50):
        y = layout.bolt_phase + k * s.P + lead * PHI / (2 * math.pi) - (apex - R) / SQRT3
        inside = (y >= layout.y_bearing + (s.da / 2 - R) / SQRT3) & (y <= layout.y_bearing + 5.0)
        inside &= np.abs(PHI) >= math.radians(WINDOW_WIDTH) / 2
        total += element[inside].sum()
    return total


@pytest.mark.slow
def test_window_and_jaw_faces(model, layout):
    """The window's nut faces are its two walls (on the planes at +-width/2), the bolt faces in it lie in the
    sector within the nut's height; the jaws are the two flats normal to z at s/2."""
    s = layout.size
    nut = model.mesh.points[model.mesh.boundary_nodes("window_nut")]
    _, _, phi = _polar(nut)
    np.testing.assert_allclose(np.abs(phi), math.radians(WINDOW_WIDTH) / 2, atol=1e-6)
    bolt = model.mesh.points[model.mesh.boundary_nodes("window_bolt")]
    _, y, phi = _polar(bolt)
    assert np.all(np.abs(phi) <= math.radians(WINDOW_WIDTH) / 2 + 1e-6)
    assert np.all((y >= layout.y_bearing - 1e-6) & (y <= layout.y_top + 1e-6))
    jaws = model.mesh.points[model.mesh.boundary_nodes("nut_jaws")]
    np.testing.assert_allclose(np.abs(jaws[:, 2]), s.nut_s / 2, atol=1e-9)
    assert (jaws[:, 2] > 0).any() and (jaws[:, 2] < 0).any()



#: the M6 of tests/test_bolt3d_verification.py (SMALL) with the nut meshed on its own
SEPARATE = dict(size="M6", model="3d", length=24.0, engaged_length=2.0, thread_length=9.5, n_axial=2, flank_size=1.0,
                contact_size=3.0, root_size=0.3, mesh_size=4.0, forces=(1500.0,), n_increments=1, cutout=False,
                jaws=False, nut_mesh="separate", root_refinement="engaged")


@pytest.mark.slow
def test_separate_nut_is_coupled_by_mortar_with_the_zones_on_its_flanks():
    """``nut_mesh = "separate"``: four bodies; the thread a mortar interface whose contact side (zones, pairs) is
    the nut's load flanks and whose target "bolt_contact" is the bolt's, both sides the same area (one helicoid,
    within 1 %); the pairs follow the nut's flank_size, not the bolt's root refinement (fewer than 0.7 times the
    bolt's flank nodes: 363 against 562). The meshes' initial gaps (curved mid-side nodes kept on one side and not
    on the other) are tens of um at most, far from the next turn's flank 0.87 P = 866 um behind the nut's tooth,
    which is not coupled; the builder sets them to zero (``adjust``). Measured: gaps -27.2 to +3.6 um (RMS 3.8);
    9 of the 372 nut flank nodes fall below the mortar's coverage rule, the pairs' area is 99.6 % of the zones'
    (90 % when the clipping took the curved facets' corner triangles: 58 nodes left out): checked 98 %."""
    from frictionid.fem.interface import interface_pairs
    from frictionid.fem.mortar3d import dual_coefficients, mortar_pairs_3d

    model = bolt_model(**SEPARATE)
    mesh, thread = model.mesh, model.interfaces[0]
    assert (thread.discretisation, thread.target, thread.adjust) == ("mortar", "bolt_contact", True)
    label = bodies(mesh)
    assert label.max() + 1 == 4
    nut, bolt = (label[mesh.cells[mesh.regions[n][0]][0]] for n in ("nut", "bolt"))
    space = Space.build(mesh, model.kind, model.element)
    pairs, how = interface_pairs(space, model, 0)
    assert how == "mortar" and np.all(label[pairs.nodes] == nut) and np.all(pairs.gap == 0)
    target = mesh.boundary_nodes("bolt_contact")
    assert np.all(label[target] == bolt)
    zone_nodes = np.unique(np.concatenate([mesh.boundary_nodes(z) for z in thread.zones]))
    assert np.all(np.isin(pairs.nodes, zone_nodes))
    area = [dual_coefficients(mesh.points[np.vstack([mesh.boundary(b) for b in names])], "triangle6")[1].sum()
            for names in (thread.zones, ("bolt_contact",))]
    assert area[0] == pytest.approx(area[1], rel=0.01) and 0.98 * area[0] < pairs.weight.sum() <= area[0] * 1.001
    assert pairs.n_pairs < 0.7 * len(target)
    geometric = mortar_pairs_3d(space, model, 0).gap
    assert np.abs(geometric).max() < 0.1 * 1.0
    # the nut flank nodes the mortar leaves out are eliminated last as well: the small-sliding check reads the
    # interfaces from the Schur factors ("mumps") instead of making every body's factor again
    from frictionid.fem import mumps_schur
    from frictionid.fem.problem import Problem
    if mumps_schur.available():
        assert pairs.n_pairs < len(zone_nodes)
        problem = Problem.build(model, factorisation="mumps")
        solution = problem.solve(np.full(len(model.zone_names), 0.15), max_slip=None)
        assert problem.interface_displacement(solution, [0])[1]


def _failing_mesher(monkeypatch, failures: int) -> list[float]:
    """gmsh's volume meshing made to fail with its PLC error the first ``failures`` times (after the surface
    mesh, as a real failure); returns the list that records Mesh.Algorithm3D at each attempt."""
    tried, generate = [], gmsh.model.mesh.generate

    def flaky(dim):
        tried.append(gmsh.option.getNumber("Mesh.Algorithm3D"))
        if len(tried) <= failures:
            generate(2)
            raise Exception("PLC Error:  A segment and a facet intersect at point")
        generate(dim)

    monkeypatch.setattr(gmsh.model.mesh, "generate", flaky)
    return tried


def _box():
    gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)


def test_head_size_meshes_the_head_and_its_transition_only():
    """``head_size``'s field (:func:`bolt3d_mesh.head_field`) on a block from y = -2 k to 3 k around the M6 head
    (k 4 mm, s 10 mm): edges of about head_size 0.5 mm in the head's box, mesh_size 4 mm beyond its k/2
    transition."""
    layout = bolt_layout("M6")
    k, corner = layout.size.head_k, layout.size.head_s / SQRT3
    with gmsh_session("head"):
        gmsh.model.occ.addBox(-2 * corner, -2 * k, -2 * corner, 4 * corner, 5 * k, 4 * corner)
        gmsh.model.occ.synchronize()
        use_size_fields(bolt3d_mesh.head_field(layout, 0.5, 4.0))
        gmsh.option.setNumber("Mesh.MeshSizeMax", 4.0)
        gmsh.model.mesh.generate(3)
        _, tags, nodes = gmsh.model.mesh.getElements(3)
        node_tags, xyz, _ = gmsh.model.mesh.getNodes()
    index = np.zeros(int(node_tags.max()) + 1, dtype=int)
    index[node_tags.astype(int)] = np.arange(len(node_tags))
    corners = xyz.reshape(-1, 3)[index[np.asarray(nodes[0], dtype=int).reshape(-1, 4)]]
    edge = np.linalg.norm(corners[:, 1] - corners[:, 0], axis=1)
    centre = corners.mean(axis=1)
    inside = (np.abs(centre[:, [0, 2]]).max(axis=1) < corner) & (centre[:, 1] > -k) & (centre[:, 1] < 0)
    far = centre[:, 1] > k
    # gmsh's edges come out about 1.1-1.4 times the size asked (measured 0.70 mm inside, 4.3 mm beyond)
    assert np.median(edge[inside]) < 1.5 * 0.5 and np.median(edge[far]) > 0.75 * 4.0


def _tetrahedra() -> int:
    _, tags, _ = gmsh.model.mesh.getElements(3)
    return sum(len(t) for t in tags)


def test_volume_mesher_falls_back_to_frontal(monkeypatch, caplog):
    """Delaunay failing with a PLC error: a new session, Frontal meshes it, and the log says so."""
    tried = _failing_mesher(monkeypatch, 1)
    with caplog.at_level(logging.WARNING, logger="frictionid.builders.bolt3d_mesh"):
        n_tets = mesh_with_fallback(_box, _tetrahedra, "box")
    assert tried == [1, 4] and n_tets > 0
    assert "box: gmsh's Delaunay 3-D mesher failed (PLC Error" in caplog.text and "trying Frontal" in caplog.text


def test_volume_mesher_tries_frontal_when_the_mesh_read_is_refused(caplog):
    """A volume mesh that gmsh makes without an error but that the reader refuses (on the separate nut's M36 bolt
    with the 3-D defaults, Frontal left nodes of a face in no cell) is a failure of that algorithm as well."""
    reads = []

    def read():
        reads.append(gmsh.option.getNumber("Mesh.Algorithm3D"))
        if len(reads) == 1:
            raise InputError("box: boundary 'side' has nodes that belong to no cell")
        return _tetrahedra()

    with caplog.at_level(logging.WARNING, logger="frictionid.builders.bolt3d_mesh"):
        assert mesh_with_fallback(_box, read, "box") > 0
    assert reads == [1, 4] and "Delaunay 3-D mesher failed (box: boundary 'side'" in caplog.text

    def refused():
        raise InputError("box: boundary 'side' has nodes that belong to no cell")

    with pytest.raises(InputError, match=r"Delaunay: box: boundary 'side'.*Frontal: box: boundary 'side'.*nut_mesh"):
        mesh_with_fallback(_box, refused, "box")


def test_volume_mesher_says_when_every_algorithm_fails(monkeypatch):
    tried = _failing_mesher(monkeypatch, 2)
    with pytest.raises(InputError, match=r"box: gmsh could not mesh the volumes \(Delaunay: PLC Error.*Frontal: PLC"):
        mesh_with_fallback(_box, _tetrahedra, "box")
    assert tried == [1, 4]


def test_volume_mesher_refines_the_knife_edges_after_the_attempts_without(monkeypatch, caplog):
    """A model with knife edges (``make`` returns true) is tried as it is by each algorithm first (a model that
    meshes so keeps its mesh), then with the edges refined; a model without them is not tried twice."""
    tried = _failing_mesher(monkeypatch, 2)
    knives = []

    def make(knife):
        knives.append(knife)
        _box()
        return True

    with caplog.at_level(logging.WARNING, logger="frictionid.builders.bolt3d_mesh"):
        assert mesh_with_fallback(make, _tetrahedra, "box", refinable=True) > 0
    assert tried == [1, 4, 1] and knives == [False, False, True]
    assert "Frontal 3-D mesher failed (PLC Error" in caplog.text
    assert "trying Delaunay (knife edges refined)" in caplog.text

    tried.clear()
    monkeypatch.setattr(gmsh.model.mesh, "generate", lambda dim: (_ for _ in ()).throw(Exception("PLC Error")))
    with pytest.raises(InputError, match=r"Delaunay: PLC Error; Frontal: PLC Error\)"):
        mesh_with_fallback(lambda knife: _box() or False, _tetrahedra, "box", refinable=True)
