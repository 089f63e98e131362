"""Finite sliding in 3-D (fem/sliding.py with the 3-D dual mortar) against the CalculiX backend (surface-to-surface
contact, which follows the deformation) on the seed's block test: 3-D block pulled 2 mm at 2000 N, four zones, at
several mesh sizes of the block builder (default grading and elements); per mesh: pull reaction (finite and small
sliding against ccx), displacements at the DIC points in % of ccx's range, forward-solve times and their ratio;
the forward solve also re-coupled until every increment's fixed point converges (RECOUPLE_FRACTION 0) and, so,
with the mortar integrated facet by facet (the former builder, tests/mortar3d_facets.py): couplings built, times
and the change of the results.

Run: PYTHONPATH=src .venv/bin/python benchmarks/finite_sliding_3d.py [--n-pull N] [mesh_size ...]
(default 5 2.5; N the pull's increments, default 10)
"""

import os
import resource
import sys
import tempfile
import time

import numpy as np

from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
from frictionid.builders.block import block_model
from frictionid.fem import mortar3d, sliding
from frictionid.fem.problem import Problem

import _tests  # noqa: F401  (tests/ importable)
import mortar3d_facets
from sliding3d_case import MU, POINTS, QUANTITIES, REGIONS


def cpu_now() -> float:
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def counted_solve(problem, fraction=None, integrate=None):
    """Wall and CPU time [s] of one finite-sliding forward solve, the couplings it built and its solution; with
    ``fraction`` as RECOUPLE_FRACTION and ``integrate`` as the 3-D mortar's integration if given."""
    saved = sliding.RECOUPLE_FRACTION, mortar3d._integrate, sliding.Coupling.__init__
    built = []
    sliding.Coupling.__init__ = lambda self, *a: built.append(1) or saved[2](self, *a)
    sliding.RECOUPLE_FRACTION = saved[0] if fraction is None else fraction
    mortar3d._integrate = integrate or saved[1]
    try:
        wall, cpu = time.perf_counter(), cpu_now()
        solution = problem.solve(MU)
        return time.perf_counter() - wall, cpu_now() - cpu, len(built), solution
    finally:
        sliding.RECOUPLE_FRACTION, mortar3d._integrate, sliding.Coupling.__init__ = saved


def one_mesh(mesh_size: float, n_pull: int):
    model = block_model(pull=2.0, force=2000.0, mesh_size=mesh_size, n_pull=n_pull)
    pull = model.reaction_labels.index("block_top.y")
    start = time.perf_counter()
    finite = Problem.build(model, points=POINTS, quantities=QUANTITIES, regions=REGIONS, sliding="finite")
    condensation = time.perf_counter() - start
    wall, cpu, n_couplings, got = counted_solve(finite)
    converged = counted_solve(finite, fraction=0.0)
    former = counted_solve(finite, fraction=0.0, integrate=mortar3d_facets.integrate)
    small = Problem.build(model, points=POINTS, quantities=QUANTITIES, regions=REGIONS).solve(MU, max_slip=None)
    with tempfile.TemporaryDirectory() as tmp:
        backend = CalculixBackend(model, POINTS, QUANTITIES, REGIONS, CalculixSettings(work_dir=tmp))
        ccx_wall, ccx_cpu = time.perf_counter(), cpu_now()
        ccx = backend.solve(MU, full_field=False)
        ccx_wall, ccx_cpu = time.perf_counter() - ccx_wall, cpu_now() - ccx_cpu
    reference = np.asarray(ccx.observations[-1]).reshape(-1, 3)
    span = np.ptp(reference, axis=0)
    print(f"mesh_size {mesh_size:g}: {model.mesh.n_nodes} nodes, {finite.pairs.n_pairs} contact pairs, "
          f"{len(finite.interface_dofs)} interface dofs, {n_pull} pull increments")
    for name, s in (("finite", got), ("small", small)):
        difference = np.abs(np.asarray(s.observations[-1]).reshape(-1, 3) - reference).max(axis=0)
        print(f"  {name:6s} pull reaction {s.reactions[-1, pull]:9.2f} N ({s.reactions[-1, pull] / ccx.reactions[-1, pull] - 1:+.2%}"
              f" vs ccx {ccx.reactions[-1, pull]:.2f} N); sum mu N {MU @ s.zone_normal_force[-1]:9.2f} N; "
              f"largest |difference| at the points {difference.max() / np.ptp(reference):.2%} of ccx's range of "
              "all components; ux / uy / uz in % of their own range: "
              + " / ".join(f"{d:.2%}" for d in difference / span))
    print(f"  ccx: sum mu N {MU @ ccx.zone_normal_force[-1]:9.2f} N, sum of tangential forces "
          f"{ccx.zone_tangential_force[-1].sum():9.2f} N, zone normal forces "
          + " / ".join(f"{v:.1f}" for v in ccx.zone_normal_force[-1]) + " N (finite sliding: "
          + " / ".join(f"{v:.1f}" for v in got.zone_normal_force[-1]) + " N)")
    print(f"  times: condensation {condensation:.2f} s; forward finite {wall:.2f} s wall {cpu:.2f} s CPU "
          f"({n_couplings} couplings); ccx {ccx_wall:.2f} s wall {ccx_cpu:.2f} s CPU; ratio ccx / finite "
          f"{ccx_wall / wall:.1f} wall {ccx_cpu / cpu:.1f} CPU")
    observed = np.asarray(got.observations)
    for name, (w, c, n, s) in (("re-coupled to convergence", converged), ("the same, mortar facet by facet", former)):
        print(f"  forward finite, {name}: {w:.2f} s wall {c:.2f} s CPU ({n} couplings; ccx / it {ccx_cpu / c:.1f} "
              f"CPU); reactions differ by {np.abs(s.reactions - got.reactions).max() / np.abs(s.reactions).max():.1e} "
              f"of the largest, displacements at the points by "
              f"{np.abs(np.asarray(s.observations) - observed).max() / np.ptp(observed):.1e} of their range")
    print(f"  load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores", flush=True)


def main(*mesh_sizes: float, n_pull: int = 10):
    for h in mesh_sizes or (5.0, 2.5):
        one_mesh(h, n_pull=n_pull)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    increments = 10
    if "--n-pull" in arguments:             # the pull's increments, for both codes (CalculiX's path needs many)
        at = arguments.index("--n-pull")
        increments = int(arguments[at + 1])
        del arguments[at:at + 2]
    main(*(float(a) for a in arguments), n_pull=increments)
