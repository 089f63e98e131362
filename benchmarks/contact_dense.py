"""How the dense contact operations grow with the number of contact dofs n_w = dim n_c: the condensation's dense
part for a two-body interface (per body, node-to-node contact rows T on its Schur complement S = L L^T: the
product's S^-1 from L and T S^-1 T^T, fem/condense.py; and, for comparison, the triangular solves Z = L^-1 T^T and
Z^T Z it replaced, BLAS's default threads) and the load path's stuck contact Jacobian's inverse
(:meth:`frictionid.fem.updated_jacobian.StuckInverse.build`, the product's code), on a synthetic SPD W of size n_w.

One size per process, so that the peak resident memory is that size's (ru_maxrss). The sparse factorisation of K
is not part of it (benchmarks/condensation.py measures that against dofs).

``--stuck-only``: W is the half-space interface's (benchmarks/halfspace.py, no floating mode) and only the stuck
inverse is made, once by LU (``STUCK = "lu"``: LU factorisation and n solves) and once from the Cholesky factor
(``"auto"``), each with one BLAS thread as a solve makes it, in that order (the peak printed after each is the
process's so far: the LU's is the larger), and the two inverses' largest difference relative to the largest entry;
``--cholesky-only``: the Cholesky construction alone, its peak its own.

Run: .venv/bin/python benchmarks/contact_dense.py 2000 4000 6000
     .venv/bin/python benchmarks/contact_dense.py --stuck-only 6000 12000 17500
     .venv/bin/python benchmarks/contact_dense.py --cholesky-only 17500
"""

import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp


def node_rows(n_w: int, rng) -> sp.csr_matrix:
    """(n_w, n_w) contact rows of one body as node-to-node pairs make them: each pair's normal and tangents (a
    random rotation) on the three dofs of its node, the nodes in random order among the body's Schur dofs."""
    n_c = n_w // 3
    frames = np.linalg.qr(rng.standard_normal((n_c, 3, 3)))[0]                 # (n_c, 3, 3) orthonormal
    nodes = rng.permutation(n_c)
    rows = np.repeat(np.arange(n_w), 3)
    cols = (3 * nodes[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1).ravel()
    return sp.csr_matrix((frames.ravel(), (rows, cols)), shape=(n_w, n_w))


def one(n_w: int) -> None:
    from frictionid.fem.condense import _add_products
    from frictionid.fem.updated_jacobian import StuckInverse
    rng = np.random.default_rng(0)
    s = n_w                                       # one body's contact dofs (the other body's block: the same)
    seconds = {"solves": [0.0, 0.0], "inverse": [0.0, 0.0]}
    out, got = np.zeros((n_w, n_w)), np.zeros((n_w, n_w))
    for _ in range(2):                            # bolt side, nut side
        L = np.asfortranarray(np.tril(rng.standard_normal((s, s))) + s * np.eye(s))
        T = node_rows(n_w, rng)
        cpu, wall = time.process_time(), time.perf_counter()
        Z = la.solve_triangular(L, T.T.toarray(), lower=True, check_finite=False)
        out += Z.T @ Z
        del Z
        seconds["solves"][0] += time.process_time() - cpu
        seconds["solves"][1] += time.perf_counter() - wall
        cpu, wall = time.process_time(), time.perf_counter()
        _add_products(got, T, L, True, n_w)      # the product's kernel (fem/condense.py)
        seconds["inverse"][0] += time.process_time() - cpu
        seconds["inverse"][1] += time.perf_counter() - wall
        del L
    difference = np.abs(got - out).max() / np.abs(out).max()
    del got
    W = 0.5 * (out + out.T) / n_w
    del out
    cpu, wall = time.process_time(), time.perf_counter()
    stuck = StuckInverse.build(W, np.zeros((0, n_w)), 1.0 / np.mean(np.diag(W)), None,
                               np.zeros(n_w // 3, dtype=bool))
    stuck_cpu, stuck_wall = time.process_time() - cpu, time.perf_counter() - wall
    assert stuck is not None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    (old_cpu, old_wall), (new_cpu, new_wall) = seconds["solves"], seconds["inverse"]
    print(f"n_w {n_w:6d} (n_c {n_w // 3:5d}): dense condensation by triangular solves {old_cpu:7.1f} s CPU "
          f"({old_wall:7.1f} s wall), by S^-1 {new_cpu:7.1f} s CPU ({new_wall:7.1f} s wall), largest difference "
          f"{difference:.1e} of the largest entry; stuck inverse {stuck_cpu:7.1f} s CPU ({stuck_wall:7.1f} s wall), "
          f"peak {peak:5.2f} GB = {peak * 2**30 / (8.0 * n_w ** 2):.1f} n_w^2 doubles", flush=True)


def stuck_only(n_w: int, names=("lu", "auto")) -> None:
    """Time the stuck inverse by LU and from the Cholesky factor (``names``) on the half-space interface's W."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from halfspace import compliance, lattice

    from frictionid.fem import updated_jacobian
    from frictionid.fem.threads import one_blas_thread
    W = compliance(lattice(n_w // 3, 0.05), 0.05)
    n_w = len(W)
    r = 1.0 / np.mean(np.diag(W))
    inverses = {}
    for name, flops in ((name, {"lu": 8.0 / 3.0, "auto": 1.0}[name]) for name in names):
        updated_jacobian.STUCK = name
        cpu, wall = time.process_time(), time.perf_counter()
        with one_blas_thread():
            stuck = updated_jacobian.StuckInverse.build(W, np.zeros((0, n_w)), r, None, np.zeros(n_w // 3, dtype=bool))
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
        print(f"n_w {n_w:6d}: stuck inverse by {name:4s} {cpu:7.1f} s CPU ({wall:7.1f} s wall, one BLAS thread; "
              f"{flops * n_w ** 3 / cpu / 1e9:5.1f} GFlop/s at {flops:.2f} n^3 flops), peak so far {peak:5.2f} GB = "
              f"{peak * 2**30 / (8.0 * n_w ** 2):.1f} n_w^2 doubles", flush=True)
        inverses[name] = stuck.A[:2000, :].copy() if name == "lu" else stuck.A[:2000, :]
        del stuck
    if len(inverses) < 2:
        return
    difference = np.abs(inverses["lu"] - inverses["auto"]).max() / np.abs(inverses["lu"]).max()
    print(f"n_w {n_w:6d}: largest difference of the inverses' first 2000 rows / largest entry {difference:.1e}",
          flush=True)


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--one":
        one(int(sys.argv[2]))
    elif len(sys.argv) > 2 and sys.argv[1] == "--one-stuck":
        stuck_only(int(sys.argv[2]), sys.argv[3].split(","))
    elif len(sys.argv) > 1 and sys.argv[1] in ("--stuck-only", "--cholesky-only"):
        for n in sys.argv[2:]:
            subprocess.run([sys.executable, __file__, "--one-stuck", n,
                            "auto" if sys.argv[1] == "--cholesky-only" else "lu,auto"], check=True)
    else:
        for n in sys.argv[1:] or ("2000", "4000", "6000"):
            subprocess.run([sys.executable, __file__, "--one", n], check=True)
