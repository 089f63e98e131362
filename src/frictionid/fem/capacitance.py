"""Factorisations of the capacitance matrix of the contact Jacobian's corrections (fem/updated_jacobian.py).

For a Jacobian J whose rows K differ from J0's, the Woodbury correction solves with C = R A[:, K] (k x k; R the
rows K of J, A = J0^-1). Between Newton steps of a partial-slip increment a few pairs change state, so the new
C differs from an earlier, factorised one C1 (rows K1) in a few rows and columns. Over U = K u K1 both are
capacitance matrices of J and J1 (a row of U outside K is J0's own row: its capacitance row is the identity row,
its right-hand side zero), and over U

    C1_U = [[C1, X], [0, I]]     (blocks: K1, U \\ K1;  X = R1 A[:, U \\ K1])

is factorised with C1. C_U differs from C1_U in the rows D where J's rows differ from J1's (added, dropped and
changed rows): C_U = C1_U + E_D Delta, Delta = C_U[D] - C1_U[D] (d x u), and by the Woodbury identity once more

    C_U^-1 v = w - G S^-1 Delta w,   w = C1_U^-1 v,   G = C1_U^-1 E_D,   S = I_d + Delta G   (d x d),

so a new state costs d + |U \\ K1| solves with C1's factors instead of a factorisation of order k^3.

A fresh factorisation of :data:`SINGLE_MIN_ROWS` rows or more is made in single precision (LAPACK sgetrf: half the
time and half the memory of dgetrf) and each solve with it refined against C in double until its backward error
is that of a double LU solve (LAPACK dsgesv's idea): the solution is C's in double precision; where C is too
ill-conditioned for single precision, or the refinement stalls, C is factorised in double.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.linalg as la

from .threads import large_kernel

#: how fresh factorisations are made: "mixed" (single precision from SINGLE_MIN_ROWS rows, refined; module
#: docstring) or "double" (always double: the previous path, kept for the equality tests and benchmarks)
PRECISION = "mixed"
#: fresh factorisations of at least this many rows are made in single precision where PRECISION is "mixed"
SINGLE_MIN_ROWS = 500
#: a single-precision factorisation whose reciprocal condition estimate is below this is made in double instead
#: (the refinement contracts by about cond(C) x 6e-8 per step)
SINGLE_RCOND_MIN = 1e-5
#: refinement steps of a solve with a single-precision factorisation before C is factorised in double
MAX_REFINE = 8
#: a refined solve ends where |C x - v| <= REFINE_RTOL (|C| |x| + |v|) per column (maximum norms): the backward
#: error of a double LU solve of these sizes or below
REFINE_RTOL = 1e-13


def _norm(matrix: np.ndarray) -> float:
    """1-norm of a matrix."""
    return np.abs(matrix).sum(axis=0).max(initial=0.0)


#: rows per block where the maximum row sum of a large matrix is taken (no k x k temporary)
_BLOCK = 1024


def _row_norm(matrix: np.ndarray) -> float:
    """Maximum row sum of |matrix| (its infinity norm), block by block of rows."""
    return max((np.abs(matrix[start:start + _BLOCK]).sum(axis=1).max() for start in range(0, len(matrix), _BLOCK)),
               default=0.0)


def _lu(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(LU, pivots) of a square matrix by LAPACK directly (no wrapper cost per call; ``matrix`` is not
    overwritten); NaN factors where it is exactly singular."""
    lu, pivots, info = la.lapack.dgetrf(matrix)
    if info > 0:
        lu[:] = np.nan
    return lu, pivots


def _rcond(lu: np.ndarray, norm: float) -> float:
    gecon = la.lapack.sgecon if lu.dtype == np.float32 else la.lapack.dgecon
    return gecon(lu, norm, norm="1")[0] if np.all(np.isfinite(lu)) else 0.0


