"""The discretisation control again at the fitted values: a refit on the finer mesh it asks for, none when the
fitted values are within the target, and an interrupted refit resumed from the store.

The case: the two-zone plane-strain block (linear triangles, 2 mm) fitted to noise-free data of a 0.25 mm mesh
(A 0.32, B 0.18). Its estimated displacement error grows with the coefficients (the block carries more shear),
so a target between the estimate at the start values 0.1 and the one at the truth is met at the start and
missed where the fit ends: the control chooses nothing before the fit and asks for a refinement after it.
"""

import json

import numpy as np
import pytest

from block2d_case import CONTROL_TRUE as TRUE, control_config, control_data
from frictionid.cli import main
from frictionid.config import read_config
from frictionid.identification import prepare
from frictionid.inverse.discretisation_control import control
from frictionid.inverse.discretisation_refit import PhaseStore, StoredEstimate, phase
from frictionid.options import ModelSpec
from frictionid.run.store import RunStore

START = dict.fromkeys(TRUE, 0.1)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """(folder with the 0.25 mm data, estimate at the start values, estimate at the truth), u RMS in noise levels
    of the 2 mm mesh as given."""
    folder = control_data(tmp_path_factory.mktemp("refit"))
    setup = prepare(read_config(control_config(folder, "estimate", 2.0, TRUE, "measured.csv")))
    at = {name: control(setup.model_options, setup.model, setup.observations, np.array(list(mu.values())),
                        0.5).record["error_as_given"]["u"] for name, mu in (("start", START), ("truth", TRUE))}
    assert at["start"] < 0.8 * at["truth"], at        # the premise: the start values understate the error
    return folder, at["start"], at["truth"]


def _identify(folder, name: str, target: float, *extra, mode: str | None = "off") -> dict:
    """result.json of the fit of ``name`` with the control's ``target``; ``mode``: identify.model_error (None: the
    default). "off" where a test compares the result with the control's rounds, which "include" continues from."""
    identify = f"refine_target = {target!r}\n" + (f'model_error = "{mode}"\n' if mode else "")
    assert main(["identify", str(control_config(folder, name, 2.0, START, "measured.csv", identify)), *extra]) == 0
    return json.loads((folder / f"runs/{name}/result.json").read_text())


def test_a_fit_beyond_the_target_at_its_values_is_refitted_on_the_finer_mesh(case, capsys):
    folder, at_start, at_truth = case
    target = float(np.sqrt(at_start * at_truth))     # met at the start values, missed near the truth
    result = _identify(folder, "refit", target)
    out = capsys.readouterr().out
    record = result["model"]["discretisation"]
    assert record["status"] == "not needed" and record["error_as_given"]["u"] < target
    first, *later = record["at_fitted"]
    assert first["status"] == "refit" and first["error_fitted"]["u"] > target
    assert first["factors"] == {"element sizes": 2} and first["predicted_error"]["u"] <= target
    assert result["model"]["mesh_size"] == pytest.approx(1.0) and first["n_nodes"] > 2 * record["n_nodes"]
    # the refit starts where the fit ended, and lands nearer the 0.25 mm mesh's truth in both zones
    refit = first["refit"]["value"]
    for zone, truth in TRUE.items():
        assert abs(refit[zone] - truth) < abs(first["at"][zone] - truth), (zone, first["at"], refit)
        assert result["parameters"][zone]["value"] == pytest.approx(refit[zone], rel=1e-12)
    assert result["n_iterations"] == first["n_iterations"] + 1 + first["refit"]["n_iterations"]
    # estimated again at the refit's values: the refined model is within the target there, so it stops
    assert len(later) == 1 and later[0]["status"] == "within target" and later[0]["error_fitted"]["u"] <= target
    assert later[0]["at"] == first["refit"]["value"]
    assert "discretisation control at the fitted values: beyond the target" in out and "refit converged" in out
    assert "at the fitted values (round 1): estimated error of the model fitted" in out      # the fit report


def test_a_fit_within_the_target_at_its_values_is_not_refitted(case, capsys):
    folder, _, at_truth = case
    result = _identify(folder, "within", 2.0 * at_truth)
    out = capsys.readouterr().out
    (only,) = result["model"]["discretisation"]["at_fitted"]
    assert only["status"] == "within target" and "refit" not in only
    assert only["error_fitted"]["u"] <= 2.0 * at_truth and result["model"]["mesh_size"] == 2.0
    assert {z: p["value"] for z, p in result["parameters"].items()} == only["at"]
    assert "within the target" in out and "refit on the refined model" not in out


