"""The cross-check's coefficient shift (no ccx needed): what observation differences mean for identified
coefficients, checked on differences whose cause is known (the embedded backend at other coefficients)."""

import numpy as np
import pytest

from frictionid.backends.comparison import CrossCheck
from frictionid.builders.block import block_model_2d
from frictionid.data.measurements import read_measurements
from frictionid.errors import InputError
from frictionid.fem.problem import Problem
from frictionid.inverse.observations import observations_from
from frictionid.inverse.shift import coefficient_shift, observed_shift
from frictionid.report.crosscheck import cross_check_table
from frictionid.options import DataSpec

QUANTITIES = ("ux", "uy", "exx", "eyy", "exy")
POINTS = np.array([[x, y] for x in (-4.0, 0.0, 4.0) for y in (1.0, 3.0)])
NOISE = {"u": 0.0005, "e": 1e-5, "force": 1.0}


def stand_in(mu, other_mu, points=POINTS, quantities=QUANTITIES) -> CrossCheck:
    """A cross-check whose "calculix" side is the embedded backend itself at ``other_mu``."""
    model = block_model_2d(mesh_size=2.0, order=1, quads=True, n_zones=2, n_pull=4)
    problem = Problem.build(model, points=points, quantities=quantities, regions=["block"] * len(points))
    reference, other = problem.solve(np.asarray(mu), sensitivities=True), problem.solve(np.asarray(other_mu))
    ends = [reference.stage_end(s) for s in range(model.n_stages)]
    zero = np.zeros((model.n_stages, model.n_zones))
    return CrossCheck("stand-in", model.mesh.n_nodes, np.asarray(mu), quantities, points,
                      reference.observations[ends], other.observations[ends], reference.reaction_labels,
                      reference.reactions[ends], other.reactions[ends], model.zone_names, zero, zero, zero, zero,
                      0.0, 0.0, 0.0, (1.0, 1.0), reference.d_observations[ends], reference.d_reactions[ends])


def test_shift_recovers_the_coefficients_behind_the_differences():
    """A "calculix" model that gives at mu what the embedded one gives at mu + delta fits embedded data at
    mu - delta: the linearised shift must return -delta (sign included)."""
    mu, delta = np.array([0.3, 0.2]), np.array([0.004, -0.003])
    check = stand_in(mu, mu + delta)
    shift = coefficient_shift(check, NOISE, stages=[2])
    np.testing.assert_allclose(shift.shift, -delta, rtol=0.02)
    assert shift.n_rows == len(POINTS) * len(QUANTITIES) and shift.stages == (2,)
    assert np.all(np.isfinite(shift.stderr)) and shift.rms > 0
    with_force = coefficient_shift(check, NOISE, stages=[2], quantities=("exx",), force="block_top.x")
    np.testing.assert_allclose(with_force.shift, -delta, rtol=0.02)
    assert with_force.n_rows == len(POINTS) + 1 and with_force.quantities == ("exx", "force")
    # identical solutions: no shift
    np.testing.assert_allclose(coefficient_shift(stand_in(mu, mu), NOISE).shift, 0.0, atol=1e-12)


def test_shift_table_and_unresolved_zones():
    mu = np.array([0.3, 0.2])
    check = stand_in(mu, mu + np.array([0.004, -0.003]))
    # stage 1 is the press: friction does no work there, neither zone is seen
    blind = coefficient_shift(check, NOISE, stages=[1])
    assert np.all(np.isinf(blind.stderr)) and np.all(np.isnan(blind.shift))
    assert "| A | 0.3 | not resolved | - | - |" in cross_check_table(check, blind)
    rows = {line.split("|")[1].strip(): line.split("|")
            for line in cross_check_table(check, coefficient_shift(check, NOISE, stages=[2])).splitlines()
            if line.startswith("| A ") or line.startswith("| B ")}
    assert float(rows["A"][3]) == pytest.approx(-0.004, rel=0.02)
    assert float(rows["B"][3]) == pytest.approx(0.003, rel=0.02)
    assert "Give [data] noise" in cross_check_table(check, None, "Give [data] noise (e.g. ...)")


