"""examples/parts3d end to end: block and plate meshed as separate gmsh parts (non-matching interface, 3-D dual
mortar), twin data at rear 0.2 and front 0.4, identified through `frictionid identify`."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from frictionid.builders.mesh import read_mesh_file
from frictionid.cli import main

ROOT = Path(__file__).parents[1]
TRUTH = {"rear": 0.2, "front": 0.4}              # examples/parts3d/truth.toml: A = B = 0.2, C = D = 0.4

pytestmark = pytest.mark.slow                    # mesh, simulate and identify: about 16 s of CPU


@pytest.fixture(scope="module")
def parts(tmp_path_factory):
    """A copy of examples/parts3d (without meshes, runs or data) after its three commands."""
    folder = tmp_path_factory.mktemp("parts3d") / "parts3d"
    shutil.copytree(ROOT / "examples" / "parts3d", folder,
                    ignore=shutil.ignore_patterns("runs", "measured.*", "*.msh", "__pycache__"))
    subprocess.run([sys.executable, "mesh.py"], cwd=folder, check=True)
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    assert main(["identify", str(folder / "identify.toml")]) == 0
    return folder


def test_the_parts_do_not_share_or_match_interface_nodes(parts):
    mesh = read_mesh_file(parts / "block_plate.msh")
    block = np.unique(np.concatenate([mesh.boundaries[z].ravel() for z in "ABCD"]))
    plate = np.unique(mesh.boundaries["plate_top"])
    assert not np.intersect1d(block, plate).size
    distance = np.linalg.norm(mesh.points[block][:, None] - mesh.points[plate][None], axis=2).min(axis=1)
    # 5 and 4 elements per half side: block nodes face plate nodes only where x and y are both 0 or +-5 mm
    assert len(block) == 11 ** 2 and np.count_nonzero(distance < 1e-9) == 9


def test_identify_recovers_both_coefficients_with_the_mortar_contact(parts):
    result = json.loads((parts / "runs" / "parts3d" / "result.json").read_text())
    assert result["status"] == "converged"
    for zone, truth in TRUTH.items():
        parameter = result["parameters"][zone]
        low, high = parameter["ci95"]
        assert low <= truth <= high
        assert parameter["value"] == pytest.approx(truth, abs=1e-6)       # noise-free data from the same mesh
    # README: standard errors 0.0188 (rear), 0.000126 (front)
    assert result["parameters"]["rear"]["stderr"] == pytest.approx(0.0188, rel=0.02)
    assert result["parameters"]["front"]["stderr"] == pytest.approx(0.000126, rel=0.02)
    assert result["model"]["contact"][0]["discretisation"] == "mortar"
