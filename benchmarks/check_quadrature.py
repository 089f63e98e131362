"""The small-sliding check's 3-D coupling at triangle rules of several degrees: the check's mean gap error and
ratio per interface (Problem.gap_errors) and its CPU time, on one solved 3-D bolt (docs/solver.md, "How far small
sliding holds"; the check's rule is frictionid.fem.sliding.CHECK_DEGREE, the solver's mortar3d.DEGREE).

Run (from the checkout): PYTHONPATH=src .venv/bin/python benchmarks/check_quadrature.py ['<bolt_model options as
JSON>'] [--degrees 10 6 4 2]
Default: the full M6 nut of tests/test_bolt3d_verification.py with the nut meshed on its own (``FULL_NUT`` with
``"nut_mesh": "separate"``: 75,868 nodes, 896 thread pairs), mu 0.15, MUMPS. The CPU time per degree includes the
undeformed and the deformed coupling and the interface displacements from the Schur factors.
"""

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from frictionid.builders.bolt import bolt_model
from frictionid.fem.facet_shapes import triangle_quadrature
from frictionid.fem.problem import Problem
from frictionid.fem.sliding import CHECK_DEGREE, mortar_builder

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_bolt3d_verification import FULL_NUT, MU  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("options", nargs="?", default=json.dumps({**FULL_NUT, "nut_mesh": "separate"}))
    parser.add_argument("--degrees", type=int, nargs="+", default=[10, 6, 4, 2])
    args = parser.parse_args()
    model = bolt_model(**{**json.loads(args.options), "model": "3d"})
    start = time.process_time()
    problem = Problem.build(model, factorisation="mumps")
    print(f"Problem.build {time.process_time() - start:.1f} s CPU; {problem.pairs.n_pairs} pairs", flush=True)
    start = time.process_time()
    solution = problem.solve(np.full(model.n_zones, MU), max_slip=None)
    print(f"solve without the check {time.process_time() - start:.1f} s CPU", flush=True)
    print(f"the check's rule: degree {CHECK_DEGREE}")
    print("degree | points | CPU [s] | per interface: mean gap error [nm], ratio")
    for degree in args.degrees:
        builder = mortar_builder(problem.space, model, degree)
        start = time.process_time()
        found = problem.gap_errors(solution, builder=builder)
        seconds = time.process_time() - start
        print(f"{degree} | {len(triangle_quadrature(degree)[1])} | {seconds:.2f} | " + "; ".join(
            f"{model.interfaces[f['interface']].name} {f['mean'] * 1e6:.4f}, {f['ratio']:.5f}" for f in found),
            flush=True)


if __name__ == "__main__":
    main()
