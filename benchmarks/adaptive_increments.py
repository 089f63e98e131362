"""Adaptive increments against the fixed ones, side by side in one process as a user runs them ([solver]
increments = "adaptive" against the default "fixed"): per model the increments taken, Newton iterations, the CPU
median of forward + sensitivity solves (the two taking turns), and the path error: the largest difference of the
stage-end contact forces, adaptive minus fixed, relative to the largest force; for the 3-D blocks also the fixed
path's own increment error (the same model with twice the pull increments), the scale the adaptive difference
is to be read against.

Run: .venv/bin/python benchmarks/adaptive_increments.py [repeats] [model ...]
(models: plane_strain, clamp, block25, block; default all, 3 repeats)
"""

import statistics
import sys
import time
from pathlib import Path

import numpy as np

from frictionid.builders.block import block_model, block_model_2d
from frictionid.builders.registry import build_model
from frictionid.config import read_config
from frictionid.fem.problem import Problem

CLAMP = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "clamp" / "clamp.toml"
MODELS = {
    "plane_strain": ("plane-strain block, 2 + 12 increments",
                     lambda k: block_model_2d(pull=0.1, height=4.0, mesh_size=2.0, contact_size=1.0, n_zones=2,
                                              n_press=2, n_pull=12 * k), [0.3, 0.2]),
    "clamp": ("clamp (tests/fixtures/clamp), 1 + 10 + 10 + 10 increments",
              lambda k: build_model(read_config(CLAMP).model_spec), [0.15, 0.2, 0.25, 0.18, 0.22, 0.3]),
    "block25": ("3-D block, mesh 2.5 mm, 1 + 20 increments", lambda k: block_model(mesh_size=2.5, n_pull=20 * k),
                [0.3, 0.2, 0.4, 0.25]),
    "block": ("3-D block, the default (mesh 1 mm), 1 + 10 increments", lambda k: block_model(n_pull=10 * k),
              [0.3, 0.2, 0.4, 0.25]),
}


def stage_end_forces(problem: Problem, solution) -> np.ndarray:
    return solution.lam[[solution.stage_end(s) for s in range(len(problem.model.stages))]]


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def compare(name: str, repeats: int) -> None:
    title, make, mu = MODELS[name]
    problem = Problem.build(make(1))
    cpu = {"fixed": [], "adaptive": []}
    solutions = {}
    problem.solve(mu, sensitivities=True)                   # the model's stuck inverse, made once
    for k in range(repeats):
        for kind in (("fixed", "adaptive") if k % 2 == 0 else ("adaptive", "fixed")):
            start = time.process_time()
            solutions[kind] = problem.solve(mu, sensitivities=True, increments=kind)
            cpu[kind].append(time.process_time() - start)
    fixed, adaptive = solutions["fixed"], solutions["adaptive"]
    difference = relative(stage_end_forces(problem, adaptive), stage_end_forces(problem, fixed))
    line = (f"{title}: increments {fixed.n_increments} fixed / {adaptive.n_increments} adaptive, Newton iterations "
            f"{int(fixed.n_newton.sum())} / {int(adaptive.n_newton.sum())}, CPU median "
            f"{statistics.median(cpu['fixed']):.3f} / {statistics.median(cpu['adaptive']):.3f} s (ratio "
            f"{statistics.median(cpu['fixed']) / statistics.median(cpu['adaptive']):.2f}); stage-end contact forces "
            f"adaptive - fixed {difference:.1e} of the largest")
    if name.startswith("block"):
        finer = Problem.build(make(2))
        own = relative(stage_end_forces(problem, fixed), stage_end_forces(finer, finer.solve(mu)))
        line += f"; the fixed path's own increment error (against twice the pull increments) {own:.1e}"
    print(line, flush=True)


def main(argv: list[str]) -> None:
    repeats = int(argv[0]) if argv and argv[0].isdigit() else 3
    names = [a for a in argv if not a.isdigit()] or list(MODELS)
    for name in names:
        compare(name, repeats)


if __name__ == "__main__":
    main(sys.argv[1:])
