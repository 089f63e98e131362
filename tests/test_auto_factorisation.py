"""``factorisation = "auto"`` picks MUMPS where CHOLMOD's estimated condensation exceeds the default max_memory
(fem/memory.py ``automatic``), so that a large 3-D model builds with the defaults; CHOLMOD otherwise."""

import pytest

from frictionid.builders.block import block_model
from frictionid.fem import memory, mumps_schur
import frictionid.fem.problem as problem_module
from frictionid.fem.problem import Problem

pytestmark = pytest.mark.skipif(not mumps_schur.available(), reason="python-mumps is not installed")


@pytest.fixture(scope="module")
def model():
    return block_model(mesh_size=1.0, n_pull=2)     # 7,865 nodes: MUMPS's estimate below CHOLMOD's


def test_auto_is_cholmod_where_its_estimate_fits(model):
    assert memory.automatic(model) == "cholmod"


def test_auto_is_mumps_where_cholmod_exceeds_the_default_limit(model, monkeypatch):
    cholmod, mumps = (memory.estimate(model, "", None, name) for name in ("cholmod", "mumps"))
    assert mumps.above < cholmod.above
    # a machine whose default limit lies between the two estimates
    monkeypatch.setattr(memory, "machine_memory",
                        lambda: (cholmod.needed + mumps.needed) / 2 / memory.DEFAULT_FRACTION)
    assert memory.automatic(model) == "mumps"
    assert memory.estimate(model, "", None, "auto").needed == pytest.approx(mumps.needed, rel=0.05)
    used = []

    def recorded(*args, factorisation, **kwargs):     # the condensation's choice, not its work
        used.append(factorisation)
        raise Stop

    monkeypatch.setattr(problem_module, "condense", recorded)
    with pytest.raises(Stop):
        Problem.build(model, points=model.mesh.points[:3], quantities=("uy",))
    assert used == ["mumps"]


class Stop(Exception):
    pass
