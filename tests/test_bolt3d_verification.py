"""Issue 29's verifications of the 3-D bolt-nut model in tension on the smallest M6 models with the helix and the
seed's layout (no window, no jaws, mu 0.15 everywhere, 1,500 N): against CalculiX on the same mesh (the seed's ten
points, the machine; threads engaged over two pitches) and against the axisymmetric model of the same layout (load
share per engaged thread, bolt elongation; the full nut, five threads). The measurements and the larger runs are
in docs/bolt-study.md ("Against the axisymmetric model", "Against CalculiX on the same mesh"); the functions are
the benchmarks' (benchmarks/bolt3d_vs_axisymmetric.py, benchmarks/bolt3d_calculix.py)."""

import numpy as np
import pytest

from helpers import benchmark as _benchmark, needs_ccx

#: the smallest model with the helix and the seed's layout that CalculiX solves within a few CPU minutes: M6, threads
#: engaged over two pitches, flank_size = P (the 0.6 mm flank is 0.6 element sizes across), coarse elsewhere; 28,374
#: nodes, 833 contact pairs (build 41 s CPU, gmsh's Delaunay fails and Frontal meshes it)
SMALL = {"size": "M6", "model": "3d", "length": 24.0, "engaged_length": 2.0, "thread_length": 9.5, "n_axial": 2,
         "flank_size": 1.0, "contact_size": 3.0, "root_size": 0.3, "mesh_size": 4.0, "forces": [1500.0],
         "n_increments": 1, "cutout": False, "jaws": False}
MU = 0.15


@pytest.fixture(scope="module")
def small():
    from frictionid.builders.bolt import bolt_model
    return bolt_model(**SMALL)


@pytest.mark.slow
@needs_ccx
def test_ten_points_and_machine_against_calculix_on_the_same_mesh(small):
    """The embedded solver against ccx on the same tetra10 mesh (C3D10), one SURFACE TO SURFACE pair per zone with
    linear penalty contact, normal and stick slope 1e8 N/mm^3 (benchmarks/bolt3d_calculix.py): uy at the seed's ten
    points P1-P5 of flanks 1 and 2, the machine's displacement (plate 1's mean uy at four rim points) and the
    machine reaction (the held plate's; the machine force is prescribed, so it equals 1,500 N in both).

    The issue's 1 % of the ten points' range (0.72 um here: 7 nm) is not shown on a mesh this coarse: measured
    1.02 % with the product's order-4 quadrature (ccx above at flank 1's points, below at flank 2's) and 1.74 % with
    ccx's own 4-point C3D10 rule on the embedded side (docs/bolt-study.md, "Against CalculiX on the same mesh"). The
    1 % is checked on the 0.5 mm flank mesh against ccx's stored results (test_bolt3d_calculix_fixture.py; that ccx
    run took 11 CPU minutes); this test runs ccx, so that the backend's deck for the 3-D bolt is exercised. Checked
    here: 2 % and 2.5 % of the range; the machine's displacement within 1 % (measured -0.04 / -0.08 %) and the
    reactions to 1e-5."""
    calculix = _benchmark("bolt3d_calculix")
    from frictionid.backends.calculix.backend import CalculixSettings
    points, regions = calculix.observed(SMALL)
    ccx = calculix.ccx_result(small, points, regions, MU, CalculixSettings(normal_stiffness=1e8, stick_slope=1e8,
                                                                            timeout=3600))
    bolt, plate = slice(0, 10), slice(10, 14)
    for order, tolerance in ((4, 0.02), (2, 0.025)):
        embedded = calculix.embedded_result(small, points, regions, MU, "mumps", order)
        uy, uy_ccx = embedded["embedded"][bolt, 1], ccx["ccx"][bolt, 1]
        assert np.abs(uy_ccx - uy).max() < tolerance * np.ptp(uy), order
        machine = embedded["embedded"][plate, 1].mean()
        assert ccx["ccx"][plate, 1].mean() == pytest.approx(machine, rel=0.01)
        reactions = dict(zip(embedded["labels"], embedded["embedded_reactions"]))
        assert reactions["plate2_rim.y"] == pytest.approx(-1500.0, rel=1e-6)
        np.testing.assert_allclose(ccx["ccx_reactions"], embedded["embedded_reactions"], rtol=1e-5, atol=1e-3)


#: the full M6 nut (five rings, P 1 mm) at the same coarse sizes: 35,767 nodes, 1,585 contact pairs
FULL_NUT = {k: v for k, v in SMALL.items() if k != "engaged_length"}
#: stations on the axis [mm]: the head's centre 0.5 mm below its top face, the head's bearing face, the shank 3 mm
#: below it, the shank 4.7 mm below the thread's start (y 14.5), the bolt end's centre 0.5 mm inside it
STATIONS = (-3.5, 0.0, 3.0, 9.8, 23.5)
#: phases of the ring model averaged (benchmarks/bolt3d_vs_axisymmetric.py --phases; 16 and 32 agree to 0.3 points)
N_PHASES = 16


