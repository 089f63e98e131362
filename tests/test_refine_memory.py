"""The discretisation control and the model-error estimate say what they do (level, mesh, dofs, memory) and refuse a condensation
that would take more memory than [solver] max_memory allows, before it is built ."""

import json
import re
from pathlib import Path

import pytest

from block2d_case import REGION_TABLE, data_table, points_csv
import frictionid.inverse.discretisation_control as control_module
from frictionid.builders.registry import build_model
from frictionid.cli import main
from frictionid.fem import memory
from helpers import write_config
from frictionid.options import ModelSpec

TRUE = {"A": 0.32, "B": 0.18}


def _config(folder: Path, name: str, identify: str, solver: str = "", mesh_size: float = 2.0) -> Path:
    return write_config(folder / f"{name}.toml", solver + f'[run]\ndir = "runs/{name}"\n',
                        model={"builder": "block2d", "mesh_size": mesh_size, "height": 4.0, "order": 1},
                        friction={"zones": {"A": 0.1, "B": 0.1}}, data=data_table("measured.csv", noise=0.0001),
                        identify=identify)


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    folder = tmp_path_factory.mktemp("refine_memory")
    (folder / "points.csv").write_text(points_csv(stage=2, quantities=("ux", "uy")))
    truth = write_config(folder / "truth.toml", model={"builder": "block2d", "mesh_size": 1.0, "height": 4.0,
                                                       "order": 1},
                         friction={"zones": {"A": 0.32, "B": 0.18}},
                         data={"file": "points.csv", "observables": ["ux", "uy"], "stages": [2],
                               "regions": REGION_TABLE})
    assert main(["simulate", str(truth), "--out", str(folder / "measured.csv")]) == 0
    return folder


@pytest.mark.discretisation_control
def test_the_control_prints_its_phases_with_mesh_dofs_and_memory(measured, capsys):
    config = _config(measured, "progress", "refine_target = 1000\nrefine_budget = 2\n")
    assert main(["identify", str(config)]) == 0
    out = capsys.readouterr().out
    assert re.search(r"discretisation control: the model's error at the start values by refining it in each of 1 "
                     r"direction\(s\) \(element sizes\), target 1000", out), out
    line = re.search(r"discretisation control: element sizes x2: ([\d,]+) nodes, ([\d,]+) dofs, "
                     r"estimated memory ([\d.]+) GB of ([\d.]+) GB allowed", out)
    assert line, out
    assert int(line[2].replace(",", "")) == 2 * int(line[1].replace(",", ""))       # plane strain: 2 dofs a node
    assert float(line[4]) == pytest.approx(memory.DEFAULT_FRACTION * memory.machine_memory() / memory.GB, abs=0.06)
    assert re.search(r"discretisation control: estimated error as given u [\d.]+; fitting the model as given "
                     r"\([\d,]+ nodes\), predicted u [\d.]+ noise levels RMS: target 1000 not needed", out), out


@pytest.mark.discretisation_control
def test_a_refinement_over_the_memory_allowed_is_not_condensed_and_the_record_says_so(measured, capsys,
                                                                                      monkeypatch):
    # the process holds 1 GB (fixed: its real resident memory moves by more than this model's condensation) and
    # may take 3 times the fitted model's condensation more: the fit fits, the directional model (about 4 times
    # the nodes, 5 times the memory) does not, so the control condenses none and the model is fitted as given
    monkeypatch.setattr(memory, "resident", lambda: memory.GB)
    model = build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 2.0, "height": 4.0, "order": 1}))
    allowed = 1.0 + 3.0 * memory.condensation_bytes(2 * model.mesh.n_nodes, 2) / memory.GB
    config = _config(measured, "memory", "refine_target = 1\nrefine_budget = 2\n",
                     f"[solver]\nmax_memory = {allowed:.6f}\n")
    assert main(["identify", str(config)]) == 0
    out = capsys.readouterr().out
    line = (r"discretisation control: element sizes x2: [\d,]+ nodes, [\d,]+ dofs, estimated memory [\d.]+ GB of "
            r"[\d.]+ GB allowed: more than \[solver\] max_memory allows, not condensed")
    assert re.search(line + "; the model is fitted as it is", out), out
    record = json.loads((measured / "runs/memory/result.json").read_text())["model"]
    assert record["discretisation"]["status"] == "skipped" and re.match(line, record["discretisation"]["why"])
    assert record["mesh_size"] == 2.0


@pytest.mark.discretisation_control
def test_a_refinement_over_the_memory_allowed_at_its_least_growth_is_not_even_built(measured, capsys, monkeypatch):
    # allowed: 1.2 times the fitted model's condensation; every size halved gives at least twice its nodes in 2-D
    # (memory.check_growth's least growth), over that, so the refined mesh is refused before it is built
    monkeypatch.setattr(memory, "resident", lambda: memory.GB)
    model = build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 2.0, "height": 4.0, "order": 1}))
    allowed = 1.0 + 1.2 * memory.condensation_bytes(2 * model.mesh.n_nodes, 2) / memory.GB
    config = _config(measured, "least", "refine_target = 1\nrefine_budget = 2\n",
                     f"[solver]\nmax_memory = {allowed:.6f}\n")
    built, solved = [], []
    monkeypatch.setattr(control_module, "build_model", lambda *args: built.append(args) or build_model(*args))
    values = control_module.values
    monkeypatch.setattr(control_module, "values", lambda *args, **kw: solved.append(args) or values(*args, **kw))
    assert main(["identify", str(config)]) == 0
    out = capsys.readouterr().out
    line = (r"discretisation control: element sizes x2 \(at least\): [\d,]+ nodes, [\d,]+ dofs, estimated memory "
            r"[\d.]+ GB of [\d.]+ GB allowed: more than \[solver\] max_memory allows, not built")
    assert re.search(line + "; the model is fitted as it is", out), out
    assert built == [] and solved == []          # nor the model solved for the control: the fit's first solve


