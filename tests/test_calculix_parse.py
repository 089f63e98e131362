"""CalculiX .dat / .frd readers on stored output (tests/fixtures/calculix, see its README); no ccx needed."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from frictionid.backends.calculix.backend import _node_index
from frictionid.backends.calculix.parse import fortran_float, read_dat, read_frd, reals
from frictionid.errors import SolverError

FIXTURES = Path(__file__).parent / "fixtures" / "calculix"


@pytest.mark.parametrize("text, value", [
    ("-2.961518-105", -2.961518e-105),     # Fortran drops the 'E' of a three-digit exponent
    ("1.23450+101", 1.2345e101),
    ("-1.000000E+00", -1.0),
    ("0.5D-03", 0.5e-3),
    ("  NaN", np.nan),
])
def test_fortran_float(text, value):
    np.testing.assert_equal(fortran_float(text), value)


def test_reals_split_values_that_run_together():
    assert reals("1.000000E+00-2.000000E+02-2.961518-105 3.5") == [1.0, -200.0, -2.961518e-105, 3.5]


def test_dat_real_run_has_every_stage_end_and_gross_slip_ratio():
    dat = read_dat(FIXTURES / "block2d.dat")
    totals = dat.totals[("total force (fx,fy,fz)", "N1")]
    assert sorted(totals) == [1.0, 1.5, 2.0]
    np.testing.assert_allclose(totals[1.0], [6.924910e-03, 2.0e2, -9.714451e-15])
    assert sorted(dat.nodal[("displacements (vx,vy,vz)", "NOBS")][2.0]) == [8, 10, 38, 43, 44, 52, 83, 84]
    np.testing.assert_allclose(dat.nodal[("displacements (vx,vy,vz)", "NOBS")][1.0][8],
                               [-1.202585e-03, -1.332183e-02, 0.0])
    zone_b = dat.contact[("SZ2", "ST1")][2.0]
    # the fixture's pull ends in gross slip: shear / normal = mu_B = 0.2 (ccx's penalty friction: 0.2003)
    assert zone_b["shear"] / -zone_b["normal"] == pytest.approx(0.2, rel=2e-3)
    np.testing.assert_array_equal(zone_b["force"], [-3.063984e1, 1.546300e2, -3.877667e-17])
    assert (zone_b["area"], zone_b["normal"], zone_b["shear"]) == (3.140572, -1.545655e2, 3.096326e1)


def test_dat_edge_cases():
    dat = read_dat(FIXTURES / "edge.dat")
    rows = dat.nodal[("displacements (vx,vy,vz)", "NOBS")][1.0]
    np.testing.assert_array_equal(rows[1], [1e-2, -2.961518e-105, 0.0])
    np.testing.assert_array_equal(rows[2], [-1.234567e-3, -2e-2, 3e-104])
    np.testing.assert_array_equal(dat.totals[("total force (fx,fy,fz)", "N1")][1.0], [-2.961518e-105, 200.0, -1.0])
    open_zone = dat.contact[("SZ1", "ST1")][1.0]
    assert open_zone["area"] == 0.0 and np.isnan(open_zone["normal"])
    closed = dat.contact[("SZ2", "ST1")][1.0]
    np.testing.assert_array_equal(closed["force"], [-15.0, 50.0, -1.058586e-118])
    assert (closed["normal"], closed["shear"]) == (-50.0, 15.0)


def test_frd_real_run_matches_dat():
    frd = read_frd(FIXTURES / "block2d.frd")
    assert len(frd.nodes) == 86 and frd.coordinates.shape == (86, 3)
    assert [(b.step, b.increment, b.time) for b in frd.blocks] == [(1, 1, 1.0), (2, 1, 1.5), (2, 2, 2.0)]
    last = frd.last_of_step("DISP", 2)
    dat = read_dat(FIXTURES / "block2d.dat").nodal[("displacements (vx,vy,vz)", "NOBS")][2.0]
    for node, values in dat.items():
        # .frd keeps 6 significant digits (e12.5), .dat 7
        np.testing.assert_allclose(last.values[last.nodes == node][0], values, rtol=1e-5, atol=1e-9)


def test_frd_edge_cases_and_expanded_node_numbers():
    frd = read_frd(FIXTURES / "edge.frd")
    assert [b.name for b in frd.blocks] == ["DISP", "STRESS", "DISP"]
    disp = frd.last_of_step("DISP", 1)
    np.testing.assert_array_equal(disp.values[0], [-2.96152e-105, -1e-2, 0.0])
    np.testing.assert_array_equal(disp.values[1], [1e-2, -2e-2, 1.2345e-101])
    model = SimpleNamespace(mesh=SimpleNamespace(n_nodes=3, points=np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])))
    index = _node_index(frd, model)
    # nodes 11 and 13 are the off-plane copies of model node 3 (0-based 2), node 12 its mid-plane copy
    np.testing.assert_array_equal(index(disp.nodes), [0, 1, -1, 2, -1])
    assert frd.last_of_step("DISP", 2).time == 2.0
    with pytest.raises(SolverError, match="no DISP result for step 3"):
        frd.last_of_step("DISP", 3)


def test_incomplete_frd_is_a_solver_error():
    with pytest.raises(SolverError, match="incomplete output"):
        read_frd(FIXTURES / "truncated.frd")


def test_missing_file_is_a_solver_error(tmp_path):
    with pytest.raises(SolverError, match="cannot be read"):
        read_dat(tmp_path / "job.dat")
