"""An interface whose initial gaps are set to zero (``ContactInterface.adjust``) in the CalculiX deck: *CLEARANCE,
VALUE=0 on each zone's SURFACE TO SURFACE pair (ccx 2.20 manual, *CLEARANCE: the value replaces the gap at every
slave integration point of face-to-face contact). The deck's text without ccx; ccx's behaviour on two blocks with
a meshed gap, pressed by a prescribed displacement, against the embedded solver (needs ccx)."""

import dataclasses
import re
import shutil

import numpy as np
import pytest

from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
from frictionid.backends.calculix.deck import ContactSettings
from frictionid.builders.block import block_model
from frictionid.errors import InputError
from frictionid.fem.problem import Problem
from frictionid.model import Displacement, Stage

from test_calculix_deck import deck_of

GAP = 0.002          # [mm] the block meshed this far above the plate
PRESS = 0.004        # [mm] the block's top face moved down this far
MU = [0.2, 0.2, 0.2, 0.2]


def gapped_block(adjust: bool, low: float = GAP, high: float = GAP):
    """Reference test 1's block (mesh 5 mm, C3D8I) lifted by ``low`` at x = -5 to ``high`` at x = +5 [mm]
    (negative: into the plate), its top face pressed down by PRESS (x, y held) in one increment; the interface
    adjusted (gaps set to zero) or not."""
    model = block_model(mesh_size=5.0)
    points = np.array(model.mesh.points, dtype=float)
    block = np.unique(model.mesh.cells[model.mesh.regions["block"]])
    points[block, 2] += low + (high - low) * (points[block, 0] + 5.0) / 10.0
    mesh = dataclasses.replace(model.mesh, points=points)
    loads = tuple(Displacement("block_top", c, (v,)) for c, v in ((0, 0.0), (1, 0.0), (2, -PRESS)))
    interfaces = tuple(dataclasses.replace(i, adjust=adjust) for i in model.interfaces)
    return dataclasses.replace(model, mesh=mesh, loads=loads, stages=(Stage("press", 1),), interfaces=interfaces)


def test_an_adjusted_interface_gets_a_zero_clearance_on_each_zone_pair():
    deck, _ = deck_of(gapped_block(adjust=True), MU)
    pairs = re.findall(r"\*CONTACT PAIR, INTERACTION=I\d, TYPE=SURFACE TO SURFACE\n(SZ\d), (ST\d)\n"
                       r"\*CLEARANCE, MASTER=(ST\d), SLAVE=(SZ\d), VALUE=0\n", deck)
    assert [(s, m) for s, m, _, _ in pairs] == [("SZ1", "ST1"), ("SZ2", "ST1"), ("SZ3", "ST1"), ("SZ4", "ST1")]
    assert all(s == slave and m == master for s, m, master, slave in pairs)
    assert "*CLEARANCE" not in deck_of(gapped_block(adjust=False), MU)[0]


def test_an_adjusted_interface_is_refused_with_node_to_surface_pairs():
    contact = ContactSettings(normal_stiffness=1e6, stick_slope=1e6, pair_type="NODE TO SURFACE")
    with pytest.raises(InputError, match=r"interface 'block_plate' .*adjust.*SURFACE TO SURFACE"):
        deck_of(gapped_block(adjust=True), MU, contact)


def machine_force(labels, reactions) -> float:
    """[N] the reaction of the block's pressed top face along z."""
    return float(reactions[list(labels).index("block_top.z")])


@pytest.mark.ccx
@pytest.mark.skipif(shutil.which("ccx") is None, reason="ccx (CalculiX) is not installed: apt-get install calculix-ccx")
@pytest.mark.parametrize("adjust", [False, True])
def test_calculix_closes_the_meshed_gap_where_the_interface_is_adjusted(adjust, tmp_path):
    """Pressed by 2 GAP: without *CLEARANCE the contact closes by GAP (half the force), with it by 2 GAP. ccx's
    force within 1 % of the embedded solver's on the same interface; the two cases differ by a factor of about 2
    (the elastic response is linear in the closure). Measured at 1e8: not adjusted ccx -279.79 N, embedded -279.80
    N; adjusted ccx -559.58 N, embedded -559.60 N."""
    model = gapped_block(adjust)
    expected = machine_force(*_solved(model))
    settings = CalculixSettings(normal_stiffness=1e8, stick_slope=1e8, work_dir=str(tmp_path))
    ccx = CalculixBackend(model, settings=settings).solve(np.array(MU), full_field=False)
    force = machine_force(ccx.reaction_labels, ccx.reactions[-1])
    np.testing.assert_allclose(force, expected, rtol=0.01)
    full = machine_force(*_solved(gapped_block(adjust=True)))
    assert abs(force / full - (1.0 if adjust else (PRESS - GAP) / PRESS)) < 0.02


@pytest.mark.ccx
@pytest.mark.skipif(shutil.which("ccx") is None, reason="ccx (CalculiX) is not installed: apt-get install calculix-ccx")
@pytest.mark.parametrize("low, high", [(0.0, 2 * GAP), (-GAP, GAP)])
def test_calculix_zeroes_a_varying_gap_and_an_interference(low, high, tmp_path):
    """Gaps varying across the face (0 to 4 um; -2 to +2 um, half of it interference), adjusted: ccx's force is
    the flat adjusted block's (the embedded solver's: -559.60 N; measured ccx -559.58 N at 1e8 for both)."""
    model = gapped_block(True, low, high)
    full = machine_force(*_solved(gapped_block(True)))
    settings = CalculixSettings(normal_stiffness=1e8, stick_slope=1e8, work_dir=str(tmp_path))
    ccx = CalculixBackend(model, settings=settings).solve(np.array(MU), full_field=False)
    assert machine_force(ccx.reaction_labels, ccx.reactions[-1]) == pytest.approx(full, rel=0.001)


def _solved(model):
    solution = Problem.build(model).solve(np.array(MU))
    return solution.reaction_labels, solution.reactions[-1]
