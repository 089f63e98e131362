"""identify end to end through the command line: recovery, outputs, kill -9 and --resume, bad input."""

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from block2d_case import MODEL_TABLE, POINTS, TRUE, data_table
from frictionid.cli import main
from helpers import write_config


def _config(folder: Path, name: str, zones: str, data: str, extra: str = "", run: str = "runs/r") -> Path:
    return write_config(folder / name, extra + f'[run]\ndir = "{run}"\n', model=MODEL_TABLE,
                        friction=f"zones = {{ {zones} }}\n", data=data_table(data))


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """Data made by `frictionid simulate` with the true coefficients (same mesh: a check of the machinery)."""
    folder = tmp_path_factory.mktemp("identify")
    (folder / "points.csv").write_text(POINTS)
    truth = _config(folder, "truth.toml", ", ".join(f"{k} = {v}" for k, v in TRUE.items()), "points.csv")
    assert main(["simulate", str(truth), "--out", str(folder / "measured.csv")]) == 0
    return folder


def test_trf_recovers_the_coefficients_and_writes_its_files(measured, capsys):
    config = _config(measured, "trf.toml", "A = 0.1, B = 0.1, C = 0.1", "measured.csv", run="runs/trf")
    assert main(["identify", str(config)]) == 0
    out = capsys.readouterr().out
    assert "iter   0" in out and "[[Variables]]" in out
    result = json.loads((measured / "runs/trf/result.json").read_text())
    assert result["status"] == "converged"
    for zone, value in TRUE.items():
        assert result["parameters"][zone]["value"] == pytest.approx(value, abs=1e-6)
        assert result["parameters"][zone]["stderr"] > 0
    assert result["n_sensitivity_solves"] < 15 and result["n_forward_solves"] == 0
    assert (measured / "runs/trf/history.csv").read_text().startswith("iteration,objective,A,B,C")
    assert (measured / "runs/trf/convergence.png").stat().st_size > 1000
    assert (measured / "runs/trf/residuals.png").stat().st_size > 1000
    # data simulated on the fit's own mesh carry no noise: chi-square far below its 1 % quantile
    assert "[[Fit Adequacy]]" in out and "SMALLER THAN THE STATED NOISE ALLOWS" in out
    assert result["fit"]["consistent"] is True and result["fit"]["reduced_chi2"] < 1e-6
    assert result["fit"]["too_small"] is True and "the stated noise is too large" in result["fit"]["hint"]
    assert [p["point"] for p in result["fit"]["points"]] == ["P1", "P2", "P3", "P4", "P5", "P6"]


@pytest.mark.parametrize("extra, key", [('[identify]\nloss = "l1"\n', "identify.loss"),
                                        ('[identify]\nmethod = "lbfgsb"\nloss = "huber"\n', "identify.loss"),
                                        ("[identify]\nloss_scale = 0\n", "identify.loss_scale")])
def test_bad_robust_loss_settings_exit_2_naming_the_key(measured, capsys, extra, key):
    config = _config(measured, "loss.toml", "A = 0.1, B = 0.1, C = 0.1", "measured.csv", extra, run="runs/loss")
    assert main(["identify", str(config)]) == 2
    assert key in capsys.readouterr().err


def test_a_fixed_zone_stays_put(measured):
    config = _config(measured, "fixed.toml", "A = 0.1, B = 0.1", "measured.csv", run="runs/fixed")
    config.write_text(config.read_text().replace("[data]", "fixed = { C = 0.41 }\n[data]"))
    assert main(["identify", str(config)]) == 0
    result = json.loads((measured / "runs/fixed/result.json").read_text())
    assert result["parameters"]["C"] == {"value": 0.41, "initial": 0.41, "fixed": True}
    assert result["parameters"]["A"]["value"] == pytest.approx(TRUE["A"], abs=1e-6)


def _evaluations(store: Path) -> int:
    try:
        with sqlite3.connect(store) as db:
            return db.execute("select count(*) from evaluations").fetchone()[0]
    except sqlite3.Error:
        return 0


