"""Static condensation of a model onto its contact pairs, observation rows and reaction sums.

With free dofs f, prescribed dofs p, rigid modes R of floating bodies and a generalised inverse K^g of K_ff,

    u_f = K^g (b + B_f^T lam) + R alpha,     R^T (b + B_f^T lam) = 0,     b = f_f - K_fp u_p,

so every output is affine in (lam, alpha):  w = w0 + W lam + W_a alpha,  obs = obs0 + G lam + G_a alpha,
reactions = reac0 + C lam + C_a alpha. The operators do not depend on mu nor on the load level: they are
computed once per geometry (one sparse factorisation and d * n_pairs solves).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InputError
from ..progress import bar
from .assembly import LoadChannels

_BLOCK = 256  # right-hand sides per block solve


@dataclass(frozen=True)
class Affine:
    """An output that is affine in (lam, alpha): value = channels @ amplitude + on_lam @ lam + on_alpha @ alpha."""

    channels: np.ndarray   # (n_channels, n_out)
    on_lam: np.ndarray     # (n_out, n_w)
    on_alpha: np.ndarray   # (n_out, m)

    def __call__(self, amplitude: np.ndarray, x: np.ndarray) -> np.ndarray:
        n_w = self.on_lam.shape[1]
        return amplitude @ self.channels + self.on_lam @ x[:n_w] + self.on_alpha @ x[n_w:]

    @property
    def full(self) -> np.ndarray:
        """(n_out, n_w + m) derivative with respect to x = (lam, alpha)."""
        return np.hstack([self.on_lam, self.on_alpha])


class GeneralisedInverse:
    """Solves K_ff u = b for self-equilibrated b, with the floating bodies pinned at a few dofs.

    Pickled without its factor (SuperLU objects cannot be), which is computed again at the first solve after
    unpickling."""

    def __init__(self, K_ff: sp.csr_matrix, modes: np.ndarray, ordering: str = "MMD_AT_PLUS_A"):
        n = K_ff.shape[0]
        pinned = la.qr(modes.T, pivoting=True, mode="r")[1][:modes.shape[1]] if modes.size else np.zeros(0, int)
        self.keep = np.setdiff1d(np.arange(n), pinned)
        self.n = n
        self.matrix, self.ordering = K_ff[self.keep][:, self.keep].tocsc(), ordering
        self.lu = self._factor()

    def _factor(self):
        try:
            return spla.splu(self.matrix, permc_spec=self.ordering)
        except RuntimeError:
            raise InputError("model: the stiffness matrix is singular: a body is not held by supports or "
                             "contact in some direction (a mechanism)") from None

    def __getstate__(self):
        return {**self.__dict__, "lu": None}

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self.lu is None:
            self.lu = self._factor()
        out = np.zeros((self.n,) + b.shape[1:])
        out[self.keep] = self.lu.solve(np.ascontiguousarray(b[self.keep]))
        return out


@dataclass(frozen=True)
class Condensed:
    """Condensed operators of one geometry (see module docstring).

    Attributes
    ----------
    gap_ops : Affine for w (pair-major, n_w = dim * n_pairs) [mm]
    obs_ops : Affine for the observation rows
    reac_ops : Affine for the reaction sums [N]
    equilibrium : Affine for R^T (b + B_f^T lam) [N], zero in equilibrium (m rows)
    """

    free: np.ndarray
    prescribed: np.ndarray
    modes: np.ndarray
    inverse: GeneralisedInverse
    particular: np.ndarray       # (n_channels, n_f) K^g b of each channel
    gap_ops: Affine
    obs_ops: Affine
    reac_ops: Affine
    equilibrium: Affine

    @property
    def n_modes(self) -> int:
        return self.modes.shape[1]

    def displacement(self, B: sp.csr_matrix, prescribed_values: np.ndarray, amplitude: np.ndarray,
                     x: np.ndarray) -> np.ndarray:
        """Full dof vector u [mm] for load amplitudes and x = (lam, alpha): one solve with the stored factor.

        ``prescribed_values`` (n_channels, n_prescribed) are the unit prescribed displacements of the channels.
        """
        n_w = B.shape[0]
        u = np.zeros(len(self.free) + len(self.prescribed))
        load = B[:, self.free].T @ x[:n_w]
        u[self.free] = amplitude @ self.particular + self.inverse.solve(load) + self.modes @ x[n_w:]
        u[self.prescribed] = amplitude @ prescribed_values
        return u


def condense(K: sp.csr_matrix, B: sp.csr_matrix, channels: LoadChannels, modes: np.ndarray,
             observe: sp.csr_matrix, reaction_sums: sp.csr_matrix, dim: int = 2) -> Condensed:
    """Condense the model onto the contact pairs.

    Parameters
    ----------
    K : (n_dofs, n_dofs) stiffness; B : (n_w, n_dofs) relative displacement operator
    modes : (n_dofs, m) rigid modes vanishing on prescribed dofs
    observe : (n_obs, n_dofs) observation rows; reaction_sums : (n_reac, n_prescribed) sums of reactions
    """
    n = K.shape[0]
    p = channels.prescribed
    f = np.setdiff1d(np.arange(n), p)
    K = K.tocsr()
    K_ff, K_fp, K_pf, K_pp = K[f][:, f], K[f][:, p], K[p][:, f], K[p][:, p]
    R = modes[f]
    # SuperLU orderings measured here: 2-D 52k dofs COLAMD factors in 0.45 s vs 1.8 s (MMD), same solves;
    # 3-D 17k dofs MMD_AT_PLUS_A solves 363 right-hand sides in 2.1 s vs 13 s (COLAMD)
    inverse = GeneralisedInverse(K_ff, R, "COLAMD" if dim == 2 else "MMD_AT_PLUS_A")
    B_f, B_p = B[:, f].tocsr(), B[:, p].tocsr()
    O_f, O_p = observe[:, f].tocsr(), observe[:, p].tocsr()
    n_w = B.shape[0]
    W, G, KX = np.zeros((n_w, n_w)), np.zeros((observe.shape[0], n_w)), np.zeros((len(p), n_w))
    for start in bar(range(0, n_w, _BLOCK), -(-n_w // _BLOCK), f"condensation ({n_w} columns)"):
        cols = slice(start, min(start + _BLOCK, n_w))
        X = inverse.solve(B_f[cols].T.toarray())
        W[:, cols] = B_f @ X
        G[:, cols] = O_f @ X
        KX[:, cols] = K_pf @ X
    W = 0.5 * (W + W.T)
    b = channels.forces[:, f].T - K_fp @ channels.displacements.T          # (n_f, n_channels)
    Y = inverse.solve(b)
    up = channels.displacements.T
    reac_channels = K_pf @ Y + K_pp @ up - channels.forces[:, p].T
    return Condensed(
        free=f, prescribed=p, modes=R, inverse=inverse, particular=Y.T,
        gap_ops=Affine((B_f @ Y + B_p @ up).T, W, B_f @ R),
        obs_ops=Affine((O_f @ Y + O_p @ up).T, G, O_f @ R),
        reac_ops=Affine((reaction_sums @ reac_channels).T, reaction_sums @ (KX - B_p.T.toarray()),
                        reaction_sums @ (K_pf @ R)),
        equilibrium=Affine((R.T @ b).T, (B_f @ R).T, np.zeros((R.shape[1], R.shape[1]))),
    )
