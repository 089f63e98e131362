"""How the dense contact operations grow with the number of contact dofs n_w = dim n_c: the condensation's dense
part for a two-body interface (per body: the triangular solve of its trailing factor block with the contact rows,
then T K^-1 B^T = Z^T Z) and the load path's stuck contact Jacobian (its LU and inverse,
:meth:`frictionid.fem.updated_jacobian.StuckInverse.build`, the product's code), on a synthetic SPD W of size n_w.

One size per process, so that the peak resident memory is that size's (ru_maxrss). The sparse factorisation of K
is not part of it (benchmarks/condensation.py measures that against dofs).

Run: .venv/bin/python benchmarks/contact_dense.py 2000 4000 6000
"""

import resource
import subprocess
import sys
import time

import numpy as np
import scipy.linalg as la


def one(n_w: int) -> None:
    from frictionid.fem.updated_jacobian import StuckInverse
    rng = np.random.default_rng(0)
    s = n_w                                       # one body's contact dofs (the other body's block: the same)
    cpu, wall = time.process_time(), time.perf_counter()
    out = np.zeros((n_w, n_w))
    for _ in range(2):                            # bolt side, nut side
        L = np.tril(rng.standard_normal((s, s))) + s * np.eye(s)
        rows = rng.standard_normal((s, n_w))
        Z = la.solve_triangular(L, rows, lower=True, check_finite=False)
        del rows, L
        out += Z.T @ Z
        del Z
    condense_cpu, condense_wall = time.process_time() - cpu, time.perf_counter() - wall
    W = 0.5 * (out + out.T) / n_w
    del out
    cpu, wall = time.process_time(), time.perf_counter()
    stuck = StuckInverse.build(W, np.zeros((0, n_w)), 1.0 / np.mean(np.diag(W)), None,
                               np.zeros(n_w // 3, dtype=bool))
    stuck_cpu, stuck_wall = time.process_time() - cpu, time.perf_counter() - wall
    assert stuck is not None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    print(f"n_w {n_w:6d} (n_c {n_w // 3:5d}): dense condensation {condense_cpu:7.1f} s CPU ({condense_wall:7.1f} s "
          f"wall), stuck inverse {stuck_cpu:7.1f} s CPU ({stuck_wall:7.1f} s wall), peak {peak:5.2f} GB = "
          f"{peak * 2**30 / (8.0 * n_w ** 2):.1f} n_w^2 doubles", flush=True)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--one":
        one(int(sys.argv[2]))
    else:
        for n in sys.argv[1:] or ("2000", "4000", "6000"):
            subprocess.run([sys.executable, __file__, "--one", n], check=True)
