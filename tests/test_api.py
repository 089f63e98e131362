"""The Python interface: Parameters in code with per-zone bounds, identify() on objects or files, the result
object, config_from_dict; the command line and the API give the same result.json."""

import csv
import doctest
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

import frictionid
from frictionid import (IdentificationResult, InputError, Parameter, Parameters, block_model_2d, config_from_dict,
                        identify, read_measurements)
from frictionid.cli import main

ROOT = Path(__file__).parents[1]
#: examples/first: the block's side points L*, R* lie on the block, the others on the base
REGIONS = {**{f"{side}{k}": "block" for side in "LR" for k in range(1, 7)}, "*": "base"}
#: entries of result.json that differ between two runs of the same identification
TIMING = {"wall_time_s", "timings"}


@pytest.fixture(scope="module")
def cli_run(first):
    """The example's identification through the command line: its run folder."""
    assert main(["identify", str(first / "identify.toml")]) == 0
    return first / "runs/first"


def without_timing(result: dict) -> dict:
    return {key: value for key, value in result.items() if key not in TIMING}


@pytest.mark.slow          # 50 s in the fast suite on the shared machine (about 1/7 idle)
def test_cli_and_api_write_the_same_result_json(first, cli_run, monkeypatch):
    cli = json.loads((cli_run / "result.json").read_text())
    monkeypatch.chdir(first)                                   # the API resolves relative paths against the cwd
    result = identify({"builder": "block2d", "mesh_size": 1.0, "pull": 0.05}, "measured.csv",
                      {"A": 0.1, "B": 0.1}, observables=["ux", "uy"], stages=[2], noise={"u": 0.0005},
                      regions=REGIONS, run_dir="runs/api")
    api = json.loads((first / "runs/api/result.json").read_text())
    assert without_timing(api) == without_timing(cli)
    assert result.to_dict() == api and result.run_dir == (first / "runs/api").resolve()
    assert (first / "runs/api/report.html").exists()


def test_model_and_measurements_as_objects_give_the_table_and_file_results(first, cli_run):
    from_files = IdentificationResult.read(cli_run)
    params = Parameters([Parameter("A", 0.1), Parameter("B", 0.1)])
    result = identify(block_model_2d(mesh_size=1.0, pull=0.05), read_measurements(first / "measured.csv"), params,
                      observables=["ux", "uy"], stages=[2], noise={"u": 0.0005}, regions=REGIONS)
    assert result.run_dir is None and result.status == from_files.status
    for zone in ("A", "B"):
        assert result.coefficients[zone] == pytest.approx(from_files.coefficients[zone], abs=1e-12)
        assert result.stderr[zone] == pytest.approx(from_files.stderr[zone], rel=1e-9)
    # a model object has no [model] table: only the contact map and what the discretisation control did (here off)
    assert set(result["model"]) == {"contact", "discretisation"}


def test_measurements_as_a_list_of_files_or_tables_reach_the_data_table(first, cli_run):
    """identify() takes [data] file's list form: a list of one path fits as the path does; a file table's own
    keys (here relative_to) reach the fit."""
    from_file = IdentificationResult.read(cli_run)
    model, params = block_model_2d(mesh_size=1.0, pull=0.05), {"A": 0.1, "B": 0.1}
    options = {"observables": ["ux", "uy"], "stages": [2], "noise": {"u": 0.0005}, "regions": REGIONS}
    listed = identify(model, [first / "measured.csv"], params, **options)
    for zone in ("A", "B"):
        assert listed.coefficients[zone] == pytest.approx(from_file.coefficients[zone], abs=1e-12)
    relative = identify(model, [{"path": str(first / "measured.csv"), "relative_to": "L1"}], params, **options)
    assert list(relative["data"]["relative_to"]) == ["L1"] and not from_file["data"]["relative_to"]
    assert relative["fit"]["chi2"] != pytest.approx(from_file["fit"]["chi2"], rel=1e-6)


def test_the_result_object_reads_like_result_json_and_cannot_be_changed(cli_run):
    result = IdentificationResult.read(cli_run / "result.json")
    assert result["parameters"]["B"]["identifiable"] is True and result.identifiable == {"A": False, "B": True}
    low, high = result.ci95["B"]
    assert low <= 0.15 <= high and result.stderr["B"] > 0
    report = result.fit_report()
    assert "[[Variables]]" in report and "NOT RESOLVED" in report.split("    A ")[1].splitlines()[0]
    with pytest.raises(TypeError):
        result["status"] = "converged"
    with pytest.raises(TypeError):
        result["parameters"]["B"]["value"] = 0.0
    copy = result.to_dict()
    copy["parameters"]["B"]["value"] = 0.0
    assert result.coefficients["B"] != 0.0


