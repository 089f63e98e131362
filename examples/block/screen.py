"""Screen observation designs of the block twin before fitting: the first-order bias of each design.

For an identification mesh, a finer data mesh and an observation set, the model error e = W (f_id(mu) -
f_data(mu)) at the goal coefficients biases a least-squares fit by about -pinv(J) e, J = W df_id/dmu (analytic
sensitivities). A design is usable when that bias is well below the target (0.01) in every zone; the standard
errors show what the stated noise (0.5 um, 1 N) adds. Two solves per mesh, no fitting.

Run: .venv/bin/python examples/block/screen.py [--seeds 8] ['{"mesh_size": 2.5, ...}' '{"mesh_size": 2.5, ...}']
(identification and data mesh options; default frictionid.studies.block's ID_MESH and DATA_MESH). ``--seeds N`` also screens the
shipped design at N other random goals (seeds 1..N, uniform in [0.1, 0.5]).
"""

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from frictionid.builders.block import block_model  # noqa: E402
from frictionid.data.measurements import QUANTITIES  # noqa: E402
from frictionid.fem.problem import Problem  # noqa: E402
from frictionid.studies import block as twin  # noqa: E402

SIGMA_STRAIN = 1e-5
#: the paper's gauges (the earlier example): block side faces, 0.5 and 1.5 mm above the contact, 3 mm off centre
GAUGES = [(x, y, z) for z in (0.5, 1.5) for s in (-3.0, 3.0) for x, y in ((-5.0, s), (5.0, s), (s, -5.0), (s, 5.0))]


def designs(labels: list[str]) -> dict:
    """name -> (point rows, stages (1-based), with machine force); rows index (point, quantity) pairs."""
    n = len(labels)
    faces = [i for i, p in enumerate(labels) if p.startswith("F")]
    plate = [i for i, p in enumerate(labels) if p.startswith("T")]
    gauges = range(n, n + len(GAUGES))

    def rows(points, quantities):
        return [p * len(QUANTITIES) + QUANTITIES.index(q) for p in points for q in quantities]

    dic = rows(faces, ("ux", "uy", "uz")) + rows(plate, ("ux", "uy"))
    strains = rows(gauges, QUANTITIES[3:])
    return {
        "shipped: DIC faces + plate top + force, pull 0.04 and 0.2": (dic, (2, 3), True),
        "  same without the machine force": (dic, (2, 3), False),
        "  same at 0.2 mm only (gross slip)": (dic, (3,), True),
        "  block faces only + force, 0.04 and 0.2": (rows(faces, ("ux", "uy", "uz")), (2, 3), True),
        "  plate top only + force, 0.04 and 0.2": (rows(plate, ("ux", "uy")), (2, 3), True),
        "paper: strains at 16 gauges, 0.2 mm only": (strains, (3,), False),
        "  16 gauges + force, 0.04 and 0.2": (strains, (2, 3), True),
    }


def build(mesh: dict, points: np.ndarray) -> Problem:
    start = time.perf_counter()
    problem = Problem.build(block_model(pull_levels=twin.PULL_LEVELS, **mesh), points=points,
                            quantities=QUANTITIES)
    print(f"  {mesh}: {problem.space.n_dofs} dofs, built in {time.perf_counter() - start:.1f} s", flush=True)
    return problem


def responses(problem: Problem, mu: np.ndarray):
    """(values (n_stages, n_rows + 1), derivatives) at stage ends; the last row is the machine force."""
    solution = problem.solve(mu, sensitivities=True)
    ends = [solution.stage_end(s) for s in range(problem.model.n_stages)]
    force = problem.reaction_labels.index("block_top.y")
    values = np.hstack([solution.observations[ends], solution.reactions[ends][:, [force]]])
    derivatives = np.concatenate([solution.d_observations[ends], solution.d_reactions[ends][:, [force]]], axis=1)
    return values, derivatives


def bias_and_stderr(id_problem, data_problem, mu, sigma, rows, stages):
    """First-order bias -pinv(J) e and standard errors of one design at goal ``mu``."""
    (f_id, d_id), (f_data, _) = responses(id_problem, mu), responses(data_problem, mu)
    idx = [s - 1 for s in stages]
    w = np.tile(1.0 / sigma[rows], len(idx))
    J = w[:, None] * d_id[idx][:, rows].reshape(-1, len(mu))
    e = w * (f_id[idx][:, rows] - f_data[idx][:, rows]).ravel()
    return -np.linalg.pinv(J) @ e, np.sqrt(np.diag(np.linalg.pinv(J.T @ J))), len(e)


def screen(id_mesh: dict, data_mesh: dict, seeds: int = 0) -> None:
    mu = np.array(list(twin.goal_coefficients().values()))
    xyz, labels = twin.points()
    points = np.vstack([xyz, GAUGES])
    print("goal coefficients", np.round(mu, 4).tolist())
    id_problem, data_problem = build(id_mesh, points), build(data_mesh, points)
    force_row = len(points) * len(QUANTITIES)
    sigma = np.array([twin.SIGMA_U if q.startswith("u") else SIGMA_STRAIN for _ in points for q in QUANTITIES]
                     + [twin.SIGMA_FORCE])
    print(f"{'design':<58}{'n_obs':>6}   bias A, B, C, D                     stderr A, B, C, D")
    all_designs = designs(labels)
    for name, (rows, stages, force) in all_designs.items():
        bias, stderr, n = bias_and_stderr(id_problem, data_problem, mu, sigma,
                                          rows + ([force_row] if force else []), stages)
        print(f"{name:<58}{n:>6}   " + " ".join(f"{b:+.4f}" for b in bias) + "     "
              + " ".join(f"{s:.4f}" for s in stderr))
    rows, stages, _ = next(iter(all_designs.values()))
    for seed in range(1, seeds + 1):
        goal = np.random.default_rng(seed).uniform(0.1, 0.5, 4)
        bias, stderr, _ = bias_and_stderr(id_problem, data_problem, goal, sigma, rows + [force_row], stages)
        print(f"shipped design, goal seed {seed} {np.round(goal, 3).tolist()}".ljust(64) + "   "
              + " ".join(f"{b:+.4f}" for b in bias) + "     " + " ".join(f"{s:.4f}" for s in stderr))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("meshes", nargs="*", help="identification and data mesh options as JSON")
    parser.add_argument("--seeds", type=int, default=0, help="also screen the shipped design at other goals")
    args = parser.parse_args()
    meshes = [json.loads(a) for a in args.meshes[:2]]
    screen(*(meshes + [twin.ID_MESH, twin.DATA_MESH][len(meshes):]), seeds=args.seeds)
