"""Contact solves: the updated Jacobian solves (fem/updated_jacobian.py, the default) against the previous path (a
fresh dense LU factorisation of the whole condensed Jacobian every Newton step), side by side in one run.

Models: the plane-strain clamp of tests/fixtures/clamp (6.5k nodes of quadratic triangles, two interfaces, six
zones, 31 increments), the default 3-D block (block_model()) and the default M20 bolt (bolt_model, 10 and 30 kN).
Each repeat solves forward + sensitivities once with each path, the two paths taking turns (each first in every
other repeat); the figures are the median per path and the median of the per-repeat ratios, then the largest
differences between the paths' results relative to each field's largest value. The process's CPU time is printed
too: on a machine shared with other jobs it moves less than the wall time. The first updated solve of a model
also makes its stuck inverse (once per model, kept for the fit's later solves): printed apart.

Run: .venv/bin/python benchmarks/contact_solves.py [repeats] [model ...]   (models: clamp block bolt)
     .venv/bin/python benchmarks/contact_solves.py --parts [repeats] [model ...]   (where the CPU time of a corrected
     solve goes: each part's own time, without the parts it calls, by wrapping the solver's methods)
"""

import collections
import functools
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from frictionid.builders.block import block_model
from frictionid.builders.bolt import bolt_model
from frictionid.builders.registry import build_model
from frictionid.config import read_config
from frictionid.fem import contact, loadpath, updated_jacobian
from frictionid.fem.problem import Problem
from frictionid.studies.bolt import FORCES
from frictionid.options import ModelSpec

CLAMP = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "clamp" / "clamp.toml"


def models():
    """name -> (model, coefficients)."""
    return {
        "clamp": (lambda: build_model(read_config(CLAMP).model_spec), [0.15, 0.2, 0.25, 0.18, 0.22, 0.3]),
        "block": (block_model, [0.3, 0.2, 0.4, 0.25]),
        "bolt": (lambda: bolt_model(forces=FORCES), None),
    }


def timed_solve(problem: Problem, mu, path: str):
    """(wall time [s], CPU time of this process [s], solution) of one forward + sensitivity solve."""
    loadpath._LINEAR = path
    start, cpu = time.perf_counter(), time.process_time()
    solution = problem.solve(mu, sensitivities=True)
    return time.perf_counter() - start, time.process_time() - cpu, solution


def difference(a, b) -> dict:
    """Largest difference of each field relative to its largest value."""
    out = {}
    for name in ("lam", "w", "reactions", "d_reactions"):
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        out[name] = float(np.max(np.abs(x - y), initial=0.0) / max(np.max(np.abs(x), initial=0.0), 1e-300))
    return out


def run(name: str, make, mu, repeats: int) -> None:
    model = make()
    problem = Problem.build(model)
    mu = np.full(model.n_zones, 0.15) if mu is None else np.asarray(mu)
    first, _, _ = timed_solve(problem, mu, "updated")                  # makes the model's stuck inverse
    times = {"dense": [], "updated": []}
    cpu = {"dense": [], "updated": []}
    ratios, cpu_ratios, solutions = [], [], {}
    for k in range(repeats):
        order = ("dense", "updated") if k % 2 == 0 else ("updated", "dense")
        for path in order:
            t, c, solutions[path] = timed_solve(problem, mu, path)
            times[path].append(t)
            cpu[path].append(c)
        ratios.append(times["dense"][-1] / times["updated"][-1])
        cpu_ratios.append(cpu["dense"][-1] / cpu["updated"][-1])
    loadpath._LINEAR = "updated"
    dense, updated = solutions["dense"], solutions["updated"]
    print(f"{name}: {model.mesh.n_nodes} nodes, {problem.pairs.n_pairs} contact pairs "
          f"({problem.pairs.n_pairs * problem.pairs.dim + problem.condensed.n_modes} unknowns), {model.n_zones} zones, "
          f"{dense.n_increments} increments; final states open/stick/slip "
          f"{np.bincount(updated.state[-1], minlength=3).tolist()}")
    print(f"  forward + sensitivities, median of {repeats}: dense {statistics.median(times['dense']):.3f} s "
          f"({int(dense.n_newton.sum())} Newton iterations), updated {statistics.median(times['updated']):.3f} s "
          f"({int(updated.n_newton.sum())}); ratio {statistics.median(ratios):.1f} "
          f"(per repeat {', '.join(f'{r:.1f}' for r in ratios)}); first updated solve {first:.3f} s")
    print(f"  CPU time, median: dense {statistics.median(cpu['dense']):.3f} s, updated "
          f"{statistics.median(cpu['updated']):.3f} s; ratio {statistics.median(cpu_ratios):.1f}")
    print("  largest difference / largest value: "
          + ", ".join(f"{k} {v:.1e}" for k, v in difference(dense, updated).items()))


#: the parts of a corrected solve timed by --parts: (owner, method, label)
PARTS = (
    (updated_jacobian.UpdatedSolver, "_corrected", "corrected solves: the two products with A, capacitance solves, R y"),
    (updated_jacobian.UpdatedSolver, "_factorised", "capacitance matrices: gathers, LU factorisations, updates"),
    (contact, "linearise", "linearising (each with a product with W)"),
    (updated_jacobian.UpdatedSolver, "product", "residual checks of the sensitivity solves (a product with W)"),
    (loadpath.LoadPathSolver, "_predictor", "predictors"),
    (loadpath.LoadPathSolver, "_sensitivity", "sensitivity right-hand sides"),
    (loadpath.LoadPathSolver, "step", "the rest of the load path: Newton loop, cuts, outputs"),
)


def parts(name: str, make, mu, repeats: int) -> None:
    """CPU time of each part of a corrected forward + sensitivity solve, its own time only."""
    model = make()
    problem = Problem.build(model)
    mu = np.full(model.n_zones, 0.15) if mu is None else np.asarray(mu)
    problem.solve(mu, sensitivities=True)                               # makes the model's stuck inverse
    own, inner = collections.defaultdict(float), []

    def timed(method, label):
        @functools.wraps(method)
        def wrapper(*args, **kwargs):
            start = time.process_time()
            inner.append(0.0)
            try:
                return method(*args, **kwargs)
            finally:
                spent = time.process_time() - start
                own[label] += spent - inner.pop()
                if inner:
                    inner[-1] += spent
        return wrapper

    originals = [(owner, attr, getattr(owner, attr)) for owner, attr, _ in PARTS]
    for (owner, attr, label), (_, _, method) in zip(PARTS, originals):
        setattr(owner, attr, timed(method, label))
    try:
        start = time.process_time()
        for _ in range(repeats):
            problem.solve(mu, sensitivities=True)
        total = time.process_time() - start
    finally:
        for owner, attr, method in originals:
            setattr(owner, attr, method)
    print(f"{name}: corrected forward + sensitivities, CPU {total / repeats:.3f} s per solve ({repeats} solves)")
    for _, _, label in PARTS:
        print(f"  {100 * own[label] / total:5.1f} %  {label}")
    print(f"  {100 * (1 - sum(own.values()) / total):5.1f} %  outside these (Problem.solve's set-up and outputs)")


def main(argv: list[str]) -> None:
    measure = run
    if argv[:1] == ["--parts"]:
        measure, argv = parts, argv[1:]
    repeats = int(argv[0]) if argv else 5
    chosen = argv[1:] or list(models())
    for name in chosen:
        make, mu = models()[name]
        measure(name, make, mu, repeats)


if __name__ == "__main__":
    main(sys.argv[1:])
