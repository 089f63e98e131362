"""The small-sliding check's ratio (Problem.gap_errors) against small and finite sliding on the block builder:
the table of docs/solver.md, "How far small sliding holds".

    PYTHONPATH=src .venv/bin/python benchmarks/small_sliding_check.py ["mesh_size=1.0, edge_splits=3, ..."]

Each case (default: the table's four rows) prints the largest slip in shortest elements at the pair, the check's
ratio and largest gap error at the increment of each stage with the largest slip, and finite minus small sliding
at the last increment: observations (largest / range), the pull reaction, the zone normal forces and the largest
pair normal force difference.
"""

import sys
from pathlib import Path

import numpy as np

from frictionid.builders.block import block_model
from frictionid.fem.problem import Problem

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from sliding3d_case import MU, POINTS, QUANTITIES, REGIONS  # noqa: E402

CASES = ("mesh_size=2.5", "mesh_size=1.0", "mesh_size=1.0, edge_splits=3, edge_band=0.5, interface_splits=2",
         "mesh_size=5.0, pull=2.0, n_pull=20")


def compare(options: str) -> None:
    model = block_model(**eval(f"dict({options})"))
    small = Problem.build(model, points=POINTS, regions=REGIONS, quantities=QUANTITIES)
    s = small.solve(MU, max_slip=None)
    print(f"{options}: {model.mesh.n_nodes} nodes, {small.pairs.n_pairs} pairs, slip / element "
          f"{(np.linalg.norm(s.slip, axis=2) / small.pair_length()).max():.3f}")
    for found in small.gap_errors(s):
        print(f"  increment {found['increment'] + 1}: ratio {found['ratio']:.4f}, largest {found['largest']:.3e} mm "
              f"at {small.pairs.position[found['worst']].round(3).tolist()}, slip {found['slip']:.4f} mm")
    f = Problem.build(model, points=POINTS, regions=REGIONS, quantities=QUANTITIES, sliding="finite").solve(MU)
    obs_s, obs_f = np.asarray(s.observations[-1]), np.asarray(f.observations[-1])
    pull = small.reaction_labels.index("block_top.y")
    print(f"  finite - small: observations {1e3 * np.abs(obs_f - obs_s).max():.2f} um / {1e3 * np.ptp(obs_s):.1f} um, "
          f"pull reaction {100 * (f.reactions[-1, pull] / s.reactions[-1, pull] - 1):+.2f} %, zone normal forces "
          f"{np.round(f.zone_normal_force[-1] - s.zone_normal_force[-1], 2).tolist()} N, pair normal force "
          f"{np.abs(f.lam[-1, :, 0] - s.lam[-1, :, 0]).max():.2f} / {s.lam[-1, :, 0].max():.2f} N")


if __name__ == "__main__":
    for case in sys.argv[1:] or CASES:
        compare(case)
