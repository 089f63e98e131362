"""The identification's discretisation error through the command line: estimate, include, bad keys (the control
before the fit: test_discretisation_control.py)."""

import json
from pathlib import Path

import pytest

from block2d_case import data_table, points_csv
from frictionid.cli import main
from helpers import write_config

TRUE = {"A": 0.32, "B": 0.18}
POINTS = points_csv(stage=2, quantities=("ux", "uy"))


def _config(folder: Path, name: str, mesh: float, zones: dict, data: str, identify: str = "") -> Path:
    return write_config(folder / f"{name}.toml", model={"builder": "block2d", "mesh_size": mesh, "height": 4.0,
                                                        "order": 1},
                        friction={"zones": zones}, data=data_table(data, noise=0.0001), identify=identify,
                        run={"dir": f"runs/{name}"})


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """Data from a mesh 4 times finer than the identification's (linear triangles: a real model error)."""
    folder = tmp_path_factory.mktemp("discretisation")
    (folder / "points.csv").write_text(POINTS)
    assert main(["simulate", str(_config(folder, "truth", 0.25, TRUE, "points.csv")),
                 "--out", str(folder / "measured.csv")]) == 0
    return folder


@pytest.mark.slow          # 40 s in the fast suite on the shared machine (about 1/7 idle)
def test_the_estimate_is_reported_and_included_in_the_weights(measured, capsys):
    start = dict.fromkeys(TRUE, 0.1)
    assert main(["identify", str(_config(measured, "plain", 1.0, start, "measured.csv"))]) == 0
    plain = json.loads((measured / "runs/plain/result.json").read_text())
    assert main(["identify", str(_config(measured, "include", 1.0, start, "measured.csv",
                                         'model_error = "include"\n'))]) == 0
    out = capsys.readouterr().out
    result = json.loads((measured / "runs/include/result.json").read_text())
    error = result["fit"]["model_error"]
    assert error["mode"] == "include" and error["factor"] == 2 and error["n_points"] == 2
    assert error["refined_options"]["mesh_size"] == 0.5 and len(error["in_noise"]) == result["fit"]["n_obs"]
    assert "estimated discretisation error" in out and "included in the weights" in out
    assert "refit with the model error in the weights" in result["message"]
    # at 0.1 um noise the linear mesh's error dominates (about 10 noise levels): the plain fit calls itself
    # inconsistent and claims no zone; with the model error in the weights the misfit is explained and the
    # intervals hold the truth
    assert error["summary"]["all"]["rms"] > 3.0 and plain["fit"]["consistent"] is False
    for zone in TRUE:
        assert not plain["parameters"][zone]["identifiable"]
        assert "the data contradict each other" in plain["parameters"][zone]["why"]
    assert result["fit"]["consistent"] is True
    for zone, value in TRUE.items():
        low, high = result["parameters"][zone]["ci95"]
        assert low <= value <= high


ABSORBED_POINTS = """# block sides and base top; at a 0.01 mm pull zone A sticks and B partly slips
point,x,y,z,stage
L1,-5.0,0.5,0.0,2
L2,-5.0,1.5,0.0,2
L3,-5.0,3.0,0.0,2
R1,5.0,0.5,0.0,2
R2,5.0,1.5,0.0,2
R3,5.0,3.0,0.0,2
B1,-7.0,0.0,0.0,2
B2,7.0,0.0,0.0,2
"""
ABSORBED_MODEL = '[model]\nbuilder = "block2d"\nn_zones = 2\npull = 0.01\nmesh_size = '
ABSORBED_DATA = ('observables = ["ux", "uy", "force"]\nstages = [2]\nnoise = { u = 0.0005, force = 0.05 }\n'
                 'regions = { L1 = "block", L2 = "block", L3 = "block", R1 = "block", R2 = "block", '
                 'R3 = "block", "*" = "base" }\n')


