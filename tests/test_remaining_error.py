"""The discretisation error the control leaves, carried to the coefficients (inverse/remaining_error.py): the
linearised bias against a brute-force refit, the control's prediction against the actual offset, and the claim
rule of a zone whose systematic error exceeds its statistical one."""

import json

import numpy as np
import pytest

from block2d_case import CONTROL_TRUE as TRUE, control_config as _config, control_data
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.cli import main
from frictionid.config import read_config
from frictionid.inverse import remaining_error
from frictionid.inverse.evaluator import Evaluator
from frictionid.inverse.least_squares import LeastSquares
from frictionid.inverse.optimisers import optimise
from frictionid.inverse.uncertainty import SYSTEMATIC_LIMIT, estimate
from frictionid.preparation import prepare


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """Noise-free data of six points from linear triangles of 0.25 mm (8 times finer than the fits' 2 mm)."""
    return control_data(tmp_path_factory.mktemp("remaining"))


def _fit(model, obs, params):
    evaluator = Evaluator(EmbeddedBackend(model, obs.points, obs.quantities, obs.point_regions, obs.reactions), obs,
                          params)
    problem = LeastSquares(evaluator.residuals, evaluator.jacobian, params.x0, params.lower, params.upper,
                           params.free_names, noise_known=True)
    return evaluator, optimise(problem, "trf").x


def test_the_linearised_bias_of_a_known_model_error_is_the_refit_offset(measured):
    """The 2 mm mesh against data of the 0.25 mm mesh: its error at the truth, delta = f_2mm(truth) - y (7.6 noise
    levels RMS), carried through the weighted Jacobian at the fitted point, predicts the brute-force fit's offset
    from the truth within 20 % per zone (measured: A +0.0752 predicted against +0.0685 fitted, B +0.0346 against
    +0.0372). The sign matters: a model whose values are too large is compensated by the coefficients."""
    setup = prepare(read_config(_config(measured, "propagate", 2.0, dict.fromkeys(TRUE, 0.1), "measured.csv")))
    obs, params = setup.observations, setup.parameters
    evaluator, x = _fit(setup.model, obs, params)
    truth = np.array(list(TRUE.values()))
    delta = evaluator.model_values(truth) - obs.y
    assert np.sqrt(np.mean((delta / obs.sigma) ** 2)) > 5.0
    actual = x - truth
    predicted = remaining_error.bias(evaluator.jacobian(x), obs.weight, delta)
    assert np.all(np.abs(actual) > 0.03)                                  # far above the fit's tolerance
    np.testing.assert_allclose(predicted, actual, rtol=0.2)


@pytest.mark.discretisation_control
def test_the_fit_on_the_refined_mesh_carries_the_controls_remaining_error(measured):
    """With the control (target 0.5: the 2 mm mesh refined 4 times), result.json gives each zone the offset the
    remaining error predicts (``discretisation_bias``) and the systematic error (the larger of it and the same at
    half the orders), added to the statistical error in quadrature. The fitted offset from the data's truth is
    within the systematic error (measured: A -0.0022 within 0.0105, B +0.0156 within 0.0195; the offset at the
    control's orders alone, +0.0031 and +0.0057, would not hold B: the 2-D block's displacements converge
    slower than order 1 here). The data's own mesh is taken as converged (its error is a quarter of the 0.5 mm
    mesh's at order 1). model_error "off": the prediction alone, as a fit without it in the weights carries it
    (the default, "auto", includes it: test_discretisation_refit.py)."""
    assert main(["identify", str(_config(measured, "carried", 2.0, dict.fromkeys(TRUE, 0.1), "measured.csv",
                                         'refine_target = 0.5\nmodel_error = "off"\n'))]) == 0
    result = json.loads((measured / "runs/carried/result.json").read_text())
    assert result["model"]["discretisation"]["factors"] == {"element sizes": 4}
    assert set(result["model"]["discretisation"]["predicted_error_slow"]) == {"u"}
    for zone, truth in TRUE.items():
        entry = result["parameters"][zone]
        offset = entry["value"] - truth
        assert abs(entry["discretisation_bias"]) <= entry["stderr_systematic"]
        assert abs(offset) <= entry["stderr_systematic"], (zone, offset, entry)
        assert entry["stderr"] > entry["stderr_systematic"]
    assert abs(result["parameters"]["B"]["discretisation_bias"]) < abs(result["parameters"]["B"]["value"] - 0.18)


def test_a_zone_whose_systematic_error_exceeds_its_statistical_one_is_not_claimed():
    """Two resolved zones (statistical standard errors 0.01 and 0.0071), the second with a systematic error of
    0.02: its interval is widened (hypot) and, with the control's limit (default mode), it is not claimed, with the
    reason; the first, with 0.005, is claimed with its widened interval. Without the limit (include mode, whose
    systematic part the misfit calibrates) both are claimed."""
    jac = np.array([[100.0, 0.0], [0.0, 100.0], [0.0, 100.0]])
    x = np.array([0.3, 0.2])
    unc = estimate(jac, np.zeros(3), x, np.zeros(2), np.ones(2), noise_known=True, tolerance=0.05,
                   names=("A", "B"), systematic=np.array([0.005, 0.02]), systematic_limit=SYSTEMATIC_LIMIT)
    assert unc.identifiable.tolist() == [True, False]
    widened = estimate(jac, np.zeros(3), x, np.zeros(2), np.ones(2), noise_known=True, tolerance=0.05,
                       names=("A", "B"), systematic=np.array([0.005, 0.02]))     # include mode: widened only
    assert widened.identifiable.tolist() == [True, True]
    np.testing.assert_allclose(unc.stderr, [np.hypot(0.01, 0.005), np.hypot(0.01 / np.sqrt(2), 0.02)])
    assert "remaining discretisation error moves it by up to 0.02, more than its statistical standard error " \
           "0.00707" in unc.why[1]


def test_the_controls_decision_does_not_read_the_measured_values(measured):
    """The control's choice and its predicted remaining error depend on the model, the observation layout, the
    stated noise and the start values only: measured values replaced by others give the same (so a replicate
    study may run it once, benchmarks/dense_acceptance.py)."""
    from dataclasses import replace

    from frictionid.inverse.discretisation_control import control
    setup = prepare(read_config(_config(measured, "layout", 2.0, dict.fromkeys(TRUE, 0.1), "measured.csv")))
    obs, mu = setup.observations, np.full(2, 0.1)
    first = control(setup.model_options, setup.model, obs, mu, 0.5)
    other = control(setup.model_options, setup.model, replace(obs, y=obs.y * -3.0 + 1.0), mu, 0.5)
    assert first.record["factors"] == other.record["factors"] and first.options == other.options
    np.testing.assert_array_equal(first.remaining.nominal, other.remaining.nominal)
    np.testing.assert_array_equal(first.remaining.slow, other.remaining.slow)
    assert np.abs(first.remaining.nominal).max() > 0
