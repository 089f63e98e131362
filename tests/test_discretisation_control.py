"""The discretisation control before a fit (identify.refine_target, default 0.5 noise levels RMS per quantity
kind): its estimate against a much finer mesh, the refinement it chooses, the record and the switch."""

import json
from pathlib import Path

import numpy as np
import pytest

from block2d_case import CONTROL_TRUE as TRUE, control_config as _config, control_data
from frictionid import identify
from frictionid.builders.block import block_model_2d
from frictionid.builders.registry import build_model
from frictionid.cli import main
from frictionid.config import read_config
from frictionid.inverse.discretisation_control import control, kind_rms, values
from frictionid.identification import prepare
from frictionid.inverse.model_error import observation_kinds
from frictionid.options import ModelSpec


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """Noise-free data from linear triangles 8 times finer than the fits' 2 mm (a real discretisation error)."""
    return control_data(tmp_path_factory.mktemp("control"))


def test_the_predicted_error_of_the_chosen_mesh_is_its_error_against_a_finer_one(measured):
    """At the truth the 2 mm mesh's values differ from the 0.25 mm mesh's data by several noise levels; the
    control's estimate for the mesh as given is its actual difference to the data within 25 % (measured 1.04), its
    prediction for the refinement it chooses that refinement's actual difference to the data or up to twice it
    (measured 1.5: order 1 is the singularity's bound, the observed order here is higher). The 0.25 mm mesh is
    taken as converged: its own error is about a tenth of the 2 mm mesh's."""
    setup = prepare(read_config(_config(measured, "predict", 2.0, TRUE, "measured.csv")))
    obs, mu = setup.observations, np.array(list(TRUE.values()))
    chosen = control(setup.model_options, setup.model, obs, mu, 0.5)
    record, kinds = chosen.record, observation_kinds(obs)
    as_given = kind_rms(np.abs(values(setup.model, obs, mu) - obs.y) / obs.sigma, kinds)["u"]
    assert as_given > 3.0 and record["status"] in ("reached", "not reached")
    assert 0.8 < record["error_as_given"]["u"] / as_given < 1.25
    factor = record["factors"]["element sizes"]
    assert factor > 1 and chosen.options.option("mesh_size") == pytest.approx(2.0 / factor)
    actual = kind_rms(np.abs(values(chosen.model, obs, mu) - obs.y) / obs.sigma, kinds)["u"]
    assert 1.0 <= record["predicted_error"]["u"] / actual < 2.0, (record, actual)
    # the chosen model's actual change confirms the prediction here, so the remaining error stays the prediction
    assert record["check"]["not_holding"] == [] and record["check"]["missed"]["u"] < 0.5 * \
        record["check"]["predicted_change"]["u"]
    assert record["check"]["remaining"]["nominal"]["u"] == pytest.approx(record["predicted_error"]["u"], rel=1e-3)


@pytest.mark.discretisation_control
def test_by_default_the_fit_runs_on_the_refined_mesh_and_says_so(measured, capsys):
    start = dict.fromkeys(TRUE, 0.1)
    assert main(["identify", str(_config(measured, "default", 2.0, start, "measured.csv"))]) == 0
    out = capsys.readouterr().out
    assert main(["identify", str(_config(measured, "off", 2.0, start, "measured.csv", "refine_target = 0\n"))]) == 0
    default = json.loads((measured / "runs/default/result.json").read_text())
    off = json.loads((measured / "runs/off/result.json").read_text())
    record = default["model"]["discretisation"]
    factor = record["factors"]["element sizes"]
    assert record["target"] == 0.5 and factor > 1 and default["model"]["mesh_size"] == pytest.approx(2.0 / factor)
    assert f"fitting the model refined: element sizes x{factor}" in out
    assert f"discretisation control: estimated error of the mesh as given u {record['error_as_given']['u']:.2f}" in out
    assert off["model"]["discretisation"]["status"] == "off" and off["model"]["mesh_size"] == 2.0
    # the refined mesh's coefficients are closer to the truth than the given mesh's
    for zone, truth in TRUE.items():
        assert abs(default["parameters"][zone]["value"] - truth) < abs(off["parameters"][zone]["value"] - truth)


def test_a_model_object_is_fitted_as_given_and_the_record_says_why(measured):
    result = identify(block_model_2d(mesh_size=2.0, height=4.0, order=1), measured / "measured.csv",
                      dict.fromkeys(TRUE, 0.1), observables=["ux", "uy"], stages=[2], noise={"u": 2e-4},
                      regions={"P1": "block", "P2": "block", "P3": "block", "P4": "block", "P5": "base",
                               "P6": "base"}, refine_target=0.5)
    record = result["model"]["discretisation"]
    assert record["status"] == "skipped" and "not a builder's [model] table" in record["why"]


