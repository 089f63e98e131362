"""The replaced rows of a contact Jacobian (fem/updated_jacobian.py) read from a stuck inverse A: the products
R z and R A[:, columns] and the index data they need, made once per row set."""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .updated_jacobian import StuckInverse


def gather(A: np.ndarray, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """A[rows][:, columns] of a Fortran-ordered A, gathered from its (C-ordered) transpose, the smaller index set
    first (a few columns of an update's X, a few rows of its C[D]): numpy's take along either axis of a
    Fortran-ordered array is several times slower."""
    At = A.T
    if len(columns) <= len(rows):
        return At.take(columns, axis=0).take(rows, axis=1).T
    return At.take(rows, axis=1).take(columns, axis=0).T


class ReplacedRows:
    """Where the products of a set of replaced rows K (sorted) of J read from a stuck inverse: the rows' pairs,
    their positions in W_open, the columns of C = R A[:, K] their Q terms add to, and (made when a capacitance
    matrix is first formed for K, kept for the next: in 3-D the slip directions change each Newton step while the
    slipping pairs stay) the block A[pairs' rows, K]."""

    def __init__(self, stuck: StuckInverse, K: np.ndarray, dim: int):
        self.stuck, self.K, self.dim = stuck, K, dim
        self.lam_rows = (K // dim)[:, None] * dim + np.arange(dim)               # (k, dim)
        self.closed = stuck.open_rows[self.lam_rows[:, 0]] < 0
        self.held = np.flatnonzero(~self.closed)
        self.held_rows = stuck.open_rows[self.lam_rows[self.held]]
        closed = np.flatnonzero(self.closed)
        self.closed_rows = slice(None) if len(closed) == len(K) else closed
        self.closed_lam = self.lam_rows[self.closed_rows]
        self._add_K = None
        self._block: np.ndarray | None = None

    @cached_property
    def pairs(self) -> tuple[np.ndarray, np.ndarray | None]:
        """(A's rows of each pair of K once, the position of each row of K among those rows: None where K holds
        them all); what a product with columns of A needs, made when first asked for (most row sets multiply
        vectors only)."""
        dim, pair = self.dim, self.K // self.dim
        first = np.r_[True, pair[1:] != pair[:-1]]
        pair_rows = (pair[first][:, None] * dim + np.arange(dim)).ravel()
        position = (np.cumsum(first) - 1) * dim + self.K % dim                   # (k,) row -> its pair row
        return pair_rows, None if len(position) == len(pair_rows) else position

    def _adds(self, columns):
        """(rows, components, columns) where the rows' Q / r terms fall in R A[:, columns]."""
        position = np.full(self.stuck.A.shape[0], -1)
        position[columns] = np.arange(len(columns))
        column = position[self.lam_rows]                                         # (k, dim) column or -1
        a, c = np.nonzero(self.closed[:, None] & (column >= 0))
        return a, c, column[a, c]                                                # (a, column) are distinct

    def drop_block(self) -> None:
        self._block = None

    def times(self, P_K, Q_K, z, b) -> np.ndarray:
        """R z for z = A b (n, ...)."""
        s = self.stuck
        out = np.einsum("ac,ac...->a...", P_K, z[self.lam_rows])
        out[self.closed_rows] += np.einsum("ac,ac...->a...", Q_K[self.closed_rows], b[self.closed_lam]) / s.r
        if len(self.held):
            out[self.held] += np.einsum("ac,ac...->a...", Q_K[self.held], (s.W_open @ z)[self.held_rows])
        return out

    def capacitance(self, P_K, Q_K, columns=None) -> np.ndarray:
        """R A[:, columns] (k, len(columns)); columns None: C = R A[:, K] (its block of A kept)."""
        s, dim = self.stuck, P_K.shape[1]
        pair_rows, position = self.pairs
        if columns is None:
            if self._add_K is None:
                self._add_K = self._adds(self.K)
            columns, adds = self.K, self._add_K
            if self._block is None:
                self._block = gather(s.A, pair_rows, columns).reshape(-1, dim, len(columns))
            gathered = self._block
        else:
            adds = self._adds(columns)
            gathered = gather(s.A, pair_rows, columns).reshape(-1, dim, len(columns))
        # each pair's rows at once, (pairs, dim, dim) @ (pairs, dim, columns), the rows outside K zero and dropped
        # afterwards: one batched product instead of a product per component over gathered blocks
        if position is None:
            P_pairs = P_K
        else:
            P_pairs = np.zeros((len(pair_rows), dim))
            P_pairs[position] = P_K
        out = np.matmul(P_pairs.reshape(-1, dim, dim), gathered).reshape(len(pair_rows), -1)
        if position is not None:
            out = out.take(position, axis=0)
        a, c, column = adds
        out[a, column] += Q_K[a, c] / s.r
        if len(self.held):
            out[self.held] += np.einsum("ac,ac...->a...", Q_K[self.held], s.WA_open[:, columns][self.held_rows])
        return out
