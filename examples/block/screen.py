"""Screen observation designs of the block twin before fitting: the first-order bias of each design.

For an identification mesh, a finer data mesh and an observation set, the model error e = W (f_id(mu) -
f_data(mu)) at the goal coefficients biases a least-squares fit by about -pinv(J) e, J = W df_id/dmu (analytic
sensitivities). A design is usable when that bias is well below the target (0.01) in every zone; the standard
errors show what the stated noise (0.5 um, 1 N) adds. Two solves per mesh, no fitting.

Run: .venv/bin/python examples/block/screen.py ['{"mesh_size": 2.5, ...}' '{"mesh_size": 2.5, ...}']
(identification and data mesh options; default twin.ID_MESH and twin.DATA_MESH)
"""

import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))

import twin  # noqa: E402
from frictionid.builders.block import block_model  # noqa: E402
from frictionid.fem.problem import Problem  # noqa: E402

QUANTITIES = ("ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz")
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


def responses(mesh: dict, points: np.ndarray, mu: np.ndarray):
    """(values (n_stages, n_rows + 1), derivatives) at stage ends; the last row is the machine force."""
    start = time.perf_counter()
    problem = Problem.build(block_model(pull_levels=twin.PULL_LEVELS, **mesh), points=points,
                            quantities=QUANTITIES)
    solution = problem.solve(mu, sensitivities=True)
    ends = [solution.stage_end(s) for s in range(problem.model.n_stages)]
    force = problem.reaction_labels.index("block_top.y")
    values = np.hstack([solution.observations[ends], solution.reactions[ends][:, [force]]])
    derivatives = np.concatenate([solution.d_observations[ends], solution.d_reactions[ends][:, [force]]], axis=1)
    print(f"  {mesh}: {problem.space.n_dofs} dofs, {time.perf_counter() - start:.1f} s", flush=True)
    return values, derivatives


def screen(id_mesh: dict, data_mesh: dict) -> None:
    mu = np.array(list(twin.goal_coefficients().values()))
    xyz, labels = twin.points()
    points = np.vstack([xyz, GAUGES])
    print("goal coefficients", np.round(mu, 4).tolist())
    f_id, d_id = responses(id_mesh, points, mu)
    f_data, _ = responses(data_mesh, points, mu)
    force_row = f_id.shape[1] - 1
    sigma = np.array([twin.SIGMA_U if q.startswith("u") else SIGMA_STRAIN for _ in points for q in QUANTITIES]
                     + [twin.SIGMA_FORCE])
    print(f"{'design':<58}{'n_obs':>6}   bias A, B, C, D                     stderr A, B, C, D")
    for name, (rows, stages, force) in designs(labels).items():
        rows = rows + ([force_row] if force else [])
        idx = [s - 1 for s in stages]
        w = np.tile(1.0 / sigma[rows], len(idx))
        J = w[:, None] * d_id[idx][:, rows].reshape(-1, len(mu))
        e = w * (f_id[idx][:, rows] - f_data[idx][:, rows]).ravel()
        bias = -np.linalg.pinv(J) @ e
        stderr = np.sqrt(np.diag(np.linalg.pinv(J.T @ J)))
        print(f"{name:<58}{len(e):>6}   " + " ".join(f"{b:+.4f}" for b in bias) + "     "
              + " ".join(f"{s:.4f}" for s in stderr))


if __name__ == "__main__":
    meshes = [json.loads(a) for a in sys.argv[1:3]]
    screen(*(meshes + [twin.ID_MESH, twin.DATA_MESH][len(meshes):]))
