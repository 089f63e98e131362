"""Refinement and the model-error estimate say what they do (level, mesh, dofs, memory) and refuse a condensation
that would take more memory than [solver] max_memory allows, before it is built (issue 31 item 3)."""

import re
from pathlib import Path

import pytest

from block2d_case import points_csv
from frictionid.cli import main
from frictionid.fem import memory

TRUE = {"A": 0.32, "B": 0.18}
REGIONS = 'regions = { P1 = "block", P2 = "block", P3 = "block", P4 = "block", P5 = "base", P6 = "base" }\n'


def _config(folder: Path, name: str, identify: str, solver: str = "") -> Path:
    path = folder / f"{name}.toml"
    path.write_text('[model]\nbuilder = "block2d"\nmesh_size = 2.0\nheight = 4.0\norder = 1\n'
                    "[friction]\nzones = { A = 0.1, B = 0.1 }\n"
                    '[data]\nfile = "measured.csv"\nobservables = ["ux", "uy"]\nstages = [2]\n'
                    "noise = { u = 0.0001 }\n" + REGIONS + f"[identify]\n{identify}" + solver
                    + f'[run]\ndir = "runs/{name}"\n')
    return path


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    folder = tmp_path_factory.mktemp("refine_memory")
    (folder / "points.csv").write_text(points_csv(stage=2, quantities=("ux", "uy")))
    truth = folder / "truth.toml"
    truth.write_text('[model]\nbuilder = "block2d"\nmesh_size = 1.0\nheight = 4.0\norder = 1\n'
                     "[friction]\nzones = { A = 0.32, B = 0.18 }\n"
                     '[data]\nfile = "points.csv"\nobservables = ["ux", "uy"]\nstages = [2]\n' + REGIONS)
    assert main(["simulate", str(truth), "--out", str(folder / "measured.csv")]) == 0
    return folder


def test_refinement_prints_its_phases_with_mesh_dofs_and_memory(measured, capsys):
    config = _config(measured, "progress", "refine_target = 1000\nrefine_budget = 2\n")
    assert main(["identify", str(config)]) == 0
    out = capsys.readouterr().out
    assert re.search(r"refinement level 0 of at most 2: the model has [\d,]+ nodes", out)
    line = re.search(r"model error: the model refined by 2 \(mesh_size 1\): ([\d,]+) nodes, ([\d,]+) dofs, "
                     r"estimated memory ([\d.]+) GB of ([\d.]+) GB allowed", out)
    assert line, out
    assert int(line[2].replace(",", "")) == 2 * int(line[1].replace(",", ""))       # plane strain: 2 dofs a node
    assert float(line[4]) == pytest.approx(memory.DEFAULT_FRACTION * memory.machine_memory() / memory.GB, abs=0.06)
    assert re.search(r"refinement level 0: estimated model error [\d.e+-]+ noise levels RMS \(target 1000\)", out)


def test_a_refinement_over_the_memory_allowed_is_refused_before_it_is_built(measured, capsys):
    # less than this process already holds: any condensation is over it, so the first refinement is refused
    allowed = 0.9 * memory.resident() / memory.GB
    config = _config(measured, "memory", "refine_target = 1\nrefine_budget = 2\n",
                     f"[solver]\nmax_memory = {allowed:.6f}\n")
    assert main(["identify", str(config)]) == 2
    err = capsys.readouterr().err
    assert re.search(r"model error: the model refined by 2 \(mesh_size 1\) \(at least\): [\d,]+ nodes, [\d,]+ "
                     r"dofs, estimated memory [\d.]+ GB of [\d.]+ GB allowed: more than \[solver\] max_memory "
                     r"allows; refused before condensing it", err), err
    assert "Traceback" not in err
    assert not (measured / "runs/memory").exists()                     # nothing started, nothing to lose


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
