"""Plane-strain block on a base, about 50k dofs, 4 zones: condensation, forward, forward + sensitivities.

Issue 2 targets on one core: condensation under 5 s, 25-increment forward solve with sensitivities for
4 zones under 0.3 s (an unvectorised prototype: 6.5 s and 0.3 s). Run: .venv/bin/python benchmarks/forward_block2d.py
"""

import numpy as np

from _measure import best_of, peak_memory_mb, timed
from frictionid.builders.block import block_model_2d
from frictionid.fem.problem import Problem


def main(mesh_size: float = 0.21):
    figures = {}
    with timed(figures, "mesh"):
        model = block_model_2d("plane_strain", pull=0.2, height=4.0, mesh_size=mesh_size, n_zones=4,
                               n_press=5, n_pull=20)
    with timed(figures, "condensation"):
        problem = Problem.build(model)
    mu = np.array([0.12, 0.3, 0.45, 0.2])
    forward, solution = best_of(3, lambda: problem.solve(mu))
    with_sens, solution = best_of(3, lambda: problem.solve(mu, sensitivities=True))
    states = np.bincount(solution.state[-1], minlength=3)
    print(f"plane-strain block: {problem.space.n_dofs} dofs, {problem.pairs.n_pairs} contact pairs, "
          f"{model.n_zones} zones, {solution.n_increments} increments "
          f"(final: {states[0]} open, {states[1]} stick, {states[2]} slip)")
    print(f"  mesh                         {figures['mesh']:8.3f} s")
    print(f"  assembly + condensation      {figures['condensation']:8.3f} s   (target < 5 s)")
    print(f"  forward solve                {forward:8.3f} s   ({int(solution.n_newton.sum())} Newton iterations)")
    print(f"  forward + sensitivities      {with_sens:8.3f} s   (target < 0.3 s)")
    print(f"  peak memory                  {peak_memory_mb():8.0f} MB")


if __name__ == "__main__":
    main()
