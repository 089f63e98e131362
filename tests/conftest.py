"""Models several test modules share; models are immutable, so one build per session serves them all."""

import pytest

from frictionid.builders.block import block_model, block_model_2d


@pytest.fixture(scope="session")
def block3d():
    """Reference test 1's block with the builder's defaults (linear hexahedra with incompatible modes, graded),
    coarse: mesh_size 5 mm."""
    return block_model(mesh_size=5.0)


@pytest.fixture(scope="session")
def block2d():
    """The plane-strain block (two zones, quadratic triangles) with the builder's defaults, mesh_size 2 mm."""
    return block_model_2d(mesh_size=2.0)