def _single_lu(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """(LU, pivots, transposed) of a square matrix in single precision, None where it is singular or too
    ill-conditioned there (:data:`SINGLE_RCOND_MIN`). A C-ordered matrix is factorised as its transpose (LAPACK's
    column order without a transposing copy: 0.03 s against 0.22 s at 6,300 rows)."""
    transposed = matrix.flags.c_contiguous
    lu, pivots, info = la.lapack.sgetrf(np.asfortranarray(matrix.T if transposed else matrix, dtype=np.float32),
                                        overwrite_a=1)
    norm = _row_norm(matrix) if transposed else _norm(matrix)                 # 1-norm of what was factorised
    if info != 0 or not _rcond(lu, norm) >= SINGLE_RCOND_MIN:
        return None
    return lu, pivots, transposed


def _converged(residual: np.ndarray, x: np.ndarray, v: np.ndarray, norm_C: float, rtol: float) -> bool:
    """|residual| <= rtol (norm_C |x| + |v|) in each column (maximum norms)."""
    scale = norm_C * np.abs(x).max(axis=0, initial=0.0) + np.abs(v).max(axis=0, initial=0.0)
    return bool(np.all(np.abs(residual).max(axis=0, initial=0.0) <= rtol * scale))


@dataclass(frozen=True)
class Fresh:
    """An LU factorisation of C made for its rows K (pair rows ``P_K``, ``Q_K`` of J), in single precision from
    :data:`SINGLE_MIN_ROWS` rows (module docstring); ``C`` kept for updates, for the refinement and for its norm,
    which a condition estimate needs (most factorisations are never asked for one)."""

    K: np.ndarray
    P_K: np.ndarray
    Q_K: np.ndarray
    C: np.ndarray
    lu: np.ndarray
    pivots: np.ndarray
    #: the factors are C^T's (single precision, :func:`_single_lu`)
    transposed: bool = False

    @classmethod
    def factorise(cls, K, P_K, Q_K, C: np.ndarray) -> "Fresh":
        with large_kernel(len(C)):                              # BLAS threads for a large one (fem/threads.py)
            if PRECISION == "mixed" and len(C) >= SINGLE_MIN_ROWS:
                single = _single_lu(C)
                if single is not None:
                    return cls(K, P_K, Q_K, C, *single)
            return cls(K, P_K, Q_K, C, *_lu(C))

    @property
    def single(self) -> bool:
        """Whether the factors are single precision (solves refined)."""
        return self.lu.dtype == np.float32

    @property
    def singular(self) -> bool:
        return not np.isfinite(self.lu[0, 0])

    def precondition(self, v: np.ndarray) -> np.ndarray:
        """C^-1 v from the factors as they are, unrefined (in single precision for single factors, v scaled to
        its largest entry per column first): an iterated solve's preconditioner."""
        if not self.single:
            return la.lapack.dgetrs(self.lu, self.pivots, v)[0]
        scale = np.abs(v).max(axis=0, initial=0.0)
        scale = np.where(scale > 0.0, scale, 1.0)
        x = la.lapack.sgetrs(self.lu, self.pivots, (v / scale).astype(np.float32), trans=int(self.transposed))[0]
        return x * scale

    def solve(self, v: np.ndarray) -> np.ndarray:
        """C^-1 v, v (k,) or (k, n_rhs); from single factors refined to :data:`REFINE_RTOL` against C, else by
        C's factorisation in double (made then and kept)."""
        if not self.single:
            return la.lapack.dgetrs(self.lu, self.pivots, v)[0]
        if "_double" not in self.__dict__:
            x = self.precondition(v)
            for _ in range(MAX_REFINE):
                residual = v - self.C @ x
                if _converged(residual, x, v, self._norm_rows, REFINE_RTOL):
                    return x
                x += self.precondition(residual)
        return self.double().solve(v)

    def double(self) -> "Fresh":
        """C factorised in double precision (self where it is), made when first asked for and kept."""
        if not self.single:
            return self
        if "_double" not in self.__dict__:
            with large_kernel(len(self.C)):
                self.__dict__["_double"] = Fresh(self.K, self.P_K, self.Q_K, self.C, *_lu(self.C))
        return self.__dict__["_double"]

    def rcond(self) -> float:
        """Reciprocal condition number of C (1-norm estimate; infinity norm where the factors are C^T's)."""
        return self._rcond

    @cached_property
    def _rcond(self) -> float:
        return _rcond(self.lu, self._norm_rows if self.transposed else _norm(self.C))      # C^T's 1-norm

    @cached_property
    def _norm_rows(self) -> float:
        """Maximum row sum of |C| (the refinement's scale, as :func:`gmres`'s)."""
        return _row_norm(self.C)


@dataclass(frozen=True)
class Updated:
    """C over U = K u K1 as an update of a :class:`Fresh` base (K1) on the rows D (module docstring)."""

    K: np.ndarray          # (u,) U, sorted
    P_K: np.ndarray        # (u, dim) J's pair rows on U (J0's where U is outside J's K)
    Q_K: np.ndarray
    base: Fresh
    in_base: np.ndarray    # (k1,) positions of the base's rows in U
    new: np.ndarray        # (u - k1,) positions of U \ K1
    X: np.ndarray          # (k1, u - k1)
    D: np.ndarray          # (d,) positions in U of the rows that differ from the base's Jacobian
    G: np.ndarray          # (u, d)
    delta: np.ndarray      # (d, u)
    lu: np.ndarray         # LU of S (d x d)
    pivots: np.ndarray
    norm: float

    @classmethod
    def build(cls, base: Fresh, U, P_U, Q_U, D: np.ndarray, C_D: np.ndarray, X: np.ndarray) -> "Updated":
        """The update from ``base`` to rows U with J's rows ``P_U``, ``Q_U``; ``D`` the positions in U where J's
        rows differ from the base's Jacobian's, ``C_D`` (d, u) = C_U[D], ``X`` = R1 A[:, U \\ K1]."""
        in_base = np.searchsorted(U, base.K)
        outside = np.ones(len(U), dtype=bool)
        outside[in_base] = False
        new = np.flatnonzero(outside)                              # U \ K1
        old = np.full(len(U), -1)
        old[in_base] = np.arange(len(in_base))
        base_rows = np.zeros_like(C_D)                          # C1_U[D]: [C1 row, X row] or an identity row
        from_base = old[D] >= 0
        base_rows[np.ix_(from_base, in_base)] = base.C[old[D[from_base]]]
        base_rows[np.ix_(from_base, new)] = X[old[D[from_base]]]
        base_rows[np.flatnonzero(~from_base), D[~from_base]] = 1.0
        delta = C_D - base_rows
        E = np.zeros((len(U), len(D)))
        E[D, np.arange(len(D))] = 1.0
        partial = cls(U, P_U, Q_U, base, in_base, new, X, D, None, delta, None, None, 0.0)
        G = partial._base_solve(E)
        S = np.eye(len(D)) + delta @ G
        return cls(U, P_U, Q_U, base, in_base, new, X, D, G, delta, *_lu(S), _norm(S))

    @property
    def singular(self) -> bool:
        return self.base.singular or not np.isfinite(self.lu[0, 0])

    def _base_solve(self, v: np.ndarray) -> np.ndarray:
        """C1_U^-1 v."""
        w = np.empty_like(v)
        w[self.new] = v[self.new]
        w[self.in_base] = self.base.solve(v[self.in_base] - self.X @ v[self.new])
        return w

    def solve(self, v: np.ndarray) -> np.ndarray:
        """C_U^-1 v, v (u,) or (u, n_rhs), refined once with C_U's residual: the nested corrections lose a few
        digits that one refinement (products of order k^2) wins back."""
        u = self._solve_once(v)
        return u + self._solve_once(v - self._times(u))

    def _solve_once(self, v: np.ndarray) -> np.ndarray:
        w = self._base_solve(v)
        return w - self.G @ la.lapack.dgetrs(self.lu, self.pivots, self.delta @ w)[0]

    def _times(self, u: np.ndarray) -> np.ndarray:
        """C_U u = C1_U u + E_D Delta u."""
        out = u.copy()
        out[self.in_base] = self.base.C @ u[self.in_base] + self.X @ u[self.new]
        out[self.D] += self.delta @ u
        return out

    def rcond(self) -> float:
        """An estimate of C_U's reciprocal condition number: the product of the base's and S's (C_U is
        singular where C1 or S is: det C_U = det C1 det S)."""
        return self.base.rcond() * _rcond(self.lu, self.norm)


#: an iterated solve (:class:`Iterated`) takes at most this many Krylov iterations per right-hand side, then C is
#: factorised afresh (an iteration costs two products of order k^2, a factorisation 2 k^3 / 3 flops)
MAX_KRYLOV = 30
#: an iterated solve ends where |C x - v| <= KRYLOV_RTOL (|C| |x| + |v|) (maximum norms), the backward error of
#: a direct LU solve of these sizes or below
KRYLOV_RTOL = 1e-13


def gmres(C: np.ndarray, v: np.ndarray, precondition, rtol: float = KRYLOV_RTOL,
          max_iterations: int = MAX_KRYLOV) -> tuple[np.ndarray | None, int | np.ndarray]:
    """(x, iterations) with C x = v by GMRES right-preconditioned by ``precondition`` (an approximate C^-1 of a
    (k, n) block), restarted where the residual estimate is met and the true residual is not; x None where
    |C x - v| did not reach ``rtol`` (|C| |x| + |v|) (maximum norms) in ``max_iterations``. v (k,), or (k, n): each
    column in its own Krylov space (the iterations of a column alone, to round-off), the products with C and the
    preconditioner made for the columns still iterating at once (one pass over C and the factors for all: the
    sensitivities' n_z right-hand sides); iterations then per column, x None where any column did not converge."""
    V = v.reshape(len(v), -1)
    norm_C = np.abs(C).sum(axis=1).max(initial=0.0)
    x = precondition(V)
    used = np.zeros(V.shape[1], dtype=int)
    while True:
        r = V - C @ x
        scale = rtol * (norm_C * np.abs(x).max(axis=0, initial=0.0) + np.abs(V).max(axis=0, initial=0.0))
        active = np.flatnonzero(np.abs(r).max(axis=0, initial=0.0) > scale)
        if not len(active):
            return (x, used) if v.ndim > 1 else (x[:, 0], int(used[0]))
        if np.any(used[active] >= max_iterations) or not np.all(np.isfinite(r[:, active])):
            return None, used if v.ndim > 1 else int(used[0])
        x[:, active] += precondition(_arnoldi(C, r[:, active], precondition, scale[active], used, active,
                                              max_iterations))


def _arnoldi(C, r, precondition, scale, used, active, max_iterations) -> np.ndarray:
    """One GMRES cycle from residuals ``r`` (k, n_a), column by column as in :func:`gmres` (modified Gram-Schmidt,
    Givens rotations), the products for the columns still iterating made together: the combination of each
    column's basis that minimises its residual estimate (before the preconditioner). ``used`` (iterations per
    column of the whole block) is counted up for the ``active`` columns."""
    n_a = r.shape[1]
    size = max_iterations - int(used[active].min())
    norms = np.linalg.norm(r, axis=0)
    basis = [r / norms]
    H, g = np.zeros((n_a, size + 1, size)), np.zeros((n_a, size + 1))
    g[:, 0] = norms
    c, s = np.zeros((n_a, size)), np.zeros((n_a, size))
    steps = np.zeros(n_a, dtype=int)
    live = np.flatnonzero(used[active] < max_iterations)
    for j in range(size):
        w = C @ precondition(basis[j][:, live])
        for i, q in enumerate(basis):                                     # modified Gram-Schmidt
            H[live, i, j] = np.einsum("kc,kc->c", q[:, live], w)
            w -= H[live, i, j] * q[:, live]
        below = np.linalg.norm(w, axis=0)
        for i in range(j):                                                # the earlier rotations on column j
            upper, lower = H[live, i, j], H[live, i + 1, j]
            H[live, i, j], H[live, i + 1, j] = c[live, i] * upper + s[live, i] * lower, \
                -s[live, i] * upper + c[live, i] * lower
        h = np.hypot(H[live, j, j], below)
        nonzero = h > 0.0
        c[live, j] = np.where(nonzero, H[live, j, j] / np.where(nonzero, h, 1.0), 1.0)
        s[live, j] = np.where(nonzero, below / np.where(nonzero, h, 1.0), 0.0)
        H[live, j, j] = c[live, j] * H[live, j, j] + s[live, j] * below
        g[live, j + 1], g[live, j] = -s[live, j] * g[live, j], c[live, j] * g[live, j]
        used[active[live]] += 1
        steps[live] += 1
        stop = (np.abs(g[live, j + 1]) <= 0.5 * scale[live]) | (below == 0.0) | \
            (used[active[live]] >= max_iterations)
        following = np.zeros_like(r)
        following[:, live] = w / np.where(below > 0.0, below, 1.0)
        basis.append(following)
        live = live[~stop]
        if not len(live):
            break
    out = np.zeros_like(r)
    for a in range(n_a):
        k = steps[a]
        y = la.solve_triangular(H[a, :k, :k], g[a, :k], check_finite=False)
        out[:, a] = np.column_stack([q[:, a] for q in basis[:k]]) @ y
    return out


class Iterated:
    """C of the same rows K as a :class:`Fresh` base with other values (in 3-D the slip directions of the
    slipping pairs turn at each Newton step, so every one of their rows changes a little): solved by
    :func:`gmres` preconditioned by the base's LU factors, factorised afresh (``fallback``) where it does not
    converge in :data:`MAX_KRYLOV` iterations; ``fell_back`` says GMRES did not converge (a factorisation made for
    :meth:`rcond` and then used by the solves does not set it).
    ``counted(n)`` is told each right-hand side's iterations. ``context``: what the owner needs to make the
    factorisation its base (plain data: no reference back to the owner, whose arrays a reference cycle would keep
    until the garbage collector runs)."""

    def __init__(self, K, P_K, Q_K, C: np.ndarray, base: Fresh, counted=None, context=None):
        self.K, self.P_K, self.Q_K, self.C, self.base = K, P_K, Q_K, C, base
        self._counted, self.context = counted, context
        self.fell_back = False
        self.fallback: Fresh | None = None
        self.iterations: list[int] = []

    @property
    def singular(self) -> bool:
        return self.fallback is not None and self.fallback.singular

    def solve(self, v: np.ndarray) -> np.ndarray:
        """C^-1 v, v (k,) or (k, n_rhs)."""
        if self.fallback is None:
            x, n = gmres(self.C, v.reshape(len(v), -1), self.base.precondition)
            for each in n:
                self.iterations.append(int(each))
                if self._counted is not None:
                    self._counted(int(each))
            if x is not None:
                return x.reshape(v.shape)
            self.fell_back = True
        return self.fresh().solve(v)

    def fresh(self) -> Fresh:
        """C's own LU factorisation, made when first asked for."""
        if self.fallback is None:
            self.fallback = Fresh.factorise(self.K, self.P_K, self.Q_K, self.C)
        return self.fallback

    def rcond(self) -> float:
        """C's reciprocal condition number (from its own factorisation: a predictor asks for it)."""
        return self.fresh().rcond()
