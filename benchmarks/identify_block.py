"""Solves and wall time to reach |mu - mu_true| < 0.01 on the 3-D block: trf + analytic Jacobian versus the
paper's gradient descent + forward differences, measured in one run (issue 3 target: 20x fewer, 20x faster).

Same data for both: the shipped twin experiment (frictionid.studies.block): goal coefficients random in
[0.1, 0.5] (fixed seed), data from a finer mesh (no inverse crime), DIC displacements on the block's faces and
the plate top plus the machine force at pull levels 0.04 and 0.2 mm; both methods start from 0.1.
When gradient descent does not reach the target within its budget, the ratio printed is a lower bound.
Run: .venv/bin/python benchmarks/identify_block.py [max_gd_iterations]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

from frictionid.cli import main as cli
from frictionid.studies import block as twin

def main(gd_iterations: int = 150):
    mu_true = np.array(list(twin.goal_coefficients().values()))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        twin.write_points(folder / "points.csv")
        truth = twin.config(folder, "truth", twin.DATA_MESH, twin.goal_coefficients(), "points.csv")
        assert cli(["simulate", str(truth), "--out", str(folder / "simulated.csv")]) == 0
        twin.as_measured(folder / "simulated.csv", folder / "measured.csv")
        trf = twin.identify_traced(folder, "trf", "trf", "analytic", 50, mu_true)
        gd = twin.identify_traced(folder, "gd", "gradient-descent", "forward", gd_iterations, mu_true)
    print(f"3-D block, goal coefficients {np.round(mu_true, 4).tolist()}, start 0.1, target |mu - mu_true| < "
          f"{twin.TARGET}; finer-mesh data {twin.DATA_MESH}, identification mesh {twin.ID_MESH}")
    for name, r in (("trf + analytic", trf), ("gradient descent + forward differences", gd)):
        res = r["result"]
        reached = (f"reached after {r['reached'][0]} solves, {r['reached'][1]:.2f} s" if r["reached"]
                   else "NOT reached ({1} solves, {2:.1f} s, final error {0:.3g})".format(*r["trace"][-1]))
        print(f"  {name:<40} {reached}; {res['n_iterations']} iterations, status {res['status']}")
    if trf["reached"] and gd["reached"]:
        print(f"  ratio: {gd['reached'][0] / trf['reached'][0]:.1f}x fewer solves, "
              f"{gd['reached'][1] / trf['reached'][1]:.1f}x less time")
    elif trf["reached"]:
        _, solves, seconds = gd["trace"][-1]
        print(f"  ratio: more than {solves / trf['reached'][0]:.0f}x fewer solves and "
              f"{seconds / trf['reached'][1]:.0f}x less time (gradient descent never got there)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 150)
