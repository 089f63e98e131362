"""Models and data several test modules share; models are immutable, so one build per session serves them all."""

import shutil
from pathlib import Path

import pytest

from frictionid import config
from frictionid.builders.block import block_model, block_model_2d
from frictionid.cli import main

ROOT = Path(__file__).parents[1]


@pytest.fixture(scope="session", autouse=True)
def discretisation_control_off():
    """The discretisation control (identify.refine_target, default 0.5) off in the whole session, module- and
    session-scoped fixtures included: it costs two refined condensations per identification and, on the twins'
    data, fits another mesh than the one their assertions are about. Tests marked ``discretisation_control`` get
    the real default back (:func:`discretisation_control_default`)."""
    default = config.SCHEMA["identify"]["refine_target"]
    config.SCHEMA["identify"]["refine_target"] = 0.0
    yield default
    config.SCHEMA["identify"]["refine_target"] = default


@pytest.fixture(autouse=True)
def discretisation_control_default(request, monkeypatch, discretisation_control_off):
    """The control's default within the tests marked ``discretisation_control``."""
    if request.node.get_closest_marker("discretisation_control") is not None:
        monkeypatch.setitem(config.SCHEMA["identify"], "refine_target", discretisation_control_off)


@pytest.fixture(scope="session")
def block3d():
    """Reference test 1's block with the builder's defaults (linear hexahedra with incompatible modes, graded),
    coarse: mesh_size 5 mm."""
    return block_model(mesh_size=5.0)


@pytest.fixture(scope="session")
def block2d():
    """The plane-strain block (two zones, quadratic triangles) with the builder's defaults, mesh_size 2 mm."""
    return block_model_2d(mesh_size=2.0)


@pytest.fixture(scope="session")
def first(tmp_path_factory):
    """A copy of examples/first with its twin data made (A 0.30, B 0.15 on the 0.5 mm mesh), stages 1 and 2; tests
    write their runs into it under names of their own."""
    folder = tmp_path_factory.mktemp("first") / "first"
    shutil.copytree(ROOT / "examples" / "first", folder)
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    return folder
