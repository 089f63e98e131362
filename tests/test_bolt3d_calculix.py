"""The 3-D bolt-nut tensile test against CalculiX on the same mesh (the product's deck: C3D10, one surface-to-surface
penalty pair per zone on the conforming node pairs): the seed's ten points and the machine's side.

The model is the smallest that still has the helix: an M6 with two engaged pitches, the bolt threaded from a pitch
below the nut, coarse elements, no window, no jaws (benchmarks/bolt3d_calculix.py prints the same comparison for
any 3-D options). Needs ccx; about 8 minutes on a shared two-core machine (SPOOLES, about 10 contact iterations).

What it checks is the deck and the backends on a helical model (loads, supports, C3D10, the per-zone pairs, the
observation nodes), not the friction: on this mesh the backends differ by more than the ten points move when one
zone's coefficient doubles (docs/bolt-study.md, "Against CalculiX on the same mesh").
"""

import numpy as np
import pytest

from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
from frictionid.builders.bolt import bolt_layout, bolt_model
from frictionid.builders.bolt3d import measurement_points_3d
from frictionid.fem.problem import Problem
from helpers import needs_ccx

SMALL = dict(size="M6", model="3d", length=24.0, engaged_length=2.0, thread_length=9.5, n_axial=2, flank_size=1.0,
             contact_size=3.0, root_size=0.3, mesh_size=4.0, forces=(1000.0,), n_increments=1, cutout=False,
             jaws=False)
MU = 0.15
QUANTITIES = ("ux", "uy", "uz")


def observed_points() -> tuple[np.ndarray, list[str]]:
    """The ten points P1-P5 of flanks 1 and 2 moved 0.1 mm radially into the bolt tooth (the straight-sided tets
    lie inside the helicoid), and four points of the pulled plate 1 near its rim (the machine's displacement)."""
    layout = bolt_layout("M6", SMALL["length"], SMALL["engaged_length"], None, 2, SMALL["n_axial"], None,
                         SMALL["thread_length"])
    ten = measurement_points_3d(layout)
    radius = np.hypot(ten[:, 0], ten[:, 2])
    ten[:, [0, 2]] *= ((radius - 0.1) / radius)[:, None]
    r, y = 0.97 * layout.r_outer, 0.5 * sum(layout.plate1)
    rim = np.array([[r * np.cos(t), y, r * np.sin(t)] for t in np.radians([0.0, 90.0, 180.0, 270.0])])
    return np.vstack([ten, rim]), ["bolt"] * 10 + ["plate1"] * 4


@pytest.fixture(scope="module")
def results():
    model = bolt_model(**SMALL)
    points, regions = observed_points()
    mu = np.full(len(model.zone_names), MU)
    problem = Problem.build(model, points=points, quantities=QUANTITIES, regions=regions)
    solution = problem.solve(mu)
    end = solution.stage_end(0)
    ccx = CalculixBackend(model, points, QUANTITIES, regions, CalculixSettings()).solve(mu, full_field=False)
    return model, solution, end, ccx


@needs_ccx
@pytest.mark.ccx
@pytest.mark.slow
def test_ten_points_agree_within_seven_percent_of_their_range(results):
    _, solution, end, ccx = results
    embedded, other = (np.reshape(u, (-1, 3))[:10] for u in (solution.observations[end], ccx.observations[0]))
    span = np.ptp(embedded[:, 1])
    # measured: ux / uy / uz differ by at most 3.1 / 5.0 / 2.3 % of the range of uy (0.485 um) over the ten points;
    # the target is 1 %, met by neither this mesh nor the finer one of docs/bolt-study.md (3.6 %)
    assert np.abs(other - embedded).max() < 0.07 * span


@needs_ccx
@pytest.mark.ccx
@pytest.mark.slow
def test_machine_side_agrees_within_one_percent(results):
    model, solution, end, ccx = results
    embedded, other = (np.reshape(u, (-1, 3))[10:, 1].mean() for u in (solution.observations[end],
                                                                           ccx.observations[0]))
    # the force is prescribed: the machine's counterpart is plate 1's axial displacement at its rim
    assert other == pytest.approx(embedded, rel=0.01)
    held = list(solution.reaction_labels).index("plate2_rim.y")
    assert ccx.reactions[0, held] == pytest.approx(solution.reactions[end, held], rel=0.01)
    assert solution.reactions[end, held] == pytest.approx(-SMALL["forces"][0], rel=1e-6)