@pytest.mark.slow              # 92 s measured on the shared machine (two full fits and a killed process)
def test_kill_9_then_resume_recomputes_nothing_and_ends_where_an_uninterrupted_run_ends(measured):
    extra = '[identify]\nmethod = "gradient-descent"\njacobian = "forward"\nmax_iterations = 30\n'
    whole = _config(measured, "whole.toml", "A = 0.1, B = 0.1, C = 0.1", "measured.csv", extra, "runs/whole")
    assert main(["identify", str(whole)]) == 0
    reference = json.loads((measured / "runs/whole/result.json").read_text())
    killed = _config(measured, "killed.toml", "A = 0.1, B = 0.1, C = 0.1", "measured.csv", extra, "runs/killed")
    store = measured / "runs/killed/store.sqlite"
    child = subprocess.Popen([sys.executable, "-m", "frictionid.cli", "identify", str(killed)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 600
    while _evaluations(store) < 20 and time.monotonic() < deadline and child.poll() is None:
        time.sleep(0.02)
    os.kill(child.pid, signal.SIGKILL)
    child.wait()
    before = _evaluations(store)
    assert 20 <= before < reference["n_forward_solves"], "the kill must land in the middle of the run"
    assert main(["identify", str(killed), "--resume"]) == 0
    resumed = json.loads((measured / "runs/killed/result.json").read_text())
    assert [p["value"] for p in resumed["parameters"].values()] == [p["value"] for p in reference["parameters"].values()]
    assert resumed["n_replayed"] >= before - 1          # at most the evaluation in flight is lost
    assert _evaluations(store) == reference["n_forward_solves"]   # nothing evaluated twice


@pytest.mark.slow          # 38 s in the fast suite on the shared machine (about 1/7 idle)
def test_ctrl_c_as_a_real_signal_stops_with_exit_1_a_result_and_the_resume_hint(measured):
    """SIGINT to the command-line process mid-run (after gmsh built the mesh: gmsh must not leave Ctrl-C killing
    the process): exit status 1, the message naming --resume, result.json "interrupted", the store kept."""
    extra = '[identify]\nmethod = "gradient-descent"\njacobian = "forward"\nmax_iterations = 30\n'
    config = _config(measured, "sigint.toml", "A = 0.1, B = 0.1, C = 0.1", "measured.csv", extra, "runs/sigint")
    store = measured / "runs/sigint/store.sqlite"
    # as at a terminal: a test runner started in the background of a shell ignores SIGINT, and so would its child
    child = subprocess.Popen([sys.executable, "-m", "frictionid.cli", "identify", str(config)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 600
    while _evaluations(store) < 10 and time.monotonic() < deadline and child.poll() is None:
        time.sleep(0.02)
    # the signal lands in the fit, not before it (on a loaded machine the start takes long)
    assert child.poll() is None and _evaluations(store) >= 10, "the run did not reach 10 evaluations in 600 s"
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=60)
    assert child.returncode == 1, (child.returncode, err)
    assert "interrupted" in err and "--resume" in err and "Traceback" not in err
    result = json.loads((measured / "runs/sigint/result.json").read_text())
    assert result["status"] == "interrupted" and _evaluations(store) >= 10


@pytest.mark.parametrize("change, message", [
    (("A = 0.1, B = 0.1, C = 0.1", "A = 0.1, B = 0.1, Z = 0.1"), "unknown zone(s) ['Z']"),
    (("A = 0.1, B = 0.1, C = 0.1", "A = 1.5, B = 0.1, C = 0.1"), "zones.A = 1.5 lies outside bounds"),
    (('observables = ["ux", "uy"]', 'observables = ["ux", "exx"]'), "no measured quantity 'exx'"),
    (('stages = [2]', 'stages = [3]'), "stage 3 is not one of the model's stages 1..2"),
    (('mesh_size = 1.0', 'mesh_sise = 1.0'), "did you mean 'mesh_size'"),
    (('stages = [2]', 'stages = 2'), "data.stages must be a list of stage numbers"),
    (('zones = { A = 0.1, B = 0.1, C = 0.1 }', 'zones = 0.1'), "friction.zones must be a table"),
    (('observables = ["ux", "uy"]', 'observables = ["ux", 3]'), "data.observables has 3"),
    (("[run]", "[identify]\nmethod = \"newton\"\n[run]"), "'newton'"),
    (("[run]", "[identify]\ntikhonov = 1.0\nprior = [0.2, 0.2]\n[run]"), "identify.prior must be a number or a list of 3"),
    (("[run]", "[identify]\nmethod = \"gradient-descent\"\noptions = { xtol = 1e-6 }\n[run]"),
     "[identify] option 'xtol' is not an option of method 'gradient-descent'"),
])
def test_bad_config_exits_2_with_a_message(measured, capsys, change, message):
    config = _config(measured, "bad.toml", "A = 0.1, B = 0.1, C = 0.1", "measured.csv", run="runs/bad")
    config.write_text(config.read_text().replace(*change))
    assert main(["identify", str(config)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_empty_data_exits_2(measured, capsys):
    (measured / "empty.csv").write_text("point,x,y,z,stage,ux\n")
    config = _config(measured, "empty.toml", "A = 0.1, B = 0.1, C = 0.1", "empty.csv", run="runs/empty")
    assert main(["identify", str(config)]) == 2
    assert "no data rows" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["identify", "simulate"])
def test_a_point_outside_its_region_is_named_by_label_and_file(measured, capsys, command):
    text = (measured / "measured.csv").read_text().replace("P4,5.0,", "P4,5.5,")      # beside the block
    (measured / "outside.csv").write_text(text)
    config = _config(measured, "outside.toml", "A = 0.1, B = 0.1, C = 0.1", "outside.csv", run="runs/outside")
    extra = ["--out", str(measured / "unused.csv")] if command == "simulate" else []
    assert main([command, str(config), *extra]) == 2
    err = capsys.readouterr().err
    assert "outside.csv: point 'P4' at [5.5, 1.5] [mm] is outside region 'block'" in err and "Traceback" not in err
    assert not (measured / "runs/outside").exists(), "a run that never started must leave no store behind"


def test_an_interrupted_run_leaves_its_result_and_store(measured, monkeypatch):
    """Ctrl-C after the second iteration: exit 1, result.json says interrupted with the last iterate."""
    import frictionid.cli as cli_module

    def interrupt(text):
        if text.startswith("iter   2 "):
            raise KeyboardInterrupt

    monkeypatch.setattr(cli_module, "_echo", interrupt)
    config = _config(measured, "ctrlc.toml", "A = 0.1, B = 0.1, C = 0.1", "measured.csv", run="runs/ctrlc")
    assert main(["identify", str(config)]) == 1
    result = json.loads((measured / "runs/ctrlc/result.json").read_text())
    assert result["status"] == "interrupted" and result["n_iterations"] == 2
    assert result["parameters"]["A"]["value"] != 0.1
    monkeypatch.undo()
    assert main(["identify", str(config), "--resume"]) == 0
    assert json.loads((measured / "runs/ctrlc/result.json").read_text())["status"] == "converged"
