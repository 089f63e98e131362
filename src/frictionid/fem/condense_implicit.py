"""Condensation that never forms the contact compliance W: the operators of fem/condense.py with W applied by the
sparse factor of K.

The dense path (:func:`frictionid.fem.condense.condense`) makes W = B_f K^g B_f^T (n_w x n_w) and the load path
inverts the stuck contact Jacobian built from it: n_w^3 flops and about 4 n_w^2 doubles (docs/bolt-study.md, "What
limits a 3-D solve"). Here K_ff is factorised once in a fill-reducing order (no dofs ordered last) and

    W x = B_f K^g (B_f^T x)        one sparse solve per product,

while the outputs with few rows stay dense, each row from one solve: the observations G = O_f K^g B_f^T
= (B_f K^g O_f^T)^T (n_obs solves) and the reaction sums (n_reac solves, as on the dense path). The contact scale
r = 1 / mean(diag W) is the mean over at most :data:`SCALE_PAIRS` pairs spread over the interface (exact where a
model has no more pairs; the solution does not depend on r, only Newton's path does). The load path then solves
its Newton systems iteratively (:mod:`frictionid.fem.contact_krylov`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from . import cholesky
from .assembly import LoadChannels
from .condense import Affine, Condensed, GeneralisedInverse, factorisation_name, partition

log = logging.getLogger(__name__)

#: pairs whose diagonal blocks of W are computed for the contact scale r (dim solves each)
SCALE_PAIRS = 8
#: Problem.build(contact="auto") takes this path above this many contact dofs (dim x pairs, small sliding): never
#: for now. It saves the dense path's 4 n_w^2 doubles, but on every size measured it was 10-100x slower than the
#: dense path (docs/bolt-study.md, "What limits a 3-D solve"), so it is taken only when asked for
#: (``contact="implicit"``)
IMPLICIT_ABOVE = float("inf")


class Compliance:
    """W = B_f K^g B_f^T (n_w x n_w) applied by solves with a :class:`~frictionid.fem.condense.GeneralisedInverse`;
    ``W @ x`` for x (n_w,) or (n_w, k). ``mean_diagonal``: the mean of diag W over the sampled pairs."""

    def __init__(self, inverse: GeneralisedInverse, B_f: sp.csr_matrix, mean_diagonal: float, nodes: np.ndarray):
        self.inverse, self.B_f, self.mean_diagonal = inverse, sp.csr_matrix(B_f), float(mean_diagonal)
        self.nodes = nodes                     # (n_f,) the node of each free dof (for a fill-reducing order)
        self.shape = (B_f.shape[0], B_f.shape[0])
        #: right-hand sides solved for so far (products)
        self.n_solves = 0

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        self.n_solves += 1 if x.ndim == 1 else x.shape[1]
        return self.B_f @ self.inverse.solve(self.B_f.T @ x)


class FullCompliance:
    """[W | W_a] (n_w x (n_w + m)) applied to x = (lam, alpha): ``Wfull @ x`` for x (n_w + m,) or (n_w + m, k)."""

    def __init__(self, W: Compliance, W_a: np.ndarray):
        self.W, self.W_a = W, W_a
        self.shape = (W.shape[0], W.shape[0] + W_a.shape[1])

    @property
    def mean_diagonal(self) -> float:
        return self.W.mean_diagonal

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        n_w = self.W.shape[0]
        return self.W @ x[:n_w] + self.W_a @ x[n_w:]


@dataclass(frozen=True)
class ImplicitAffine(Affine):
    """An :class:`~frictionid.fem.condense.Affine` whose ``on_lam`` is a :class:`Compliance` (never dense)."""

    @property
    def full(self) -> FullCompliance:
        return FullCompliance(self.on_lam, self.on_alpha)


def is_implicit(condensed: Condensed) -> bool:
    """Whether ``condensed`` came from :func:`condense_implicit` (its W is applied, not stored)."""
    return isinstance(condensed.gap_ops, ImplicitAffine)


def sampled_mean_diagonal(inverse: GeneralisedInverse, B_f: sp.csr_matrix, dim: int,
                          n_sample: int = SCALE_PAIRS) -> float:
    """mean(diag W) over ``n_sample`` pairs evenly spread over the pair order (all pairs where there are fewer)."""
    n_pairs = B_f.shape[0] // dim
    if n_pairs == 0:
        return 1.0
    pairs = np.unique(np.linspace(0, n_pairs - 1, min(n_pairs, n_sample)).round().astype(int))
    rows = (dim * pairs[:, None] + np.arange(dim)).ravel()
    columns = B_f[rows]
    solved = inverse.solve(columns.T.toarray())                            # (n_f, len(rows))
    return float(np.mean(np.asarray(columns.multiply(solved.T).sum(axis=1)).ravel()))


def condense_implicit(K: sp.csr_matrix, B: sp.csr_matrix, channels: LoadChannels, modes: np.ndarray,
                      observe: sp.csr_matrix, reaction_sums: sp.csr_matrix, dim: int = 2,
                      factorisation: str = "auto") -> Condensed:
    """The operators of :func:`frictionid.fem.condense.condense` (same arguments) with W applied, not formed."""
    f, p, K_ff, K_fp, K_pf, K_pp, R, B_f, B_p, O_f, O_p = partition(K, B, channels, modes, observe)
    name = factorisation_name(factorisation)
    if name == "mumps":     # MUMPS gives the dense path's Schur complements; here K is solved with, column by column
        name = "cholmod" if cholesky.available() else "superlu"
        log.warning("implicit condensation: factorisation 'mumps' is for the dense contact operators; the implicit "
                    "path factorises K with %s", "CHOLMOD" if name == "cholmod" else "SuperLU")
    if name in ("cholmod", "cholmod_solves"):
        inverse = GeneralisedInverse(K_ff, R, last=np.zeros(0, int), nodes=f // dim)
    else:
        inverse = GeneralisedInverse(K_ff, R, "COLAMD" if dim == 2 else "MMD_AT_PLUS_A")
    b = channels.forces[:, f].T - K_fp @ channels.displacements.T          # (n_f, n_channels)
    sums_K = (reaction_sums @ K_pf).tocsr()
    columns = [b, sums_K.T.toarray(), O_f.T.toarray()]
    split = np.cumsum([c.shape[1] for c in columns])
    Y, X_sums, X_obs, _ = np.split(inverse.solve(np.hstack(columns)), split, axis=1)
    W = Compliance(inverse, B_f, sampled_mean_diagonal(inverse, B_f, dim), f // dim)
    log.info("implicit condensation: %d contact dofs, %d observation rows, %d reaction sums solved for",
             B.shape[0], O_f.shape[0], sums_K.shape[0])
    up = channels.displacements.T
    reac_channels = K_pf @ Y + K_pp @ up - channels.forces[:, p].T
    return Condensed(
        free=f, prescribed=p, modes=R, inverse=inverse, particular=Y.T,
        gap_ops=ImplicitAffine((B_f @ Y + B_p @ up).T, W, B_f @ R),
        obs_ops=Affine((O_f @ Y + O_p @ up).T, (B_f @ X_obs).T, O_f @ R),
        reac_ops=Affine((reaction_sums @ reac_channels).T, (B_f @ X_sums).T - (reaction_sums @ B_p.T).toarray(),
                        reaction_sums @ (K_pf @ R)),
        equilibrium=Affine((R.T @ b).T, (B_f @ R).T, np.zeros((R.shape[1], R.shape[1]))),
    )
