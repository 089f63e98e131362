"""Observations: measured values mapped onto a model's backend rows, stages, noise and regions."""

import numpy as np
import pytest

from block2d_case import XY
from frictionid.data.measurements import read_measurements
from frictionid.errors import InputError
from frictionid.inverse.observations import observations_from
from frictionid.options import DataSpec

REGIONS = {"P1": "block", "P2": "block", "P3": "block", "P4": "block", "P5": "base", "P6": "base"}


@pytest.fixture
def measured(tmp_path):
    """The six points of block2d_case at stage 2 with ux, uy = 1000 * point number + 1 / 2 (distinct values)."""
    rows = ["point,x,y,z,stage,ux,uy"] + [f"{p},{x},{y},0.0,2,{1000 * k + 1},{1000 * k + 2}"
                                           for k, (p, (x, y)) in enumerate(XY.items(), start=1)]
    (tmp_path / "m.csv").write_text("\n".join(rows) + "\n")
    return read_measurements(tmp_path / "m.csv")


def test_each_value_gets_its_backend_row_stage_label_and_noise(block2d, measured):
    obs = observations_from(measured, block2d, DataSpec(observables=["ux", "uy"], stages=[2], noise={"u": 5e-4},
                                                        regions=REGIONS))
    assert obs.n_obs == 12 and obs.quantities == ("ux", "uy") and obs.noise_known
    assert obs.point_labels == tuple(XY) and obs.point_regions == tuple(REGIONS[p] for p in XY)
    np.testing.assert_array_equal(obs.points, [XY[p] for p in XY])
    np.testing.assert_array_equal(obs.stage, 1)                      # stage 2 of the file, 0-based
    np.testing.assert_allclose(obs.sigma, 5e-4)
    for label, row, y in zip(obs.labels, obs.row, obs.y):
        point, quantity = label.split("@")[0].split(":")
        k = obs.point_labels.index(point)
        assert label.endswith("@2") and row == 2 * k + obs.quantities.index(quantity)
        assert y == 1000 * (k + 1) + 1 + obs.quantities.index(quantity)


def test_predicted_reads_the_rows_and_stages_it_was_built_for(block2d, measured):
    obs = observations_from(measured, block2d, DataSpec(observables=["uy"], stages=[2], noise={"u": 5e-4},
                                                        regions=REGIONS))
    values = np.arange(block2d.n_stages * 12, dtype=float).reshape(block2d.n_stages, 12)   # backend rows, per stage
    np.testing.assert_array_equal(obs.predicted(values), values[1, obs.row])
    assert obs.quantities == ("uy",) and obs.row.tolist() == list(range(6))
    derivatives = np.stack([values, -values], axis=-1)
    np.testing.assert_array_equal(obs.derivatives(derivatives), np.column_stack([values[1, :6], -values[1, :6]]))


def test_a_displacement_relative_to_a_reference_point_is_a_difference(block2d, measured):
    obs = observations_from(measured, block2d, DataSpec(observables=["ux"], stages=[2], noise={"u": 5e-4},
                                                        regions=REGIONS), relative={"P3": "P1"})
    values = np.arange(block2d.n_stages * 6, dtype=float).reshape(block2d.n_stages, 6) ** 2
    k3, k1 = obs.point_labels.index("P3"), obs.point_labels.index("P1")
    i = obs.labels.index("P3:ux@2")
    assert obs.minus_row[i] == k1 and obs.predicted(values)[i] == values[1, k3] - values[1, k1]
    assert obs.y[i] == 3001 - 1001


def test_a_stage_the_model_does_not_have_or_a_missing_noise_is_an_input_error(block2d, measured):
    with pytest.raises(InputError, match="stage 5 is not one of the model's stages"):
        observations_from(measured, block2d, DataSpec(observables=["ux"], stages=[5], noise={"u": 5e-4},
                                                      regions=REGIONS))
    unweighted = observations_from(measured, block2d, DataSpec(observables=["ux"], stages=[2], noise={},
                                                               regions=REGIONS))
    assert not unweighted.noise_known


def test_point_and_per_stage_observables_are_split_in_one_place():
    """simulate, the cross-check and the design take the point quantities from here: torque and clamp are
    per-stage reaction sums like the machine force, never point quantities."""
    from frictionid.inverse.observations import split_observables
    from frictionid.inverse.reactions import STAGE_OBSERVABLES

    points, stages = split_observables(["uy", "clamp", "exx", "torque", "force"])
    assert points == ("uy", "exx") and stages == ("clamp", "torque", "force")
    assert set(STAGE_OBSERVABLES) == {"force", "torque", "clamp"}


def test_simulate_writes_every_quantity_of_the_models_kind_when_none_is_named(tmp_path):
    """Without observables simulate writes the model kind's quantities (fem.points.QUANTITIES): the plane-strain
    block's displacements and in-plane strains (its ezz is zero by definition), an axisymmetric model's hoop
    strain ezz too."""
    import shutil
    from pathlib import Path

    from frictionid.builders.verification import interference_model
    from frictionid.cli import main
    from frictionid.inverse.observations import default_quantities

    folder = tmp_path / "first"
    shutil.copytree(Path(__file__).parents[1] / "examples" / "first", folder)
    text = (folder / "truth.toml").read_text().replace('["ux", "uy"]', "[]")
    (folder / "all.toml").write_text(text.replace("mesh_size = 0.5", "mesh_size = 2.0"))
    assert main(["simulate", str(folder / "all.toml"), "--out", str(folder / "all.csv")]) == 0
    assert read_measurements(folder / "all.csv").quantities == ("ux", "uy", "exx", "eyy", "exy")
    assert default_quantities(interference_model(size=2.0)) == ("ux", "uy", "exx", "eyy", "ezz", "exy")
