"""The small-sliding check's ratio (Problem.gap_errors) against small and finite sliding on the block builders:
the tables of docs/solver.md, "How far small sliding holds".

    PYTHONPATH=src .venv/bin/python benchmarks/small_sliding_check.py ["3d: mesh_size=1.0, edge_splits=3" ...]

Each case ("3d: OPTIONS" of block_model, "2d: OPTIONS" of block_model_2d; default: the tables' rows) prints the
largest slip in shortest elements at the pair, the check's ratio and largest gap error at the increment of each
stage with the largest slip, and finite minus small sliding at the last increment: observations (largest /
range), the pull reaction, the zone normal forces and the largest pair normal force difference; and the gap
error of the fixed pairing evaluated at small sliding's state (the estimate) and at finite sliding's.
"""

import sys
from pathlib import Path

import numpy as np

from frictionid.builders.block import block_model, block_model_2d
from frictionid.fem.problem import Problem
from frictionid.fem.sliding import pairing_gap_error

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import sliding3d_case  # noqa: E402

CASES = ("3d: mesh_size=2.5", "3d: mesh_size=1.0", "3d: mesh_size=1.0, edge_splits=3, edge_band=0.5, interface_splits=2",
         "3d: mesh_size=1.0, edge_splits=4, edge_band=0.5",
         "3d: mesh_size=1.0, pull=0.5, n_pull=25", "3d: mesh_size=1.0, pull=1.0, n_pull=50",
         "3d: mesh_size=5.0, pull=2.0, n_pull=20",
         "2d: pull=0.2, height=4.0, mesh_size=1.0", "2d: pull=0.5, height=4.0, mesh_size=1.0",
         "2d: pull=0.5, height=4.0, mesh_size=0.5", "2d: pull=1.0, height=4.0, mesh_size=1.0, n_pull=20",
         "2d: pull=2.0, height=4.0, mesh_size=1.0, n_pull=40")
#: 2-D: 9 points on the block, 5 on the base's top 1 mm down
POINTS_2D = np.array([[x, y] for x in (-5.0, 0.0, 5.0) for y in (1.0, 2.0, 4.0)]
                     + [[x, -1.0] for x in (-8.0, -4.0, 0.0, 4.0, 8.0)])


def setting(case: str):
    """(model, build keywords, coefficients, pull reaction label) of a case."""
    kind, options = case.split(":", 1)
    options = eval(f"dict({options})")
    if kind.strip() == "2d":
        return (block_model_2d("plane_strain", **options), dict(points=POINTS_2D, quantities=("ux", "uy"),
                regions=["block"] * 9 + ["base"] * 5), np.array([0.3, 0.2]), "block_top.x")
    return (block_model(**options), dict(points=sliding3d_case.POINTS, regions=sliding3d_case.REGIONS,
            quantities=sliding3d_case.QUANTITIES), sliding3d_case.MU, "block_top.y")


def compare(case: str) -> None:
    model, build, mu, label = setting(case)
    small = Problem.build(model, **build)
    s = small.solve(mu, max_slip=None)
    print(f"{case}: {model.mesh.n_nodes} nodes, {small.pairs.n_pairs} pairs, slip / element "
          f"{(np.linalg.norm(s.slip, axis=2) / small.pair_length()).max():.3f}")
    for found in small.gap_errors(s):
        print(f"  increment {found['increment'] + 1}: ratio {found['ratio']:.4f}, largest {found['largest']:.3e} mm "
              f"at {small.pairs.position[found['worst']].round(3).tolist()}, slip {found['slip']:.4f} mm")
    finite = Problem.build(model, sliding="finite", **build)
    f = finite.solve(mu)
    # the fixed pairing's gap error at finite sliding's own state (its closed pairs): what the estimate predicts
    u_f = finite.displacement(f, -1)
    at_finite = pairing_gap_error(small, u_f.ravel(), (small.pairs.B @ u_f.ravel())[::small.pairs.dim],
                                  reference=small._coupled_gap)
    u_s = small.displacement(s, -1)
    at_small = pairing_gap_error(small, u_s.ravel(), s.w[-1, :, 0], reference=small._coupled_gap)
    both = (f.state[-1] != 0) & (s.state[-1] != 0) & np.isfinite(at_finite) & np.isfinite(at_small)
    weight = small.pairs.weight[both]
    print(f"  gap error at the last increment, area mean / largest over the pairs closed in both: from small sliding "
          f"{weight @ np.abs(at_small[both]) / weight.sum():.3e} / {np.abs(at_small[both]).max():.3e} mm, at finite "
          f"sliding's state {weight @ np.abs(at_finite[both]) / weight.sum():.3e} / "
          f"{np.abs(at_finite[both]).max():.3e} mm")
    obs_s, obs_f = np.asarray(s.observations[-1]), np.asarray(f.observations[-1])
    pull = small.reaction_labels.index(label)
    print(f"  finite - small: observations {1e3 * np.abs(obs_f - obs_s).max():.2f} um / {1e3 * np.ptp(obs_s):.1f} um, "
          f"pull reaction {100 * (f.reactions[-1, pull] / s.reactions[-1, pull] - 1):+.2f} %, zone normal forces "
          f"{np.round(f.zone_normal_force[-1] - s.zone_normal_force[-1], 2).tolist()} of "
          f"{np.round(s.zone_normal_force[-1], 1).tolist()} N, pair normal force "
          f"{np.abs(f.lam[-1, :, 0] - s.lam[-1, :, 0]).max():.2f} / {s.lam[-1, :, 0].max():.2f} N", flush=True)


if __name__ == "__main__":
    for case in sys.argv[1:] or CASES:
        compare(case)
