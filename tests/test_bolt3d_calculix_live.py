"""Issue 29's verification of the 3-D bolt-nut model against CalculiX run at test time on the same mesh (the seed's
ten points, the machine), so that `make check` exercises the backend's deck for the 3-D bolt; the model is
tests/test_bolt3d_verification.py's SMALL with coarser roots and volume (LIVE). In a file of its own so that
test_bolt3d_verification.py's solves and this ccx run go to different pytest-xdist workers (``--dist loadfile``)."""

import numpy as np
import pytest

from helpers import benchmark as _benchmark, needs_ccx
from test_bolt3d_verification import MU, SMALL


#: SMALL (M6, two engaged pitches, flank_size 1.0) with the roots at 0.5 mm and mesh_size 6: 20,544 nodes against
#: SMALL's 28,374; build, ccx and the two embedded solves 32 + 90 + 13 s wall against 37 + 156 + 36 s (one run
#: each, the machine's other core busy)
LIVE = {**SMALL, "root_size": 0.5, "mesh_size": 6.0}


@pytest.fixture(scope="module")
def small():
    from frictionid.builders.bolt import bolt_model
    return bolt_model(**LIVE)


@pytest.mark.slow
@needs_ccx
def test_ten_points_and_machine_against_calculix_on_the_same_mesh(small):
    """The embedded solver against ccx on the same tetra10 mesh (C3D10), one SURFACE TO SURFACE pair per zone with
    linear penalty contact, normal and stick slope 1e8 N/mm^3 (benchmarks/bolt3d_calculix.py): uy at the seed's ten
    points P1-P5 of flanks 1 and 2, the machine's displacement (plate 1's mean uy at four rim points) and the
    machine reaction (the held plate's; the machine force is prescribed, so it equals 1,500 N in both).

    The issue's 1 % of the ten points' range is not shown on a mesh this coarse: measured 1.95 % with the product's
    order-4 quadrature and 1.68 % with ccx's own 4-point C3D10 rule on the embedded side (SMALL, with its roots at
    0.3 mm and mesh_size 4: 1.02 and 1.74 %; docs/bolt-study.md, "Against CalculiX on the same mesh"). The 1 % is
    checked on the 0.5 mm flank mesh against ccx's stored results (test_bolt3d_calculix_fixture.py; that ccx run
    took 11 CPU minutes); this test runs ccx, so that the backend's deck for the 3-D bolt is exercised. Checked
    here: 2.5 % of the range with either rule, the machine's displacement within 1 % (measured -0.06 / -0.09 %)
    and the reactions to 1e-5; with mu 0.3 on the embedded side the ten points are 20.8 / 20.5 % off and the
    machine 6.1 %."""
    calculix = _benchmark("bolt3d_calculix")
    from frictionid.backends.calculix.backend import CalculixSettings
    points, regions = calculix.observed(LIVE)
    ccx = calculix.ccx_result(small, points, regions, MU, CalculixSettings(normal_stiffness=1e8, stick_slope=1e8,
                                                                            timeout=3600))
    bolt, plate = slice(0, 10), slice(10, 14)
    for order in (4, 2):
        embedded = calculix.embedded_result(small, points, regions, MU, "mumps", order)
        uy, uy_ccx = embedded["embedded"][bolt, 1], ccx["ccx"][bolt, 1]
        assert np.abs(uy_ccx - uy).max() < 0.025 * np.ptp(uy), order
        machine = embedded["embedded"][plate, 1].mean()
        assert ccx["ccx"][plate, 1].mean() == pytest.approx(machine, rel=0.01)
        reactions = dict(zip(embedded["labels"], embedded["embedded_reactions"]))
        assert reactions["plate2_rim.y"] == pytest.approx(-1500.0, rel=1e-6)
        np.testing.assert_allclose(ccx["ccx_reactions"], embedded["embedded_reactions"], rtol=1e-5, atol=1e-3)
