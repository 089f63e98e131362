"""The load path: increments solved in order, cut when Newton fails, sensitivities carried along (DDM).

Direct differentiation of the converged increment n (docs/design.md, sensitivities):

    J_n S_n = -(dF/dmu + dF/dw_prev W_full S_{n-1}),   S = dx/dmu,   S_0 = 0,

with dF_T/dmu_z = -lam_hat t share_z on slipping pairs and dF_T/dw_prev_T = -Q_TT (stick and slip rows).
Tangential directions held by the supports enter J and Q through the projectors of
:func:`frictionid.fem.contact.free_tangents`, so the sensitivities treat them as the increments do: no friction
force in them, its derivative zero.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from ..errors import SolverError
from .condense import Condensed
from .contact import (OPEN, SLIP, Increment, Linearisation, NewtonResult, free_tangents, held_normals, jacobian,
                      newton, stick_predictor)
from .pairs import ContactPairs
from .updated_jacobian import StuckInverses, UpdatedSolver

log = logging.getLogger(__name__)
MAX_CUTS = 8
#: how the Newton steps and sensitivities solve with the Jacobian: "updated" (corrections of the model's stuck
#: inverse, fem/updated_jacobian.py) or "dense" (a fresh LU factorisation each time: the previous path, kept for
#: the equality tests and benchmarks/contact_solves.py)
_LINEAR = "updated"
#: Newton starts from the secant of the last two increments where the state predictor is singular or not made
#: (:meth:`LoadPathSolver._secant`); False: the stick predictor there (the previous path, kept for the equality
#: tests and benchmarks)
SECANT = True


def contact_scale(condensed: Condensed) -> float:
    """r = 1 / mean(diag W) [N/mm], the scale of the Alart-Curnier equations."""
    mean = getattr(condensed.gap_ops.on_lam, "mean_diagonal", None)     # W applied, not stored (condense_implicit)
    if mean is not None:
        return 1.0 / mean
    diag = np.diag(condensed.gap_ops.on_lam)
    return 1.0 / np.mean(diag) if diag.size else 1.0


def stuck_inverses(condensed: Condensed, pairs: ContactPairs) -> StuckInverses:
    """The model's :class:`~frictionid.fem.updated_jacobian.StuckInverses` (its ``base`` None: J0 unusable,
    dense solves)."""
    return StuckInverses(condensed.gap_ops.full, condensed.equilibrium.on_lam, contact_scale(condensed),
                         free_tangents(pairs.B, condensed.free, pairs.dim),
                         held_normals(pairs.B, condensed.free, pairs.dim))


@dataclass
class _Path:
    """Running state along the path: x, tangential w, sensitivities."""

    x: np.ndarray
    w_T: np.ndarray
    S: np.ndarray | None
    state: np.ndarray | None = None   # contact state of the last converged increment
    direction: np.ndarray | None = None   # (n_pairs, dim - 1) its slip directions
    #: (n_pairs, dim - 1, n_z) derivative of w_T; None: W S (a caller that changes the coupling between
    #: increments sets it, fem/sliding.py)
    dw_T: np.ndarray | None = None
    #: (amplitude, x) of the converged increment before x, the secant start's other point (None: unknown)
    before: tuple[np.ndarray, np.ndarray] | None = None


@dataclass(frozen=True)
class StepResult:
    """How one nominal increment went: the converged state's contact states, Newton iterations and cuts."""

    state: np.ndarray
    n_newton: int
    n_cuts: int


