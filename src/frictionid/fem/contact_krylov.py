"""The contact Jacobian solved by GMRES without forming W: products by the sparse factor of K, a preconditioner from
a penalised factor of K.

The Newton systems of an increment (:mod:`frictionid.fem.contact`) read, per pair, P_i dlam_i + Q_i dw_i = b_i with
dw = W dlam + W_a dalpha, and the floating bodies' equilibrium W_a^T dlam = b_eq. W = B_f K^g B_f^T is applied by one
sparse solve (:class:`frictionid.fem.condense_implicit.Compliance`), so J x costs one solve; GMRES (right
preconditioned, :func:`gmres`) iterates on it to a relative residual of :data:`RTOL`.

Preconditioner. The rows of J split into constraint rows A (P row zero, Q row q e_k, q > 0: a closed pair's normal,
a stuck pair's free tangential direction: r w_k = b_k, q = r as linearise makes them) and the others U (open pairs, slipping pairs' tangential rows, held
directions), which are local: with P_UU taken as the identity and w_A = b_A / r from the pair's constraint rows,

    lam_U = c_U - P_UA lam_A,   c_U = b_U - Q_UA b_A / r

(exact for open pairs and in 2-D for slipping ones; in 3-D a slipping pair's rows also hold kappa (E - t t^T)
(r w_T - lam_T), left to GMRES). The constraint rows then need (W_AA)^-1, which the penalised stiffness gives:
with K_rho = K + rho B_A^T B_A and W_rho = B_A K_rho^-1 B_A^T = (W_AA^-1 + rho I)^-1 (Woodbury),

    M = rho I - rho^2 W_rho  has eigenvalues rho / (1 + rho w) against W_AA's 1 / w,

so M W_AA has its spectrum in [rho w_min / (1 + rho w_min), 1): within 1e-3 of 1 for rho = :data:`PENALTY` r
where w_min is above a tenth of the mean diagonal. The friction coupling of lam_U to the constraint rows' gaps
(W_AU (-P_UA lam_A)) is left to GMRES too. The floating bodies' alpha enters by a bordered solve of size m.

K_rho is factorised per pattern A (one sparse Cholesky factorisation in a fill-reducing order computed once for
the pattern of K + B^T B); a pattern that differs from the factorised one in at most :data:`REUSE_FRACTION` of its
rows keeps that factor, the differing rows scaled by r.
"""

from __future__ import annotations

import logging
from types import SimpleNamespace

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import cholesky
from .condense import Condensed

log = logging.getLogger(__name__)

#: GMRES stops at |b - J x| <= RTOL |b| (2-norms)
RTOL = 1e-12
#: a solve that has not reached RTOL after this many iterations is accepted at ACCEPT_RTOL, else failed (NaN)
MAX_ITERATIONS = 80
ACCEPT_RTOL = 1e-9
#: rho = PENALTY * r (module docstring)
PENALTY = 1e3
#: the preconditioner accounts for the gaps the U rows' forces c_U open at the constraint rows (one more solve
#: per iteration); False: GMRES does
LOCAL_FORCES = False
#: a pattern keeps the factor of another that differs from it in at most this fraction of the factor's rows
REUSE_FRACTION = 0.05


def gmres(apply, precondition, b: np.ndarray, rtol: float = RTOL, max_iterations: int = MAX_ITERATIONS,
          x0: np.ndarray | None = None) -> tuple[np.ndarray, float, int]:
    """x with |b - apply(x)| <= rtol |b| by right-preconditioned GMRES (flexible: the preconditioned directions are
    kept), restarted once from the reached x with the true residual. Returns (x, relative residual, iterations)."""
    beta0 = float(np.linalg.norm(b))
    x = np.zeros_like(b) if x0 is None else x0.copy()
    if beta0 == 0.0:
        return x, 0.0, 0
    total = 0
    for _ in range(2):
        residual = b - apply(x) if (total or x0 is not None) else b.copy()
        beta = float(np.linalg.norm(residual))
        if beta <= rtol * beta0:
            return x, beta / beta0, total
        V, Z = [residual / beta], []
        H = np.zeros((max_iterations + 1, max_iterations))
        g = np.zeros(max_iterations + 1)
        g[0] = beta
        rotations = []
        for j in range(max_iterations):
            Z.append(precondition(V[j]))
            w = apply(Z[j])
            for _ in range(2):                                  # modified Gram-Schmidt, twice
                for i in range(j + 1):
                    h = w @ V[i]
                    H[i, j] += h
                    w -= h * V[i]
            H[j + 1, j] = np.linalg.norm(w)
            for i, (c, s) in enumerate(rotations):
                H[i, j], H[i + 1, j] = c * H[i, j] + s * H[i + 1, j], -s * H[i, j] + c * H[i + 1, j]
            denominator = np.hypot(H[j, j], H[j + 1, j])
            c, s = (1.0, 0.0) if denominator == 0 else (H[j, j] / denominator, H[j + 1, j] / denominator)
            rotations.append((c, s))
            H[j, j], H[j + 1, j] = denominator, 0.0
            g[j], g[j + 1] = c * g[j], -s * g[j]
            total += 1
            if abs(g[j + 1]) <= 0.1 * rtol * beta0 or H[j, j] == 0 or j + 1 == max_iterations:
                break
            V.append(w / np.linalg.norm(w) if np.linalg.norm(w) > 0 else w)
        k = len(Z)
        y = la.solve_triangular(H[:k, :k], g[:k], check_finite=False) if k else np.zeros(0)
        x = x + np.column_stack(Z) @ y
    relative = float(np.linalg.norm(b - apply(x))) / beta0
    return x, relative, total


