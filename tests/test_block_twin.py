"""Twin experiment on the 3-D block (DESIGN.md reference test 1, issue 3): data from a finer mesh, trf recovers
all four zone coefficients, noise-free within 0.01 and with 0.5 um displacement noise within 3 standard errors.

The set-up is the shipped example's (frictionid.studies.block, reasons and screening in examples/block/README.md):
stereo DIC on the block's side faces, 2-D DIC of the plate top around the block and the machine force, at the
pull levels 0.04 mm (trailing zones sliding, leading zones partly sticking) and 0.2 mm (gross slip); quadratic
hexahedra graded towards the interface, 6 divisions per block side for the identification, 8 for the data.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from frictionid.cli import main
from frictionid.studies import block as twin
from frictionid.options import DataSpec
from helpers import central_difference


#: issue 3 acceptance for noise-free finer-mesh data; the first-order bias pinv(J) e of this set-up is at most
#: 0.0065 (zone B, examples/block/README.md), so the margin is the set-up's, not a tuned tolerance
NOISE_FREE_TOL = 0.01
#: issue 3 acceptance for the noisy twin: within 3 of the estimate's own standard errors
N_STDERR = 3.0
#: seed of the added noise (any seed should pass with probability ~0.99 per zone; this one is fixed)
NOISE_SEED = 20240


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """Measurements simulated on the finer data mesh at the paper's random goal coefficients."""
    folder = tmp_path_factory.mktemp("block_twin")
    twin.write_points(folder / "points.csv")
    truth = twin.config(folder, "truth", twin.DATA_MESH, twin.goal_coefficients(), "points.csv")
    assert main(["simulate", str(truth), "--out", str(folder / "simulated.csv")]) == 0
    return folder


def _identify(folder: Path, name: str, data: str) -> dict:
    path = twin.config(folder, name, twin.ID_MESH, dict.fromkeys("ABCD", 0.1), data,
                       '[identify]\nmethod = "trf"\njacobian = "analytic"\n')
    assert main(["identify", str(path)]) == 0
    return json.loads((folder / f"runs/{name}/result.json").read_text())


@pytest.mark.slow     # with the fixture's data on a quadratic graded mesh: 45 s
def test_trf_recovers_all_four_zones_from_finer_mesh_data(simulated):
    twin.as_measured(simulated / "simulated.csv", simulated / "measured.csv")
    result = _identify(simulated, "noise_free", "measured.csv")
    assert result["status"] == "converged"
    for zone, value in twin.goal_coefficients().items():
        assert abs(result["parameters"][zone]["value"] - value) < NOISE_FREE_TOL, zone


@pytest.mark.slow     # shares the 26 s fixture above
def test_trf_with_displacement_noise_lands_within_three_standard_errors(simulated):
    twin.as_measured(simulated / "simulated.csv", simulated / "noisy.csv", np.random.default_rng(NOISE_SEED))
    result = _identify(simulated, "noisy", "noisy.csv")
    assert result["status"] == "converged"
    # the stated noise is the noise: chi^2 / dof near 1 (model error adds about 0.04, the noise-free chi^2 / dof)
    assert 0.8 < result["fit"]["chi2"] / result["fit"]["dof"] < 1.2
    for zone, value in twin.goal_coefficients().items():
        entry = result["parameters"][zone]
        assert entry["stderr"] is not None and entry["stderr"] > 0, zone
        assert abs(entry["value"] - value) < N_STDERR * entry["stderr"], zone


# ------------------------------------------------------------------ the pieces the twin needs: pull levels, force

