"""Sparse Cholesky factorisation with chosen dofs ordered last (CHOLMOD from the kvxopt wheel, METIS ordering from
pymetis): the factor's trailing block is the Cholesky factor of the Schur complement onto those dofs.

With the dofs s ordered last, P K P^T = L L^T and L = [[L_ii, 0], [L_si, L_ss]] give

    S = K_ss - K_si K_ii^-1 K_is = L_ss L_ss^T,        (K^-1)_ss = S^-1 = L_ss^-T L_ss^-1,

so every operator T K^-1 B^T whose rows T and B live on s is T_s S^-1 B_s^T: S^-1 from L_ss (LAPACK's potri,
:func:`inverse`) and products with the sparse rows, instead of one sparse solve per column. The supernodal
factorisation runs in BLAS.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from .threads import one_blas_thread

log = logging.getLogger(__name__)

#: columns per block where a symmetric matrix's upper triangle is copied to its lower one
_BLOCK = 1024


def symmetrise(A: np.ndarray) -> None:
    """Copy the upper triangle of a Fortran-ordered square A to its lower triangle, in place, block by block (no
    n x n temporary)."""
    n = len(A)
    for start in range(0, n, _BLOCK):
        end = min(start + _BLOCK, n)
        A[start:end, start:end] = np.triu(A[start:end, start:end]) + np.triu(A[start:end, start:end], 1).T
        A[end:, start:end] = A[start:end, end:].T


def inverse(L: np.ndarray, overwrite: bool = False) -> np.ndarray:
    """S^-1 (n, n), Fortran order, symmetric, from the lower Cholesky factor L of S = L L^T (LAPACK's potri:
    2 n^3 / 3 flops; ``overwrite``: in L's memory where L is Fortran-ordered). Products of S^-1 with sparse rows
    then cost their nonzeros times n, where the triangular solves L^-1 T^T and the product of their results cost
    n^2 |T| + n |T|^2 flops."""
    L = np.asarray(L)
    if not L.size:                      # LAPACK's potri refuses n = 0 (and prints so)
        return np.zeros(L.shape, order="F")
    lower = L.flags.f_contiguous
    # a C-ordered L is, read in LAPACK's column order, the upper factor U = L^T (S = U^T U): no transposing copy.
    # One BLAS thread: with the second core busy, OpenBLAS's threaded potri (trtri, lauum) took 6 to 35 times one
    # thread's CPU time at 2,400 rows and 2.1 to 3.6 times its wall time at 8,000 (docs/solver.md)
    with one_blas_thread():
        inv, info = la.lapack.dpotri(L if lower else L.T, lower=int(lower), overwrite_c=int(overwrite))
    if info != 0:
        raise np.linalg.LinAlgError(f"potri: the factor is singular (info {info})")
    symmetrise(inv.T if lower else inv)
    return inv


def available() -> bool:
    """Whether CHOLMOD (kvxopt) can be imported."""
    try:
        from kvxopt import cholmod  # noqa: F401
    except ImportError:
        return False
    return True


@contextmanager
def _options(**values):
    """CHOLMOD's options for the block (kvxopt keeps them in a module-wide dict)."""
    from kvxopt import cholmod
    saved = dict(cholmod.options)
    cholmod.options.update(values)
    try:
        yield cholmod
    finally:
        cholmod.options.clear()
        cholmod.options.update(saved)


def _kvxopt_lower(K: sp.spmatrix):
    """The lower triangle of K as a kvxopt spmatrix (what CHOLMOD reads of a symmetric matrix)."""
    from kvxopt import matrix, spmatrix
    lower = sp.tril(K).tocoo()
    return spmatrix(matrix(lower.data.astype(float)), matrix(lower.row.astype(np.int64)),
                    matrix(lower.col.astype(np.int64)), lower.shape)


def fill_reducing_order(K: sp.spmatrix, nodes: np.ndarray) -> np.ndarray:
    """Fill-reducing order of the rows of K: METIS nested dissection of the graph of ``nodes`` (the node of each
    row; the rows of one node stay together), or AMD on the rows where pymetis is not installed."""
    n = K.shape[0]
    if n == 0:
        return np.zeros(0, int)
    try:
        import pymetis
    except ImportError:
        from kvxopt import amd
        log.info("pymetis is not installed: AMD ordering (more fill in 3-D than nested dissection)")
        return np.asarray(amd.order(_kvxopt_lower(K)), dtype=int).ravel()
    numbers, node_of_row = np.unique(nodes, return_inverse=True)
    to_node = sp.csr_matrix((np.ones(n), (node_of_row, np.arange(n))), shape=(len(numbers), n))
    K = sp.csr_matrix(K)
    pattern = sp.csr_matrix((np.ones(K.nnz), K.indices, K.indptr), shape=K.shape)   # K's index arrays, shared
    graph = (to_node @ pattern @ to_node.T).tocsr()
    graph.setdiag(0)
    graph.eliminate_zeros()
    node_order = np.asarray(pymetis.nested_dissection(
        pymetis.CSRAdjacency(graph.indptr.astype(np.int64), graph.indices.astype(np.int64)))[0], dtype=int)
    rank = np.empty(len(numbers), int)
    rank[node_order] = np.arange(len(numbers))
    return np.lexsort((np.arange(n), rank[node_of_row]))


class Cholesky:
    """P K P^T = L L^T of a symmetric positive definite K with the rows ``last`` ordered last, the others in a
    fill-reducing order (:func:`fill_reducing_order`).

    Raises ``ArithmeticError`` if K is not positive definite. Pickled without its factor, which is computed
    again at the first solve after unpickling.
    """

    def __init__(self, K: sp.spmatrix, last: np.ndarray, nodes: np.ndarray):
        n = K.shape[0]
        self.matrix = sp.csc_matrix(K)
        self.last = np.asarray(last, dtype=int)
        first = np.setdiff1d(np.arange(n), self.last)
        order = fill_reducing_order(self.matrix[first][:, first], nodes[first])
        self.perm = np.concatenate([first[order], self.last])
        self.factor = self._factor()

    def _factor(self):
        from kvxopt import matrix
        # nmethods 1: CHOLMOD takes the given order (by default it also tries AMD and keeps the better one);
        # postorder off: the etree postorder would move rows of `last` among the others
        with _options(nmethods=1, postorder=False, supernodal=2) as cholmod:
            A = _kvxopt_lower(self.matrix)
            factor = cholmod.symbolic(A, p=matrix(self.perm.astype(np.int64)))
            cholmod.numeric(A, factor)
        try:
            cholmod.diag(factor)       # numeric leaves a factor that is not positive definite unfinished, silently
        except ValueError:
            raise ArithmeticError("the matrix is not positive definite") from None
        return factor

    def __getstate__(self):
        return {**self.__dict__, "factor": None}

    def solve(self, b: np.ndarray) -> np.ndarray:
        """K^-1 b for b (n,) or (n, k)."""
        from kvxopt import cholmod, matrix
        if self.factor is None:
            self.factor = self._factor()
        x = matrix(np.asfortranarray(np.reshape(b, (b.shape[0], -1)), dtype=float))
        cholmod.solve(self.factor, x)
        return np.array(x).reshape(b.shape)

    def solve_sparse(self, b: sp.spmatrix) -> np.ndarray:
        """K^-1 b (n, k) dense for a sparse b (n, k): CHOLMOD's sparse solve, half the time per column of
        :meth:`solve` on unit columns (benchmarks/cholmod_rhs.py)."""
        from kvxopt import cholmod, matrix, spmatrix
        if self.factor is None:
            self.factor = self._factor()
        coo = sp.coo_matrix(b)
        rhs = spmatrix(matrix(coo.data.astype(float)), matrix(coo.row.astype(np.int64)),
                       matrix(coo.col.astype(np.int64)), coo.shape)
        return np.array(matrix(cholmod.spsolve(self.factor, rhs)))

    def trailing(self, blocks: list[np.ndarray] | None = None) -> Iterator[np.ndarray]:
        """The diagonal blocks L_ss[b][:, b] (dense, lower triangular) for each index array b into ``last``
        (default: one block, all of ``last``): L_ss L_ss^T is the Schur complement of K onto ``last`` (in the
        order of ``last``). Where K has no coupling between the blocks (separate bodies) L_ss has none either,
        so each block is the factor of its own Schur complement and the dense memory is the largest block's
        square instead of |last|^2.

        kvxopt's getfactor turns the factor into a simplicial one in place, which its solve refuses: the factor
        is dropped here and computed again at the next :meth:`solve`."""
        from kvxopt import cholmod, matrix
        n, m = self.matrix.shape[0], len(self.last)
        blocks = [np.arange(m)] if blocks is None else blocks
        if self.factor is None:
            self.factor = self._factor()
        L = cholmod.getfactor(self.factor)
        self.factor = None
        log.info("Cholesky factor: %d rows, %d entries; the Schur complement onto %d of them in %d block(s)",
                 n, len(L), m, len(blocks))
        for block in blocks:
            rows = matrix(np.asarray(n - m + block, dtype=np.int64))
            sparse = L[rows, rows]
            dense = matrix(sparse)
            del sparse
            # a view of kvxopt's column-major buffer, not a copy
            yield np.asarray(dense)