@pytest.mark.slow          # 84 s for both modes in the fast suite on the shared machine (about 1/7 idle)
@pytest.mark.parametrize("mode", ["estimate", "include"])
def test_a_model_error_the_coefficients_absorb_is_found_by_the_estimate(tmp_path, capsys, mode):
    """Quadratic triangles of 1 mm fitted to data of a 0.5 mm mesh: the machine force's discretisation error
    (about 5 noise levels) lies along zone B's sensitivity, so the fit absorbs it into B (0.08 for 0.15) and leaves
    no misfit: the chi-square test passes and, without the estimate, B would be claimed resolved 4 standard errors
    from the truth. The estimate's signed error, mapped through the sensitivities, moves B by about the error the
    fit made, and B is not claimed."""
    (tmp_path / "points.csv").write_text(ABSORBED_POINTS)
    (tmp_path / "truth.toml").write_text(ABSORBED_MODEL + '0.5\n[friction]\nzones = { A = 0.3, B = 0.15 }\n'
                                         '[data]\nfile = "points.csv"\n' + ABSORBED_DATA)
    assert main(["simulate", str(tmp_path / "truth.toml"), "--out", str(tmp_path / "measured.csv")]) == 0
    results = {}
    for name, extra in (("off", ""), (mode, f'[identify]\nmodel_error = "{mode}"\n')):
        config = tmp_path / f"{name}.toml"
        config.write_text(ABSORBED_MODEL + '1.0\n[friction]\nzones = { A = 0.1, B = 0.1 }\n'
                          '[data]\nfile = "measured.csv"\n' + ABSORBED_DATA + extra + f'[run]\ndir = "runs/{name}"\n')
        assert main(["identify", str(config)]) == 0
        results[name] = json.loads((tmp_path / f"runs/{name}/result.json").read_text())
    out = capsys.readouterr().out
    off, checked = results["off"], results[mode]
    b = off["parameters"]["B"]
    assert off["fit"]["consistent"] is True and b["identifiable"]            # the blind spot this closes
    assert abs(b["value"] - 0.15) > 3 * b["stderr"]
    assert "not checked: the mesh's discretisation error" in out
    shift = checked["fit"]["model_error"]["shift"]["B"]
    assert 0.5 < shift / (0.15 - checked["parameters"]["B"]["value"]) < 2.0
    assert not checked["parameters"]["B"]["identifiable"]
    assert "estimated discretisation error moves it" in checked["parameters"]["B"]["why"]
    assert "corrected for that error the coefficients would move by" in out


@pytest.mark.parametrize("identify, key", [('model_error = "maybe"\n', "identify.model_error"),
                                           ("refine_target = -1\n", "identify.refine_target"),
                                           ("refine_target = 1\nrefine_budget = 0\n", "identify.refine_budget")])
def test_bad_settings_exit_2_naming_the_key(measured, capsys, identify, key):
    assert main(["identify", str(_config(measured, "bad", 1.0, {"A": 0.1, "B": 0.1}, "measured.csv",
                                         identify))]) == 2
    assert key in capsys.readouterr().err


def test_a_misspelt_model_error_names_the_key_the_choices_and_the_closest(measured, capsys):
    assert main(["identify", str(_config(measured, "typo", 1.0, {"A": 0.1, "B": 0.1}, "measured.csv",
                                         'model_error = "inclued"\n'))]) == 2
    err = capsys.readouterr().err
    assert 'identify.model_error must be "auto", "off", "estimate" or "include", got \'inclued\'' in err
    assert "(did you mean 'include'?)" in err and "Traceback" not in err


def test_the_api_refuses_an_unknown_model_error_naming_it(measured):
    from frictionid import identify
    from frictionid.errors import InputError

    with pytest.raises(InputError, match=r"identify.model_error must be .*got 'maybe'"):
        identify({"builder": "block2d", "mesh_size": 1.0}, measured / "measured.csv", {"A": 0.1, "B": 0.1},
                 observables=["ux", "uy"], stages=[2], noise={"u": 1e-4}, model_error="maybe")


@pytest.mark.parametrize("record, remaining, mode, because", [
    ({"target": 0.5, "status": "skipped", "why": "backend 'calculix' (the estimate needs the embedded backend)"},
     None, "off", "did not run (backend 'calculix'"),
    ({"target": 0.5, "status": "skipped", "why": "footprint divisions x2: ... more than [solver] max_memory allows"},
     None, "off", "more than [solver] max_memory allows"),
    ({"target": 0.5, "status": "reached", "at_fitted": [{"round": 1, "status": "skipped", "why": "memory"}]},
     "prediction", "include", "made at the start values (its estimate at the fitted values was skipped)"),
    ({"target": 0.5, "status": "reached", "at_fitted": [{"round": 1, "status": "refit"},
                                                        {"round": 2, "status": "no finer model"}]},
     "prediction", "include", "made at the fitted values (round 2)"),
    ({"target": 0.5, "status": "not needed"}, "prediction", "include", "made at the start values, is included")])
def test_auto_is_include_exactly_where_the_control_made_a_prediction_and_says_which(record, remaining, mode,
                                                                                      because):
    """The control's record and prediction decide "auto" (the end-to-end runs: test_discretisation_refit.py): a
    control skipped (CalculiX backend, directional models over max_memory) leaves it off, with the reason; a
    prediction, from the start values or the last round at the fitted values, is included."""
    from frictionid.inverse.discretisation import used_mode

    used, why = used_mode("auto", remaining, record)
    assert used == mode and because in why and why.startswith('identify.model_error = "auto": ')
    for explicit in ("off", "estimate", "include"):             # explicit modes are used as given
        assert used_mode(explicit, remaining, record) == (explicit, f'identify.model_error = "{explicit}"')