def test_per_zone_bounds_hold_and_reach_result_json(first):
    params = Parameters.from_dict({"A": 0.1, "B": 0.1}, bounds={"B": [0.0, 0.12], "*": [0.0, 0.8]})
    result = identify({"builder": "block2d", "mesh_size": 1.0, "pull": 0.05}, first / "measured.csv", params,
                      observables=["ux", "uy"], stages=[2], noise={"u": 0.0005}, regions=REGIONS)
    b = result["parameters"]["B"]
    assert b["bounds"] == (0.0, 0.12) and result["parameters"]["A"]["bounds"] == (0.0, 0.8)   # lists read as tuples
    assert b["value"] == pytest.approx(0.12, abs=1e-6) and b["at_bound"]      # B wants 0.15
    assert 0.0 <= b["ci95"][0] <= b["ci95"][1] <= 0.12


def test_the_package_exports_its_interface_lazily():
    assert {"identify", "Parameters", "IdentificationResult", "config_from_dict"} <= set(frictionid.__all__)
    assert callable(frictionid.identify) and frictionid.identify.__module__ == "frictionid.identification"
    with pytest.raises(AttributeError):
        frictionid.no_such_name


@pytest.mark.parametrize("build, message", [
    (lambda: Parameter("A", 0.7, max=0.6), "start value 0.7 lies outside bounds [0.0, 0.6]"),
    (lambda: Parameter("A", 0.1, min=-0.1), "lower bound -0.1 is negative"),
    (lambda: Parameters([Parameter("A", 0.1), Parameter("A", 0.2)]), "zone(s) ['A'] given more than once"),
    (lambda: Parameters.from_dict({"A": 0.1}, bounds={"B": [0, 1]}), "zone(s) ['B'] are not free zones"),
    (lambda: Parameters.from_dict({"A": 0.1}, bounds={"A": [0.5, 0.2]}), "bounds.A [0.5, 0.2]: the lower"),
    (lambda: Parameters.from_dict({"A": 0.9}, bounds={"*": [0, 0.5]}), "zones.A = 0.9 lies outside"),
    (lambda: Parameters([Parameter("A", 0.1, vary=False)]), "every zone is fixed"),
])
def test_bad_parameters_are_refused_by_name(build, message):
    with pytest.raises(InputError) as info:
        build()
    assert message in str(info.value)


def test_bad_api_input_names_the_key(first):
    common = dict(observables=["ux", "uy"], stages=[2], regions=REGIONS)
    model = {"builder": "block2d", "mesh_size": 1.0, "pull": 0.05}
    with pytest.raises(InputError, match=r"unknown zone\(s\) \['Z'\]"):
        identify(model, first / "measured.csv", {"A": 0.1, "B": 0.1, "Z": 0.1}, **common)
    with pytest.raises(InputError, match=r"identify\(\): unknown key identify.methd \(did you mean 'method'\?\)"):
        identify(model, first / "measured.csv", {"A": 0.1, "B": 0.1}, methd="trf", **common)
    with pytest.raises(InputError, match="identify.max_iterations must be a whole number"):
        identify(model, first / "measured.csv", {"A": 0.1, "B": 0.1}, max_iterations=2.5, **common)


def test_config_from_dict_validates_like_a_file():
    config = config_from_dict({"model": {"builder": "block2d"}, "friction": {"zones": {"A": 0.1, "B": 0.1},
                               "bounds": {"A": [0, 0.5]}}, "solver": {"work_dir": None}})
    assert config.friction["bounds"] == {"A": [0, 0.5]} and config.where == "config"
    assert tomllib.loads(config.text) == {"model": {"builder": "block2d"}, "solver": {},      # TOML has no null
                                          "friction": {"zones": {"A": 0.1, "B": 0.1}, "bounds": {"A": [0, 0.5]}}}
    with pytest.raises(InputError, match=r"^config: unknown table \[frcition\] \(did you mean 'friction'\?\)"):
        config_from_dict({"model": {"builder": "block2d"}, "frcition": {}})


