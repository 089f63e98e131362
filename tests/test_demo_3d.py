"""`frictionid demo --model 3d`: the command line reaches the 3-D study, and refuses what it cannot do before
building anything (the study itself takes about half an hour: benchmarks/bolt3d_identify_m20.py runs it too);
that benchmark's per-face rigid-motion correction of the window's field."""

import pytest

import frictionid.studies.bolt as axisymmetric
import frictionid.studies.bolt3d as study
from frictionid.cli import main


@pytest.fixture
def no_study(monkeypatch):
    """The studies' work replaced by a recorder: a test that reaches it when it should not fails."""
    calls = []

    def record(out, settings, resume, echo):
        calls.append((out, settings, resume))
        return {}
    monkeypatch.setattr(study, "_study", record)
    monkeypatch.setattr(axisymmetric, "_run", lambda *args: pytest.fail("the axisymmetric study was started"))
    return calls


@pytest.mark.parametrize("option", ["--quick", "--block"])
def test_3d_refuses_the_options_it_has_no_variant_for(tmp_path, capsys, no_study, option):
    assert main(["demo", "--model", "3d", option, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"demo --model 3d: {option} is not available" in err and "Traceback" not in err
    assert no_study == [] and not (tmp_path / "out").exists()


def test_3d_refuses_a_folder_with_runs_unless_resumed(tmp_path, capsys, no_study):
    (tmp_path / "runs" / "trf").mkdir(parents=True)
    (tmp_path / "runs" / "trf" / "store.sqlite").write_bytes(b"")
    assert main(["demo", "--model", "3d", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "already holds the demo's runs ['trf']" in err and "--resume" in err and no_study == []
    assert main(["demo", "--model", "3d", "--resume", "--out", str(tmp_path)]) == 0
    (out, settings, resume), = no_study
    assert out == tmp_path and resume is True and settings == study.Settings3d()


def test_3d_out_must_be_a_folder(tmp_path, capsys, no_study):
    (tmp_path / "file").write_text("x")
    assert main(["demo", "--model", "3d", "--out", str(tmp_path / "file")]) == 2
    assert "is a file; expected a folder" in capsys.readouterr().err and no_study == []


def test_model_must_be_one_the_demo_has(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["demo", "--model", "2d"])
    assert exit_.value.code == 2 and "invalid choice: '2d'" in capsys.readouterr().err


def test_fig9_table_lines_up_iterations_of_both_methods():
    runs = {name: {"method": method, "jacobian": jacobian, "relative_error": curve}
            for (name, _, method, jacobian), curve in zip(study.PLAN, ([1.0, 0.5, 0.01], [1.0, 0.9]))}
    lines = study.fig9_lines(runs)
    assert "trf (analytic)" in lines[1] and "gradient-descent (forward)" in lines[1]
    assert [line.split() for line in lines[2:]] == [["0", "1", "1"], ["1", "0.5", "0.9"], ["2", "0.01"]]


def test_the_window_benchmark_takes_each_faces_rigid_motion_out():
    """benchmarks/bolt3d_identify_m20.py's without_rigid: per face (bolt rows first), a translation plus a small
    rotation t + w x p is removed exactly; with the translation only, the rotation's part is left; a deformation
    that is not rigid is kept."""
    import importlib.util
    import sys
    from pathlib import Path

    import numpy as np
    benchmarks = Path(__file__).parents[1] / "benchmarks"
    sys.path.insert(0, str(benchmarks))
    spec = importlib.util.spec_from_file_location("bolt3d_identify_m20", benchmarks / "bolt3d_identify_m20.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    rng = np.random.default_rng(0)
    points = rng.normal(size=(30, 3)) * 5.0
    rigid = np.vstack([np.array(t) + np.cross(w, p) for t, w, rows in
                       (([1.0, 2.0, 3.0], [0.01, -0.02, 0.03], points[:20]),
                        ([-4.0, 0.5, 0.0], [0.0, 0.02, -0.01], points[20:]))
                       for p in rows])
    assert np.abs(bench.without_rigid(rigid, points, 20, rotation=True)).max() < 1e-12
    assert np.abs(bench.without_rigid(rigid, points, 20, rotation=False)).max() > 0.1
    stretch = np.zeros_like(points)
    stretch[:, 1] = 1e-3 * points[:, 1] ** 2                  # not rigid: kept (less its own rigid part)
    assert np.abs(bench.without_rigid(stretch + rigid, points, 20, rotation=True)).max() > 1e-3
