"""One load increment of frictional contact: Alart-Curnier equations solved by semi-smooth Newton.

Unknowns x = (lam, alpha): contact forces lam (n_pairs, dim) [N], pair-major, and rigid-mode amplitudes alpha.
Per pair, with g = gap + w_N, ds = w_T - w_T_prev, lam_hat = max(0, lam_N - r g), tau = lam_T - r ds:

    open  (lam_N - r g <= 0): F_N = lam_N,  F_T = lam_T
    closed:                   F_N = r g
      stick (|tau| < mu lam_hat): F_T = r ds
      slip:                       F_T = lam_T - mu lam_hat tau / |tau|

plus equilibrium of the floating bodies h = R^T (b + B^T lam) = 0. The generalised Jacobian of each pair's rows
is ``P dlam_i + Q dw_i`` with d×d blocks P, Q; dw = [W | W_a] dx (Alart & Curnier 1991, docs/design.md, contact formulation).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

OPEN, STICK, SLIP = 0, 1, 2


@dataclass(frozen=True)
class Linearisation:
    """Residual and generalised Jacobian of one increment at a point x."""

    F: np.ndarray          # (n_w + m,)
    J: np.ndarray          # (n_w + m, n_w + m)
    state: np.ndarray      # (n_pairs,) OPEN | STICK | SLIP
    Q: np.ndarray          # (n_pairs, dim, dim) derivative of the pair rows with respect to w
    lam_hat: np.ndarray    # (n_pairs,) augmented normal force of closed pairs [N]
    direction: np.ndarray  # (n_pairs, dim - 1) unit slip direction tau/|tau| (0 where undefined)


@dataclass(frozen=True)
class Increment:
    """Data of one increment: w = w0 + Wfull x, the previous tangential displacement and the equilibrium."""

    w0: np.ndarray         # (n_w,) w at x = 0 [mm]
    w_prev_T: np.ndarray   # (n_pairs, dim - 1) tangential relative displacement at the previous increment [mm]
    h0: np.ndarray         # (m,) equilibrium residual at lam = 0 [N]


def linearise(x, inc: Increment, Wfull, Wa_T, gap, mu, r) -> Linearisation:
    """Residual F(x) and generalised Jacobian of the increment (vectorised over pairs)."""
    n_pairs, dim = len(gap), inc.w_prev_T.shape[1] + 1
    n_w = n_pairs * dim
    lam = x[:n_w].reshape(n_pairs, dim)
    w = (inc.w0 + Wfull @ x).reshape(n_pairs, dim)
    g, ds = gap + w[:, 0], w[:, 1:] - inc.w_prev_T
    closed = lam[:, 0] - r * g > 0
    lam_hat = np.where(closed, lam[:, 0] - r * g, 0.0)
    tau = lam[:, 1:] - r * ds
    norm = np.linalg.norm(tau, axis=1)
    stick = closed & (norm < mu * lam_hat)
    slip = closed & ~stick
    t = np.divide(tau, norm[:, None], out=np.zeros_like(tau), where=norm[:, None] > 0)
    kappa = np.divide(mu * lam_hat, norm, out=np.zeros_like(norm), where=(norm > 0) & slip)

    F = lam.copy()
    F[closed, 0] = r * g[closed]
    F[stick, 1:] = r * ds[stick]
    F[slip, 1:] = lam[slip, 1:] - (mu * lam_hat)[slip, None] * t[slip]

    eye_T = np.eye(dim - 1)
    proj = eye_T - t[:, :, None] * t[:, None, :]                       # I - t t^T
    P = np.broadcast_to(np.eye(dim), (n_pairs, dim, dim)).copy()
    Q = np.zeros((n_pairs, dim, dim))
    P[closed, 0, :] = 0.0
    Q[closed, 0, 0] = r
    P[stick, 1:, :] = 0.0
    Q[stick, 1:, 1:] = r * eye_T
    P[slip, 1:, 1:] = eye_T - kappa[slip, None, None] * proj[slip]
    P[slip, 1:, 0] = -mu[slip, None] * t[slip]
    Q[slip, 1:, 0] = r * mu[slip, None] * t[slip]
    Q[slip, 1:, 1:] = r * kappa[slip, None, None] * proj[slip]

    m = Wa_T.shape[0]
    J = np.zeros((n_w + m, n_w + m))
    J[:n_w] = np.einsum("nij,njk->nik", Q, Wfull.reshape(n_pairs, dim, Wfull.shape[1])).reshape(n_w, Wfull.shape[1])
    blocks = J[:n_w, :n_w].reshape(n_pairs, dim, n_pairs, dim)
    index = np.arange(n_pairs)
    blocks[index, :, index, :] += P
    J[n_w:, :n_w] = Wa_T
    h = inc.h0 + Wa_T @ x[:n_w]
    state = np.where(slip, SLIP, np.where(stick, STICK, OPEN)).astype(np.int8)
    return Linearisation(np.concatenate([F.ravel(), h]), J, state, Q, lam_hat, t)


@dataclass(frozen=True)
class NewtonResult:
    x: np.ndarray
    lin: Linearisation
    converged: bool
    n_iterations: int
    residual: float
    cycling: bool


def newton(x0, inc: Increment, Wfull, Wa_T, gap, mu, r, atol, max_iterations=50) -> NewtonResult:
    """Semi-smooth Newton with Armijo backtracking on 0.5 |F|^2 from x0."""
    x = x0.copy()
    lin = linearise(x, inc, Wfull, Wa_T, gap, mu, r)
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
            dx = la.solve(lin.J, -lin.F, check_finite=False)
        except la.LinAlgError:
            break
        if not np.all(np.isfinite(dx)):
            break
        merit = 0.5 * lin.F @ lin.F
        step = 1.0
        while True:
            trial = linearise(x + step * dx, inc, Wfull, Wa_T, gap, mu, r)
            if 0.5 * trial.F @ trial.F <= (1 - 1e-4 * step) * merit or step < 1e-3:
                break
            step *= 0.5
        x, lin = x + step * dx, trial
    return NewtonResult(x, lin, False, iteration, float(np.max(np.abs(lin.F), initial=0.0)), cycling)


def stick_predictor(inc: Increment, Wfull, Wa_T, gap, r, held: np.ndarray) -> np.ndarray | None:
    """Elastic predictor: the ``held`` pairs closed and stuck (no slip increment), the others open.

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