def test_axisymmetric_table_says_which_reactions_to_compare():
    """ccx 2.20's radial reaction totals of CAX elements are off by several % (Lame check, docs/calculix.md):
    an axisymmetric cross-check says so under its forces, other kinds do not."""
    import dataclasses
    check = stand_in(np.array([0.3, 0.2]), np.array([0.3, 0.2]))
    assert "radial (x) reaction totals" not in cross_check_table(check)
    table = cross_check_table(dataclasses.replace(check, kind="axisymmetric"))
    assert "Axisymmetric: ccx 2.20's radial (x) reaction totals are too small" in table
    assert table.index("| zone B abs(T)") < table.index("Axisymmetric:") < table.index("| backend |")


def test_shift_needs_the_noise_of_every_quantity_and_real_stages():
    check = stand_in(np.array([0.3, 0.2]), np.array([0.3, 0.2]))
    with pytest.raises(InputError, match=r"data.noise: no standard deviation for \['exx', 'eyy', 'exy'\]"):
        coefficient_shift(check, {"u": 0.0005})
    with pytest.raises(InputError, match=r"data.stages: \[3\] not among the model's stages 1..2"):
        coefficient_shift(check, NOISE, stages=[3])
    with pytest.raises(InputError, match=r"data.noise.force"):
        coefficient_shift(check, {"u": 0.0005, "e": 1e-5, "force": -1.0}, quantities=("ux",), force="block_top.x")


def test_observed_shift_counts_exactly_the_measured_rows(tmp_path):
    """From an identification's Observations: only values present in the file count, with the file's sigma."""
    mu, delta = np.array([0.3, 0.2]), np.array([0.004, -0.003])
    check = stand_in(mu, mu + delta, quantities=("ux", "exx"))
    rows = ["point,x,y,z,stage,ux,exx,sigma_exx"]
    rows += [f"P{i},{x},{y},0,2,0.0,{'' if i == 0 else 0.0},{'' if i == 0 else 2e-5}"
             for i, (x, y) in enumerate(POINTS)]
    (tmp_path / "m.csv").write_text("\n".join(rows) + "\n")
    model = block_model_2d(mesh_size=2.0, order=1, quads=True, n_zones=2, n_pull=4)
    data = DataSpec(observables=["ux", "exx"], stages=[2], noise={"u": 0.0005}, regions={"*": "block"})
    observations = observations_from(read_measurements(tmp_path / "m.csv"), model, data)
    shift = observed_shift(check, observations)
    assert shift.n_rows == 2 * len(POINTS) - 1 and shift.stages == (2,)
    assert shift.noise == {"ux": 0.0005, "exx": 2e-5}
    np.testing.assert_allclose(shift.shift, -delta, rtol=0.02)


@pytest.mark.parametrize("values", [False, True])
def test_point_outside_the_model_is_named_with_its_file(tmp_path, capsys, values):
    """Points from the data file that lie outside their region: exit 2 naming the label and the file, before
    any ccx run (the embedded problem is built first), with or without measured values in the file."""
    from frictionid.cli import main
    header, rows = "point,x,y,z,stage", ["P1,0.0,2.0,0.0,2", "far,0.0,99.0,0.0,2"]
    if values:
        header, rows = header + ",ux", [row + ",0.001" for row in rows]
    (tmp_path / "points.csv").write_text("\n".join([header] + rows) + "\n")
    (tmp_path / "c.toml").write_text(
        '[model]\nbuilder = "block2d"\nmesh_size = 4.0\norder = 1\nquads = true\n[friction]\n'
        'zones = { A = 0.3, B = 0.2 }\n[data]\nfile = "points.csv"\nobservables = ["ux"]\nstages = [2]\n'
        'noise = { u = 0.0005 }\nregions = { "*" = "block" }\n[solver]\nbackend = "calculix"\nccx = "no-such-ccx"\n')
    assert main(["crosscheck", str(tmp_path / "c.toml")]) == 2
    err = capsys.readouterr().err
    assert "points.csv" in err and "point 'far'" in err and "region 'block'" in err and "P1" not in err
    assert "Traceback" not in err