class LoadPathSolver:
    """Solves a condensed problem along the load path for one vector of zone coefficients."""

    def __init__(self, condensed: Condensed, pairs: ContactPairs, rtol: float = 1e-10,
                 stuck: StuckInverses | None = None, linear=None, zones: np.ndarray | None = None):
        self.c, self.pairs = condensed, pairs
        #: the pairs' shares of the zones whose coefficients the sensitivities are taken to (``zones``: their
        #: indices; None: every zone), one column per zone
        self.share = pairs.zone_share if zones is None else pairs.zone_share[:, zones]
        self.Wfull = condensed.gap_ops.full
        self.Wa_T = condensed.equilibrium.on_lam
        self.r = contact_scale(condensed)
        self.rtol = rtol
        #: projectors onto the tangential directions the supports leave free (None: all free); those the stuck
        #: inverses were made with (the same model) where given
        self.free_T = stuck.free_T if stuck is not None else linear.free_T if linear is not None else \
            free_tangents(pairs.B, condensed.free, pairs.dim)
        #: J^-1 by corrections of the inverses ``stuck`` (:func:`stuck_inverses`), or by ``linear`` (a solver with
        #: UpdatedSolver's interface: fem/contact_krylov.py); None: dense solves
        self.updated = linear if linear is not None else UpdatedSolver(stuck) if stuck is not None \
            and stuck.base is not None and _LINEAR == "updated" else None
        #: contact states (bytes of the state array) whose state predictor was singular: not tried again. Where
        #: every closed pair slips, the predictor's rows fix lam_T by lam_N alone and leave the floating bodies'
        #: tangential motion free (the full M6 nut in gross slip: reciprocal condition 3e-19 at each increment,
        #: each estimate a capacitance factorisation, 19 % of the solve; docs/bolt-study.md)
        self.singular_states: set[bytes] = set()

    def start(self) -> _Path:
        """The unloaded state the load path starts from."""
        n_x = self.pairs.n_pairs * self.pairs.dim + self.c.n_modes
        return _Path(np.zeros(n_x), np.zeros((self.pairs.n_pairs, self.pairs.dim - 1)), None)

    def _solve(self, lin: Linearisation, rhs, check: bool = True) -> np.ndarray:
        """J^-1 rhs for the Jacobian of ``lin`` (``check``: see :class:`UpdatedSolver`)."""
        if self.updated is not None:
            return self.updated(lin.P, lin.Q, rhs, check)
        return la.lu_solve(la.lu_factor(jacobian(lin.P, lin.Q, self.Wfull, self.Wa_T), check_finite=False), rhs,
                           check_finite=False)

    def _times_W(self, x) -> np.ndarray:
        """Wfull x (the updated solver keeps it from its residual check of x)."""
        return self.updated.times_W(x) if self.updated is not None else self.Wfull @ x

    def _step(self, lin: Linearisation, rhs) -> np.ndarray:
        """A Newton step: Newton checks the residual it reaches itself."""
        return self._solve(lin, rhs, check=False)

    def _predictor(self, inc: Increment, held: np.ndarray, mu=None, path: _Path | None = None) -> np.ndarray | None:
        """:func:`~frictionid.fem.contact.stick_predictor` as the Jacobian system of ``held`` pairs stuck and the
        others open (rows scaled by r), solved by the updated solver; None when that system is singular.

        With ``path``: the state predictor instead, the contact states of its last increment held: its slipping
        pairs closed (g = 0) and slipping in their last direction t (lam_T = mu lam_N t), the others as above. Where the
        states and (in 2-D) the slip directions stay, as in gross slip, it is the increment's solution."""
        n_pairs, dim = self.pairs.n_pairs, self.pairs.dim
        state = None if path is None else path.state.tobytes()
        if state in self.singular_states:
            return None
        s = self.updated.inverses.base                  # its stuck rows (held gaps: open rows)
        P = np.where(held[:, None, None], s.P0, np.eye(dim))
        Q = np.where(held[:, None, None], s.Q0, 0.0)
        slip = np.zeros(n_pairs, dtype=bool) if path is None else path.state == SLIP
        if slip.any():
            # the rows linearise makes for slip at lam_hat = lam_N, tau along t: the same rows as Newton's, so
            # the same factorisation serves both while the states stay (gross slip)
            P[slip, 1:, 0] = -mu[slip, None] * path.direction[slip]
            P[slip, 1:, 1:] = np.eye(dim - 1)
            Q[slip, 1:, 0] = self.r * mu[slip, None] * path.direction[slip]
            Q[slip, 1:, 1:] = 0.0
        if self.updated.rcond(P, Q) < np.finfo(float).eps:
            if state is not None:
                self.singular_states.add(state)
            return None
        target = (np.column_stack([-self.pairs.gap, inc.w_prev_T]).ravel() - inc.w0).reshape(n_pairs, dim)
        if self.free_T is not None:
            target[:, 1:] = np.einsum("nij,nj->ni", self.free_T, target[:, 1:])
        target[slip, 1:] = (mu[slip] * target[slip, 0])[:, None] * path.direction[slip] if slip.any() else 0.0
        rhs = np.concatenate([np.where(held[:, None], self.r * target, 0.0).ravel(), -inc.h0])
        x = self.updated(P, Q, rhs, check=False)           # a start: Newton checks where it leads
        return x if np.all(np.isfinite(x)) else None

    def _increment(self, amplitude, w_prev_T) -> Increment:
        return Increment(self.c.gap_ops.channels.T @ amplitude, w_prev_T,
                         self.c.equilibrium.channels.T @ amplitude)

    def _atol(self, inc: Increment, x) -> float:
        n_w = len(self.pairs.gap) * self.pairs.dim
        scale = max(np.max(np.abs(x[:n_w]), initial=0.0), self.r * np.max(np.abs(inc.w0), initial=0.0),
                    np.max(np.abs(inc.h0), initial=0.0), 1e-300)
        return self.rtol * scale

    def _newton(self, path: _Path, start, amplitude, mu) -> NewtonResult:
        """Newton from the predictors of :meth:`_starts`, each tried when the one before failed."""
        inc = self._increment(amplitude, path.w_T)
        if path.state is None:
            extent = np.ptp(self.pairs.position) if self.pairs.n_pairs else 1.0
            held = self.pairs.gap <= 1e-9 * (extent or 1.0)
        else:
            held = path.state != OPEN
        for x0 in self._starts(path, inc, held, mu, start, amplitude):
            result = newton(x0, inc, self.Wfull, self.Wa_T, self.pairs.gap, mu, self.r, self._atol(inc, x0),
                            free_T=self.free_T, solve=self._step)
            if not result.converged and result.residual <= self._atol(inc, result.x):
                # the tolerance scales with the solution, which may have grown during the iterations
                result = NewtonResult(result.x, result.lin, True, result.n_iterations, result.residual, False)
            if result.converged:
                return result
        return result

    def _starts(self, path: _Path, inc: Increment, held: np.ndarray, mu, start, amplitude):
        """Newton's starts, each made when the one before failed: the state predictor (updated solves, after
        the first increment), where it is singular or not made the secant start (:meth:`_secant`), the stick
        predictor, the previous solution."""
        if self.updated is None:
            x0 = stick_predictor(inc, self.Wfull, self.Wa_T, self.pairs.gap, self.r, held, self.free_T)
        else:
            x0 = self._predictor(inc, held, mu, path) if path.state is not None else None
            if x0 is None and SECANT:
                x0 = self._secant(path, start, amplitude)
            if x0 is not None:
                yield x0
            x0 = self._predictor(inc, held)
        if x0 is not None:
            yield x0
        yield path.x

    @staticmethod
    def _secant(path: _Path, start, amplitude) -> np.ndarray | None:
        """The solution extrapolated along the secant of the last two converged increments, x + c (x - x_before),
        where the load moves on along the same direction (amplitude - start = c (start - amplitude_before),
        c > 0: proportional loading, or one channel ramped with the others held); None elsewhere.

        Where every closed pair of a floating body slips, the state predictor is singular (it leaves the body's
        tangential motion free) and the stick predictor starts far from the solution: in 3-D each of its Newton
        steps has other replaced rows and slip directions, a fresh capacitance factorisation each
        (docs/bolt-study.md). In gross slip from the first increment under a proportional load and zero initial
        gaps the secant start is the increment's solution (x and w_T grow in proportion, the slip directions
        stay); elsewhere a start near it, which Newton corrects."""
        if path.before is None:
            return None
        amplitude_before, x_before = path.before
        last, step = np.asarray(start, float) - amplitude_before, np.asarray(amplitude, float) - start
        size = float(last @ last)
        if size == 0.0:
            return None
        c = float(step @ last) / size
        if not c > 0.0 or np.max(np.abs(step - c * last), initial=0.0) > 1e-12 * np.max(np.abs(step), initial=0.0):
            return None
        return path.x + c * (path.x - x_before)

    def _sensitivity(self, path: _Path, lin: Linearisation, zone_share) -> np.ndarray:
        n_pairs, dim = self.pairs.n_pairs, self.pairs.dim
        n_z = zone_share.shape[1]
        rhs = np.zeros((len(lin.F), n_z))
        slip = lin.state == SLIP
        top = rhs[:n_pairs * dim].reshape(n_pairs, dim, n_z)
        top[slip, 1:, :] = -(lin.lam_hat[slip, None, None] * lin.direction[slip, :, None]
                             * zone_share[slip, None, :])
        if path.dw_T is not None or path.S is not None:
            dw_prev = path.dw_T if path.dw_T is not None else \
                self._times_W(path.S).reshape(n_pairs, dim, n_z)[:, 1:, :]
            top[:, 1:, :] -= np.einsum("nij,njz->niz", lin.Q[:, 1:, 1:], dw_prev)
        return self._solve(lin, -rhs)

    def _overlap_held(self, amplitude) -> str:
        """The failure's likely cause where pairs that overlap at ``amplitude`` have their gap held by the
        supports on both sides (:func:`held_normals`), else ''."""
        held = held_normals(self.pairs.B, self.c.free, self.pairs.dim)
        gap = self.pairs.gap + self._increment(amplitude, None).w0[::self.pairs.dim]
        stuck = np.flatnonzero(held & (gap < 0))
        if not stuck.size:
            return ""
        i = stuck[0]
        return (f"; the supports hold both sides of {len(stuck)} overlapping contact pair(s) in the normal "
                f"direction (first at node {int(self.pairs.nodes[i])}, position "
                f"{np.round(self.pairs.position[i], 6).tolist()}), so their gap cannot close and their contact "
                "force is undetermined: release the normal support on one side of the interface")

    def step(self, path: _Path, start, end, mu, sensitivities: bool, where: str) -> StepResult:
        """Advance ``path`` from amplitude ``start`` to ``end``, halving the step on failure."""
        pending = [(start, end, 0)]
        n_newton = n_cuts = 0
        while pending:
            a, b, depth = pending.pop()
            result = self._newton(path, a, b, mu)
            n_newton += result.n_iterations
            if not result.converged:
                if depth >= MAX_CUTS:
                    raise SolverError(
                        f"contact did not converge in {where}: residual {result.residual:.3g} N after "
                        f"{result.n_iterations} Newton iterations and {depth} increment cuts"
                        + ("; the active set cycles" if result.cycling else "") + self._overlap_held(b))
                n_cuts += 1
                log.info("%s: Newton stalled at residual %.3g N, cutting the increment (cut %d)",
                         where, result.residual, depth + 1)
                middle = 0.5 * (a + b)
                pending += [(middle, b, depth + 1), (a, middle, depth + 1)]
                continue
            if sensitivities:
                path.S, path.dw_T = self._sensitivity(path, result.lin, self.share), None
            w = self.c.gap_ops(b, result.x).reshape(self.pairs.n_pairs, self.pairs.dim)
            path.before = (np.asarray(a, float), path.x)
            path.x, path.w_T, path.state = result.x, w[:, 1:], result.lin.state
            path.direction = result.lin.direction
        return StepResult(path.state, n_newton, n_cuts)