def test_the_readme_example_runs(first, monkeypatch):
    """README.md's Python example, as a doctest in the example's folder."""
    monkeypatch.chdir(first)
    failures, tried = doctest.testfile(str(ROOT / "README.md"), module_relative=False,
                                       optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert tried >= 4 and failures == 0


def test_measurements_digest_follows_the_content(first):
    m = read_measurements(first / "measured.csv")
    same = read_measurements(first / "measured.csv")
    assert m.digest() == same.digest()
    values = {q: v.copy() for q, v in m.values.items()}
    values["ux"][0] += 1e-12
    changed = type(m)(m.points, m.coordinates, m.stage, m.force, values, m.sigma, m.comments, m.source)
    assert changed.digest() != m.digest() and np.isfinite(m.values["ux"][0])


def test_the_api_is_quiet_unless_asked_and_the_cli_shows_each_phase(first, cli_run, capsys):
    """One line per phase (model, condensation, resolution, iterations with objective and step) on the command
    line and with progress=print; nothing from identify() by default."""
    common = dict(observables=["ux", "uy"], stages=[2], noise={"u": 0.0005}, regions=REGIONS)
    model = {"builder": "block2d", "mesh_size": 1.0, "pull": 0.05}
    capsys.readouterr()
    identify(model, first / "measured.csv", {"A": 0.1, "B": 0.1}, **common)
    assert capsys.readouterr() == ("", "")
    lines = []
    identify(model, first / "measured.csv", {"A": 0.1, "B": 0.1}, progress=lines.append, **common)
    assert lines[0].startswith("model: builder 'block2d', plane_strain, ") and "zones A, B" in lines[0]
    assert lines[1].startswith("contact 'block_base': 21 pairs node-to-node")
    assert lines[2].startswith("embedded backend ready: 40 observations at 20 points")
    assert lines[3].startswith("[[Resolution before fitting]]")
    iterations = [line for line in lines if line.startswith("iter ")]
    assert iterations[0].startswith("iter   0  J=") and "step=" not in iterations[0]
    assert all("step=" in line and "A=" in line for line in iterations[1:]) and len(iterations) >= 3
    assert main(["identify", str(first / "identify.toml"), "--resume"]) == 0          # replays cli_run's store
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("model: ") and out[1].startswith("contact 'block_base'")
    assert out[2].startswith("embedded backend ready") and "[[Variables]]" in out


def test_observations_csv_holds_measured_against_fitted(cli_run):
    """observations.csv: one row per observation of result.json's fit.observations, split into point, quantity
    and stage, with the residual in the quantity's unit and in noise levels."""
    result = IdentificationResult.read(cli_run)
    with (cli_run / "observations.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    expected = result["fit"]["observations"]
    assert len(rows) == len(expected) == result["fit"]["n_obs"]
    for row, obs in zip(rows, expected):
        assert f"{row['point']}:{row['quantity']}@{row['stage']}" == obs["label"]
        assert float(row["measured"]) == obs["measured"] and float(row["model"]) == obs["model"]
        residual = obs["model"] - obs["measured"]
        assert float(row["residual"]) == residual
        assert float(row["residual_sigma"]) == pytest.approx(residual / 0.0005, rel=1e-12)


@pytest.mark.slow          # two fits of the block's example (the second replayed from the store)
def test_fields_false_keeps_the_run_folder_without_fields(first, monkeypatch):
    monkeypatch.chdir(first)
    args = ({"builder": "block2d", "mesh_size": 1.0, "pull": 0.05}, "measured.csv", {"A": 0.1, "B": 0.1})
    kwargs = dict(observables=["ux", "uy"], stages=[2], noise={"u": 0.0005}, regions=REGIONS, run_dir="runs/nofields")
    without = identify(*args, **kwargs, fields=False)
    assert (first / "runs/nofields/result.json").exists() and not (first / "runs/nofields/fields").exists()
    again = identify(*args, **kwargs, resume=True)                   # the default writes them
    assert any((first / "runs/nofields/fields").iterdir()) and again.to_dict()["parameters"] == \
        without.to_dict()["parameters"]


@pytest.mark.slow          # three fits of the block's example
def test_a_condensation_held_from_an_earlier_run_is_not_estimated_again(first, monkeypatch):
    """A second identification on the same model and points reuses the first one's condensation, so the memory
    estimate (which counts what the process holds, that condensation included) is not made again; other
    observations mean another condensation, which is estimated."""
    from frictionid.fem import memory

    monkeypatch.chdir(first)
    model = block_model_2d(mesh_size=1.0, pull=0.05)
    kwargs = dict(stages=[2], noise={"u": 0.0005}, regions=REGIONS, refine_target=0, suggestions=0)
    fitted = identify(model, "measured.csv", {"A": 0.1, "B": 0.1}, observables=["ux", "uy"], **kwargs)

    def refuse(*args, **kw):
        raise InputError("estimated again")
    monkeypatch.setattr(memory, "check", refuse)
    again = identify(model, "measured.csv", {"A": 0.1, "B": 0.1}, observables=["ux", "uy"], method="gradient-descent",
                     max_iterations=1, **kwargs)
    assert again.status and fitted.status
    with pytest.raises(InputError, match="estimated again"):
        identify(model, "measured.csv", {"A": 0.1, "B": 0.1}, observables=["ux"], **kwargs)
