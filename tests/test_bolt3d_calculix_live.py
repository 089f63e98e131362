"""Issue 29's verification of the 3-D bolt-nut model against CalculiX run at test time on the same mesh (the seed's
ten points, the machine), so that `make check` exercises the backend's deck for the 3-D bolt; the model is
tests/test_bolt3d_verification.py's SMALL. In a file of its own so that test_bolt3d_verification.py's solves and
this ccx run go to different pytest-xdist workers (``--dist loadfile``)."""

import numpy as np
import pytest

from helpers import benchmark as _benchmark, needs_ccx
from test_bolt3d_verification import MU, SMALL


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
