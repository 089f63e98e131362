"""Issue 29's verification against CalculiX on the same mesh at the issue's 1 %: the embedded solver on the 3-D M6
bolt with 0.5 mm flanks stored in tests/fixtures/bolt3d_calculix, against ccx's results on that mesh stored beside
it (README there; generate.py remakes mesh and results, the ccx run took 11 min CPU). No ccx at test time."""

import json

import numpy as np
import pytest

from fixtures.bolt3d_calculix import MU, OPTIONS, generate, results, stored_model

#: ccx's normal and stick penalty slope [N/mm^3] of the stored run compared here
PENALTY = 1e8


@pytest.fixture(scope="module")
def compared():
    """ccx's stored results at PENALTY and the embedded backend's on the model rebuilt from the stored mesh, with
    ccx's 4-point C3D10 rule (quadrature order 2) and with the product's order 4 for the tetra10 stiffness."""
    calculix = generate.calculix
    model = stored_model(calculix.layout_of(OPTIONS))
    points, regions = calculix.observed(OPTIONS)
    ccx = json.loads(results(PENALTY).read_text())
    assert ccx["n_nodes"] == model.mesh.n_nodes and ccx["options"] == OPTIONS and ccx["mu"] == MU
    np.testing.assert_array_equal(ccx["points"], points)
    embedded = {order: calculix.embedded_result(model, points, regions, MU, "mumps", order) for order in (2, 4)}
    return ccx, embedded


BOLT, RIM = slice(0, 10), slice(10, 14)
#: the largest |ccx - embedded| of the ten points' ux, uy, uz allowed, as a fraction of their uy range, per
#: quadrature order of the embedded tetra10 stiffness: 2 is ccx's own 4-point C3D10 rule (the issue's 1 %;
#: measured 0.93 %), 4 the product's (measured 1.98 %: the two rules differ on the cells with curved mid-side nodes)
BOUNDS = {2: 0.01, 4: 0.02}


@pytest.mark.slow
def test_ten_points_against_calculix_within_one_percent_of_their_range(compared):
    """The seed's ten points P1-P5 of flanks 1 and 2 (0.1 mm inside the bolt tooth): ux, uy, uz of the embedded
    solver against ccx, the largest difference as a fraction of the ten points' uy range (0.76 um). Measured
    (README): 0.93 % (uy; ux 0.33 %, uz 0.29 %) with ccx's rule, 1.98 % (uy) with the product's order 4, ccx above
    at every point; with mu 0.3 on the embedded side instead of 0.15, 18.4 %."""
    ccx, embedded = compared
    u_ccx = np.array(ccx["u"])
    for order, bound in BOUNDS.items():
        u = embedded[order]["embedded"]
        span = np.ptp(u[BOLT, 1])
        assert np.abs(u_ccx[BOLT] - u[BOLT]).max() < bound * span, order


@pytest.mark.slow
def test_machine_against_calculix(compared):
    """The machine's side, with both quadrature rules: the held plate's reaction within 1 % (the issue's bound; the
    force is prescribed, so it is -1,500 N in both, measured equal to 1e-11), the machine's displacement (plate
    1's mean uy at four rim points, 12.76 um) within 0.1 % (measured +0.044 % with ccx's rule, +0.090 % with order
    4; with mu 0.3 on the embedded side +6.1 %), and the axial contact force of each zone within 12 % (measured
    +4.3 / +1.9 / -10.5 / -2.9 % on A / B / C / D with order 4: the two contact discretisations split the flank load
    differently; head and nut bearing 1,500 N in both)."""
    ccx, embedded = compared
    u_ccx = np.array(ccx["u"])
    for order in BOUNDS:
        result = embedded[order]
        reactions = dict(zip(result["labels"], result["embedded_reactions"]))
        assert reactions["plate2_rim.y"] == pytest.approx(-1500.0, rel=1e-9)
        assert ccx["reactions"]["plate2_rim.y"] == pytest.approx(reactions["plate2_rim.y"], rel=0.01)
        assert u_ccx[RIM, 1].mean() == pytest.approx(result["embedded"][RIM, 1].mean(), rel=0.001)
        axial = np.array(list(ccx["zone_axial"].values()))
        np.testing.assert_allclose(axial, result["embedded_axial"], rtol=0.12)


@pytest.mark.slow
def test_penalty_extrapolation_brings_calculix_closer(compared):
    """ccx's penalty compliance is part of the difference: with ccx's rule on the embedded side the ten points'
    largest uy difference falls from 3.39 % of the range at penalty 1e7 (calculix_1e7.json) to 0.93 % at 1e8, and
    ccx extrapolated to an infinite penalty from the two by d(S) = d0 + c / S
    (benchmarks/bolt3d_calculix.py ``penalty_limit``) leaves 0.66 % (the machine's displacement +0.29 / +0.044 /
    +0.017 %): what is left is the two contact discretisations' own difference."""
    _, embedded = compared
    runs = [{"stiffness": (s,), "u": np.array(json.loads(results(s).read_text())["u"])} for s in (1e7, PENALTY)]
    limit = generate.calculix.penalty_limit(runs, "u")
    u = embedded[2]["embedded"]
    span = np.ptp(u[BOLT, 1])
    worst = [np.abs(v[BOLT, 1] - u[BOLT, 1]).max() / span for v in (runs[0]["u"], runs[1]["u"], limit)]
    assert worst[0] > worst[1] > worst[2]
    assert worst[2] < 0.0075
    machine = [abs(v[RIM, 1].mean() / u[RIM, 1].mean() - 1) for v in (runs[0]["u"], runs[1]["u"], limit)]
    assert machine[0] > machine[1] > machine[2]
