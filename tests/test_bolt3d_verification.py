"""Issue 29's verifications of the 3-D bolt-nut model in tension on the smallest M6 models with the helix and the
seed's layout (no window, no jaws, mu 0.15 everywhere, 1,500 N) against the axisymmetric model of the same layout
(load share per engaged thread, bolt elongation; the full nut, five threads), the full nut also with the nut meshed
on its own (``nut_mesh = "separate"``, the thread by dual mortar) against both. SMALL (threads engaged over two
pitches), with coarser roots and volume, is the model tests/test_bolt3d_calculix_live.py runs CalculiX on. The
measurements and the larger runs are in docs/bolt-study.md ("Against the axisymmetric model", "Against CalculiX on
the same mesh"); the functions are the benchmark's (benchmarks/bolt3d_vs_axisymmetric.py)."""

import numpy as np
import pytest

from helpers import benchmark as _benchmark

#: the smallest model with the helix and the seed's layout that CalculiX solves within a few CPU minutes: M6, threads
#: engaged over two pitches, flank_size = P (the 0.6 mm flank is 0.6 element sizes across), coarse elsewhere; 28,374
#: nodes, 833 contact pairs (build 41 s CPU, gmsh's Delaunay fails and Frontal meshes it)
SMALL = {"size": "M6", "model": "3d", "length": 24.0, "engaged_length": 2.0, "thread_length": 9.5, "n_axial": 2,
         "flank_size": 1.0, "contact_size": 3.0, "root_size": 0.3, "mesh_size": 4.0, "forces": [1500.0],
         "n_increments": 1, "cutout": False, "jaws": False, "nut_mesh": "conforming", "root_refinement": "engaged"}
MU = 0.15


#: the full M6 nut (five rings, P 1 mm) at the same sizes, but the bolt's roots inside the nut at 0.125 mm (R is
#: 0.144 mm) and its head at 0.75 mm: 87,754 nodes, 2,751 contact pairs (build 47 s CPU, Frontal); at the coarse
#: sizes alone (roots 0.3 mm, head at the others' sizes) the thread and the head were too stiff by 2.6 % and from
#: +1.2 to -7.7 % with mesh_size (docs/bolt-study.md, "Against the axisymmetric model")
FULL_NUT = {**{k: v for k, v in SMALL.items() if k != "engaged_length"}, "root_size": 0.125, "head_size": 0.75}
#: stations [mm] where uy is averaged over the bolt's section: 0.5 mm below the head's top face, the head's bearing
#: face, the shank 3 mm below it, the shank 4.7 mm below the thread's start (y 14.5), 0.5 mm inside the bolt end
STATIONS = (-3.5, 0.0, 3.0, 9.8, 23.5)
#: phases of the ring model averaged (benchmarks/bolt3d_vs_axisymmetric.py --phases; 16 and 32 agree to 0.3 points)
N_PHASES = 16


@pytest.fixture(scope="module")
def rings():
    """The axisymmetric model of the full nut's layout at mu = MU: the layout, the cut y_start [mm] and the number
    of rings n (benchmarks/bolt3d_vs_axisymmetric.py), the thread's load per turn (below the first cut, the five
    turns, above the last; shares of the thread force) and uy's changes between the STATIONS [mm], both averaged
    over N_PHASES phases of its teeth (the helix's sections)."""
    compare = _benchmark("bolt3d_vs_axisymmetric")
    from frictionid.builders.bolt import bolt_model
    from frictionid.report.bolt import ring_gap, thread_loads
    layout = _benchmark("bolt3d").layout_of(FULL_NUT)
    axi = {k: v for k, v in FULL_NUT.items() if k not in compare.AXISYMMETRIC_ONLY + ("model", "cutout", "jaws")}
    model = bolt_model(**axi)
    solution, _ = compare.solved(model, layout, 2)
    P, n = layout.size.P, thread_loads(model, solution).n_threads
    y_start = ring_gap(model, solution, P)
    shares, changes = compare.phase_average(axi, layout, y_start, n, N_PHASES, heights=STATIONS)
    return layout, y_start, n, shares.mean(axis=0), changes.mean(axis=0)


def _helix(options: dict, rings) -> dict:
    """The 3-D model of ``options`` at mu = MU: its load per turn counted as the rings' ("turn, ends apart"), uy's
    changes between the STATIONS (section averages) and uy at the seed's ten points P1-P5 of flanks 1 and 2."""
    compare = _benchmark("bolt3d_vs_axisymmetric")
    from frictionid.builders.bolt import bolt_model
    from frictionid.fem.problem import Problem
    layout, y_start, n = rings[:3]
    model = bolt_model(**options)
    points, weights = compare.elongation_points(layout, 3, STATIONS)
    ten = _benchmark("bolt3d").ten_points(layout)
    problem = Problem.build(model, points=np.vstack([points, ten]), quantities=("uy",),
                            regions=["bolt"] * (len(points) + len(ten)), factorisation="mumps")
    solution = problem.solve(np.full(len(model.zone_names), MU))
    uy = np.asarray(solution.observations[-1])
    return {"helix": compare.shares_3d(model, solution, y_start, layout.size.P, n)["turn, ends apart"],
            "changes3": np.diff(uy[:len(points)].reshape(-1, len(weights)) @ weights), "ten": uy[len(points):]}


@pytest.fixture(scope="module")
def helix_and_rings(rings):
    """The conforming 3-D full nut (:func:`_helix`) and the rings' averages ("rings", "changes")."""
    return {**_helix(FULL_NUT, rings), "rings": rings[3], "changes": rings[4]}


