"""Tightening stage versus tensile test on the default M20 mesh (issue 17, performance): build + condensation,
forward solve and forward + sensitivities (wall time, peak memory), each case in a process of its own.

Tension: forces 10 and 30 kN, 3 increments each, ux, uy at the ten default DIC points. Tightening: the nut turned
4 and 12 deg, 3 increments each (axisymmetric with twist: three dofs per node), ux, uy, uz at the same points.

Run: .venv/bin/python benchmarks/tightening.py [flank_size]
"""

import subprocess
import sys
import time

import numpy as np

from _measure import best_of, peak_memory_mb, timed
from frictionid.builders.bolt import bolt_layout, bolt_model, measurement_points
from frictionid.fem.problem import Problem

CASES = {"tension": dict(load="tension", forces=(10000.0, 30000.0)),
         "tightening": dict(load="tightening", angles=(4.0, 12.0))}


def run(case: str, flank: float) -> None:
    figures = {}
    points = measurement_points(bolt_layout("M20"))
    quantities = ("ux", "uy", "uz") if case == "tightening" else ("ux", "uy")
    with timed(figures, "build"):
        model = bolt_model(flank_size=flank, n_increments=3, **CASES[case])
    with timed(figures, "condense"):
        problem = Problem.build(model, points=points, quantities=quantities, regions=["bolt"] * len(points))
    mu = np.full(model.n_zones, 0.15)
    figures["forward"], _ = best_of(3, lambda: problem.solve(mu))
    figures["sensitivities"], _ = best_of(3, lambda: problem.solve(mu, sensitivities=True))
    print(f"  {case:<10} {model.mesh.n_nodes} nodes, {model.n_components * model.mesh.n_nodes} dofs, "
          f"{problem.pairs.n_pairs} pairs ({problem.pairs.dim} unknowns each): build + mesh {figures['build']:.2f} s, "
          f"condensation {figures['condense']:.2f} s, forward {figures['forward']:.3f} s, forward + sensitivities "
          f"{figures['sensitivities']:.3f} s, peak memory {peak_memory_mb():.0f} MB")


def main(flank: float = 0.1) -> None:
    print(f"M20 bolt-nut, flank size {flank} mm, 2 stages x 3 increments, 8 zones:")
    for case in CASES:
        start = time.perf_counter()
        subprocess.run([sys.executable, __file__, case, str(flank)], check=True, timeout=1800)
        print(f"  ({case}: {time.perf_counter() - start:.1f} s with the interpreter start)")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] in CASES:
        run(sys.argv[1], float(sys.argv[2]))
    else:
        main(*[float(a) for a in sys.argv[1:2]])
