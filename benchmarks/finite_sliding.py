"""Finite sliding (fem/sliding.py) against small sliding on the 2-D block pulled 2 mm (the seed's block test in
plane strain): condensation, forward, forward + sensitivities, re-coupling passes, and where the time goes.

Run: PYTHONPATH=src .venv/bin/python benchmarks/finite_sliding.py [mesh_size]
"""

import cProfile
import pstats
import sys

import numpy as np

from _measure import best_of, peak_memory_mb, timed
from frictionid.builders.block import block_model_2d
from frictionid.fem.problem import Problem


def main(mesh_size: float = 1.0):
    model = block_model_2d("plane_strain", pull=2.0, force=2000.0, height=4.0, mesh_size=mesh_size, n_zones=4,
                           n_press=1, n_pull=20, order=1)
    mu = np.array([0.3, 0.2, 0.4, 0.25])
    figures = {}
    problems = {}
    for sliding in ("small", "finite"):
        with timed(figures, f"condensation {sliding}"):
            problems[sliding] = Problem.build(model, sliding=sliding)
    small, finite = problems["small"], problems["finite"]
    forward_small, a = best_of(3, lambda: small.solve(mu, max_slip=None))
    sens_small, _ = best_of(3, lambda: small.solve(mu, sensitivities=True, max_slip=None))
    forward_finite, b = best_of(1, lambda: finite.solve(mu))
    profile = cProfile.Profile()
    profile.enable()
    sens_finite, _ = best_of(1, lambda: finite.solve(mu, sensitivities=True))
    profile.disable()
    stats = pstats.Stats(profile)
    coupling = next(v[3] for k, v in stats.stats.items() if k[2] == "build" and k[0].endswith("sliding.py"))
    n_couplings = next(v[1] for k, v in stats.stats.items() if k[2] == "build" and k[0].endswith("sliding.py"))
    pull = model.reaction_labels.index("block_top.x")
    print(f"plane-strain block pulled 2 mm: {small.space.n_dofs} dofs, {finite.pairs.n_pairs} contact pairs "
          f"(finite: mortar on every interface; small: {small.pairs.n_pairs}), {len(finite.interface_dofs)} "
          f"interface dofs, {a.n_increments} increments")
    for name, value in figures.items():
        print(f"  {name:34s} {value:8.3f} s")
    print(f"  forward small                      {forward_small:8.3f} s")
    print(f"  forward + sensitivities small      {sens_small:8.3f} s")
    print(f"  forward finite                     {forward_finite:8.3f} s   ({int(b.n_newton.sum())} Newton "
          "iterations)")
    print(f"  forward + sensitivities finite     {sens_finite:8.3f} s   ({n_couplings} couplings built, "
          f"{coupling:.3f} s in the mortar builder, {n_couplings / b.n_increments:.1f} per increment)")
    print(f"  pull reaction small / finite       {a.reactions[-1, pull]:10.3f} / {b.reactions[-1, pull]:10.3f} N/mm"
          f"   (sum mu N finite {mu @ b.zone_normal_force[-1]:.3f})")
    print(f"  peak memory                        {peak_memory_mb():8.0f} MB")


if __name__ == "__main__":
    main(*(float(a) for a in sys.argv[1:]))
