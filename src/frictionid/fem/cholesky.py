"""Sparse Cholesky factorisation with chosen dofs ordered last (CHOLMOD from the kvxopt wheel, METIS ordering from
pymetis): the factor's trailing block is the Cholesky factor of the Schur complement onto those dofs.

With the dofs s ordered last, P K P^T = L L^T and L = [[L_ii, 0], [L_si, L_ss]] give

    S = K_ss - K_si K_ii^-1 K_is = L_ss L_ss^T,        (K^-1)_ss = S^-1 = L_ss^-T L_ss^-1,

so every operator T K^-1 B^T whose rows T and B live on s is T_s S^-1 B_s^T: S^-1 from L_ss (LAPACK's potri,
:func:`inverse`) and products with the sparse rows, instead of one sparse solve per column. The supernodal
factorisation runs in BLAS. Taking L_ss out of CHOLMOD takes the whole factor out (kvxopt's getfactor); it is kept
as a :class:`SparseFactor`, so that later solves (the displacement field, the small-sliding check) need no
factorisation again.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve_triangular

from .threads import one_blas_thread

log = logging.getLogger(__name__)

#: columns per block where a symmetric matrix's upper triangle is copied to its lower one
_BLOCK = 1024
#: columns per chunk where a dense block is gathered from a SparseFactor (bounds the index temporaries)
_GATHER = 256


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


class SparseFactor:
    """L of P K P^T = L L^T (n, n) in CSC with 32-bit indices: 12 bytes per entry (kvxopt's getfactor hands out
    16). Solves by two sparse triangular solves (scipy's spsolve_triangular) with L = L1 D, L1 unit lower
    triangular and D the diagonal: at the first solve L's columns are scaled to L1 in place (before it,
    :meth:`block` reads L's numbers as CHOLMOD made them).

    ``colptr``, ``rows``, ``values``: L's compressed columns with sorted rows, the diagonal first in each column;
    ``perm``: the permutation (row i of P K P^T is row perm[i] of K).
    """

    def __init__(self, colptr: np.ndarray, rows: np.ndarray, values: np.ndarray, perm: np.ndarray):
        n = len(colptr) - 1
        if not np.array_equal(rows[colptr[:-1]], np.arange(n)):
            raise ValueError("the factor's columns do not start at their diagonal")
        self.perm = perm
        self.diagonal = values[colptr[:-1]].copy()
        index = np.int32 if colptr[-1] < np.iinfo(np.int32).max else np.int64       # 64-bit past 2^31 entries
        self.matrix = sp.csc_array((values, rows.astype(index), colptr.astype(index)), shape=(n, n))
        self.scaled = False

    @classmethod
    def taken(cls, factor, perm: np.ndarray) -> "SparseFactor":
        """The factor taken out of CHOLMOD's ``factor`` (which kvxopt's getfactor leaves symbolic only)."""
        from kvxopt import cholmod
        L = cholmod.getfactor(factor)
        colptr, rows, values = (np.asarray(a).ravel() for a in L.CCS)        # copies of L's arrays
        del L
        return cls(colptr, rows, values, perm)

    @property
    def nbytes(self) -> int:
        A = self.matrix
        return A.data.nbytes + A.indices.nbytes + A.indptr.nbytes + self.diagonal.nbytes

    def solve(self, b: np.ndarray) -> np.ndarray:
        """K^-1 b for b (n,) or (n, k): P^T L^-T L^-1 P b."""
        A = self.matrix
        if np.size(b) == 0:
            return np.zeros(np.shape(b))
        if not self.scaled:
            for start in range(0, A.shape[0], _GATHER):         # L1 = L D^-1, in place, by chunks of columns
                end = min(start + _GATHER, A.shape[0])
                cut = slice(A.indptr[start], A.indptr[end])
                A.data[cut] /= np.repeat(self.diagonal[start:end], np.diff(A.indptr[start:end + 1]))
            self.scaled = True
        d = self.diagonal if np.ndim(b) == 1 else self.diagonal[:, None]
        # L1's unit diagonal is stored: spsolve_triangular's setdiag(1) changes nothing, and with overwrite_A it
        # neither copies L1 nor scales it (L1.T is a CSR view of the same arrays)
        y = spsolve_triangular(A, np.asarray(b, dtype=float)[self.perm], lower=True, overwrite_A=True,
                               overwrite_b=True, unit_diagonal=True)
        x = spsolve_triangular(A.T, y / d**2, lower=False, overwrite_A=True, overwrite_b=True, unit_diagonal=True)
        out = np.empty_like(x)
        out[self.perm] = x
        return out

    def block(self, positions: np.ndarray) -> np.ndarray:
        """L[positions][:, positions] (len(positions) squared, Fortran order) for ascending ``positions``."""
        m, A = len(positions), self.matrix
        at = np.full(A.shape[0], -1)
        at[positions] = np.arange(m)
        out = np.zeros((m, m), order="F")
        for start in range(0, m, _GATHER):
            cols = positions[start:start + _GATHER]
            first, counts = A.indptr[cols].astype(np.int64), np.diff(A.indptr)[cols].astype(np.int64)
            entries = np.repeat(first - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())
            rows = at[A.indices[entries]]
            column = np.repeat(np.arange(start, start + len(cols)), counts)
            kept = rows >= 0
            values = A.data[entries[kept]]
            out[rows[kept], column[kept]] = values * self.diagonal[positions[column[kept]]] if self.scaled else values
        return out


class Cholesky:
    """P K P^T = L L^T of a symmetric positive definite K with the rows ``last`` ordered last, the others in a
    fill-reducing order (:func:`fill_reducing_order`).

    Raises ``ArithmeticError`` if K is not positive definite. After :meth:`trailing` the factor lives on as
    :attr:`sparse` (:class:`SparseFactor`), which the solves use. Pickled without either, the factor is computed
    again at the first solve after unpickling.
    """

    #: the factor once :meth:`trailing` took it out of CHOLMOD
    sparse: SparseFactor | None = None

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
        return {**self.__dict__, "factor": None, "sparse": None}

    def solve(self, b: np.ndarray) -> np.ndarray:
        """K^-1 b for b (n,) or (n, k)."""
        from kvxopt import cholmod, matrix
        if self.factor is None and self.sparse is not None:
            return self.sparse.solve(b)
        if self.factor is None:
            self.factor = self._factor()
        x = matrix(np.asfortranarray(np.reshape(b, (b.shape[0], -1)), dtype=float))
        cholmod.solve(self.factor, x)
        return np.array(x).reshape(b.shape)

    def solve_sparse(self, b: sp.spmatrix) -> np.ndarray:
        """K^-1 b (n, k) dense for a sparse b (n, k): CHOLMOD's sparse solve, half the time per column of
        :meth:`solve` on unit columns (benchmarks/cholmod_rhs.py)."""
        from kvxopt import cholmod, matrix, spmatrix
        if self.factor is None and self.sparse is not None:
            return self.sparse.solve(sp.csc_matrix(b).toarray())
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

        kvxopt's getfactor takes the numbers out of CHOLMOD's factor (which its solve then refuses): they are
        kept as :attr:`sparse` (12 bytes per entry; getfactor's own copy, 16 bytes per entry, is freed at once),
        which the blocks are gathered from and the solves use."""
        m = len(self.last)
        blocks = [np.arange(m)] if blocks is None else blocks
        if self.sparse is None:
            if self.factor is None:
                self.factor = self._factor()
            self.sparse = SparseFactor.taken(self.factor, self.perm)
            self.factor = None
        n = self.matrix.shape[0]
        log.info("Cholesky factor: %d rows, %d entries (%.3g GB kept); the Schur complement onto %d of them in %d "
                 "block(s)", n, self.sparse.matrix.nnz, self.sparse.nbytes / 1e9, m, len(blocks))
        for block in blocks:
            yield self.sparse.block(n - m + np.asarray(block))
