"""The contact solver on shared cores: a forward + sensitivity solve with the BLAS threads the library allows
(one, set inside Problem.solve) against BLAS's own default (all cores), on an idle machine and while a second
process keeps one core busy, as another job or a second evaluation worker does.

Prints per model (default 3-D block, default M20 bolt) and condition the best of 3 solve times [s] and the ratio
default / one thread. Run: .venv/bin/python benchmarks/blas_threads.py (about 2 min).
"""

import multiprocessing
import time

from threadpoolctl import threadpool_info

from _measure import best_of
from frictionid.builders.registry import build_model
from frictionid.fem import problem as problem_module
from frictionid.fem.problem import Problem
from frictionid.studies.bolt import TRUE_MU
from frictionid.options import ModelSpec

MODELS = {"block (default, mesh 1.0)": ({"builder": "block"}, {"A": 0.35, "B": 0.2, "C": 0.45, "D": 0.15}),
          "bolt (default M20)": ({"builder": "bolt"}, {**TRUE_MU, "head_plate": 0.15, "nut_plate": 0.15})}


def _busy(stop):
    while not stop.is_set():
        sum(range(10000))


class _Unlimited:
    """A limit that leaves BLAS at its default (to time the solver as it was)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def solve_time(problem: Problem, mu: dict, limited: bool) -> float:
    limit = problem_module.one_blas_thread
    problem_module.one_blas_thread = limit if limited else _Unlimited
    try:
        return best_of(3, lambda: problem.solve(mu, sensitivities=True))[0]
    finally:
        problem_module.one_blas_thread = limit


def main() -> None:
    print("BLAS:", ", ".join(f"{d['internal_api']} {d['num_threads']} threads" for d in threadpool_info()))
    for name, (options, mu) in MODELS.items():
        problem = Problem.build(build_model(ModelSpec.from_table(options)))
        print(f"{name}: {problem.pairs.n_pairs} contact pairs")
        for condition in ("idle", "one core busy"):
            stop = multiprocessing.Event()
            worker = multiprocessing.Process(target=_busy, args=(stop,)) if condition != "idle" else None
            if worker:
                worker.start()
                time.sleep(0.5)
            try:
                one, default = solve_time(problem, mu, True), solve_time(problem, mu, False)
            finally:
                if worker:
                    stop.set()
                    worker.join()
            print(f"  {condition:14s} one BLAS thread {one:7.3f} s   BLAS default {default:7.3f} s   "
                  f"ratio {default / one:6.1f}")


if __name__ == "__main__":
    main()
