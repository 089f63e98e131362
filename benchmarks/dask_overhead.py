"""Dask as the executor of independent solves (issue 16 item 3): its overhead per task, the speed-up of a
CalculiX finite-difference Jacobian with 1 and 2 workers, and the estimate for a larger cluster from the task
times, measured in one run.

Overhead: the same embedded forward solve (plane-strain block, 4 zones) called in this process and sent to a
2-worker LocalCluster (scheduler = "local"), one task at a time (latency: submit, solve, result back) and 40 at
once (per task of a batch); the difference to the in-process time is Dask's. Jacobian: forward differences of
the 4 zone coefficients of the same model with ccx (4 perturbed runs after the base point, which is not timed),
on 1 worker (this process), 2 forked processes and the 2-worker LocalCluster; ccx with one thread
(OMP_NUM_THREADS=1). The machine has 2 cores, shared: the load average is printed.
Run: .venv/bin/python benchmarks/dask_overhead.py [mesh_size]     (default 2.0: about 1 minute on an idle machine)
"""

import math
import os
import sys
import tempfile
import time

import numpy as np

from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.block import block_model_2d
from frictionid.inverse.evaluator import Evaluator
from frictionid.inverse.observations import Observations
from frictionid.inverse.parameters import Parameters
from frictionid.run.executor import make_executor

MU = {"A": 0.3, "B": 0.2, "C": 0.4, "D": 0.25}
POINTS = np.array([[-5.0, 0.5], [5.0, 0.5], [-5.0, 2.0], [5.0, 2.0], [-7.0, 0.0], [7.0, 0.0]])
REGIONS = ["block"] * 4 + ["base"] * 2
N_BATCH = 40


def observations() -> Observations:
    n = 2 * len(POINTS)
    return Observations(POINTS, tuple(REGIONS), ("ux", "uy"), np.arange(n), np.ones(n, int), np.zeros(n),
                        np.full(n, 1e-3), tuple(map(str, range(n))), True)


def overhead(backend, mu: np.ndarray) -> dict:
    """Seconds per embedded solve: in this process, one Dask task at a time, and per task of a batch."""
    local = []
    for _ in range(5):
        start = time.perf_counter()
        backend.predict(mu)
        local.append(time.perf_counter() - start)
    start = time.perf_counter()
    executor = make_executor(backend, 2, "local")
    startup = time.perf_counter() - start
    try:
        executor.result(executor.submit(mu, False))       # each worker has the backend from here on
        single, worker = [], []
        for _ in range(10):
            start = time.perf_counter()
            _, seconds = executor.result(executor.submit(mu, False))
            single.append(time.perf_counter() - start)
            worker.append(seconds)
        start = time.perf_counter()
        batch = [executor.submit(mu, False) for _ in range(N_BATCH)]
        for _ in executor.completed(batch):
            pass
        per_task = (time.perf_counter() - start) / N_BATCH
    finally:
        executor.close()
    return {"local": float(np.median(local)), "single": float(np.median(single)),
            "worker": float(np.median(worker)), "batch": per_task, "startup": startup}


def jacobian_time(backend, obs, params, workers: int, scheduler=None) -> tuple[float, np.ndarray]:
    """Wall time of one forward-difference Jacobian [s] and the Jacobian."""
    executor = make_executor(backend, workers, scheduler)
    evaluator = Evaluator(backend, obs, params, jacobian="forward", step=1e-2, executor=executor)
    try:
        evaluator.residuals(params.x0)              # the base point, not timed
        executor.start()
        start = time.perf_counter()
        jac = evaluator.jacobian(params.x0)
        wall = time.perf_counter() - start
    finally:
        evaluator.close()
    return wall, jac


def task_times(backend, mu: np.ndarray, n: int = 2) -> list[float]:
    """ccx forward solves in this process [s]."""
    times = []
    for k in range(n):
        start = time.perf_counter()
        backend.predict(mu * (1 + 0.01 * k))
        times.append(time.perf_counter() - start)
    return times


def main(mesh_size: float = 2.0) -> None:
    os.environ["OMP_NUM_THREADS"] = "1"
    model = block_model_2d(mesh_size=mesh_size, n_zones=4, pull=0.05)
    mu = np.array(list(MU.values()))
    obs = observations()
    params = Parameters.from_config(model.zone_names, MU, (0.0, 1.0))
    embedded = EmbeddedBackend(model, POINTS, ("ux", "uy"), REGIONS)
    cost = overhead(embedded, mu)
    with tempfile.TemporaryDirectory() as tmp:
        ccx = CalculixBackend(model, POINTS, ("ux", "uy"), REGIONS, CalculixSettings(work_dir=tmp))
        solves = task_times(ccx, mu)
        runs = {"1 worker": jacobian_time(ccx, obs, params, 1),
                "2 processes": jacobian_time(ccx, obs, params, 2),
                "2 Dask workers": jacobian_time(ccx, obs, params, 2, "local")}
    serial = runs["1 worker"][0]
    same = all(np.array_equal(jac, runs["1 worker"][1]) for _, jac in runs.values())
    print(f"plane-strain block, mesh_size {mesh_size:g}, 4 zones: {model.mesh.n_nodes} nodes, {len(POINTS)} points")
    print(f"  Dask LocalCluster, 2 workers: started and the backend sent in {cost['startup']:.1f} s")
    print(f"  embedded forward solve: {1e3 * cost['local']:.1f} ms in this process, {1e3 * cost['worker']:.1f} ms "
          f"on a worker; as one Dask task at a time {1e3 * cost['single']:.1f} ms (overhead "
          f"{1e3 * (cost['single'] - cost['worker']):.1f} ms per task), in a batch of {N_BATCH} on 2 workers "
          f"{1e3 * cost['batch']:.1f} ms per task")
    t_task = float(np.median(solves))
    print(f"  ccx forward solve: {t_task:.2f} s (median of {len(solves)})")
    for name, (wall, _) in runs.items():
        print(f"  ccx forward-difference Jacobian (4 perturbed runs), {name}: {wall:.1f} s, speed-up "
              f"{serial / wall:.2f}")
    print(f"  identical Jacobians: {same}")
    overhead_s = max(cost["single"] - cost["worker"], 0.0)
    print(f"  estimate for W workers, n independent ccx solves (ceil(n / W) rounds of {t_task:.2f} s + "
          f"{1e3 * overhead_s:.0f} ms): ", end="")
    print(", ".join(f"n = {n}, W = {w}: {math.ceil(n / w) * (t_task + overhead_s):.1f} s (speed-up "
                    f"{n * t_task / (math.ceil(n / w) * (t_task + overhead_s)):.1f})"
                    for n, w in ((12, 4), (12, 12), (48, 16))))
    print(f"  machine: {os.cpu_count()} cores; load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main(*(float(a) for a in sys.argv[1:2]))
