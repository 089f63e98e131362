"""Block reference test (DESIGN.md test 1), 3-D: dofs, contact nodes, set-up, forward, forward + sensitivities, memory.

Run: .venv/bin/python benchmarks/forward_block3d.py [mesh_size]
"""

import os
import sys

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from _measure import best_of, peak_memory_mb, timed  # noqa: E402
from frictionid.builders.block import block_model  # noqa: E402
from frictionid.fem.problem import Problem  # noqa: E402


def main(mesh_size: float = 1.0):
    figures = {}
    with timed(figures, "mesh"):
        model = block_model(mesh_size=mesh_size)
    with timed(figures, "condensation"):
        problem = Problem.build(model)
    mu = np.array([0.3, 0.2, 0.4, 0.25])
    forward, solution = best_of(3, lambda: problem.solve(mu))
    with_sens, solution = best_of(3, lambda: problem.solve(mu, sensitivities=True))
    print(f"3-D block (mesh size {mesh_size} mm): {problem.space.n_dofs} dofs, {problem.pairs.n_pairs} contact "
          f"nodes, {solution.n_increments} increments")
    print(f"  mesh                         {figures['mesh']:8.3f} s")
    print(f"  assembly + condensation      {figures['condensation']:8.3f} s")
    print(f"  forward solve                {forward:8.3f} s   ({int(solution.n_newton.sum())} Newton iterations)")
    print(f"  forward + sensitivities      {with_sens:8.3f} s")
    print(f"  peak memory                  {peak_memory_mb():8.0f} MB")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 1.0)
