"""The "axisymmetric_twist" kind against CalculiX in 3-D: two rings pressed together and turned (the smallest case of a
tightening stage: an axial clamp load, then a turn against friction), full ring of C3D8I with penalty contact
(tests/ring_ccx.py). CalculiX has no axisymmetric element with twist, so the reference is revolved.

Not covered here: the helix (ContactInterface.lead; the rings' face is flat) and the bolt itself."""

import dataclasses
import shutil

import numpy as np
import pytest
from ring_ccx import run_rings

from frictionid.builders.torsion import effective_radius, turned_rings_model
from frictionid.fem.problem import Problem
from frictionid.model import Pressure, Rotation, Stage

PRESSURE, MU, ANGLES, N_THETA = 50.0, (0.1, 0.2), (8e-5, 2e-3), 72
INNER, MIDDLE, OUTER = 6.0, 8.0, 10.0


def _twist(points, regions, cone=0.0):
    """Press, turn to 8e-5 rad (partial slip: the outer zone sticks in part), turn on to 2e-3 rad (gross slip)."""
    model = turned_rings_model(inner=INNER, outer=OUTER, pressure=PRESSURE, size=0.5, cone_deg=cone)
    model = dataclasses.replace(model, loads=(Pressure("upper_top", (PRESSURE,) * 3),
                                              Rotation("upper_top", (0.0,) + ANGLES)),
                                stages=(Stage("press", 1), Stage("turn", 4), Stage("turn on", 4)))
    problem = Problem.build(model, points=points, quantities=("ux", "uy", "uz"), regions=regions)
    solution = problem.solve(list(MU))
    ends = [solution.stage_end(s) for s in range(3)]
    labels = solution.reaction_labels
    return (np.asarray(solution.observations)[ends].reshape(3, len(points), 3),
            solution.reactions[ends][:, labels.index("upper_top.torque")],
            solution.reactions[ends][:, labels.index("lower_bottom.y")])


@pytest.mark.slow
@pytest.mark.ccx
@pytest.mark.skipif(shutil.which("ccx") is None, reason="needs ccx (CalculiX)")
def test_pressed_and_turned_rings_agree_with_calculix_in_3d():
    """Measured (72 x 4 x 4 C3D8I per ring, penalty 1e7 N/mm^3; twist kind at 0.5 mm): torque -0.17 % (partial slip,
    8e-5 rad) and -0.66 % (gross slip, 2e-3 rad); in gross slip CalculiX's zones carry +1.6 % / -1.3 % of mu p A
    r_eff (the twist kind: exact); u_r, u_y, u_t at the 45 nodes of the phi = 0 section within 0.28 % of the
    stage's largest displacement (the penalty's penetration p / k = 5e-6 mm is 0.25 % of 2e-3 mm); axial reaction =
    pressure x the 72-gon's area (ccx's faceted ring) to 2e-7. Red with the circumferential tangent 5 % short
    (gross-slip torque 4.6 % off)."""
    stages = run_rings(inner=INNER, outer=OUTER, pressure=PRESSURE, angles=ANGLES, mu=MU, n_theta=N_THETA)
    keys = sorted(stages[0]["u"])
    points = np.array(keys)
    u, torque, axial = _twist(points, ["lower" if y < 0 else "upper" for _, y in keys])
    polygon = N_THETA / (2 * np.pi) * np.sin(2 * np.pi / N_THETA)          # 72-gon area / circle area
    for s, ccx in enumerate(stages):
        assert ccx["axial"] == pytest.approx(axial[s] * polygon, rel=1e-6)
        reference = np.array([ccx["u"][k] for k in keys])
        largest = np.abs(u[s]).max()
        assert np.abs(reference - u[s]).max() < 5e-3 * largest, f"stage {s + 1}"
    for s in (1, 2):
        assert stages[s]["zone_torques"].sum() == pytest.approx(torque[s], rel=0.01)
    gross = [m * PRESSURE * np.pi * (b ** 2 - a ** 2) * effective_radius(a, b)
             for m, (a, b) in zip(MU, [(INNER, MIDDLE), (MIDDLE, OUTER)])]
    assert torque[2] == pytest.approx(sum(gross), rel=1e-9)
    np.testing.assert_allclose(stages[2]["zone_torques"], gross, rtol=0.02)
    assert torque[1] < 0.8 * torque[2]                                    # 8e-5 rad: not yet in gross slip
