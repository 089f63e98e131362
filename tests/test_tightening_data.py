"""Measured torque and clamp force of a tightening test: the `torque` [N m] and `clamp` [N] columns of the measurement
CSV, read and written like `force`, and fitted as the model's reaction sums ([data] reactions)."""

import numpy as np
import pytest

from frictionid.builders.torsion import turned_rings_model
from frictionid.data.measurements import Measurements, read_measurements, write_measurements
from frictionid.errors import InputError
from frictionid.inverse.observations import observations_from
from frictionid.inverse.reactions import channel_reaction
from frictionid.options import DataSpec

HEADER = "point,x,y,z,stage,torque,clamp,uz"


def _write(tmp_path, rows, header=HEADER):
    path = tmp_path / "m.csv"
    path.write_text("# units: mm, N, N m\n" + header + "\n" + "\n".join(rows) + "\n")
    return path


def _rings():
    """Two rings pressed (stage 1) and turned (stage 2); reactions lower_bottom.y / .torque, upper_top.torque."""
    return turned_rings_model(size=2.0, order=1)


def _data(torques=(0.0, 1.5), clamps=(15700.0, 15700.0)):
    """uz at one point on the upper ring's outer face, torque [N m] and clamp force [N] of both stages."""
    return Measurements(points=("P", "P"), coordinates=[[10.0, 2.0, 0.0]] * 2, stage=[1, 2], force=[np.nan] * 2,
                        values={"uz": [0.0, 0.02]}, channels={"torque": list(torques), "clamp": list(clamps)},
                        source="m.csv")


def test_torque_and_clamp_columns_read_back_equal_and_are_listed(tmp_path):
    path = _write(tmp_path, ["P,10,2,0,1,0,15700,0", "Q,10,3,0,1,0,15700,", "P,10,2,0,2,1.5,15800,0.02",
                             "Q,10,3,0,2,1.5,15800,0.03"])
    m = read_measurements(path)
    assert m.channels["torque"].tolist() == [0.0, 0.0, 1.5, 1.5]
    assert m.channels["clamp"].tolist() == [15700.0, 15700.0, 15800.0, 15800.0]
    assert np.isnan(m.force).all() and m.quantities == ("uz",)
    assert "torque [N m] 1: 0, 2: 1.5" in m.summary() and "clamp [N] 1: 15700, 2: 15800" in m.summary()
    assert m.select(stages=[2]).channels["torque"].tolist() == [1.5, 1.5]
    again = tmp_path / "again.csv"
    write_measurements(again, m)
    assert read_measurements(again) == m
    assert again.read_text().splitlines()[1] == HEADER
    assert m != Measurements(m.points, m.coordinates, m.stage, m.force, m.values, m.sigma, m.comments, m.source)


def test_a_stage_has_one_torque(tmp_path):
    path = _write(tmp_path, ["P,10,2,0,2,1.5,15800,0.02", "Q,10,3,0,2,1.6,15800,0.03"])
    with pytest.raises(InputError, match=r"m\.csv:4: column 'torque': 1\.6 N m differs from 1\.5 N m of stage 2 "
                                         r"on line 3; a stage has one wrench torque"):
        read_measurements(path)
    with pytest.raises(InputError, match="unknown column 'torq' \\(did you mean 'torque'\\?\\)"):
        read_measurements(_write(tmp_path, ["P,10,2,0,1,1"], "point,x,y,z,stage,torq"))


def test_torque_and_clamp_are_observed_as_the_model_reactions():
    model = _rings()
    obs = observations_from(_data(), model, DataSpec(observables=["uz", "torque", "clamp"], stages=[1, 2],
                                                     noise={"u": 1e-3, "torque": 0.01,
                            "clamp": 20.0}, reactions={"clamp": "lower_bottom.y"}))
    assert obs.reactions == ("upper_top.torque", "lower_bottom.y")
    assert obs.labels == ("P:uz@1", "P:uz@2", "torque@1", "torque@2", "clamp@1", "clamp@2")
    np.testing.assert_array_equal(obs.row, [0, 0, 1, 1, 2, 2])             # after the point's one row
    np.testing.assert_array_equal(obs.y, [0.0, 0.02, 0.0, 1500.0, 15700.0, 15700.0])     # torque in N mm
    np.testing.assert_array_equal(obs.sigma, [1e-3, 1e-3, 10.0, 10.0, 20.0, 20.0])
    # the prediction picks each channel's row: reactions appended after the point rows, in obs.reactions' order
    values = np.array([[0.1, 7.0, 8.0], [0.2, 9.0, 10.0]])
    np.testing.assert_array_equal(obs.predicted(values), [0.1, 0.2, 7.0, 9.0, 8.0, 10.0])
    only = observations_from(_data(), model, DataSpec(observables=["torque"], stages=[2], noise={"torque": 0.01}))
    assert only.reactions == ("upper_top.torque",) and only.y.tolist() == [1500.0] and only.row.tolist() == [0]


def test_a_channel_needs_its_reaction_and_its_column():
    model = _rings()
    with pytest.raises(InputError, match=r"data\.reactions: the observable 'clamp' \(clamp force \(load cell\)\) "
                                         r"needs the reaction it measures.*lower_bottom\.y"):
        observations_from(_data(), model, DataSpec(observables=["clamp"], stages=[1], noise={"clamp": 20.0}))
    with pytest.raises(InputError, match=r"data\.reactions\.clamp: 'lower_bottom\.z' is not a reaction of the "
                                         r"model \(did you mean 'lower_bottom\.y'\?\)"):
        channel_reaction(model, "clamp", {"clamp": "lower_bottom.z"})
    with pytest.raises(InputError, match=r"data\.reactions: 'clmap' is not a per-stage observable with a reaction "
                                         r"to name \(did you mean 'clamp'\?\); expected torque, clamp"):
        observations_from(_data(), model, DataSpec(observables=["torque"], stages=[2], noise={"torque": 0.01},
                                                   reactions={"clmap": "lower_bottom.y"}))
    bare = Measurements(points=("P",), coordinates=[[10.0, 2.0, 0.0]], stage=[1], force=[np.nan],
                        values={"uz": [0.0]}, source="m.csv")
    with pytest.raises(InputError, match="m.csv: data.observables has 'torque' but the data have no column 'torque'"):
        observations_from(bare, model, DataSpec(observables=["uz", "torque"], stages=[1], noise={"u": 1e-3,
                                                                                                 "torque": 0.01}))
    gap = _data(torques=(np.nan, 1.5))
    with pytest.raises(InputError, match="no row of stage 1 gives the wrench torque \\(column 'torque'\\)"):
        observations_from(gap, model, DataSpec(observables=["torque"], stages=[1, 2], noise={"torque": 0.01}))
    with pytest.raises(InputError, match="data.noise.torque: must be a positive number"):
        observations_from(_data(), model, DataSpec(observables=["torque"], stages=[2], noise={"torque": -1.0}))
    with pytest.raises(InputError, match="'force' needs a model driven by one prescribed displacement"):
        observations_from(_data(), model, DataSpec(observables=["force"], stages=[2], noise={}))
