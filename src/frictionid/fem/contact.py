"""One load increment of frictional contact: Alart-Curnier equations solved by semi-smooth Newton.

Unknowns x = (lam, alpha): contact forces lam (n_pairs, dim) [N], pair-major, and rigid-mode amplitudes alpha.
Per pair, with g = gap + w_N, ds = w_T - w_T_prev, lam_hat = max(0, lam_N - r g), tau = lam_T - r ds:

    open  (lam_N - r g <= 0): F_N = lam_N,  F_T = lam_T
    closed:                   F_N = r g
      stick (|tau| < mu lam_hat): F_T = r ds
      slip:                       F_T = lam_T - mu lam_hat tau / |tau|

plus equilibrium of the floating bodies h = R^T (b + B^T lam) = 0. The generalised Jacobian of each pair's rows
is ``P dlam_i + Q dw_i`` with d×d blocks P, Q; dw = [W | W_a] dx (Alart & Curnier 1991, docs/design.md, contact formulation).

Tangential directions held by the supports (:func:`free_tangents`): where the supports hold both sides of a pair
in a tangential direction (symmetry planes), its relative motion there is fixed, its compliance zero and its stick
equation empty. The support carries that force: with E the projector onto the pair's free tangential directions
and H = I - E, the friction force lies in range(E) and the rows read

    tau = E (lam_T - r ds);   stick: F_T = r E ds + H lam_T;   slip: F_T = lam_T - mu lam_hat tau / |tau|

(E = I where nothing is held: the equations above; E = 0: lam_T = 0).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

OPEN, STICK, SLIP = 0, 1, 2

#: a tangential direction of a pair is held when the part of its relative-displacement row on the free dofs is
#: at most this fraction of the whole row (see :func:`free_tangents`)
HELD_RTOL = 1e-6


def free_tangents(B: sp.spmatrix, free: np.ndarray, dim: int) -> np.ndarray | None:
    """(n_pairs, dim - 1, dim - 1) orthogonal projectors E onto the tangential directions in which a pair's
    relative motion is free; None when the supports hold no pair tangentially.

    A direction v of pair i is held when its relative displacement v . w_T = v . B_T,i u involves prescribed dofs
    only: then it depends on no contact force nor rigid mode (its rows of W = B_f K^g B_f^T and W_a = B_f R are
    zero), it is fixed by the supports, and the support carries the force in it. The criterion is on the
    operator, not on the computed compliance, so it does not depend on round-off in W nor on how stiff the
    bodies are: v is held when |B_f,T,i^T v| <= HELD_RTOL |B_T,i| (B_f: B on the free dofs), i.e. the free part
    of the pair's tangential rows, a (dim-1)^2 Gram matrix per pair, has an eigenvalue at most HELD_RTOL^2 times
    the whole rows' squared norm. On symmetry planes the free part is exactly zero; a direction within 1e-6 rad of
    a held one has a compliance 1e-12 of the others, which round-off in W cannot tell from zero.
    """
    B, B_f = _on_free(B, free)
    n_pairs = B.shape[0] // dim
    if n_pairs == 0:
        return None
    rows = [dim * np.arange(n_pairs) + k for k in range(1, dim)]
    gram = np.zeros((n_pairs, dim - 1, dim - 1))
    for a in range(dim - 1):
        for b in range(a, dim - 1):
            dot = np.asarray(B_f[rows[a]].multiply(B_f[rows[b]]).sum(axis=1)).ravel()
            gram[:, a, b] = gram[:, b, a] = dot
    scale = sum(np.asarray(B[r].multiply(B[r]).sum(axis=1)).ravel() for r in rows)
    values, vectors = np.linalg.eigh(gram)
    keep = values > HELD_RTOL ** 2 * scale[:, None]
    if keep.all():
        return None
    E = np.einsum("nik,nk,njk->nij", vectors, keep.astype(float), vectors)
    E[keep.all(axis=1)] = np.eye(dim - 1)              # exactly: the free pairs' equations as without projectors
    E[~keep.any(axis=1)] = 0.0
    return E


def held_normals(B: sp.spmatrix, free: np.ndarray, dim: int) -> np.ndarray:
    """(n_pairs,) pairs whose normal relative displacement the supports hold (criterion of :func:`free_tangents`):
    their gap is prescribed, their normal force undetermined. At zero gap or open they stay open with no force
    (the supports carry it); overlapping, no increment has a solution."""
    B, B_f = _on_free(B, free)
    normal = dim * np.arange(B.shape[0] // dim)
    norm = np.asarray(B[normal].multiply(B[normal]).sum(axis=1)).ravel()
    return np.asarray(B_f[normal].multiply(B_f[normal]).sum(axis=1)).ravel() <= HELD_RTOL ** 2 * norm


def _on_free(B: sp.spmatrix, free: np.ndarray) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """(B, B with the columns of prescribed dofs zeroed)."""
    B = sp.csr_matrix(B)
    on_free = np.zeros(B.shape[1])
    on_free[free] = 1.0
    return B, sp.csr_matrix((B.data * on_free[B.indices], B.indices, B.indptr), shape=B.shape)


@dataclass(frozen=True)
class Linearisation:
    """Residual and generalised Jacobian of one increment at a point x."""

    F: np.ndarray          # (n_w + m,)
    state: np.ndarray      # (n_pairs,) OPEN | STICK | SLIP
    P: np.ndarray          # (n_pairs, dim, dim) derivative of the pair rows with respect to the pair's lam
    Q: np.ndarray          # (n_pairs, dim, dim) derivative of the pair rows with respect to w
    lam_hat: np.ndarray    # (n_pairs,) augmented normal force of closed pairs [N]
    direction: np.ndarray  # (n_pairs, dim - 1) unit slip direction tau/|tau| (0 where undefined)


@dataclass(frozen=True)
class Increment:
    """Data of one increment: w = w0 + Wfull x, the previous tangential displacement and the equilibrium."""

    w0: np.ndarray         # (n_w,) w at x = 0 [mm]
    w_prev_T: np.ndarray   # (n_pairs, dim - 1) tangential relative displacement at the previous increment [mm]
    h0: np.ndarray         # (m,) equilibrium residual at lam = 0 [N]


def linearise(x, inc: Increment, Wfull, Wa_T, gap, mu, r, free_T=None) -> Linearisation:
    """Residual F(x) and generalised Jacobian of the increment (vectorised over pairs: every case's rows are
    computed for all pairs and selected by state); ``free_T`` the projectors of :func:`free_tangents` (None:
    every tangential direction free)."""
    n_pairs, dim = len(gap), inc.w_prev_T.shape[1] + 1
    n_w = n_pairs * dim
    lam = x[:n_w].reshape(n_pairs, dim)
    lam_T = lam[:, 1:]
    w = (inc.w0 + Wfull @ x).reshape(n_pairs, dim)
    g, ds = gap + w[:, 0], w[:, 1:] - inc.w_prev_T
    augmented = lam[:, 0] - r * g
    closed = augmented > 0
    lam_hat = np.where(closed, augmented, 0.0)
    tau = lam_T - r * ds
    if free_T is not None:
        tau = np.einsum("nij,nj->ni", free_T, tau)
    norm = np.sqrt(np.add.reduce(tau * tau, axis=1))                  # np.linalg.norm's sums, without its checks
    bound = mu * lam_hat
    stick = closed & (norm < bound)
    slip = closed & ~stick
    positive = norm > 0
    safe = np.where(positive, norm, 1.0)
    t = np.where(positive[:, None], tau / safe[:, None], 0.0)
    kappa = np.where(positive & slip, bound / safe, 0.0)

    eye_T = np.eye(dim - 1)
    E = eye_T if free_T is None else free_T                              # (dim - 1)^2 broadcast over the pairs
    F = np.empty((n_pairs, dim))
    F[:, 0] = np.where(closed, r * g, lam[:, 0])
    F_stick = r * ds
    if free_T is not None:
        F_stick = np.einsum("nij,nj->ni", E, F_stick) + np.einsum("nij,nj->ni", eye_T - E, lam_T)
    F[:, 1:] = np.where(stick[:, None], F_stick, np.where(slip[:, None], lam_T - bound[:, None] * t, lam_T))

    proj = E - t[:, :, None] * t[:, None, :]                            # E - t t^T
    stick3, slip3 = stick[:, None, None], slip[:, None, None]
    P = np.zeros((n_pairs, dim, dim))
    Q = np.zeros((n_pairs, dim, dim))
    P[:, 0, 0] = np.where(closed, 0.0, 1.0)
    Q[:, 0, 0] = np.where(closed, r, 0.0)
    P[:, 1:, 1:] = np.where(stick3, eye_T - E, np.where(slip3, eye_T - kappa[:, None, None] * proj, eye_T))
    P[:, 1:, 0] = np.where(slip[:, None], -mu[:, None] * t, 0.0)
    Q[:, 1:, 0] = np.where(slip[:, None], r * mu[:, None] * t, 0.0)
    Q[:, 1:, 1:] = np.where(stick3, r * E, np.where(slip3, r * kappa[:, None, None] * proj, 0.0))

    h = inc.h0 + Wa_T @ x[:n_w]
    state = np.where(slip, SLIP, np.where(stick, STICK, OPEN)).astype(np.int8)
    return Linearisation(np.concatenate([F.ravel(), h]), state, P, Q, lam_hat, t)


def jacobian(P, Q, Wfull, Wa_T) -> np.ndarray:
    """(n_w + m, n_w + m) dense generalised Jacobian: pair rows P dlam_i + Q dw_i with dw = Wfull dx, then the
    equilibrium rows [Wa_T, 0]."""
    n_pairs, dim = P.shape[:2]
    n_w, m = n_pairs * dim, Wa_T.shape[0]
    J = np.zeros((n_w + m, n_w + m))
    J[:n_w] = np.einsum("nij,njk->nik", Q, Wfull.reshape(n_pairs, dim, Wfull.shape[1])).reshape(n_w, Wfull.shape[1])
    blocks = J[:n_w, :n_w].reshape(n_pairs, dim, n_pairs, dim)
    index = np.arange(n_pairs)
    blocks[index, :, index, :] += P
    J[n_w:, :n_w] = Wa_T
    return J


def dense_solve(lin: Linearisation, rhs, Wfull, Wa_T) -> np.ndarray:
    """J^-1 rhs by a fresh LU factorisation of the dense Jacobian (the reference path)."""
    return la.solve(jacobian(lin.P, lin.Q, Wfull, Wa_T), rhs, check_finite=False)


@dataclass(frozen=True)
class NewtonResult:
    x: np.ndarray
    lin: Linearisation
    converged: bool
    n_iterations: int
    residual: float
    cycling: bool


def newton(x0, inc: Increment, Wfull, Wa_T, gap, mu, r, atol, max_iterations=50, free_T=None,
           solve=None) -> NewtonResult:
    """Semi-smooth Newton with Armijo backtracking on 0.5 |F|^2 from x0; ``solve(lin, rhs)`` gives J^-1 rhs
    (default :func:`dense_solve`)."""
    if solve is None:
        def solve(lin, rhs):
            return dense_solve(lin, rhs, Wfull, Wa_T)
    x = x0.copy()
    lin = linearise(x, inc, Wfull, Wa_T, gap, mu, r, free_T)
    seen: list[bytes] = []
    cycling = False
    for iteration in range(max_iterations + 1):
        residual = float(np.max(np.abs(lin.F), initial=0.0))
        if residual <= atol:
            return NewtonResult(x, lin, True, iteration, residual, cycling)
        if iteration == max_iterations:
            break
        key = lin.state.tobytes()
        cycling = cycling or (key in seen[:-1])
        seen.append(key)
        try:
            dx = solve(lin, -lin.F)
        except la.LinAlgError:
            break
        if not np.all(np.isfinite(dx)):
            break
        merit = 0.5 * lin.F @ lin.F
        step = 1.0
        while True:
            trial = linearise(x + step * dx, inc, Wfull, Wa_T, gap, mu, r, free_T)
            if 0.5 * trial.F @ trial.F <= (1 - 1e-4 * step) * merit or step < 1e-3:
                break
            step *= 0.5
        x, lin = x + step * dx, trial
    return NewtonResult(x, lin, False, iteration, float(np.max(np.abs(lin.F), initial=0.0)), cycling)


def stick_predictor(inc: Increment, Wfull, Wa_T, gap, r, held: np.ndarray, free_T=None) -> np.ndarray | None:
    """Elastic predictor: the ``held`` pairs closed and stuck (no slip increment), the others open; tangential
    directions the supports hold (``free_T``, :func:`free_tangents`) carry no friction force.

    It starts every increment: with floating bodies under force control the previous solution is a poor
    start (a new load moves the pinned particular solution), while holding the previously closed pairs
    gives the equilibrium the increment departs from. None when that system is singular.
    """
    n_pairs, dim = len(gap), inc.w_prev_T.shape[1] + 1
    n_w, m = n_pairs * dim, Wa_T.shape[0]
    rows = np.repeat(held, dim)
    A = np.zeros((n_w + m, n_w + m))
    rhs = np.zeros(n_w + m)
    A[:n_w][rows] = Wfull[rows]
    target = np.column_stack([-gap, inc.w_prev_T]).ravel() - inc.w0         # g = 0 and ds = 0
    rhs[:n_w][rows] = target[rows]
    if free_T is not None:
        # stuck rows of a pair with a held direction: E (w_T - target_T) + (I - E) lam_T = 0
        E = free_T[held]
        tangential = A[:n_w].reshape(n_pairs, dim, -1)[held, 1:, :]
        tangential = np.einsum("nij,njk->nik", E, tangential)
        lam_cols = (dim * np.flatnonzero(held))[:, None] + np.arange(1, dim)          # (n_held, dim - 1)
        tangential[np.arange(len(E))[:, None, None], np.arange(dim - 1)[None, :, None],
                   lam_cols[:, None, :]] += np.eye(dim - 1) - E
        A[:n_w].reshape(n_pairs, dim, -1)[held, 1:, :] = tangential
        rhs_T = rhs[:n_w].reshape(n_pairs, dim)
        rhs_T[held, 1:] = np.einsum("nij,nj->ni", E, rhs_T[held, 1:])
    free = np.flatnonzero(~rows)
    A[free, free] = 1.0
    A[n_w:, :n_w] = Wa_T
    rhs[n_w:] = -inc.h0
    with warnings.catch_warnings():
        warnings.simplefilter("error", la.LinAlgWarning)
        try:
            x = la.solve(A, rhs, check_finite=False)
        except (la.LinAlgError, la.LinAlgWarning):
            return None
    return x if np.all(np.isfinite(x)) else None
