"""The contact solve that never forms W (Problem.build(contact="implicit"): fem/condense_implicit.py,
fem/contact_krylov.py) against the dense path (contact="dense") on the 3-D block as its interface grows: the
footprint divided into N x N hexahedra (n_w = 3 (N + 1)^2 contact dofs), 2 mm elements elsewhere, press then pull
in 4 increments (stick, partial and gross slip), mu = 0.3 / 0.2 / 0.4 / 0.25.

Per N and path, one process (its peak is that size's, ru_maxrss): CPU time [s] of the condensation
(Problem.build), of a forward solve and of a forward + sensitivities solve, GMRES iterations per solve and
penalised factorisations (implicit), and the peak; then the largest difference of the paths' reactions and
reaction sensitivities over the path, relative to their largest value.

Run: .venv/bin/python benchmarks/contact_implicit.py 10 20 30 40 [--out results.jsonl]
"""

import json
import resource
import subprocess
import sys
import time

import numpy as np

MU = [0.3, 0.2, 0.4, 0.25]


def one(n: int, contact: str) -> None:
    from frictionid.builders.block import block_model
    from frictionid.fem.problem import Problem
    model = block_model(mesh_size=2.0, block_divisions=n, n_pull=4)
    cpu = time.process_time()
    problem = Problem.build(model, contact=contact)
    condense = time.process_time() - cpu
    cpu = time.process_time()
    problem.solve(MU)
    forward = time.process_time() - cpu
    cpu = time.process_time()
    solution = problem.solve(MU, sensitivities=True)
    both = time.process_time() - cpu
    krylov = problem.__dict__.get("_krylov")
    print(json.dumps({
        "N": n, "contact": contact, "n_nodes": model.mesh.n_nodes, "n_w": 3 * problem.pairs.n_pairs,
        "condense_cpu": condense, "forward_cpu": forward, "forward_sensitivities_cpu": both,
        "newton": int(solution.n_newton.sum()),
        "gmres_per_solve": None if krylov is None else krylov.n_iterations / krylov.n_calls,
        "penalised_factorisations": None if krylov is None else krylov.penalised.n_factorisations,
        "peak_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20,
        "reactions": np.asarray(solution.reactions).tolist(),
        "d_reactions": np.asarray(solution.d_reactions).tolist()}), flush=True)


def main(sizes, out=None) -> None:
    for n in sizes:
        runs = {}
        for contact in ("dense", "implicit"):
            line = subprocess.run([sys.executable, __file__, "--one", str(n), contact], check=True,
                                  capture_output=True, text=True).stdout.strip().splitlines()[-1]
            runs[contact] = json.loads(line)
        differences = {}
        for name in ("reactions", "d_reactions"):
            a, b = np.array(runs["dense"][name]), np.array(runs["implicit"][name])
            differences[name] = float(np.max(np.abs(a - b)) / np.max(np.abs(a)))
        for contact, run in runs.items():
            print(f"N {n:3d} n_w {run['n_w']:6d} ({run['n_nodes']:,} nodes) {contact:8s}: condensation "
                  f"{run['condense_cpu']:7.1f} s, forward {run['forward_cpu']:7.1f} s, forward + sensitivities "
                  f"{run['forward_sensitivities_cpu']:7.1f} s CPU, peak {run['peak_gb']:5.2f} GB"
                  + ("" if run["gmres_per_solve"] is None else
                     f"; {run['gmres_per_solve']:.1f} GMRES iterations per solve, "
                     f"{run['penalised_factorisations']} penalised factorisations"), flush=True)
        print(f"  implicit against dense: reactions {differences['reactions']:.1e}, reaction sensitivities "
              f"{differences['d_reactions']:.1e} (relative to the largest)", flush=True)
        if out:
            with open(out, "a") as file:
                for run in runs.values():
                    slim = {k: v for k, v in run.items() if k not in ("reactions", "d_reactions")}
                    file.write(json.dumps({**slim, "difference": differences}) + "\n")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--one":
        one(int(sys.argv[2]), sys.argv[3])
    else:
        args = sys.argv[1:]
        out = args[args.index("--out") + 1] if "--out" in args else None
        sizes = [int(a) for a in args if a.isdigit()] or [10, 20, 30]
        main(sizes, out)