def test_an_interrupted_refit_keeps_the_first_fit_and_resumes_from_the_store(case, monkeypatch, capsys):
    """Ctrl-C at the refit's second iteration: result.json says interrupted and keeps the first fit's values and
    the control's record; --resume reads the estimate, the choice and every stored solve back and ends where an
    uninterrupted run ends (both with the default model_error, so the fit with the control's error included
    follows the refit)."""
    import frictionid.cli as cli_module

    folder, at_start, at_truth = case
    target = float(np.sqrt(at_start * at_truth))
    whole = _identify(folder, "whole", target, mode=None)        # the default: the control's error included
    capsys.readouterr()
    refit_lines = []                                   # the iteration lines since the refit began

    def interrupt(text):
        if text.startswith("refit on the refined model"):
            refit_lines.append(text)
        elif refit_lines and text.startswith("iter"):
            refit_lines.append(text)
            if len(refit_lines) == 3:
                raise KeyboardInterrupt

    monkeypatch.setattr(cli_module, "_echo", interrupt)
    config = control_config(folder, "ctrlc", 2.0, START, "measured.csv", f"refine_target = {target!r}\n")
    assert main(["identify", str(config)]) == 1
    stopped = json.loads((folder / "runs/ctrlc/result.json").read_text())
    assert stopped["status"] == "interrupted"
    (first,) = stopped["model"]["discretisation"]["at_fitted"]
    assert first["status"] == "refit" and first["at"] == whole["model"]["discretisation"]["at_fitted"][0]["at"]
    assert stopped["n_iterations"] == first["n_iterations"] + 2        # the refit's first two iterations stored
    monkeypatch.undo()
    assert main(["identify", str(config), "--resume"]) == 0
    out = capsys.readouterr().out
    resumed = json.loads((folder / "runs/ctrlc/result.json").read_text())
    assert resumed["status"] == whole["status"] and resumed["n_iterations"] == whole["n_iterations"]
    for zone in TRUE:
        assert resumed["parameters"][zone]["value"] == pytest.approx(whole["parameters"][zone]["value"], rel=1e-12)
    assert "element sizes x2 at these values read from the run's store" in out
    # the first fit and the refit's stored iterations are replayed, not solved: fewer new solves than the whole run
    assert resumed["n_replayed"] >= stopped["n_sensitivity_solves"] - 1
    assert resumed["n_sensitivity_solves"] < whole["n_sensitivity_solves"]


def test_the_refit_phase_keeps_its_evaluations_apart_from_the_first_fits(tmp_path):
    store = RunStore.open(tmp_path, "", "print", resume=False)
    refined = PhaseStore(store, phase(ModelSpec.from_table({"builder": "block2d", "mesh_size": 1.0})))
    other = PhaseStore(store, phase(ModelSpec.from_table({"builder": "block2d", "mesh_size": 0.5})))
    x = np.array([0.3, 0.2])
    store.record(x, "forward", {"f": np.zeros(3)})
    assert refined.lookup(x, "forward") is None
    refined.record(x, "forward", {"f": np.ones(3)})
    assert refined.lookup(x, "forward")["f"].tolist() == [1.0, 1.0, 1.0]
    assert store.lookup(x, "forward")["f"].tolist() == [0.0, 0.0, 0.0] and other.lookup(x, "forward") is None
    memo = StoredEstimate(store, x)
    assert memo.get("element sizes") is None
    memo.put("element sizes", np.arange(3.0), {"n_nodes": 5, "seconds": 0.5})
    difference, step = memo.get("element sizes")
    assert difference.tolist() == [0.0, 1.0, 2.0] and step == {"n_nodes": 5, "seconds": 0.5}
    assert StoredEstimate(store, x + 1e-9).get("element sizes") is None
    calls = []
    assert memo.values("as given", lambda: calls.append(1) or np.ones(2)).tolist() == [1.0, 1.0]
    assert memo.values("as given", lambda: calls.append(1) or np.zeros(2)).tolist() == [1.0, 1.0] and calls == [1]


def test_a_refined_model_refused_after_the_fit_leaves_the_fit_reported(case, monkeypatch, capsys):
    """A refinement the set-up check refuses (here: the contact check, forced) ends the rounds with the fit so far
    reported and the reason recorded, not a run without a result."""
    from frictionid import fitted_control
    from frictionid.errors import InputError

    def refused(*args, **kwargs):
        raise InputError("contact 'block_base': refused for this test")

    monkeypatch.setattr(fitted_control, "checked_contact", refused)
    folder, at_start, at_truth = case
    result = _identify(folder, "refused", float(np.sqrt(at_start * at_truth)))
    (only,) = result["model"]["discretisation"]["at_fitted"]
    assert result["status"] == "converged" and only["status"] == "skipped" and "refused for this test" in only["why"]
    assert {z: p["value"] for z, p in result["parameters"].items()} == only["at"]
    assert result["model"]["mesh_size"] == 2.0
    assert "the fit so far is reported" in capsys.readouterr().out