@pytest.fixture(scope="module")
def helix_and_rings():
    """The 3-D full nut and the axisymmetric model of its layout at mu = MU, both with the thread's load per turn
    (below the first cut, the five turns, above the last; shares of the thread force) and uy's changes between the
    STATIONS [mm]; the axisymmetric ones averaged over N_PHASES phases of its teeth (the helix's sections)."""
    compare = _benchmark("bolt3d_vs_axisymmetric")
    from frictionid.builders.bolt import bolt_model
    from frictionid.report.bolt import ring_gap, thread_loads
    layout = _benchmark("bolt3d").layout_of(FULL_NUT)
    axi = {k: v for k, v in FULL_NUT.items() if k not in compare.AXISYMMETRIC_ONLY + ("model", "cutout", "jaws")}
    rings = bolt_model(**axi)
    solution, _ = compare.solved(rings, layout, 2)
    P, n = layout.size.P, thread_loads(rings, solution).n_threads
    y_start = ring_gap(rings, solution, P)
    shares, changes = compare.phase_average(axi, layout, y_start, n, N_PHASES, heights=STATIONS)
    helix = bolt_model(**FULL_NUT)
    solution3, changes3 = compare.solved(helix, layout, 3, "mumps", heights=STATIONS)
    return {"helix": compare.shares_3d(helix, solution3, y_start, P, n)["turn, ends apart"],
            "rings": shares.mean(axis=0), "changes3": changes3, "changes": changes.mean(axis=0)}


@pytest.mark.slow
def test_load_per_turn_is_the_rings_averaged_over_the_helix_phases(helix_and_rings):
    """Load share per engaged thread within 4 % of the first thread's share (the issue asks 5 %). A ring model is
    one section of the helix: the helix at angle theta is the ring model with both threads moved by P theta / 2 pi
    past the nut's faces and countersinks. So the helix's load is counted per turn (helical coordinate
    y - P theta / 2 pi, each turn with the ring it passes at theta = 0; :func:`frictionid.report.bolt.pitch_loads`
    with ``lead = P``, cut midway between the rings' flanks) and compared with the ring model averaged over 16
    phases of its teeth, each ring counted where its teeth were before the move; the part of the thread force below
    the first cut (a part flank at the bearing face's countersink) and above the last on their own. "First share"
    is the average's first thread with the part below it (29.16 %). Measured: helix 6.53 / 23.56 / 21.58 / 18.96 /
    18.73 / 10.64 % against 5.66 / 23.50 / 22.37 / 19.63 / 18.85 / 9.99 %, largest difference 2.99 % of the first
    share (2.97 % at mesh_size 2). Against the ring model at the layout's phase alone the helix differs by 22 %:
    the ends make it (docs/bolt-study.md, "Against the axisymmetric model")."""
    helix, rings = helix_and_rings["helix"], helix_and_rings["rings"]
    assert helix.sum() == pytest.approx(1.0, abs=1e-9) and rings.sum() == pytest.approx(1.0, abs=1e-9)
    first = rings[0] + rings[1]
    assert np.abs(helix - rings).max() < 0.04 * first


@pytest.mark.slow
def test_bolt_elongation_against_the_rings_averaged_over_the_helix_phases(helix_and_rings):
    """Bolt elongation (the change of uy averaged over the bolt's sections, benchmarks/bolt3d_vs_axisymmetric.py's
    measure) against the ring model averaged over the same 16 phases (its elongation head to end varies with the
    phase: 5.843-5.993 um, average 5.880 um; the 3-D model's 5.815 um is 1.10 % below).

    What the two models share is compared station to station, from the head's bearing face (y = 0) down: the head is
    a hexagon in 3-D and the ring of the same area in axisymmetry (its change here +1.15 %, -7.65 % at mesh_size 2).
    The plain shank between 3 and 9.8 mm: within 0.5 % (measured +0.22 %; -0.19 % at mesh_size 2). Above 9.8 mm (the
    shank below the thread's start at y 14.5, the free thread, the engaged and the nut's top) the 3-D bolt is
    stiffer by 2.59 % (2.62 % at mesh_size 2): the tetrahedra at the roots (0.3 mm here). The bolt's threaded end
    alone on these sizes, without nut, contact or head (benchmarks/thread_start.py, uy on the axis), is stiffer than
    the rings by 2.49 % from 9.8 to 21 mm, and by 1.25 % and 0.56 % with the roots at 0.15 and 0.1 mm
    (docs/bolt-study.md, "Against the axisymmetric model"). Checked: stiffer by less than 3.5 %, a margin of 0.9
    points."""
    three, rings = helix_and_rings["changes3"], helix_and_rings["changes"]
    _, _, shank, thread = three / rings - 1                     # segments between consecutive STATIONS
    assert abs(shank) < 0.005
    assert -0.035 < thread < 0
