"""Block reference test (DESIGN.md test 1), 3-D: dofs, contact nodes, set-up, forward, forward + sensitivities, memory.

Run: .venv/bin/python benchmarks/forward_block3d.py [mesh_size]
"""

import sys

import numpy as np

from _measure import best_of, peak_memory_mb, timed
from frictionid.builders.block import block_model
from frictionid.fem.problem import Problem


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
