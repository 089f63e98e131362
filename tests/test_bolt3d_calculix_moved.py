"""Issue 29's verification against CalculiX on the same mesh, for the separately meshed nut: the embedded solver
(3-D dual mortar on the thread, its multipliers on the nut's flank as the builder puts them) on a stored M6 mesh
whose nut flank was moved onto the bolt's flank (tests/fixtures/bolt3d_calculix), against ccx's results on that
mesh stored beside it (README there; generate.py remakes both). No ccx at test time.

Two such meshes are stored: mesh_moved.npz at the fixture's 0.5 mm flanks and mesh_fine.npz at FINE_FLANK. The
mortar's discretisation error on the non-matching flanks falls with the flank's elements (the ten points 4.03 % of
their range off ccx's at 0.5 mm, 1.45 % at 0.35 mm: README), so the issue's 1 % is checked on the finer one."""

import json

import numpy as np
import pytest

from fixtures.bolt3d_calculix import FINE_FLANK, MU, generate, mesh_file, nut_model, options, results

#: ccx's normal and stick penalty slope [N/mm^3] of the stored run compared here, and the others stored
PENALTY = 1e9
PENALTIES = (1e7, 1e8, 1e9)
BOLT, RIM = slice(0, 10), slice(10, 14)


def _model(nut_mesh: str):
    return nut_model(generate.calculix.layout_of(options(nut_mesh)), nut_mesh)


@pytest.fixture(scope="module")
def compared():
    """ccx's stored results at PENALTY on the fine moved mesh and the embedded backend's on it with ccx's 4-point
    C3D10 rule (quadrature order 2) for the tetra10 stiffness."""
    calculix = generate.calculix
    model = _model("fine")
    points, regions = calculix.observed(options("fine"))
    ccx = json.loads(results(PENALTY, "fine").read_text())
    assert ccx["n_nodes"] == model.mesh.n_nodes and ccx["options"] == options("fine") and ccx["mu"] == MU
    assert ccx["options"]["flank_size"] == FINE_FLANK
    np.testing.assert_array_equal(ccx["points"], points)
    return ccx, calculix.embedded_result(model, points, regions, MU, "mumps", 2)


@pytest.mark.slow
@pytest.mark.parametrize("nut_mesh", ["moved", "fine"])
def test_moved_mesh_is_one_geometry_for_both_codes(nut_mesh):
    """Each stored moved mesh: no nut flank facet overlaps the bolt's flank by more than 0.1 um at 7 points per
    facet (measured -0.085 to +0.090 um at 0.5 mm flanks, -0.028 to +0.018 um at FINE_FLANK; the separate nut's own
    mesh overlaps by up to 4.4 um at its two flank slivers), every tetra10 cell's Jacobian positive at its corners
    and at both codes' quadrature points, the thread's mortar gaps not adjusted (what ccx's deck without
    *CLEARANCE solves)."""
    import bolt3d_calculix_moved as moved         # benchmarks/, on the path through generate
    assert mesh_file(nut_mesh).exists()
    model = _model(nut_mesh)
    gap, _ = moved.pointwise_gaps(model)
    assert np.isfinite(gap).mean() > 0.99
    assert np.nanmin(gap) > -1e-4 and np.nanmax(gap) < 1e-4
    assert moved._smallest_jacobian(model.mesh, model.mesh.points).min() > 0
    assert not model.interfaces[0].adjust


@pytest.mark.slow
def test_ten_points_against_calculix(compared):
    """The seed's ten points P1-P5 of flanks 1 and 2 (0.1 mm inside the bolt tooth): ux, uy, uz of the embedded
    solver with ccx's rule against ccx at PENALTY, the largest difference within the issue's 1 % of the ten
    points' uy range (0.75 um): measured 0.60 % (uy; ux 0.43 %, uz 0.19 %), ccx above at every point by 1.5-4.5 nm.
    With mu 0.3 on the embedded side 18.8 %."""
    ccx, embedded = compared
    u, u_ccx = embedded["embedded"], np.array(ccx["u"])
    span = np.ptp(u[BOLT, 1])
    assert np.abs(u_ccx[BOLT] - u[BOLT]).max() < 0.01 * span


@pytest.mark.slow
def test_penalty_brings_calculix_closer(compared):
    """ccx's penalty compliance is part of the difference: the ten points' largest uy difference falls from
    penalty 1e7 to 1e8 to 1e9, and ccx extrapolated to an infinite penalty from the two stiffest by
    d(S) = d0 + c / S (benchmarks/bolt3d_calculix.py ``penalty_limit``) is within 1 % of the range too; the
    machine's displacement falls likewise (measured: the README)."""
    _, embedded = compared
    runs = [{"stiffness": (s,), "u": np.array(json.loads(results(s, "fine").read_text())["u"])} for s in PENALTIES]
    limit = generate.calculix.penalty_limit(runs, "u")
    u = embedded["embedded"]
    span = np.ptp(u[BOLT, 1])
    worst = [np.abs(v[BOLT, 1] - u[BOLT, 1]).max() / span for v in [r["u"] for r in runs] + [limit]]
    assert worst[0] > worst[1] > worst[2] and worst[3] < 0.01
    machine = [abs(v[RIM, 1].mean() / u[RIM, 1].mean() - 1) for v in [r["u"] for r in runs]]
    assert machine[0] > machine[1] > machine[2]


@pytest.mark.slow
def test_machine_against_calculix(compared):
    """The machine's side, the issue's bound: the held plate's reaction (the prescribed -1,500 N in both) and the
    machine's displacement (plate 1's mean uy at four rim points, 12.79 um) within 1 % (measured +0.003 %; with mu
    0.3 on the embedded side 6.0 %)."""
    ccx, embedded = compared
    reactions = dict(zip(embedded["labels"], embedded["embedded_reactions"]))
    assert reactions["plate2_rim.y"] == pytest.approx(-1500.0, rel=1e-9)
    assert ccx["reactions"]["plate2_rim.y"] == pytest.approx(reactions["plate2_rim.y"], rel=0.01)
    assert np.array(ccx["u"])[RIM, 1].mean() == pytest.approx(embedded["embedded"][RIM, 1].mean(), rel=0.01)
