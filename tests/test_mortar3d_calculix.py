"""A user's block and plate meshed separately in gmsh, their interface non-matching (3-D dual mortar in the
embedded solver, SURFACE TO SURFACE pairs in CalculiX), through `frictionid simulate` with both backends on the
same .inp deck (needs ccx; skipped without it)."""

import shutil

import numpy as np
import pytest

from frictionid.builders.mesh import mesh_model

from element_models import BLOCK_3D
from stacks3d import write_nonmatching_block
from fixtures.user_block import generate
from test_calculix_elements import _compare, _simulate_both, _user_config

pytestmark = [pytest.mark.ccx,
              pytest.mark.skipif(shutil.which("ccx") is None,
                                 reason="ccx (CalculiX) is not installed: apt-get install calculix-ccx")]

#: measured with the defaults of write_nonmatching_block, 4 pull increments (docs/solver.md)
MEASURED = ("displacements 0.09 % (press) and 0.17 % (pull) RMS of range, pull reaction embedded 635.5 N, "
            "ccx 631.7 N (-0.60 %; ccx's own sum mu_i N_i 636.3 N: its penalty friction stays 0.7 % under "
            "Coulomb's force)")


def test_separately_meshed_block_and_plate_against_calculix(tmp_path):
    """Displacements at the fixture's 46 points within 1 % of their range (RMS over points and stages), the
    pull's reaction within 1 %, in gross slip. Measured: see MEASURED."""
    write_nonmatching_block(tmp_path / "nonmatching.msh")
    model = mesh_model(tmp_path / "nonmatching.msh", **BLOCK_3D)
    contact = np.unique(np.concatenate([model.mesh.boundary_nodes(z) for z in "ABCD"]))
    assert len(contact) == 9 ** 2                     # 4 divisions per half side (the plate's footprint: 3)
    generate.write_block_inp(tmp_path / "nonmatching.msh", tmp_path / "nonmatching.inp")
    config = _user_config("identify.toml", "nonmatching.inp", "points.csv", '["ux", "uy", "uz", "force"]',
                          "increments = [1, 4]", "{ A = 0.3, B = 0.2, C = 0.4, D = 0.25 }")
    u, force = _compare(_simulate_both(tmp_path, config, "points.csv"), ("ux", "uy", "uz"))
    assert u < 0.01, MEASURED
    assert np.all(force[0] > 500.0)                                          # the pull's 0.2 mm in gross slip
    np.testing.assert_allclose(force[1], force[0], rtol=0.01, err_msg=MEASURED)