class _Ordered(cholesky.Cholesky):
    """A :class:`~frictionid.fem.cholesky.Cholesky` factor in a given order (the penalised matrices of one model
    share one fill-reducing order)."""

    def __init__(self, K: sp.spmatrix, perm: np.ndarray):
        self.matrix, self.last, self.perm = sp.csc_matrix(K), np.zeros(0, int), perm
        self.factor = self._factor()


class PenalisedFactors:
    """Factors of K_rho = K + rho B_A^T B_A (on the inverse's kept dofs) for constraint patterns A (n_w,) bool."""

    def __init__(self, matrix: sp.csc_matrix, B_kept: sp.csr_matrix, nodes: np.ndarray, rho: float):
        self.matrix, self.B, self.nodes, self.rho = matrix, B_kept, nodes, rho
        self._perm = None
        self.n_factorisations = 0

    def factor(self, A: np.ndarray):
        """A solver of K_rho for pattern ``A``: ``.solve(b)``."""
        B_A = sp.diags(A.astype(float)) @ self.B
        K_rho = (self.matrix + self.rho * (B_A.T @ B_A)).tocsc()
        self.n_factorisations += 1
        if not cholesky.available():
            return SimpleNamespace(solve=spla.splu(K_rho, permc_spec="MMD_AT_PLUS_A").solve)
        if self._perm is None:
            pattern = abs(self.matrix) + abs(self.B.T @ self.B)
            self._perm = cholesky.fill_reducing_order(pattern, self.nodes)
        return _Ordered(K_rho, self._perm)


