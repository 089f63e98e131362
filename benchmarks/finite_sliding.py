"""Finite sliding (fem/sliding.py) on the 2-D block pulled 2 mm (the seed's block test in plane strain, 2000 N/mm,
four zones) against small sliding, against the same solve with the mortar integrated segment by segment (the
former builder, tests/mortar2d_segments.py) and against the CalculiX backend on the same mesh: condensation,
forward, forward + sensitivities, re-coupling passes, where the time goes.

Run: PYTHONPATH=src .venv/bin/python benchmarks/finite_sliding.py [mesh_size]
"""

import cProfile
import os
import pstats
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import _tests  # noqa: F401  (tests/ importable)
import mortar2d_segments
from _measure import best_of, peak_memory_mb, timed
from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
from frictionid.builders.block import block_model_2d
from frictionid.fem import mortar
from frictionid.fem.problem import Problem


#: the points of tests/test_sliding_calculix.py's 2-D block test [mm]
POINTS = np.array([[-4.5, 1.0], [4.5, 3.0], [-8.0, -1.0], [12.0, -1.0], [-3.0, -0.5], [3.0, -0.5]])
MU = np.array([0.3, 0.2, 0.4, 0.25])


def cpu_children() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def calculix_forward(model) -> tuple[float, float, object]:
    """Wall and CPU time [s] of one CalculiX forward solve (deck, ccx run, parsing) and its solution."""
    with tempfile.TemporaryDirectory() as tmp:
        backend = CalculixBackend(model, POINTS, ("ux", "uy"), None, CalculixSettings(work_dir=tmp))
        wall, cpu = time.perf_counter(), time.process_time() + cpu_children()
        solution = backend.solve(MU, full_field=False)
        return time.perf_counter() - wall, time.process_time() + cpu_children() - cpu, solution


def embedded_forward(problem, repeat: int):
    """Smallest wall and CPU time [s] of ``repeat`` finite-sliding forward solves, and the last solution."""
    best_wall = best_cpu = float("inf")
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        solution = problem.solve(MU)
        best_wall, best_cpu = min(best_wall, time.perf_counter() - wall), min(best_cpu, time.process_time() - cpu)
    return best_wall, best_cpu, solution


def per_segment(problem):
    """The forward solve with the mortar integrated segment by segment (the former builder)."""
    vectorised = mortar._integrate, mortar._padded_rows
    mortar._integrate, mortar._padded_rows = mortar2d_segments.integrate, mortar2d_segments.padded_rows
    try:
        return embedded_forward(problem, 1)
    finally:
        mortar._integrate, mortar._padded_rows = vectorised


def main(mesh_size: float = 1.0):
    model = block_model_2d("plane_strain", pull=2.0, force=2000.0, height=4.0, mesh_size=mesh_size, n_zones=4,
                           n_press=1, n_pull=20, order=1)
    figures = {}
    problems = {}
    for sliding in ("small", "finite"):
        with timed(figures, f"condensation {sliding}"):
            problems[sliding] = Problem.build(model, points=POINTS, sliding=sliding)
    small, finite = problems["small"], problems["finite"]
    forward_small, a = best_of(3, lambda: small.solve(MU, max_slip=None))
    sens_small, _ = best_of(3, lambda: small.solve(MU, sensitivities=True, max_slip=None))
    wall, cpu, b = embedded_forward(finite, 3)
    wall_old, cpu_old, old = per_segment(finite)
    ccx_wall, ccx_cpu, ccx = calculix_forward(model)
    profile = cProfile.Profile()
    profile.enable()
    sens_finite, _ = best_of(1, lambda: finite.solve(MU, sensitivities=True))
    profile.disable()
    stats = pstats.Stats(profile)
    coupling = next(v[3] for k, v in stats.stats.items() if k[2] == "build" and k[0].endswith("sliding.py"))
    n_couplings = next(v[1] for k, v in stats.stats.items() if k[2] == "build" and k[0].endswith("sliding.py"))
    pull = model.reaction_labels.index("block_top.x")
    print(f"plane-strain block pulled 2 mm, mesh_size {mesh_size:g}: {small.space.n_dofs} dofs, "
          f"{finite.pairs.n_pairs} contact pairs, {len(finite.interface_dofs)} interface dofs, "
          f"{a.n_increments} increments")
    for name, value in figures.items():
        print(f"  {name:44s} {value:8.3f} s")
    print(f"  forward small                                {forward_small:8.3f} s")
    print(f"  forward + sensitivities small                {sens_small:8.3f} s")
    print(f"  forward finite (best of 3)                   {wall:8.3f} s wall {cpu:8.3f} s CPU   "
          f"({int(b.n_newton.sum())} Newton iterations)")
    print(f"  forward finite, mortar segment by segment    {wall_old:8.3f} s wall {cpu_old:8.3f} s CPU   "
          f"(reactions equal to {np.abs(old.reactions - b.reactions).max():.1e} N/mm)")
    print(f"  forward CalculiX (deck, ccx, parsing)        {ccx_wall:8.3f} s wall {ccx_cpu:8.3f} s CPU")
    print(f"  forward + sensitivities finite               {sens_finite:8.3f} s   ({n_couplings} couplings built, "
          f"{coupling:.3f} s in the mortar builder, {n_couplings / b.n_increments:.1f} per increment)")
    print(f"  speed-up from the vectorised mortar          {wall_old / wall:8.1f} x wall {cpu_old / cpu:6.1f} x CPU")
    print(f"  CalculiX / finite sliding per forward solve  {ccx_wall / wall:8.1f} x wall {ccx_cpu / cpu:6.1f} x CPU")
    print(f"  pull reaction small / finite / CalculiX      {a.reactions[-1, pull]:10.3f} / {b.reactions[-1, pull]:10.3f}"
          f" / {ccx.reactions[-1, pull]:10.3f} N/mm   (sum mu N finite {MU @ b.zone_normal_force[-1]:.3f})")
    print(f"  peak memory                                  {peak_memory_mb():8.0f} MB; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main(*(float(a) for a in sys.argv[1:]))
