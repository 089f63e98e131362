"""The 3-D bolt with the nut meshed on its own (``nut_mesh = "separate"``) against the conforming model of the same
options: the thread's pairs, the mortar's initial gaps as meshed (before the builder's ``adjust`` sets them to zero),
and at mu 0.15 the seed's ten points' uy and the machine displacement (plate 1's mean uy at four rim points) of the
separate model with and without the adjustment, against the conforming model's.

Run: .venv/bin/python benchmarks/bolt3d_separate.py '<bolt_model options as JSON>'
e.g. the M6 of tests/test_bolt3d_verification.py: '{"size": "M6", "length": 24.0, "engaged_length": 2.0,
"thread_length": 9.5, "n_axial": 2, "flank_size": 1.0, "contact_size": 3.0, "root_size": 0.3, "mesh_size": 4.0,
"forces": [1500.0], "n_increments": 1, "cutout": false, "jaws": false}' (model = "3d" is added). Run it under
/usr/bin/time -v for the peak.
"""

import dataclasses
import json
import sys

import numpy as np

from bolt3d_calculix import observed
from frictionid.builders.bolt import bolt_model
from frictionid.fem.mortar3d import mortar_pairs_3d
from frictionid.fem.problem import Problem
from frictionid.fem.space import Space

MU = 0.15


def solved(model, points, regions) -> tuple[np.ndarray, int, int]:
    """(uy (n_points,) [mm] at the end, thread pairs, thread pairs open at the end) at mu = MU."""
    problem = Problem.build(model, points=points, quantities=("uy",), regions=regions, factorisation="mumps")
    solution = problem.solve(np.full(len(model.zone_names), MU))
    thread = problem.pairs.interface == 0
    return np.asarray(solution.observations[-1]), int(thread.sum()), int(np.sum(solution.state[-1][thread] == 0))


def main(options: dict):
    options = {**options, "model": "3d"}
    points, regions = observed(options)
    conforming = bolt_model(**options)
    separate = bolt_model(**options, nut_mesh="separate")
    thread = separate.interfaces[0]
    gap = mortar_pairs_3d(Space.build(separate.mesh, "3d", separate.element), separate, 0).gap
    print(f"{json.dumps(options)}: conforming {conforming.mesh.n_nodes:,} nodes, separate {separate.mesh.n_nodes:,}")
    print(f"  the thread's initial gaps as meshed [um]: {1e3 * gap.min():.2f} to {1e3 * gap.max():.2f}, RMS "
          f"{1e3 * np.sqrt(np.mean(gap ** 2)):.2f}, 95 % within {1e3 * np.quantile(np.abs(gap), 0.95):.2f}")
    reference, n_pairs, _ = solved(conforming, points, regions)
    ten, machine = slice(0, 10), slice(10, None)
    span = np.ptp(reference[ten])
    print(f"  conforming: {n_pairs} thread pairs, ten points' uy range {1e3 * span:.4f} um, machine "
          f"{1e3 * reference[machine].mean():.4f} um")
    unadjusted = dataclasses.replace(thread, adjust=False)
    for name, model in (("separate", separate),
                        ("separate, gaps as meshed", dataclasses.replace(
                            separate, interfaces=(unadjusted,) + separate.interfaces[1:]))):
        uy, n_pairs, n_open = solved(model, points, regions)
        change = uy[machine].mean() / reference[machine].mean() - 1
        print(f"  {name}: {n_pairs} thread pairs ({n_open} open at the end), ten points' uy off by at most "
              f"{100 * np.abs(uy[ten] - reference[ten]).max() / span:.1f} % of the range, machine "
              f"{1e3 * uy[machine].mean():.4f} um ({100 * change:+.2f} %)")


if __name__ == "__main__":
    main(json.loads(sys.argv[1]))
