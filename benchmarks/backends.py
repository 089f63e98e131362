"""Forward-solve time of the embedded and CalculiX backends on the same model, and the parallel speed-up of a
finite-difference Jacobian with the calculix backend, measured in one run (issue 5).

Model: the 3-D block (reference test 1), strains and displacements at the 16 points of
benchmarks/identify_block.py. Jacobian: forward differences of the 4 zone coefficients (4 perturbed ccx runs
after the base point), once with 1 worker and once with 2; ccx runs with OMP_NUM_THREADS=1 in both.
Run: .venv/bin/python benchmarks/backends.py [mesh_size]     (mesh 5/3: about 2 minutes)
"""

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.block import block_model
from frictionid.data.measurements import QUANTITIES, read_measurements
from frictionid.inverse.evaluator import Evaluator
from frictionid.inverse.observations import observations_from
from frictionid.inverse.parameters import Parameters
from frictionid.options import DataSpec

MU = {"A": 0.3, "B": 0.2, "C": 0.4, "D": 0.25}


def observations(model, folder: Path):
    rows = ["point,x,y,z,stage," + ",".join(QUANTITIES)]
    k = 0
    for z in (0.5, 1.5):
        for s in (-3.0, 3.0):
            for x, y in ((-5.0, s), (5.0, s), (s, -5.0), (s, 5.0)):
                k += 1
                rows.append(f"P{k},{x},{y},{z},2" + ",0.0" * len(QUANTITIES))
    (folder / "points.csv").write_text("\n".join(rows) + "\n")
    data = DataSpec(observables=QUANTITIES, stages=[2], noise={"u": 1e-3, "e": 1e-5}, regions={"*": "block"})
    return observations_from(read_measurements(folder / "points.csv"), model, data)


def jacobian_time(backend, obs, params, workers: int) -> tuple[float, np.ndarray]:
    evaluator = Evaluator(backend, obs, params, jacobian="forward", step=1e-2, workers=workers)
    try:
        evaluator.residuals(params.x0)              # the base point, not timed
        start = time.perf_counter()
        jac = evaluator.jacobian(params.x0)
        return time.perf_counter() - start, jac
    finally:
        evaluator.close()


def main(mesh_size: float = 5 / 3) -> None:
    model = block_model(mesh_size=mesh_size)
    mu = np.array(list(MU.values()))
    with tempfile.TemporaryDirectory() as tmp:
        obs = observations(model, Path(tmp))
        start = time.perf_counter()
        embedded = EmbeddedBackend(model, obs.points, obs.quantities, obs.point_regions)
        setup = time.perf_counter() - start
        times = []
        for _ in range(3):
            start = time.perf_counter()
            embedded.predict(mu)
            times.append(time.perf_counter() - start)
        calculix = CalculixBackend(model, obs.points, obs.quantities, obs.point_regions,
                                   CalculixSettings(work_dir=tmp))
        start = time.perf_counter()
        calculix.predict(mu)
        ccx_time = time.perf_counter() - start
        params = Parameters.from_config(model.zone_names, MU, (0.0, 1.0))
        serial, jac1 = jacobian_time(calculix, obs, params, 1)
        parallel, jac2 = jacobian_time(calculix, obs, params, 2)
    print(f"3-D block, mesh_size {mesh_size:.3g}: {model.mesh.n_nodes} nodes, {len(obs.points)} points x "
          f"{len(QUANTITIES)} quantities, {sum(s.n_increments for s in model.stages)} increments")
    print(f"  embedded: condensation {setup:.2f} s once, forward solve {min(times):.3f} s (best of 3)")
    print(f"  calculix: forward solve {ccx_time:.2f} s (deck, ccx run, parsing)")
    print(f"  ratio calculix / embedded per forward solve: {ccx_time / min(times):.0f}")
    print(f"  calculix forward-difference Jacobian (4 perturbed runs): 1 worker {serial:.1f} s, 2 workers "
          f"{parallel:.1f} s, speed-up {serial / parallel:.2f} (identical Jacobians: {np.array_equal(jac1, jac2)})")
    print(f"  machine: {os.cpu_count()} cores; load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main(*(float(a) for a in sys.argv[1:2]))