def test_include_mode_weighs_the_refit_models_remaining_error_and_continues_after_the_refit(case):
    """With identify.model_error = "include" the model error is the last round's estimate for the refined model
    (the control's, no other refinement), and the reweighted fit starts where the refit ended."""
    folder, at_start, at_truth = case
    target = float(np.sqrt(at_start * at_truth))
    path = control_config(folder, "include", 2.0, START, "measured.csv",
                          f'refine_target = {target!r}\nmodel_error = "include"\n')
    assert main(["identify", str(path)]) == 0
    result = json.loads((folder / "runs/include/result.json").read_text())
    first, second = result["model"]["discretisation"]["at_fitted"]
    error = result["fit"]["model_error"]
    assert first["status"] == "refit" and second["status"] == "within target"
    assert error["source"] == "discretisation control" and result["model"]["mesh_size"] == pytest.approx(1.0)
    # the error carried is the second round's at the refit's values (in noise levels RMS, one kind here)
    assert np.sqrt(np.mean(np.square(error["in_noise"]))) == pytest.approx(second["error_fitted"]["u"], rel=1e-3)
    assert error["before_include"] == [second["at"][zone] for zone in TRUE]
    assert result["n_iterations"] > second["n_iterations"]


def test_a_control_decision_shared_by_two_runs_keeps_each_runs_rounds_apart(case, monkeypatch):
    """A study that reuses one decision for several fits (benchmarks/dense_acceptance.py) gets each fit's rounds
    only: the rounds go into a copy of the control's record."""
    from frictionid import identification

    made = {}

    def kept(*args, **kwargs):
        return made.setdefault("decision", control(*args, **kwargs))

    monkeypatch.setattr(identification, "control", kept)
    folder, _, at_truth = case
    first, second = (_identify(folder, name, 2.0 * at_truth) for name in ("shared1", "shared2"))
    assert len(first["model"]["discretisation"]["at_fitted"]) == len(second["model"]["discretisation"]["at_fitted"])
    assert len(second["model"]["discretisation"]["at_fitted"]) == 1 and "at_fitted" not in made["decision"].record


def test_the_default_includes_the_controls_estimate_where_the_control_ran(case, capsys):
    """identify.model_error = "auto" (the default) is "include" with the control's prediction for the fitted model
    when the control ran: the same fit as an explicit "include", recorded as used and why; an explicit "off"
    stays off (no estimate, no refit with it in the weights)."""
    folder, _, at_truth = case
    target = 2.0 * at_truth                          # within the target at the fitted values: no control refit
    auto, include, off = (_identify(folder, f"mode_{mode}", target, mode=mode) for mode in (None, "include", "off"))
    out = capsys.readouterr().out
    error = auto["fit"]["model_error"]
    assert (error["mode"], error["requested"], error["source"]) == ("include", "auto", "discretisation control")
    assert "at the fitted values (round 1)" in error["why"] and error["before_include"] is not None
    assert include["fit"]["model_error"]["mode"] == "include" and include["fit"]["model_error"]["requested"] == \
        "include"
    for zone in TRUE:
        assert auto["parameters"][zone]["value"] == pytest.approx(include["parameters"][zone]["value"], rel=1e-12)
        assert auto["parameters"][zone]["stderr"] == pytest.approx(include["parameters"][zone]["stderr"], rel=1e-12)
    # the include fit moved from the control's round (its error in the weights), the explicit off did not
    (only,) = off["model"]["discretisation"]["at_fitted"]
    assert {z: p["value"] for z, p in off["parameters"].items()} == only["at"]
    assert auto["parameters"]["A"]["value"] != pytest.approx(only["at"]["A"], abs=1e-4)
    assert off["fit"]["model_error"] == {"mode": "off", "requested": "off", "why": 'identify.model_error = "off"'}
    assert 'model error include: identify.model_error = "auto": the discretisation control\'s prediction' in out
    page = (folder / "runs/mode_None/report.html").read_text()
    assert "mode include (identify.model_error = &quot;auto&quot;: the discretisation control&#x27;s prediction" in page


@pytest.mark.parametrize("how", ["refine_target = 0", "model object"])
def test_the_default_is_off_where_the_control_did_not_run(case, capsys, how):
    """No control estimate (the control off, or a model given as an object, which it cannot refine): "auto" fits
    without a model error and says why, and refines nothing of its own."""
    from frictionid import identify
    from frictionid.builders.registry import build_model

    folder = case[0]
    if how == "model object":
        table = {"builder": "block2d", "height": 4.0, "order": 1, "mesh_size": 2.0}
        config = read_config(control_config(folder, "object", 2.0, START, "measured.csv"))
        result = identify(build_model(ModelSpec.from_table(table)), folder / "measured.csv", START,
                          observables=["ux", "uy"], stages=[2], noise={"u": 0.0002},
                          regions=dict(config.data.regions), refine_target=0.5, run_dir=folder / "runs/object",
                          fields=False).to_dict()
        cause = "the model is not a builder's [model] table"
    else:
        result = _identify(folder, "no_control", 0.0, mode=None)
        cause = "the discretisation control is off (identify.refine_target = 0)"
    out = capsys.readouterr().out
    error = result["fit"]["model_error"]
    assert (error["mode"], error["requested"]) == ("off", "auto") and cause in error["why"]
    assert set(error) == {"mode", "requested", "why"}                       # nothing estimated
    assert "refit with the model error" not in result["message"]
    assert "the model refined by 2" not in out
    page = (folder / "runs" / ("object" if how == "model object" else "no_control") / "report.html").read_text()
    assert "Discretisation error not checked" in page and cause.replace("'", "&#x27;") in page