def test_pull_levels_split_the_pull_into_stages_on_the_default_load_path(block3d):
    from frictionid.backends.embedded import EmbeddedBackend
    from frictionid.builders.block import block_model

    staged = block_model(mesh_size=5.0, pull_levels=[0.04, 0.1])
    assert [s.name for s in staged.stages] == ["press", "pull 1", "pull 2", "pull"]
    assert [s.n_increments for s in staged.stages] == [1, 2, 3, 5]      # increments of 0.2 / 10 mm each
    assert staged.loads[-1].values == (0.0, 0.04, 0.1, 0.2)
    points = np.array([[-5.0, -2.0, 1.0], [5.0, 2.0, 3.0]])
    mu = np.array([0.3, 0.2, 0.4, 0.25])
    by_stage = EmbeddedBackend(staged, points, ("ux", "uy", "uz"), reactions=("block_top.y",)).predict(mu)
    one = EmbeddedBackend(block3d, points, ("ux", "uy", "uz"), reactions=("block_top.y",))
    solution = one.problem.solve(mu)
    # stage ends at pull 0.04, 0.1, 0.2 mm are increments 2, 5, 10 of the single pull stage (index 0 presses)
    for stage, increment in ((1, 2), (2, 5), (3, 10)):
        expected = np.append(solution.observations[increment], solution.reactions[increment, -1])
        np.testing.assert_allclose(by_stage.values[stage], expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("levels, message", [([0.2], "strictly between 0 and pull"), ([0.0], "strictly between"),
                                             ([0.1, 0.05], "must increase"), ("0.1", "a list")])
def test_bad_pull_levels_are_refused(levels, message):
    from frictionid.builders.block import block_model
    from frictionid.errors import InputError

    with pytest.raises(InputError, match=message):
        block_model(mesh_size=5.0, pull_levels=levels)


def test_machine_force_rows_are_the_driven_reaction_with_its_sensitivities(block3d):
    from frictionid.backends.embedded import EmbeddedBackend
    from frictionid.inverse.reactions import machine_force

    model = block3d
    assert machine_force(model) == "block_top.y"
    backend = EmbeddedBackend(model, np.array([[5.0, 0.0, 2.0]]), ("uy",), reactions=("block_top.y",))
    mu = np.array([0.3, 0.2, 0.4, 0.25])
    prediction = backend.predict(mu, sensitivities=True)
    solution = backend.problem.solve(mu)
    # gross slip at the end of the pull (DESIGN.md): the machine force balances the friction, sum mu_z N_z,
    # less the small lateral components of the slip directions
    friction = mu @ solution.zone_normal_force[-1]
    assert prediction.values.shape == (2, 2) and 0.99 * friction < prediction.values[-1, -1] <= friction
    h = 1e-6
    central = central_difference(lambda m: backend.predict(m).values, mu, h)
    np.testing.assert_allclose(prediction.derivatives, central, rtol=1e-5, atol=1e-6)


def test_force_observable_reads_the_force_column_and_needs_its_noise(tmp_path):
    from dataclasses import replace

    from frictionid.builders.block import block_model
    from frictionid.data.measurements import read_measurements
    from frictionid.errors import InputError
    from frictionid.inverse.observations import observations_from

    model = block_model(mesh_size=5.0, pull_levels=[0.04])
    path = tmp_path / "m.csv"
    path.write_text("point,x,y,z,stage,force,uy\nP1,5,0,2,2,512.5,0.01\nP2,-5,0,2,2,512.5,0.02\n"
                    "P1,5,0,2,3,630.0,0.1\nP2,-5,0,2,3,630.0,0.2\n")
    obs = observations_from(read_measurements(path), model, DataSpec(observables=["uy", "force"], stages=[2, 3],
                                                                     noise={"u": 5e-4, "force": 2.0}))
    assert obs.reactions == ("block_top.y",) and obs.quantities == ("uy",)
    forces = [k for k, label in enumerate(obs.labels) if label.startswith("force@")]
    assert [obs.labels[k] for k in forces] == ["force@2", "force@3"]
    np.testing.assert_array_equal(obs.y[forces], [512.5, 630.0])
    np.testing.assert_array_equal(obs.row[forces], [2, 2])          # after the 2 points x 1 quantity rows
    np.testing.assert_array_equal(obs.sigma[forces], [2.0, 2.0])
    with pytest.raises(InputError, match="force is observed with uy but without a standard deviation"):
        observations_from(read_measurements(path), model, DataSpec(observables=["uy", "force"], stages=[2, 3],
                                                                   noise={"u": 5e-4}))
    no_force = tmp_path / "n.csv"
    no_force.write_text("point,x,y,z,stage,uy\nP1,5,0,2,2,0.01\n")
    with pytest.raises(InputError, match="no row of stage 2 gives the machine force"):
        observations_from(read_measurements(no_force), model, DataSpec(observables=["uy", "force"], stages=[2],
                                                                       noise={"u": 5e-4, "force": 1.0}))
    pressed_only = replace(model, loads=model.loads[:1])
    with pytest.raises(InputError, match="driven by one prescribed displacement"):
        observations_from(read_measurements(path), pressed_only, DataSpec(observables=["uy", "force"], stages=[2],
                                                                          noise={"u": 5e-4, "force": 1.0}))
