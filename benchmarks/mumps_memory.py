"""The memory estimate for ``[solver] factorisation = "mumps"`` (frictionid.fem.mumps_memory) against the measured
peak, phase by phase.

For one model in this process: the estimate ``identify`` refuses by (:func:`frictionid.fem.memory.estimate`, above
what the process holds) and its phases (:func:`frictionid.fem.mumps_memory.phases`: the assembly, the
condensation, the first solve), then the work it stands for: assembly and condensation with MUMPS
(``Problem.build``, with the ten points observed on a bolt, the block's default points on the block) and one
forward + sensitivities solve at mu 0.15. Measured: the peak of the whole above what the process held before
(:class:`frictionid.fem.memory.Peak`, Linux's VmHWM) and the largest resident memory sampled every 5 ms in each
phase (the space and the stiffness's assembly, the condensation, the solve without the small-sliding check, then
the check, which takes the interfaces' displacements from the kept Schur complements' factors where the
condensation eliminated the interfaces' dofs last, and otherwise makes MUMPS's factors again to recover the
displacement field). The solve's n_w^2 doubles: its
measured peak less the estimate's space and copies of K, per n_w^2 doubles. Also MUMPS's own figures per body:
the analysis's estimate here (INFOG(17)) against the factorisation's estimate and what it used (INFOG(22)).

Run: .venv/bin/python benchmarks/mumps_memory.py block 1.0          (the 3-D block at mesh_size 1.0 mm)
     .venv/bin/python benchmarks/mumps_memory.py bolt '<bolt_model options as JSON>' [model.pkl]
(bolt options as benchmarks/bolt3d.py takes them; the model is pickled to / read from model.pkl). One model per
process: its peak is its own.
"""

import json
import sys
import threading
import time

import numpy as np

from frictionid.fem import memory, mumps_memory
from frictionid.fem import problem as problem_module
from frictionid.fem.problem import Problem

GB = 1e9


def block(mesh_size: str):
    from frictionid.builders.block import block_model
    model = block_model(mesh_size=float(mesh_size))
    points = np.array([[x, y, 5.0] for x in (-4.0, 0.0, 4.0) for y in (-4.0, 0.0, 4.0)])
    return model, {"points": points, "quantities": ("ux", "uy", "uz"), "regions": ["block"] * len(points)}, \
        {"mesh_size": float(mesh_size)}


def bolt(options: str, cache: str | None = None):
    from bolt3d import built, observed
    options = {"model": "3d", **json.loads(options)}
    return built(options, cache, {}), observed(options), options


class Phases:
    """The largest resident memory [bytes] in each phase, sampled every 5 ms; ``phase`` names the current one."""

    def __init__(self):
        self.phase, self.peaks, self._stop = "build", {}, threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)

    def _sample(self):
        while not self._stop.wait(0.005):
            now = memory.resident()
            self.peaks[self.phase] = max(self.peaks.get(self.phase, 0.0), now)

    def during(self, module, name: str, phase: str):
        """Name ``phase`` while ``module.name`` runs."""
        function = getattr(module, name)

        def named(*args, **kwargs):
            before, self.phase = self.phase, phase
            try:
                return function(*args, **kwargs)
            finally:
                self.phase = before
        setattr(module, name, named)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def main(kind: str, *args) -> None:
    model, observe, options = {"block": block, "bolt": bolt}[kind](*args)
    start = time.perf_counter()
    cost = memory.estimate(model, kind, factorisation="mumps")
    seconds = time.perf_counter() - start
    factors, entries, analyses = mumps_memory.analysed(model)
    estimated = mumps_memory.phases(model, memory.contact_pairs(model))
    print(f"{kind} {json.dumps(options)}: {model.mesh.n_nodes:,} nodes, {model.mesh.n_cells:,} cells, {cost.n_dofs:,} "
          f"dofs, {entries:,} stored entries of K, {memory.contact_pairs(model):,} contact nodes; held before "
          f"{cost.held / GB:.2f} GB", flush=True)
    print(f"  estimate above held {cost.above / GB:.2f} GB (x {mumps_memory.SAFETY} of the largest phase: "
          + ", ".join(f"{k} {v / GB:.2f}" for k, v in estimated.items())
          + f"; MUMPS's analysis with the Schur complements {factors / GB:.2f} GB; estimated in {seconds:.1f} s)",
          flush=True)
    phases = Phases()
    phases.during(problem_module, "model_space", "assembly")
    phases.during(problem_module, "stiffness", "assembly")
    phases.during(problem_module, "condense", "condensation")
    held = memory.resident()
    with phases, memory.Peak() as took:
        problem = Problem.build(model, factorisation="mumps", **observe)
        built = memory.resident()
        phases.phase = "solve"
        solution = problem.solve(np.full(len(model.zone_names), 0.15), sensitivities=True, max_slip=None)
        solved = memory.resident()
        phases.phase = "check"             # the small-sliding check the solve makes by default, apart
        problem.check_small_sliding(solution)
    print("  analysis here (INFOG(17)) per body: " + ", ".join(f"{a.estimated_mb:,} MB (Schur onto {a.schur_size:,})"
                                                            for a in analyses))
    print("  factorisations: " + ", ".join(f"estimated {s.estimated_mb:,} MB, used {s.used_mb:,} MB (Schur onto "
                                          f"{s.schur_size:,})" for s in problem.condensed.inverse.bodies.stats))
    print("  measured peak per phase above held: " + ", ".join(f"{k} {(v - held) / GB:.2f}"
                                                             for k, v in phases.peaks.items() if k != "build"))
    again = any(factor._struc is not None for factor in problem.condensed.inverse.bodies.factors)
    how = "MUMPS's factors made again" if again else "from the kept Schur factors, no factorisation"
    n_w = problem.pairs.B.shape[0]
    added, checked = phases.peaks["solve"] - built, phases.peaks.get("check", solved) - solved
    words = (phases.peaks["solve"] - held - estimated["solve"]) / (8.0 * n_w ** 2) + mumps_memory.SOLVE_CONTACT_WORDS
    print(f"  the solve: n_w {n_w:,} contact rows ({memory.contact_pairs(model):,} pairs estimated); "
          f"{added / GB:.3f} GB above the built problem; {words:.1f} n_w^2 doubles beside the space, K_KEPT "
          f"copies of K and the kept Schur factors (the estimate counts {mumps_memory.SOLVE_CONTACT_WORDS}); its "
          f"small-sliding check {checked / GB:.3f} GB above the solved problem ({how})", flush=True)
    print(f"  measured above held: {took.above / GB:.2f} GB; estimate / measured {cost.above / took.above:.2f}; "
          f"without the margin {cost.above / mumps_memory.SAFETY / took.above:.2f}; CHOLMOD's law / measured "
          f"{memory.estimate(model, kind, factorisation='cholmod').above / took.above:.2f}; process peak "
          f"{memory.process_peak() / GB:.2f} GB", flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])
