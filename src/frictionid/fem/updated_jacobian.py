"""The contact Jacobian solved by low-rank corrections of one inverse per model: that of the stuck Jacobian.

The generalised Jacobian of an increment (:mod:`frictionid.fem.contact`) has, per pair, the rows
P_i dlam_i + Q_i dw_i with dw = Wfull dx, and the floating bodies' equilibrium rows [Wa_T, 0]. With every pair
closed and stuck it is J0: rows r W_N and r E W_T + (I - E) lam_T (pairs whose gap the supports hold: open rows,
identity), which depends on the model only, so its inverse A = J0^-1 is computed once per model. Any other
Jacobian differs from J0 in the rows of open and slipping pairs only (the set K of k rows, R those rows of J), and
by the Woodbury identity for replaced rows

    J^-1 b = y - A[:, K] C^-1 (R y - b_K),   y = A b,   C = R A[:, K]   (k x k).

No product with W is needed to form C: J0 A = I gives r E W_i A = e_i - (I - E) A[lam_i], and every row
:func:`~frictionid.fem.contact.linearise` makes has Q_i = Q_i diag(1, E), so R A[:, K] = P A[lam, K] + Q e_K / r
(pairs with held gaps, whose J0 rows are identity rows: W A from a product, made once). A Newton step then costs a
product with A (n^2) and, when the replaced rows differ from the last ones, an LU factorisation of C (k^3): in 2-D
a slipping pair's rows depend on the sign of its slip direction only, so in gross slip C stays the same from
iteration to iteration and increment to increment; in partial slip, where the slip front moves by a few pairs
per Newton step, the new C is an update of the last factorised one (fem/capacitance.py: of order k^2 instead
of k^3). Each solve checks its residual with J and falls back to a fresh LU factorisation of J where the
correction lost accuracy.

Where no tangential direction is held (the projectors E all identity), J0's rows of the closed pairs are r W, so
J0 is, up to its identity rows (pairs held open) and the floating bodies' border, r W_CC with W_CC the closed
pairs' block of W, symmetric positive definite. A is then made from the Cholesky factor of r W_CC and its inverse
(LAPACK's potrf and potri: n^3 / 3 + 2 n^3 / 3 flops) and the border's Schur complement (m x m), instead of an
LU factorisation of J0 and n solves with it (2 n^3 / 3 + 2 n^3), in one n x n array where nothing is held open
and no body floats (the LU path holds two).
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from .capacitance import Fresh, Iterated, Updated
from .cholesky import symmetrise
from .contact import jacobian
from .replaced_rows import ReplacedRows, gather
from .threads import cholesky_threads, large_kernel

log = logging.getLogger(__name__)
#: columns per block of the 1-norm of an n x n matrix (no n x n temporary)
_BLOCK = 1024

#: how A is made: "auto" (from the Cholesky factor of r W_CC where J0 allows it, module docstring; else LU) or
#: "lu" (an LU factorisation of J0 always: the previous path, kept for the equality tests and benchmarks)
STUCK = "auto"
#: a solve is refined once, then redone densely, where |J x - b| exceeds this fraction of |b| + |J| |x|
RESIDUAL_RTOL = 1e-11
#: J0 is not used where its reciprocal condition number is below this (the dense path solves instead)
RCOND_MIN = 1e-13
#: a solver takes the inverse with the Jacobian's open pairs held open when the rows of pairs open in one and
#: closed in the other are more than this fraction of the unknowns (their rows would all be replaced)
SWITCH_FRACTION = 0.2
#: stuck inverses kept per model, by their open pairs, and capacitance factorisations per solver, by their rows
#: (a predictor, Newton's last steps and the sensitivities meet the same few)
KEEP = 4
#: the stuck inverses kept per model take at most this many bytes besides the base one (n^2 x 8 bytes each: 288 MB
#: at 6,000 unknowns), and the capacitance factorisations kept per solver this many (at least one)
KEEP_BYTES = 400e6
#: a capacitance matrix is updated from the last fresh factorisation (fem/capacitance.py) where at most this
#: fraction of that one's rows, and at least UPDATE_MIN rows, differ; else factorised afresh (and the new base)
UPDATE_FRACTION = 0.25
UPDATE_MIN = 8
#: an update's condition estimate below this is checked by a fresh factorisation
RCOND_RECHECK = 1e-10
#: capacitance matrices of the same rows as a kept fresh factorisation but other values (3-D slip directions) are
#: solved iteratively, preconditioned by it (fem/capacitance.py's Iterated): "auto"; "never": factorised afresh
#: (the previous path, kept for the equality tests and benchmarks)
ITERATE = "auto"
#: fresh factorisations kept as the bases of iterated solves (the last made for a solve; a predictor's condition
#: estimate factorises its matrix without making it a base: its rows differ from Newton's)
KEEP_BASES = 1
#: capacitance matrices of fewer rows are factorised afresh, not iterated: on the 3-D block (150 to 230 rows) an
#: iterative refinement cost 0.122 s CPU per solve against 0.101 s factorised (docs/solver.md); on the half-space
#: interface of benchmarks/contact_loadpath.py, 1,000 to 2,000 rows, GMRES took 6 iterations per solve and the
#: solve 1.9 s CPU against 2.7 s
ITERATE_MIN_ROWS = 500


@dataclass(frozen=True)
class StuckInverse:
    """A = J0^-1 of a model (see the module docstring) with what the corrections need; immutable.

    J0 holds ``open_pairs`` open (the pairs whose gap the supports hold, and optionally others: the open pairs
    of a state, whose rows then need no correction) and the others closed and stuck."""

    open_pairs: np.ndarray  # (n_pairs,) bool
    A: np.ndarray          # (n, n) inverse of the stuck Jacobian
    P0: np.ndarray         # (n_pairs, dim, dim) J0's pair rows on the pair's lam
    Q0: np.ndarray         # (n_pairs, dim, dim) J0's pair rows on w
    W_open: np.ndarray     # (n_open_rows, n) rows of Wfull of the pairs J0 holds open
    WA_open: np.ndarray    # (n_open_rows, n) the same rows times A
    open_rows: np.ndarray  # (n_w,) index of a pair row in W_open, -1 for pairs J0 holds closed
    r: float

    @classmethod
    def build(cls, Wfull, Wa_T, r: float, free_T, open_pairs: np.ndarray) -> "StuckInverse | None":
        """The inverse for operators ``Wfull`` (n_w, n), ``Wa_T`` (m, n_w), the pairs' tangential projectors
        ``free_T`` (None: all free) and the pairs J0 holds open ``open_pairs`` (n_pairs,); None where J0 is
        singular or too ill-conditioned to correct from."""
        held_gap = open_pairs
        n_pairs = len(held_gap)
        dim = Wfull.shape[0] // n_pairs if n_pairs else 1
        eye_T = np.eye(dim - 1)
        E = np.broadcast_to(eye_T, (n_pairs, dim - 1, dim - 1)) if free_T is None else free_T
        P0, Q0 = np.zeros((n_pairs, dim, dim)), np.zeros((n_pairs, dim, dim))
        Q0[:, 0, 0] = r
        P0[:, 1:, 1:] = eye_T - E
        Q0[:, 1:, 1:] = r * E
        P0[held_gap], Q0[held_gap] = np.eye(dim), 0.0
        with large_kernel(Wfull.shape[1]):                     # BLAS threads for a large one (fem/threads.py)
            A = _stuck_inverse(P0, Q0, Wfull, Wa_T, r, held_gap, dim, STUCK == "auto" and free_T is None)
        return None if A is None else cls._with(A, open_pairs, P0, Q0, Wfull, dim, r)

    @classmethod
    def _with(cls, A, open_pairs, P0, Q0, Wfull, dim: int, r: float) -> "StuckInverse":
        rows = np.flatnonzero(np.repeat(open_pairs, dim))
        open_rows = np.full(len(open_pairs) * dim, -1)
        open_rows[rows] = np.arange(len(rows))
        return cls(open_pairs.copy(), A, P0, Q0, Wfull[rows], Wfull[rows] @ A, open_rows, float(r))


def _stuck_inverse(P0, Q0, Wfull, Wa_T, r: float, held_gap, dim: int, symmetric: bool) -> np.ndarray | None:
    """J0^-1 for :meth:`StuckInverse.build`: by :func:`symmetric_inverse` where ``symmetric`` allows and it
    succeeds, else by an LU factorisation of J0; None where J0 is too ill-conditioned."""
    if symmetric:
        A = symmetric_inverse(Wfull, Wa_T, r, held_gap, dim)
        if A is not None:
            return A
    J0 = jacobian(P0, Q0, Wfull, Wa_T)
    norm = np.linalg.norm(J0, 1)
    # factorised in place in LAPACK's column order, the identity solved for in place: two n x n arrays at the
    # peak instead of four (LAPACK's dgetri would need one but took 4 times as long as this solve here)
    J0 = np.asfortranarray(J0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", la.LinAlgWarning)
        lu, piv = la.lu_factor(J0, overwrite_a=True, check_finite=False)
    rcond = la.lapack.dgecon(lu, norm, norm="1")[0] if len(lu) else 1.0
    if not rcond >= RCOND_MIN:
        log.debug("stuck Jacobian ill-conditioned (rcond %.3g): dense solves", rcond)
        return None
    # Fortran order as lu_solve makes it (the capacitance rows gather from its transpose): the same A in C
    # order changes the round-off of A b enough to move the clamp's contact forces by 2e-9 of their largest;
    # the identity solved in place keeps two n x n arrays at the peak
    del J0
    return np.asfortranarray(la.lu_solve((lu, piv), np.eye(len(lu), order="F"), overwrite_b=True,
                                         check_finite=False))


def symmetric_inverse(Wfull, Wa_T, r: float, open_pairs: np.ndarray, dim: int) -> np.ndarray | None:
    """A = J0^-1 (n, n), Fortran order, for J0 with every tangential direction free: the pairs ``open_pairs``
    held open (identity rows), the others closed and stuck (rows r Wfull), the border [Wa_T, 0]; from the Cholesky
    factor of r W_CC (module docstring). None where r W_CC is not positive definite to working precision or J0 is
    too ill-conditioned (:data:`RCOND_MIN`): the LU path decides then.

    With x = (x_C, x_O, alpha): x_O = b_O, and [x_C; alpha] = T ([b_C; b_m] - [r W_CO; Wa_T_O] b_O) with T the
    inverse of [[M, U], [V, 0]], M = r W_CC, U = r Wa_C, V = Wa_T_C; by the Schur complement S = V M^-1 U (m x m)
    T = [[M^-1 - Y S^-1 Z, Y S^-1], [S^-1 Z, -S^-1]], Y = M^-1 U, Z = V M^-1."""
    n_w = len(open_pairs) * dim
    n = Wfull.shape[1]
    opened = np.repeat(open_pairs, dim)
    closed = np.flatnonzero(~opened)
    every = len(closed) == n_w
    if not len(closed):                 # all held open: the LU path (LAPACK's potri refuses n = 0, printing so)
        return None
    # W is symmetric: its transpose, Fortran-ordered, is the same block without a transposing copy
    M = np.array(Wfull[:, :n_w].T, order="F") if every else Wfull[np.ix_(closed, closed)].T
    M *= r
    norm = max((np.abs(M[:, start:start + _BLOCK]).sum(axis=0).max() for start in range(0, len(M), _BLOCK)),
               default=0.0)                                  # 1-norm by blocks of columns: no n x n temporary
    with cholesky_threads(len(M)):
        c, info = la.lapack.dpotrf(M, lower=0, clean=0, overwrite_a=1)
    if info != 0:
        return None
    rcond = la.lapack.dpocon(c, norm)[0] if len(c) else 1.0
    if not rcond >= RCOND_MIN:
        log.debug("stuck Jacobian's block ill-conditioned (rcond %.3g): LU", rcond)
        return None
    with cholesky_threads(len(c)):
        M_inv, info = la.lapack.dpotri(c, lower=0, overwrite_c=1)
    del c
    if info != 0:
        return None
    symmetrise(M_inv)
    if every and n == n_w:
        return M_inv
    modes, held = np.arange(n_w, n), np.flatnonzero(opened)
    if len(modes):
        Y, Z = M_inv @ (r * Wfull[closed, n_w:]), Wa_T[:, closed] @ M_inv
        S = Z @ (r * Wfull[closed, n_w:])
        if not np.linalg.cond(S) < 1.0 / RCOND_MIN:
            return None
        S_inv = np.linalg.inv(S)
        YS, SZ = Y @ S_inv, S_inv @ Z
        del Y
        M_inv = la.blas.dgemm(-1.0, YS, Z, 1.0, M_inv, overwrite_c=1)      # T_CC = M^-1 - Y S^-1 Z, in place
    if len(held):                                                          # T times J0's columns of the held rows
        coupling = r * Wfull[np.ix_(closed, held)]
        held_C = M_inv @ coupling
        if len(modes):
            held_C += YS @ Wa_T[:, held]
            held_m = SZ @ coupling - S_inv @ Wa_T[:, held]
    A = np.zeros((n, n), order="F")
    if every:
        A[:n_w, :n_w] = M_inv
    else:
        A[np.ix_(closed, closed)] = M_inv
    del M_inv
    if len(modes):
        A[np.ix_(closed, modes)], A[np.ix_(modes, closed)], A[np.ix_(modes, modes)] = YS, SZ, -S_inv
    if len(held):
        A[np.ix_(closed, held)] = -held_C
        if len(modes):
            A[np.ix_(modes, held)] = -held_m
        A[held, held] = 1.0
    return A


#: a product of a dense matrix with at most this many columns is made column by column (BLAS's matrix-vector
#: product): OpenBLAS's matrix-matrix product packs the whole matrix first, which made six columns of the clamp's
#: 655 x 655 inverse cost 7 to 12 matrix-vector products (one thread)
FEW_COLUMNS = 8


def times(M: np.ndarray, X: np.ndarray) -> np.ndarray:
    """M X for a dense M and X (n,) or (n, n_rhs), column by column where X has at most :data:`FEW_COLUMNS`."""
    if X.ndim == 1 or X.shape[1] > FEW_COLUMNS:
        return M @ X
    out = np.empty((M.shape[0], X.shape[1]))
    for j in range(X.shape[1]):
        out[:, j] = M @ X[:, j]
    return out


def _identity_rows(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """(n_pairs, dim) the pair rows of J that are identity rows (open pairs: F = lam)."""
    return np.all(P == np.eye(P.shape[1]), axis=2) & np.all(Q == 0.0, axis=2)


class StuckInverses:
    """The stuck inverses of one model by their open pairs, made when first asked for, the last :data:`KEEP`
    kept (a fit's solves meet the same states again)."""

    def __init__(self, Wfull, Wa_T, r: float, free_T, held_gap: np.ndarray):
        self.Wfull, self.Wa_T, self.r, self.free_T, self.held_gap = Wfull, Wa_T, r, free_T, held_gap
        self._kept: dict[bytes, StuckInverse | None] = {}
        self.base = self.get(held_gap)

    def get(self, open_pairs: np.ndarray) -> StuckInverse | None:
        """The inverse holding ``open_pairs`` and the held gaps open (None: J0 singular)."""
        open_pairs = open_pairs | self.held_gap
        key = np.packbits(open_pairs).tobytes()
        if key in self._kept:
            self._kept[key] = self._kept.pop(key)                   # most recently used last
            return self._kept[key]
        n = self.Wfull.shape[1]
        keep = min(KEEP, 1 + int(KEEP_BYTES // (8.0 * max(n, 1) ** 2)))
        while self._kept and len(self._kept) >= keep:
            self._kept.pop(next(iter(self._kept)))
        stuck = StuckInverse.build(self.Wfull, self.Wa_T, self.r, self.free_T, open_pairs)
        self._kept[key] = stuck
        return stuck


class UpdatedSolver:
    """Solves J x = b for the Jacobians of one load path by corrections of a :class:`StuckInverse`, keeping the
    LU factorisations of the last few capacitance matrices C for the next Jacobians with the same replaced rows."""

    def __init__(self, inverses: StuckInverses):
        self.inverses, self.stuck = inverses, inverses.base
        Wfull, Wa_T = inverses.Wfull, inverses.Wa_T
        self.Wfull, self.Wa_T = Wfull, Wa_T
        self._W_max = np.max(np.abs(Wfull), initial=0.0)
        #: the last few capacitance factorisations by their rows (fem/capacitance.py), the last fresh one
        self._kept: dict[bytes, Fresh | Updated | None] = {}
        self._base: Fresh | None = None
        #: (n_w, dim) pair rows P, Q of the Jacobian of the last fresh factorisation (J1)
        self._base_rows: tuple[np.ndarray, np.ndarray] | None = None
        #: the index data of the last few sets of replaced rows (:class:`ReplacedRows`)
        self._layouts: dict[bytes, ReplacedRows] = {}
        self._last_times: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
        self._base_layout: ReplacedRows | None = None
        #: the last :data:`KEEP_BASES` fresh factorisations, the bases of iterated solves (:class:`Iterated`)
        self._bases: list[Fresh] = []
        self.n_factorisations = self.n_updates = self.n_dense = self.n_switches = self.n_iterated = 0
        #: Krylov iterations of each right-hand side of the iterated solves
        self.krylov_iterations: list[int] = []

    def __call__(self, P, Q, b, check: bool = True) -> np.ndarray:
        """J^-1 b, b (n,) or (n, n_rhs), J from pair rows ``P``, ``Q`` (n_pairs, dim, dim). ``check``: the
        residual checked (a product with W), refined once and the solve redone densely if still above
        :data:`RESIDUAL_RTOL`; a Newton step, which checks its residual itself, may do without."""
        identity = _identity_rows(P, Q)
        x = self._corrected(P, Q, b, identity)
        if not check:
            return x
        for refined in (False, True):
            residual = b - self.product(P, Q, x)
            scale = np.max(np.abs(b), initial=0.0) + self._norm(P, Q) * np.max(np.abs(x), initial=0.0)
            if np.max(np.abs(residual), initial=0.0) <= RESIDUAL_RTOL * scale:
                return x
            if not refined:
                x = x + self._corrected(P, Q, residual, identity)
        self.n_dense += 1
        log.debug("corrected solve lost accuracy: a dense solve instead")
        return la.solve(jacobian(P, Q, self.Wfull, self.Wa_T), b, check_finite=False)

    def rcond(self, P, Q) -> float:
        """Reciprocal condition number of the capacitance matrix of J (1 when J = J0): near zero, J is singular."""
        identity = _identity_rows(P, Q)
        factorised = self._factorised(P, Q, identity)
        if factorised is None:
            return 1.0
        if isinstance(factorised, Iterated) and factorised.fallback is None:
            self.n_factorisations += 1                          # made for the estimate, not a base (KEEP_BASES)
        rcond = factorised.rcond()
        if isinstance(factorised, Updated) and rcond < RCOND_RECHECK:
            rcond = self._factorised(P, Q, identity, fresh=True).rcond()
        return rcond

    def product(self, P, Q, x) -> np.ndarray:
        """J x, x (n,) or (n, n_rhs)."""
        n_pairs, dim = P.shape[:2]
        n_w = n_pairs * dim
        lam = x[:n_w].reshape((n_pairs, dim) + x.shape[1:])
        w = self.times_W(x).reshape(lam.shape)
        top = np.einsum("nij,nj...->ni...", P, lam) + np.einsum("nij,nj...->ni...", Q, w)
        return np.concatenate([top.reshape((n_w,) + x.shape[1:]), self.Wa_T @ x[:n_w]])

    def times_W(self, x) -> np.ndarray:
        """Wfull x, kept for the last x (the residual check of a sensitivity solve makes W S, which the next
        increment's right-hand sides need)."""
        if x is not self._last_times[0]:
            self._last_times = (x, times(self.Wfull, x))
        return self._last_times[1]

    def _norm(self, P, Q) -> float:
        return max(np.max(np.abs(P), initial=0.0), np.max(np.abs(Q), initial=0.0) * self._W_max)

    def _corrected(self, P, Q, b, identity) -> np.ndarray:
        factorised = self._factorised(P, Q, identity)          # may switch to another inverse
        A = self.stuck.A
        y = times(A, b)
        if factorised is None:
            return y
        if factorised.singular:
            return np.full_like(y, np.nan)
        K = factorised.K
        Ry = self._rows_times(K, factorised.P_K, factorised.Q_K, y, b)
        z = b.copy()
        z[K] -= factorised.solve(Ry - b[K])
        if isinstance(factorised, Iterated) and factorised.fell_back and factorised.context is not None:
            self._new_base(factorised.fallback, *factorised.context)     # GMRES did not converge: the new base
            factorised.context = None
        x = times(A, z)                                         # y - A[:, K] u without gathering A's columns
        # identity rows of J (open pairs: F = lam) solved exactly, as a fresh LU factorisation solves them: an
        # open pair's force is exactly zero after a Newton step, not round-off of either sign
        rows = np.flatnonzero(identity.ravel())
        x[rows] = b[rows]
        return x

    def _factorised(self, P, Q, identity, fresh: bool = False) -> Fresh | Updated | None:
        """The factorised capacitance matrix of the rows where J differs from J0 (None: none differ), kept from
        an earlier call with the same rows, else updated from the last fresh one where few rows differ from it,
        else (or ``fresh``) factorised afresh; ``identity`` J's identity rows (:func:`_identity_rows`)."""
        self._switch(identity.all(axis=1))
        s = self.stuck
        changed = np.any((P != s.P0) | (Q != s.Q0), axis=2).ravel()
        K = np.flatnonzero(changed)
        dim = P.shape[1]
        P_K, Q_K = P.reshape(-1, dim)[K], Q.reshape(-1, dim)[K]
        key = K.tobytes() + P_K.tobytes() + Q_K.tobytes()
        if key in self._kept and not (fresh and isinstance(self._kept[key], Updated)):
            return self._kept[key]
        # made room for before the new one is made: C and its LU factors are 2 k^2 doubles each (2.2 GB at k
        # 11,700); the base of the updates is held apart
        keep = min(KEEP, max(1, int(KEEP_BYTES // (16.0 * max(len(K), 1) ** 2))))
        while self._kept and len(self._kept) >= keep:
            self._kept.pop(next(iter(self._kept)))
        factorised = None
        if len(K) and not fresh and self._base is not None:
            factorised = self._updated(self._base, P.reshape(-1, dim), Q.reshape(-1, dim), K)
        if len(K) and factorised is None:
            layout = self._rows(K, dim)
            rows = P.reshape(-1, dim).copy(), Q.reshape(-1, dim).copy()
            base = None if fresh or ITERATE == "never" or len(K) < ITERATE_MIN_ROWS else \
                self._nearest_base(K, P_K, Q_K)
            if base is not None:
                self.n_iterated += 1
                factorised = Iterated(K, P_K, Q_K, layout.capacitance(P_K, Q_K), base,
                                      self.krylov_iterations.append, (layout, rows))
            else:
                factorised = Fresh.factorise(K, P_K, Q_K, layout.capacitance(P_K, Q_K))
                self._new_base(factorised, layout, rows)
        self._kept[key] = factorised
        return factorised

    def _new_base(self, factorised: Fresh, layout: ReplacedRows, rows) -> None:
        """Make a fresh factorisation the base of the next updates and iterated solves."""
        self.n_factorisations += 1
        self._base, self._base_layout, self._base_rows = factorised, layout, rows
        self._bases = ([b for b in self._bases if b is not factorised] + [factorised])[-KEEP_BASES:]

    def _nearest_base(self, K, P_K, Q_K) -> Fresh | None:
        """The kept fresh factorisation of the same rows K whose rows are nearest J's (largest difference of
        P and Q / r), None where there is none: the preconditioner of an iterated solve."""
        same = [b for b in self._bases if np.array_equal(b.K, K)]
        if not same:
            return None
        r = self.stuck.r
        return min(same, key=lambda b: np.abs(b.P_K - P_K).max() + np.abs(b.Q_K - Q_K).max() / r)

    def _updated(self, base: Fresh, P_rows, Q_rows, K) -> Fresh | Updated | None:
        """C of J's rows K as an update of ``base`` (fem/capacitance.py); None where too many rows differ or the
        update is singular. ``P_rows``, ``Q_rows`` (n_w, dim): J's pair rows."""
        P1, Q1 = self._base_rows
        differ = np.flatnonzero(np.any((P_rows != P1) | (Q_rows != Q1), axis=1))
        if len(differ) > max(UPDATE_MIN, UPDATE_FRACTION * len(base.K)):
            return None
        if not len(differ):
            return base                                          # J1 itself (its entry was no longer kept)
        U = np.union1d(base.K, K)                                # rows outside both are J0's in J and J1
        P_U, Q_U = P_rows[U], Q_rows[U]
        D = np.searchsorted(U, differ)
        in_base = np.searchsorted(U, base.K)
        outside = np.ones(len(U), dtype=bool)
        outside[in_base] = False
        new = np.flatnonzero(outside)                              # U \ K1
        X = self._rows_times(base.K, base.P_K, base.Q_K, None, None, columns=U[new]) if len(new) else \
            np.zeros((len(base.K), 0))
        C_D = self._rows_times(U[D], P_U[D], Q_U[D], None, None, columns=U)
        updated = Updated.build(base, U, P_U, Q_U, D, C_D, X)
        if updated.singular:
            return None
        self.n_updates += 1
        return updated

    def _switch(self, opened) -> None:
        """Take the inverse holding the Jacobian's open pairs (``opened``, n_pairs) open where the pairs open in
        one of J and J0 and closed in the other have more than :data:`SWITCH_FRACTION` of the rows."""
        dim = len(self.stuck.open_rows) // max(len(opened), 1)
        differ = np.count_nonzero(opened != self.stuck.open_pairs)
        if dim * differ <= SWITCH_FRACTION * len(self.stuck.A):
            return
        stuck = self.inverses.get(opened)
        if stuck is not None and stuck is not self.stuck:
            self.stuck = stuck
            self._kept.clear()
            self._layouts.clear()
            self._base = self._base_rows = None
            self._bases = []
            self.n_switches += 1

    def _rows(self, K: np.ndarray, dim: int) -> "ReplacedRows":
        """The index data of rows K of the current stuck inverse, kept for the last few K (the block of A only
        for the last: k^2 dim values)."""
        if self._base is not None and K is self._base.K:
            return self._base_layout                  # kept while it is the base: the updates read its rows
        key = K.tobytes()
        rows = self._layouts.pop(key, None)
        if rows is None or rows.stuck is not self.stuck:          # the data of one inverse's rows and columns
            rows = ReplacedRows(self.stuck, K, dim)
            while len(self._layouts) >= KEEP:
                self._layouts.pop(next(iter(self._layouts)))
            for other in self._layouts.values():
                other.drop_block()
        self._layouts[key] = rows                                     # most recently used last
        return rows

    def _rows_times(self, K, P_K, Q_K, z, b, columns=None) -> np.ndarray:
        """R z for the replaced rows R (rows K of J, sorted) and z = A v (n, ...): P z[lam] + Q (W z), with
        W z = v / r on the pairs J0 holds closed (``b`` = v) and from W_open on the others; z = b = None:
        v = I[:, columns] (default K), i.e. R A[:, columns], gathering only the rows of A it needs. The index
        data of K are kept where K are the rows of a factorisation (columns None, or the columns an update adds
        to its base's rows)."""
        dim = P_K.shape[1]
        if columns is None or K is getattr(self._base, "K", None) or K.tobytes() in self._layouts:
            rows = self._rows(K, dim)
        elif z is None:
            return self._few_rows_times(K, P_K, Q_K, columns)
        else:
            rows = ReplacedRows(self.stuck, K, dim)
        if z is not None:
            return rows.times(P_K, Q_K, z, b)
        return rows.capacitance(P_K, Q_K, columns)

    def _few_rows_times(self, K, P_K, Q_K, columns) -> np.ndarray:
        """R A[:, columns] for a few rows K (the rows an update changes) and sorted ``columns``, A read row by
        row: no index data worth keeping."""
        s, dim = self.stuck, P_K.shape[1]
        lam_rows = (K // dim)[:, None] * dim + np.arange(dim)                     # (k, dim)
        gathered = np.ascontiguousarray(gather(s.A, lam_rows.ravel(), columns)).reshape(len(K), dim, -1)
        out = np.einsum("ac,ack->ak", P_K, gathered)
        closed = s.open_rows[lam_rows[:, 0]] < 0
        where = np.minimum(np.searchsorted(columns, lam_rows), len(columns) - 1)   # (k, dim) column or not
        a, c = np.nonzero(closed[:, None] & (columns[where] == lam_rows))
        out[a, where[a, c]] += Q_K[a, c] / s.r                                    # (a, column) are distinct
        if not closed.all():
            held = np.flatnonzero(~closed)
            out[held] += np.einsum("ac,ac...->a...", Q_K[held],
                                   s.WA_open[:, columns][s.open_rows[lam_rows[held]]])
        return out