def test_the_block_refines_the_footprint_the_layers_and_bands_at_the_contact_edges_separately():
    from frictionid.inverse.discretisation_control import directions, refinement, within
    options = {"builder": "block", "mesh_size": 1.0}
    spec = ModelSpec.from_table(options)
    assert directions(spec) == ["footprint divisions", "interface layers", "footprint edges", "interface band"]
    assert within(spec) == [None, None, 0, 1]                  # each band lies inside its uniform direction
    footprint, layers = (build_model(refinement(spec, k)) for k in ((2, 1, 1, 1), (1, 2, 1, 1)))
    given = build_model(spec)
    # footprint x2: the contact has (2 * 10 + 1)^2 nodes instead of 11^2, the layers unchanged
    assert np.sum(np.isclose(footprint.mesh.points[:, 2], 0.0)) == 2 * 21 ** 2 + _outside(footprint)
    assert len(np.unique(footprint.mesh.points[:, 2].round(9))) == len(np.unique(given.mesh.points[:, 2].round(9)))
    # layers x2: as many nodes across the footprint, twice the layers
    assert len(np.unique(layers.mesh.points[:, 2].round(9))) == 2 * len(np.unique(given.mesh.points[:, 2].round(9))) - 1
    assert refinement(spec, (1, 1, 2, 4)).table() == {**options, "block_divisions": 10, "edge_splits": 2,
                                                      "interface_splits": 4}


def test_a_prediction_the_refined_model_does_not_confirm_is_replaced_by_the_actual_change():
    """Where the chosen model's actual change misses the predicted one by more than half, the remaining error of
    that kind is the error as given less the actual change; a kind whose prediction holds keeps it."""
    from frictionid.inverse.discretisation_control import _checked
    from frictionid.inverse.remaining_error import RemainingError
    kinds, sigma = np.array(["u", "u", "e", "e"]), np.ones(4)
    before = RemainingError(np.array([1.0, 1.0, 3.0, 3.0]), np.array([2.0, 2.0, 6.0, 6.0]))
    left = RemainingError(np.array([0.5, 0.5, 1.0, 1.0]), np.array([1.0, 1.0, 2.0, 2.0]))   # change u 0.5, e 2
    actual = np.array([0.5, 0.45, 0.5, 0.5])                                 # u as predicted, e a quarter of it
    checked, record = _checked(left, before, actual, sigma, kinds)
    assert record["not_holding"] == ["e"] and record["missed"]["e"] == pytest.approx(1.5)
    np.testing.assert_allclose(checked.nominal, [0.5, 0.5, 2.5, 2.5])
    np.testing.assert_allclose(checked.slow, [1.0, 1.0, 5.5, 5.5])


def _outside(model) -> int:
    """Nodes at z = 0 outside the block's footprint (plate top only)."""
    points = model.mesh.points
    at = np.isclose(points[:, 2], 0.0)
    return int(np.sum(at & ((np.abs(points[:, 0]) > 5 + 1e-9) | (np.abs(points[:, 1]) > 5 + 1e-9))))


@pytest.mark.slow
def test_the_footprint_edges_band_converges_as_the_control_predicts(tmp_path):
    """The local direction is a sequence h -> 0: the band's intervals split 2 and 4 times, its width kept. From the
    split by 2 alone, the control's term predicts the change of the split by 4 (3-D block, 1.25 mm, pull 0.1 mm so
    that the split elements stay beyond the slip; the 120 points of tests/fixtures/independent_block, at the
    truth): measured, the change is u 2.76 / e 5.85 noise levels RMS and the prediction misses it by 0.10 / 1.61."""
    from frictionid.inverse.discretisation_control import refinement
    from frictionid.inverse.model_error import ELEMENT_ORDER, convergence_orders
    from frictionid.inverse.remaining_error import combined
    fixture = Path(__file__).parent / "fixtures" / "independent_block"
    text = (fixture / "identify.toml").read_text().replace('file = "measured_noisy.csv"',
                                                           f'file = "{fixture / "measured.csv"}"')
    text = text.replace('builder = "block"', 'builder = "block"\nmesh_size = 1.25\npull = 0.1')
    (tmp_path / "identify.toml").write_text(text.replace('dir = "runs/independent"', f'dir = "{tmp_path}"'))
    setup = prepare(read_config(tmp_path / "identify.toml"))
    obs, spec, kinds = setup.observations, setup.model_options, observation_kinds(setup.observations)
    mu = np.array([0.35, 0.2, 0.45, 0.15])
    orders = convergence_orders(ELEMENT_ORDER[setup.model.mesh.cell_type])
    p = np.array([orders[k] for k in kinds])
    coarse = values(setup.model, obs, mu)
    half = coarse - values(build_model(refinement(spec, (1, 1, 2, 1))), obs, mu)
    term = half * 2.0 ** p / (2.0 ** p - 1.0)
    terms = [np.zeros_like(term), np.zeros_like(term), term, np.zeros_like(term)]
    predicted = combined(terms, (1, 1, 1, 1), p, [None, None, 0, 1]) - combined(terms, (1, 1, 4, 1), p,
                                                                                [None, None, 0, 1])
    actual = coarse - values(build_model(refinement(spec, (1, 1, 4, 1))), obs, mu)
    change = kind_rms(np.abs(actual) / obs.sigma, kinds)
    missed = kind_rms(np.abs(predicted - actual) / obs.sigma, kinds)
    assert change["u"] > 1.0 and change["e"] > 2.0                      # the band matters here
    assert missed["u"] < 0.15 * change["u"] and missed["e"] < 0.4 * change["e"], (change, missed)
