"""The contact solver on shared cores: a forward + sensitivity solve with the BLAS threads the library allows
(one, set inside Problem.solve) against BLAS's own default (all cores), on an idle machine and while a second
process keeps one core busy, as another job or a second evaluation worker does.

Prints per model (default 3-D block, default M20 bolt) and condition the best of 3 solve times [s] and the ratio
default / one thread. Run: .venv/bin/python benchmarks/blas_threads.py (about 2 min).

``--dense N``: the large dense kernels of a contact solve (the stuck inverse of the half-space interface of
benchmarks/halfspace.py with N contact dofs, a single- and a double-precision LU factorisation of a capacitance
matrix of 0.7 N rows, as the load path makes them), each timed with one BLAS thread (as a solve runs them) and
with BLAS's default, one after the other, idle and with one core busy: CPU and wall time of each, the ratios
default / one thread. Run: .venv/bin/python benchmarks/blas_threads.py
--dense 6000
"""

import multiprocessing
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

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


@contextmanager
def _condition(condition: str):
    """Nothing (idle) or a second process keeping one core busy."""
    stop = multiprocessing.Event()
    worker = multiprocessing.Process(target=_busy, args=(stop,)) if condition != "idle" else None
    if worker:
        worker.start()
        time.sleep(0.5)
    try:
        yield
    finally:
        if worker:
            stop.set()
            worker.join()


def _cpu_wall(function) -> tuple[float, float]:
    cpu, wall = time.process_time(), time.perf_counter()
    function()
    return time.process_time() - cpu, time.perf_counter() - wall


def _double(capacitance, C):
    """C factorised as a fresh capacitance factorisation in double precision."""
    precision, capacitance.PRECISION = capacitance.PRECISION, "double"
    try:
        return capacitance.Fresh.factorise(None, None, None, C)
    finally:
        capacitance.PRECISION = precision


def dense(n_w: int) -> None:
    """The large kernels of a contact solve with one BLAS thread and with BLAS's default (``--dense``)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from halfspace import compliance, lattice

    from frictionid.fem import capacitance
    from frictionid.fem import threads
    from frictionid.fem.threads import one_blas_thread
    from frictionid.fem.updated_jacobian import StuckInverse
    W = compliance(lattice(n_w // 3, 0.05), 0.05)
    n_w, k = len(W), int(0.7 * len(W))
    C = np.random.default_rng(0).normal(size=(k, k)) + 3.0 * np.sqrt(k) * np.eye(k)
    kernels = {
        "stuck inverse": lambda: StuckInverse.build(W, np.zeros((0, n_w)), 1.0 / np.mean(np.diag(W)), None,
                                                    np.zeros(n_w // 3, dtype=bool)),
        f"capacitance LU single ({k} rows)": lambda: capacitance.Fresh.factorise(None, None, None, C),
        f"capacitance LU double ({k} rows)": lambda: _double(capacitance, C),
    }
    print(f"n_w {n_w}: each kernel with one BLAS thread, then with BLAS's default", flush=True)
    for condition in ("idle", "one core busy"):
        with _condition(condition):
            for name, kernel in kernels.items():
                with one_blas_thread():
                    threads.LARGE, large = np.inf, threads.LARGE       # one thread also for large kernels
                    try:
                        one = _cpu_wall(kernel)
                    finally:
                        threads.LARGE = large
                default = _cpu_wall(kernel)
                print(f"  {condition:14s} {name:36s} one thread {one[0]:6.2f} s CPU {one[1]:6.2f} s wall; "
                      f"default {default[0]:6.2f} s CPU {default[1]:6.2f} s wall; ratios CPU "
                      f"{default[0] / one[0]:4.2f}, wall {default[1] / one[1]:4.2f}", flush=True)


def main() -> None:
    print("BLAS:", ", ".join(f"{d['internal_api']} {d['num_threads']} threads" for d in threadpool_info()))
    for name, (options, mu) in MODELS.items():
        problem = Problem.build(build_model(ModelSpec.from_table(options)))
        print(f"{name}: {problem.pairs.n_pairs} contact pairs")
        for condition in ("idle", "one core busy"):
            with _condition(condition):
                one, default = solve_time(problem, mu, True), solve_time(problem, mu, False)
            print(f"  {condition:14s} one BLAS thread {one:7.3f} s   BLAS default {default:7.3f} s   "
                  f"ratio {default / one:6.1f}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--dense":
        dense(int(sys.argv[2]))
    else:
        main()
