"""3-D block (DESIGN.md test 1) with a non-matching interface (3-D dual mortar) next to the conforming one
(node-to-node), same mesh size, same number of nodes: set-up, forward, forward + sensitivities, memory.

The non-matching model is the block builder's model with the block's nodes moved in x and y by
x + a sin(pi x / 5) (a = 0.3 mesh sizes; y alike): the footprint's edges and quadrant borders stay, every other
block node leaves its plate partner, so ``discretisation = "auto"`` takes mortar; the cells stay rectangular
boxes of the same count.

Wall times are the best of 3 solves; CPU times (all threads of the process, best of 3) show the work where
other jobs load the machine.

Run: .venv/bin/python benchmarks/mortar_block3d.py [mesh_size]     (default 1.0 mm, the block builder's default)
"""

import dataclasses
import sys
import time

import numpy as np

from _measure import best_of, peak_memory_mb, timed
from frictionid.builders.block import block_model
from frictionid.fem.problem import Problem
from frictionid.model import Mesh


def non_matching(model, mesh_size: float):
    """The model with its block's nodes moved in-plane (see the module docstring)."""
    mesh = model.mesh
    points = np.array(mesh.points)
    block = np.unique(mesh.cells[mesh.regions["block"]])
    points[block, :2] += 0.3 * mesh_size * np.sin(np.pi * points[block, :2] / 5.0)
    moved = Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions), dict(mesh.boundaries))
    return dataclasses.replace(model, mesh=moved)


def cpu_best_of(repeat: int, function):
    """Smallest CPU time of ``repeat`` calls [s] (all threads of this process; robust to other jobs' load)."""
    best = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        function()
        best = min(best, time.process_time() - start)
    return best


def measure(model, mu):
    figures = {}
    start = time.process_time()
    with timed(figures, "set-up"):
        problem = Problem.build(model)
    figures["set-up CPU"] = time.process_time() - start
    figures["forward"], _ = best_of(3, lambda: problem.solve(mu))
    figures["sensitivities"], solution = best_of(3, lambda: problem.solve(mu, sensitivities=True))
    figures["forward CPU"] = cpu_best_of(3, lambda: problem.solve(mu))
    figures["sensitivities CPU"] = cpu_best_of(3, lambda: problem.solve(mu, sensitivities=True))
    figures["pull"] = dict(zip(solution.reaction_labels, solution.reactions[-1]))["block_top.y"]
    figures["newton"] = int(solution.n_newton.sum())
    figures["pairs"], figures["B nnz"] = problem.pairs.n_pairs, problem.pairs.B.nnz
    return figures


def main(mesh_size: float = 1.0):
    mu = np.array([0.3, 0.2, 0.4, 0.25])
    conforming = block_model(mesh_size=mesh_size)
    cases = {"node-to-node": measure(conforming, mu), "mortar": measure(non_matching(conforming, mesh_size), mu)}
    print(f"3-D block, mesh size {mesh_size} mm, {conforming.mesh.n_nodes} nodes, both models")
    print(f"  {'':28s} {'node-to-node':>14s} {'mortar':>14s} {'ratio':>7s}")
    for key in ("set-up", "forward", "sensitivities", "set-up CPU", "forward CPU", "sensitivities CPU"):
        a, b, unit = cases["node-to-node"][key], cases["mortar"][key], "s"
        label = key.replace("sensitivities", "forward + sensitivities")
        print(f"  {label:28s} {a:12.3f} {unit} {b:12.3f} {unit} {b / a:7.2f}")
    for key in ("pairs", "B nnz", "newton", "pull"):
        a, b = cases["node-to-node"][key], cases["mortar"][key]
        print(f"  {key + (' reaction [N]' if key == 'pull' else ''):28s} {a:14.6g} {b:14.6g}")
    print(f"  peak memory (both)           {peak_memory_mb():8.0f} MB")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 1.0)