class KrylovSolver:
    """J^-1 b for the Jacobians of a load path by GMRES (module docstring); the interface of
    :class:`frictionid.fem.updated_jacobian.UpdatedSolver` that :class:`frictionid.fem.loadpath.LoadPathSolver`
    uses (``__call__``, ``rcond``, ``inverses.base.P0/Q0``). Solves that do not converge give NaN, which Newton
    and the predictors read as a failed step."""

    def __init__(self, condensed: Condensed, r: float, free_T, held_gap: np.ndarray, dim: int):
        W = condensed.gap_ops.on_lam
        self.W, self.Wfull = W, condensed.gap_ops.full
        self.W_a, self.Wa_T = condensed.gap_ops.on_alpha, condensed.equilibrium.on_lam
        self.r, self.free_T, self.dim = float(r), free_T, dim
        keep = W.inverse.keep
        self.penalised = PenalisedFactors(W.inverse.matrix, W.B_f[:, keep].tocsr(), W.nodes[keep],
                                          PENALTY * self.r)
        self.inverses = SimpleNamespace(base=self._stuck_rows(held_gap))
        self._pattern = self._factor = self._MWa = None
        self.n_iterations = self.n_calls = 0

    def _stuck_rows(self, held_gap):
        """J0's pair rows (every pair closed and stuck, held gaps open) as in
        :meth:`frictionid.fem.updated_jacobian.StuckInverse.build`, for the load path's predictors."""
        n_pairs, dim = len(held_gap), self.dim
        eye_T = np.eye(dim - 1)
        E = np.broadcast_to(eye_T, (n_pairs, dim - 1, dim - 1)) if self.free_T is None else self.free_T
        P0, Q0 = np.zeros((n_pairs, dim, dim)), np.zeros((n_pairs, dim, dim))
        Q0[:, 0, 0] = self.r
        P0[:, 1:, 1:] = eye_T - E
        Q0[:, 1:, 1:] = self.r * E
        P0[held_gap], Q0[held_gap] = np.eye(dim), 0.0
        return SimpleNamespace(P0=P0, Q0=Q0)

    def rcond(self, P, Q) -> float:
        """Not estimated (1.0): a singular system shows as a solve that does not converge (NaN)."""
        return 1.0

    def product(self, P, Q, x) -> np.ndarray:
        """J x for x (n,)."""
        n_pairs, dim = P.shape[:2]
        n_w = n_pairs * dim
        w = (self.Wfull @ x).reshape(n_pairs, dim)
        top = np.einsum("nij,nj->ni", P, x[:n_w].reshape(n_pairs, dim)) + np.einsum("nij,nj->ni", Q, w)
        return np.concatenate([top.ravel(), self.Wa_T @ x[:n_w]])

    def times_W(self, x) -> np.ndarray:
        """Wfull x (the interface's product; W applied by the stiffness factor)."""
        return self.Wfull @ x

    def __call__(self, P, Q, b, check: bool = True) -> np.ndarray:
        """J^-1 b, b (n,) or (n, n_rhs); ``check`` is accepted for the interface (GMRES always checks)."""
        if b.ndim == 2:
            return np.column_stack([self(P, Q, column) for column in b.T]) if b.shape[1] else b.copy()
        self.n_calls += 1
        precondition = self._preconditioner(P, Q)
        x, relative, iterations = gmres(lambda v: self.product(P, Q, v), precondition, b, RTOL, MAX_ITERATIONS)
        self.n_iterations += iterations
        if not relative <= ACCEPT_RTOL:
            log.debug("GMRES stopped at relative residual %.3g after %d iterations", relative, iterations)
            return np.full_like(b, np.nan)
        return x

    def _preconditioner(self, P, Q):
        """v -> an approximate J^-1 v (module docstring)."""
        n_pairs, dim = P.shape[:2]
        n_w = n_pairs * dim
        eye = np.eye(dim, dtype=bool)
        diagonal = np.einsum("nii->ni", Q)
        A = (np.all(P == 0.0, axis=2) & np.all(np.where(eye, True, Q == 0.0), axis=2) & (diagonal > 0)).ravel()
        U = ~A
        q = np.where(A, diagonal.ravel(), 1.0)                 # constraint rows q w_k = b_k (q = r from linearise)
        rows = (dim * np.arange(n_pairs)[:, None, None] + np.arange(dim)[None, :, None]).repeat(dim, axis=2)
        cols = rows.transpose(0, 2, 1)
        coupling = U[rows] & A[cols]                                      # (n_pairs, dim, dim) U row, A column
        P_UA = sp.csr_matrix((P[coupling], (rows[coupling], cols[coupling])), shape=(n_w, n_w))
        Q_UA = sp.csr_matrix((Q[coupling], (rows[coupling], cols[coupling])), shape=(n_w, n_w))
        M, MWa = self._approximate_inverse(A)
        m = self.Wa_T.shape[0]
        S = None
        if m:
            S = self.Wa_T @ (MWa - P_UA @ MWa)

        def apply(v):
            v_lam = v[:n_w]
            c = np.where(U, v_lam - Q_UA @ np.where(A, v_lam / q, 0.0), 0.0)
            y = np.where(A, v_lam / q, 0.0)
            if LOCAL_FORCES and np.any(c):
                y -= np.where(A, self.W @ c, 0.0)
            Mz = M(y)
            alpha = np.zeros(m)
            if m:
                rhs = self.Wa_T @ (Mz - P_UA @ Mz) - (v[n_w:] - self.Wa_T @ c)
                alpha = la.lstsq(S, rhs, check_finite=False)[0]
                Mz = Mz - MWa @ alpha
            return np.concatenate([Mz + c - P_UA @ Mz, alpha])
        return apply

    def _approximate_inverse(self, A: np.ndarray):
        """(M: y -> ~ W_AA^-1 y on A, zero elsewhere; M (A W_a)), from the factor of the pattern ``A`` or of one
        within :data:`REUSE_FRACTION` of it."""
        F = self._pattern
        if F is None or np.count_nonzero(F != A) > REUSE_FRACTION * max(np.count_nonzero(F), 1):
            self._factor = None                              # one factor at a time: drop the old before the new
            self._factor = self.penalised.factor(A)
            self._pattern = F = A.copy()
            self._MWa = self._M_F(F, np.where(F[:, None], self.W_a, 0.0)) if self.W_a.shape[1] else \
                np.zeros((len(A), 0))
        scale_only = A & ~F

        def M(y):
            out = self._M_F(F, np.where(F, y, 0.0))
            out[scale_only] = self.r * y[scale_only]
            return np.where(A, out, 0.0)

        MWa = np.where(A[:, None], self._MWa, 0.0)
        MWa[scale_only] = self.r * self.W_a[scale_only]
        return M, MWa

    def _M_F(self, F: np.ndarray, y: np.ndarray) -> np.ndarray:
        """rho y - rho^2 B_F K_rho^-1 B_F^T y for y zero outside F (n_w,) or (n_w, k)."""
        B, rho = self.penalised.B, self.penalised.rho
        solved = self._factor.solve(B.T @ y)
        return np.where(F if y.ndim == 1 else F[:, None], rho * y - rho ** 2 * (B @ solved), 0.0)
