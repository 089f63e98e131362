"""CPU time per right-hand side of a CHOLMOD solve (kvxopt) with 1, 16 and 256 right-hand sides at once, on the
3-D block's stiffness (standard hexahedra, shifted by 1e-3 of its largest entry to make it definite), factorised
in a fill-reducing order, and 256 unit columns by the sparse solve (what the condensation solves for: the columns of
B^T). Block solves pay only if the time per right-hand side falls with their number.

Run: .venv/bin/python benchmarks/cholmod_rhs.py [mesh_size]   (default 0.9 mm: 35,340 dofs)
"""
import sys
import time

import numpy as np
import scipy.sparse as sp

from frictionid.builders.block import block_model
from frictionid.fem import cholesky
from frictionid.fem.assembly import stiffness
from frictionid.fem.space import Space


def main(mesh_size: float):
    model = block_model(mesh_size=mesh_size, element="standard")
    space = Space.build(model.mesh, model.kind, model.element)
    K = stiffness(space, model).tocsc()
    n = K.shape[0]
    K = K + 1e-3 * abs(K).max() * sp.identity(n, format="csc")
    factor = cholesky.Cholesky(K, np.zeros(0, int), np.arange(n) // 3)
    for k in (1, 16, 256):
        b = np.random.default_rng(0).normal(size=(n, k))
        start = time.process_time()
        factor.solve(b)
        cpu = time.process_time() - start
        print(f"{n:,} dofs, {k} right-hand sides: {cpu:.3f} s CPU, {1000 * cpu / k:.2f} ms per right-hand side",
              flush=True)
    unit = sp.csc_matrix((np.ones(256), (np.arange(0, n, n // 256)[:256], np.arange(256))), shape=(n, 256))
    start = time.process_time()
    sparse = factor.solve_sparse(unit)
    cpu = time.process_time() - start
    error = np.abs(sparse - factor.solve(unit.toarray())).max() / np.abs(sparse).max()
    print(f"{n:,} dofs, 256 unit right-hand sides by the sparse solve: {cpu:.3f} s CPU, {1000 * cpu / 256:.2f} ms per "
          f"right-hand side (dense solve's answer to {error:.0e})")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.9)