@pytest.mark.slow
def test_load_per_turn_is_the_rings_averaged_over_the_helix_phases(helix_and_rings):
    """Load share per engaged thread within 4 % of the first thread's share (the issue asks 5 %). A ring model is
    one section of the helix: the helix at angle theta is the ring model with both threads moved by P theta / 2 pi
    past the nut's faces and countersinks. So the helix's load is counted per turn (helical coordinate
    y - P theta / 2 pi, each turn with the ring it passes at theta = 0; :func:`frictionid.report.bolt.pitch_loads`
    with ``lead = P``, cut midway between the rings' flanks) and compared with the ring model averaged over 16
    phases of its teeth, each ring counted where its teeth were before the move; the part of the thread force below
    the first cut (a part flank at the bearing face's countersink) and above the last on their own. "First share"
    is the average's first thread with the part below it (29.16 %). Measured: helix 6.63 / 23.41 / 21.72 / 19.03 /
    18.74 / 10.47 % against 5.66 / 23.50 / 22.37 / 19.63 / 18.85 / 9.99 %, largest difference 3.34 % of the first
    share (2.99 % on the coarse mesh of roots 0.3 mm, 2.97 % with its mesh_size at 2). Against the ring model at
    the layout's phase alone the helix differs by 22 %: the ends make it (docs/bolt-study.md, "Against the
    axisymmetric model")."""
    helix, rings = helix_and_rings["helix"], helix_and_rings["rings"]
    assert helix.sum() == pytest.approx(1.0, abs=1e-9) and rings.sum() == pytest.approx(1.0, abs=1e-9)
    first = rings[0] + rings[1]
    assert np.abs(helix - rings).max() < 0.04 * first


@pytest.mark.slow
def test_bolt_elongation_against_the_rings_averaged_over_the_helix_phases(helix_and_rings):
    """Bolt elongation (the change of uy averaged over the bolt's sections from 0.5 mm below the head's top face
    to 0.5 mm inside its end, benchmarks/bolt3d_vs_axisymmetric.py's measure) within 1 % of the ring model's
    averaged over the same 16 phases (5.880 um; 5.843-5.993 um over the phases). Measured: 5.834 um, -0.78 %.
    On the coarse mesh (roots 0.3 mm, no head size: 35,767 nodes) it is -1.10 %, and this check fails there.

    Segment by segment, the head (y -3.5 to 0), the shank (0 to 9.8) and the rest: the head is a hexagon in 3-D
    and the ring of the same area in axisymmetry; the rings' head with the hexagon's inscribed or circumscribed
    radius instead stretches 1.4 % more or 2.6 % less, which bounds what the shape can make of it; measured -2.58 %
    (with the roots at 0.3 mm -3.85 / -2.35 / -1.57 % at head_size 1.0 / 0.75 / 0.5: the mesh's). The shank
    within 0.5 % (measured -0.03 %). The rest, thread and nut, is stiffer in 3-D by the roots' tetrahedra:
    -1.20 % at roots 0.125 mm, -1.49 % at 0.15 and -2.6 % at 0.3 (docs/bolt-study.md, "Against the axisymmetric
    model"); checked stiffer by less than 2 %."""
    three, rings = helix_and_rings["changes3"], helix_and_rings["changes"]
    assert abs(three.sum() / rings.sum() - 1) < 0.01
    head, shank, thread = (three[k].sum() / rings[k].sum() - 1 for k in (slice(0, 1), slice(1, 3), slice(3, 4)))
    assert abs(head) < 0.04 and abs(shank) < 0.005 and -0.02 < thread < 0


@pytest.fixture(scope="module")
def separate_nut(rings):
    """The full nut with ``nut_mesh = "separate"`` (:func:`_helix`): 75,868 nodes, 896 thread pairs by dual mortar
    on the nut's flanks where the conforming mesh has 1,997 on the bolt's."""
    return _helix({**FULL_NUT, "nut_mesh": "separate"}, rings)


@pytest.mark.slow
def test_separate_nut_against_the_rings_and_the_conforming_helix(separate_nut, helix_and_rings):
    """The nut meshed on its own and coupled by dual mortar: the load per turn within the issue's 5 % of the first
    share of the ring model averaged over the helix's phases (measured 4.09 %; the conforming mesh 3.34 %, which
    its test holds to 4 %: the two 3-D models differ by at most 0.22 points, 0.75 % of the first share), the bolt
    elongation within 1 % (measured -0.870 %) and its parts as the conforming test bounds them (head -2.92 %,
    shank -0.05 %, threaded part -1.32 %); the seed's ten points' uy within 5 % of their range (0.516 um) of the
    conforming model's (measured 2.7 %). A wrong coupling shows: with the mortar's normals turned inwards on the
    flanks' slivers the elongation was -1.08 % and the ten points 31 % off; with the curved facets clipped by
    their corner triangles (58 of 372 nodes uncoupled on the small M6) the ten points were 8.3 % off."""
    separate, conforming = separate_nut, helix_and_rings
    rings, changes, three = conforming["rings"], conforming["changes"], separate["changes3"]
    assert np.abs(separate["helix"] - rings).max() < 0.05 * (rings[0] + rings[1])
    assert abs(three.sum() / changes.sum() - 1) < 0.01
    head, shank, thread = (three[k].sum() / changes[k].sum() - 1 for k in (slice(0, 1), slice(1, 3), slice(3, 4)))
    assert abs(head) < 0.04 and abs(shank) < 0.005 and -0.02 < thread < 0
    assert np.abs(separate["ten"] - conforming["ten"]).max() < 0.05 * np.ptp(conforming["ten"])
