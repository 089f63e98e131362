"""The memory estimate for ``[solver] factorisation = "mumps"`` (frictionid.fem.memory) against the measured peak.

For one model in this process: the estimate ``identify`` refuses by (:func:`frictionid.fem.memory.estimate`, the
condensation's part and the dense contact part, above what the process holds), then the peak above that of the
work it stands for, measured by :class:`frictionid.fem.memory.Peak` (Linux's VmHWM, reset before): assembly and
condensation with MUMPS (``Problem.build`` with the ten points' or the block's default points observed) and one
forward + sensitivities solve at mu 0.15. Also MUMPS's own figures per body: the analysis's estimate (INFOG(17))
against what the factorisation used (INFOG(22)).

Run: .venv/bin/python benchmarks/mumps_memory.py block 1.0          (the 3-D block at mesh_size 1.0 mm)
     .venv/bin/python benchmarks/mumps_memory.py bolt '<bolt_model options as JSON>' [model.pkl]
(bolt options as benchmarks/bolt3d.py takes them; the model is pickled to / read from model.pkl). One model per
process: its peak is its own.
"""

import json
import sys
import time

import numpy as np

from frictionid.fem import memory, mumps_memory
from frictionid.fem.problem import Problem

GB = 1e9


def block(mesh_size: str):
    from frictionid.builders.block import block_model
    from frictionid.inverse.observations import default_quantities
    model = block_model(mesh_size=float(mesh_size))
    points = np.array([[x, y, 5.0] for x in (-4.0, 0.0, 4.0) for y in (-4.0, 0.0, 4.0)])
    return model, {"points": points, "quantities": ("ux", "uy", "uz"), "regions": ["block"] * len(points)}, \
        {"mesh_size": float(mesh_size)}


def bolt(options: str, cache: str | None = None):
    from bolt3d import built, observed
    options = {"model": "3d", **json.loads(options)}
    return built(options, cache, {}), observed(options), options


def main(kind: str, *args) -> None:
    model, observe, options = {"block": block, "bolt": bolt}[kind](*args)
    start = time.perf_counter()
    cost = memory.estimate(model, kind, factorisation="mumps")
    seconds = time.perf_counter() - start
    factors, entries, analyses = mumps_memory.analysed(model)
    print(f"{kind} {json.dumps(options)}: {model.mesh.n_nodes:,} nodes, {cost.n_dofs:,} dofs, {entries:,} stored "
          f"entries of K, {memory.contact_pairs(model):,} contact nodes; held before {cost.held / GB:.2f} GB",
          flush=True)
    print(f"  estimate above held {cost.above / GB:.2f} GB (MUMPS's analysis {factors / GB:.2f} GB with the Schur "
          f"complements; estimated in {seconds:.1f} s)", flush=True)
    mu = None
    with memory.Peak() as took:
        problem = Problem.build(model, factorisation="mumps", **observe)
        mu = np.full(len(model.zone_names), 0.15)
        problem.solve(mu, sensitivities=True)
    used = [s.used_mb for s in problem.condensed.inverse.bodies.stats]
    for a, s in zip(analyses, problem.condensed.inverse.bodies.stats):
        print(f"    body: Schur onto {a.schur_size:,} (run: {s.schur_size:,}); MUMPS analysis {a.estimated_mb:,} MB, "
              f"factorisation estimated {s.estimated_mb:,} MB, used {s.used_mb:,} MB", flush=True)
    measured = took.above
    print(f"  measured above held: {measured / GB:.2f} GB; estimate / measured {cost.above / measured:.2f}; MUMPS "
          f"used {sum(used) / 1e3:.2f} GB; process peak {memory.process_peak() / GB:.2f} GB", flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])