@pytest.mark.parametrize("value", ["-1", "0", '"8 GB"'])
def test_a_bad_max_memory_exits_2_naming_the_key(measured, capsys, value):
    config = _config(measured, "bad", "", f"[solver]\nmax_memory = {value}\n")
    assert main(["identify", str(config)]) == 2
    assert "max_memory" in capsys.readouterr().err


def test_the_memory_law_is_at_or_above_the_measured_condensations():
    """Peak memory of processes that built and condensed the 3-D block with observation points (the law's
    anchors, frictionid.fem.memory): the estimate is within [1, 1.6] times each, so it refuses little that would
    fit and nothing that would not."""
    measured = {23_595: 0.49, 56_187: 1.36, 113_616: 3.6}     # [GB]
    for dofs, peak in measured.items():
        assert 1.0 <= memory.condensation_bytes(dofs, 3) / memory.GB / peak <= 1.6, dofs


def test_the_estimate_counts_the_contact_pairs_and_their_dense_blocks():
    """The pairs counted from the model before they are made are the ones the condensation makes (3-D block and
    the axisymmetric bolt), and the estimate carries their dense blocks: CONTACT_WORDS (dim n_c)^2 doubles."""
    from frictionid.builders.block import block_model
    from frictionid.builders.bolt import bolt_model
    from frictionid.fem.interface import contact_pairs, model_space
    for model in (block_model(mesh_size=5.0), bolt_model(flank_size=0.25, forces=(1000.0,), n_increments=1)):
        n_pairs = contact_pairs(model_space(model), model).n_pairs
        assert memory.contact_pairs(model) == n_pairs
        dim = 3 if model.kind == "3d" else 2
        estimate = memory.estimate(model, "model")
        rest = estimate.needed - memory.contact_bytes(n_pairs, dim)
        assert rest == pytest.approx(memory.resident() + memory.condensation_bytes(estimate.n_dofs, dim), rel=0.05)
        assert memory.contact_bytes(n_pairs, dim) == memory.CONTACT_WORDS * 8 * (dim * n_pairs) ** 2


def test_peak_measures_what_a_piece_of_work_took_above_what_was_held():
    import numpy as np
    held = np.ones(10_000_000)                                       # 80 MB held before: not counted
    with memory.Peak() as took:
        block = np.ones(25_000_000)                                  # 200 MB
        del block
    if took.above is None:
        pytest.skip("this system cannot reset the process's peak memory")
    assert 0.95 * 200e6 <= took.above <= 1.3 * 200e6, took.above
    assert held.sum() == 1e7


def test_the_scale_multiplies_the_condensations_part_only():
    from frictionid.builders.block import block_model
    model = block_model(mesh_size=5.0)
    one, two = memory.estimate(model, "model"), memory.estimate(model, "model", scale=2.0)
    assert two.above == pytest.approx(2.0 * one.above, rel=1e-12)
    assert two.held == pytest.approx(one.held, rel=0.05)


@pytest.mark.discretisation_control
def test_the_control_measures_its_builds_and_scales_the_law_by_what_they_took(measured, capsys, monkeypatch):
    # every build "takes" 1 GB above what the process holds (the kernel's peak, patched: a real build's growth
    # depends on what earlier tests left in the heap), where the law estimates some hundred MB: the record and
    # the progress carry the ratio, and the directional model's estimate is scaled by it
    monkeypatch.setattr(memory, "_reset_peak", lambda: True)
    monkeypatch.setattr(memory, "_peak_resident", lambda: memory.resident() + memory.GB)
    config = _config(measured, "scaled", "refine_target = 1000\nrefine_budget = 1\n", mesh_size=0.5)
    assert main(["identify", str(config)]) == 0
    out = capsys.readouterr().out
    record = json.loads((measured / "runs/scaled/result.json").read_text())["model"]["discretisation"]
    coarse = build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 0.5, "height": 4.0, "order": 1}))
    law = memory.estimate(coarse, "model").above
    assert record["memory_scale"] == pytest.approx(memory.GB / law, rel=0.05)
    assert f"took up to {record['memory_scale']:.2f} times the memory law's estimate" in out
    fine = build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 0.25, "height": 4.0, "order": 1}))
    assert record["directions"][0]["n_nodes"] == fine.mesh.n_nodes
    scaled = record["memory_scale"] * memory.estimate(fine, "model").above / memory.GB
    assert record["directions"][0]["memory_gb"] >= 0.98 * scaled > 1.5 * memory.estimate(fine, "model").above / memory.GB


def test_the_process_peak_survives_the_resets_of_a_measured_build():
    import numpy as np
    with memory.Peak():
        block = np.ones(40_000_000)                                  # 320 MB
        del block
    with memory.Peak() as took:                                      # the kernel's peak starts anew here
        pass
    if took.above is None:
        pytest.skip("this system cannot reset the process's peak memory")
    assert memory.process_peak() >= memory.resident() + 0.9 * 320e6
