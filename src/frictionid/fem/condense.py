"""Static condensation of a model onto its contact pairs, observation rows and reaction sums.

With free dofs f, prescribed dofs p, rigid modes R of floating bodies and a generalised inverse K^g of K_ff,

    u_f = K^g (b + B_f^T lam) + R alpha,     R^T (b + B_f^T lam) = 0,     b = f_f - K_fp u_p,

so every output is affine in (lam, alpha):  w = w0 + W lam + W_a alpha,  obs = obs0 + G lam + G_a alpha,
reactions = reac0 + C lam + C_a alpha. The operators do not depend on mu nor on the load level: they are
computed once per geometry, W and G as T K^g B_f^T with sparse rows T = [B_f; O_f], C as (B_f K^g K_fp S_r^T)^T
(n_reac solves):

- "cholmod" (the default where kvxopt is installed): one sparse Cholesky factorisation with the dofs that T
  touches ordered last; T K^g B_f^T then comes from the Schur complement onto those dofs, which is the factor's
  trailing block (fem/cholesky.py), by dense triangular solves; the factor is kept for the solves after the
  condensation (the displacement field);
- "superlu" (the fallback): one sparse LU factorisation and n_w = d * n_pairs solves, in blocks of columns;
- "cholmod_solves": CHOLMOD's factor in a fill-reducing order of all dofs and the n_w solves in blocks of columns.
  Ordering thousands of contact dofs last makes the factor of a 3-D model far larger: the short 3-D bolt (132k
  tetra10 nodes, 1,703 contact pairs) went past 12 GB in the factorisation with them last;
- "mumps": per body, MUMPS's multifrontal factorisation with the dofs T touches eliminated last but the interior
  in MUMPS's own nested-dissection order, which returns the body's dense Schur complement (fem/mumps_schur.py);
  T K^g B_f^T from its Cholesky factor as for "cholmod", the other solves by MUMPS's factor of the interior. The
  Schur complements' Cholesky factors are kept after the condensation, MUMPS's factors of the interiors are not:
  displacements on the dofs eliminated last come from the former alone (:meth:`Condensed.displacement_at`).
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from ..errors import InputError
from ..progress import bar
from . import cholesky, mumps_schur
from .assembly import LoadChannels
from .threads import blas_threads_for

log = logging.getLogger(__name__)

_BLOCK = 256  # right-hand sides per block solve
#: ways to factorise K_ff; "auto" takes "cholmod" where kvxopt is installed, else "superlu"; "cholmod_solves"
#: (Python API only) factorises in a fill-reducing order of all dofs and condenses by block solves: for models whose
#: factor with the contact dofs ordered last does not fit in memory (the short 3-D bolt: module docstring)
FACTORISATIONS = ("auto", "cholmod", "superlu", "cholmod_solves", "mumps")


def factorisation_name(name: str) -> str:
    """The factorisation ``name`` stands for ("auto" resolved); InputError for an unknown or unavailable one."""
    if name not in FACTORISATIONS:
        raise InputError(f"`factorisation` must be one of {', '.join(map(repr, FACTORISATIONS))}, got {name!r}")
    if name == "superlu" or (name == "auto" and not cholesky.available()):
        return "superlu"
    if name == "mumps":
        if not mumps_schur.available():
            raise InputError("`factorisation` 'mumps' needs the python-mumps wheel (pip install python-mumps==0.0.2)")
        return name
    if not cholesky.available():
        raise InputError(f"`factorisation` {name!r} needs the kvxopt package (pip install kvxopt)")
    return "cholmod" if name == "auto" else name


@dataclass(frozen=True)
class Affine:
    """An output that is affine in (lam, alpha): value = channels @ amplitude + on_lam @ lam + on_alpha @ alpha."""

    channels: np.ndarray   # (n_channels, n_out)
    on_lam: np.ndarray     # (n_out, n_w)
    on_alpha: np.ndarray   # (n_out, m)

    def __call__(self, amplitude: np.ndarray, x: np.ndarray) -> np.ndarray:
        n_w = self.on_lam.shape[1]
        return amplitude @ self.channels + self.on_lam @ x[:n_w] + self.on_alpha @ x[n_w:]

    @classmethod
    def sharing(cls, channels: np.ndarray, on_lam: np.ndarray, on_alpha: np.ndarray) -> "Affine":
        """The same output with ``on_lam`` and ``on_alpha`` views of one (n_out, n_w + m) array, :attr:`full`:
        W held once (n_w^2 doubles, 2.45 GB at 17,500 contact dofs) where a body floats, not once more beside it."""
        full = np.hstack([on_lam, on_alpha])
        n_w = on_lam.shape[1]
        affine = cls(channels, full[:, :n_w], full[:, n_w:])
        affine.__dict__["full"] = full
        return affine

    @functools.cached_property
    def full(self) -> np.ndarray:
        """(n_out, n_w + m) derivative with respect to x = (lam, alpha): ``on_lam`` itself where no body floats,
        else made once and kept (the load path and the stuck inverses read it; a copy each took n_w^2 doubles,
        2.45 GB at 17,500 contact dofs), or the array ``on_lam`` is a view of (:meth:`sharing`). Read only."""
        if self.on_alpha.shape[1] == 0:
            return self.on_lam
        return np.hstack([self.on_lam, self.on_alpha])

    def __getstate__(self):
        state = dict(self.__dict__)
        state.pop("full", None)                      # shipped as on_lam and on_alpha
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        if isinstance(self.on_lam, np.ndarray) and self.on_alpha.shape[1]:
            shared = Affine.sharing(self.channels, self.on_lam, self.on_alpha)    # views of one array again
            self.__dict__.update(on_lam=shared.on_lam, on_alpha=shared.on_alpha, full=shared.full)


class GeneralisedInverse:
    """Solves K_ff u = b for self-equilibrated b, with the floating bodies pinned at a few dofs.

    With ``last`` (free dofs) and ``nodes`` (the node of each free dof) K_ff is factorised by CHOLMOD with
    ``last`` ordered last, so that :meth:`coupled` takes the Schur complement onto them from the factor; without
    them by SuperLU; with ``last`` and ``solver = "mumps"`` by MUMPS, body by body, with ``last`` eliminated last
    (:class:`~frictionid.fem.mumps_schur.BodySchur`). Pickled without its factor (SuperLU objects cannot be),
    which is computed again at the first solve after unpickling."""

    def __init__(self, K_ff: sp.csr_matrix, modes: np.ndarray, ordering: str = "MMD_AT_PLUS_A",
                 last: np.ndarray | None = None, nodes: np.ndarray | None = None, solver: str = "cholmod"):
        n = K_ff.shape[0]
        pinned = la.qr(modes.T, pivoting=True, mode="r")[1][:modes.shape[1]] if modes.size else np.zeros(0, int)
        self.keep = np.setdiff1d(np.arange(n), pinned)
        self.n = n
        self.matrix, self.ordering = K_ff[self.keep][:, self.keep].tocsc(), ordering
        self.lu = self.cholesky = self.bodies = None
        if last is None:
            self.lu = self._factor()
        elif solver == "mumps":
            last = np.searchsorted(self.keep, np.intersect1d(last, self.keep))
            try:
                self.bodies = mumps_schur.BodySchur(self.matrix, last)
            except mumps_schur.MumpsError as error:
                raise InputError(f"{_SINGULAR} ({error})") from None
        else:
            last = np.searchsorted(self.keep, np.intersect1d(last, self.keep))
            try:
                self.cholesky = cholesky.Cholesky(self.matrix, last, nodes[self.keep])
            except ArithmeticError:
                raise InputError(_SINGULAR) from None

    def _factor(self):
        try:
            return spla.splu(self.matrix, permc_spec=self.ordering)
        except RuntimeError:
            raise InputError(_SINGULAR) from None

    def __getstate__(self):
        return {**self.__dict__, "lu": None}

    def release(self) -> None:
        """Free what the solves after the condensation use, CHOLMOD's kept factor (fem/cholesky.SparseFactor)
        and MUMPS's factors (the Schur complements' Cholesky factors stay): a later solve factorises again."""
        if self.cholesky is not None:
            self.cholesky.sparse = None
        if self.bodies is not None:
            self.bodies.free(schur=False)

    def solve(self, b: np.ndarray) -> np.ndarray:
        out = np.zeros((self.n,) + b.shape[1:])
        if self.cholesky is not None or self.bodies is not None:
            out[self.keep] = self._solve_kept(b[self.keep])
            return out
        if self.lu is None:
            self.lu = self._factor()
        out[self.keep] = self.lu.solve(np.ascontiguousarray(b[self.keep]))
        return out

    def coupled(self, rows: sp.csr_matrix, n_w: int) -> np.ndarray:
        """rows K^g rows[:n_w]^T (n_rows, n_w) for sparse rows (n_rows, n): from the Schur complement where the
        factor has the dofs the rows touch ordered last, else by solves in blocks of columns."""
        rows = rows[:, self.keep].tocsr()
        schur = self.cholesky if self.bodies is None else self.bodies
        if schur is not None and np.isin(rows.indices, schur.last).all():
            out = self._from_schur(rows, n_w)
            if out is not None:
                return out
        out = np.zeros((rows.shape[0], n_w))
        for start in bar(range(0, n_w, _BLOCK), -(-n_w // _BLOCK), f"condensation ({n_w} columns)"):
            cols = slice(start, min(start + _BLOCK, n_w))
            out[:, cols] = rows @ self._solve_kept_sparse(rows[cols].T)
        return out

    def _solve_kept_sparse(self, b: sp.spmatrix) -> np.ndarray:
        if self.cholesky is not None:
            return self.cholesky.solve_sparse(b)
        return self._solve_kept(b.toarray())

    def _solve_kept(self, b: np.ndarray) -> np.ndarray:
        if self.bodies is not None:
            return self.bodies.solve(b)
        if self.cholesky is not None:
            return self.cholesky.solve(b)
        if self.lu is None:
            self.lu = self._factor()
        return self.lu.solve(np.ascontiguousarray(b))

    def schur_solve(self, b_last: np.ndarray) -> np.ndarray | None:
        """(K^g b)[last] (m,) or (m, k) for b nonzero on ``last`` only (``b_last`` its values there): S^-1 b_s per
        body by the Schur complements' Cholesky factors L_ss, no solve with the interior (for the kept dofs
        ordered [interior i, last s], K x = b with b_i = 0 gives x_s = S^-1 b_s). None where those factors are
        not kept (CHOLMOD, whose solves use its whole kept factor instead, SuperLU, or after unpickling)."""
        if self.bodies is None:
            return None
        out = np.zeros(np.shape(b_last))
        for block, factor in zip(self.bodies.blocks, self.bodies.factors):
            if not len(block):
                continue
            if factor.schur_cholesky is None:
                return None
            out[block] = la.cho_solve((factor.schur_cholesky, True), b_last[block], check_finite=False)
        return out

    def _from_schur(self, rows: sp.csr_matrix, n_w: int) -> np.ndarray | None:
        """T_s S^-1 B_s^T, S^-1 from L_ss (:func:`~frictionid.fem.cholesky.inverse`), summed over the bodies (the
        connected parts of K: L_ss has no coupling between them, :meth:`~frictionid.fem.cholesky.Cholesky.trailing`;
        MUMPS's per body), checked on one column against a solve with the factor (None if it disagrees: the
        factor's order was not the one asked for)."""
        schur = self.cholesky if self.bodies is None else self.bodies
        last = schur.last
        if len(last) == 0:
            return np.zeros((rows.shape[0], n_w))
        probe = np.zeros(len(self.keep))
        probe[last[-1]] = 1.0
        expected = schur.solve(probe)[last]
        if self.bodies is None:
            _, body = connected_components(self.matrix, directed=False)
            blocks = [np.flatnonzero(body[last] == b) for b in np.unique(body[last])]
            factors = self.cholesky.trailing(blocks)
        else:
            # MUMPS's factors of the interiors are not needed for the dense part: freed before it (the peak of the
            # short 3-D bolt at 1.25 mm passed 11 GB with them held), made again at the next solve
            self.bodies.free(schur=False)
            pairs = [(b, f) for b, f in zip(self.bodies.blocks, self.bodies.factors) if len(b)]
            blocks = [b for b, _ in pairs]
            factors = (f.schur_factor() for _, f in pairs)
        T = rows[:, last].tocsc()
        out = np.zeros((rows.shape[0], n_w))
        got = np.zeros(len(last))
        with blas_threads_for(max(len(b) for b in blocks)):       # one thread for small blocks (fem/threads.py)
            for block, L_bb in zip(blocks, factors):
                # MUMPS's Schur factors are kept (displacement_at), CHOLMOD's blocks are not
                column = _add_products(out, T[:, block].tocsr(), L_bb, self.bodies is None, n_w)
                if block[-1] == len(last) - 1:
                    got[block] = column
        if not np.allclose(got, expected, rtol=1e-8, atol=1e-8 * np.abs(expected).max()):
            log.warning("the factor's trailing block is not the Schur complement asked for: condensing by solves")
            return None
        return out


def _add_products(out: np.ndarray, T_b: sp.csr_matrix, L: np.ndarray, overwrite: bool, n_w: int) -> np.ndarray:
    """out += T_b S^-1 T_b[:n_w]^T in place, on the rows T_b touches, for S = L L^T (n_b, n_b); S^-1's last column
    (n_b,). X = S^-1 T_w^T for the n_used_w contact rows T_w that touch the body: by two triangular solves with L
    (2 n_b^2 n_used_w flops) where the contact rows are fewer than a third of n_b (observation dofs of a dense DIC
    field, which join s, outnumber them), else from S^-1 by :func:`~frictionid.fem.cholesky.inverse` (2/3 n_b^3;
    ``overwrite``: in L's memory). At most two n_b-sized dense arrays besides ``out`` and L."""
    used = np.flatnonzero(np.diff(T_b.indptr))                   # rows touching this body, the contact rows first
    n_used_w = int(np.searchsorted(used, n_w))
    T_u = T_b[used]
    T_w = T_u[:n_used_w]
    X, last = _by_solves(L, T_w) if 3 * n_used_w < len(L) else _by_inverse(L, T_w, overwrite)
    block = T_u @ X                                              # (n_used, n_used_w)
    del X
    if len(used) == out.shape[0] and n_used_w == n_w:
        out += block
    else:
        out[np.ix_(used, used[:n_used_w])] += block
    return last


def _by_inverse(L: np.ndarray, T_w: sp.csr_matrix, overwrite: bool) -> tuple[np.ndarray, np.ndarray]:
    """S^-1 T_w^T (n_b, n_w) in C order and S^-1's last column, from S^-1 (potri)."""
    S_inv = cholesky.inverse(L, overwrite)
    last = S_inv[:, -1].copy()
    # S_inv.T is S^-1 in C order (symmetric): scipy's sparse-times-dense reads the dense rows contiguously
    right = T_w @ S_inv.T                                        # (n_w, n_b) T_w S^-1
    del S_inv
    return np.ascontiguousarray(right.T), last


def _by_solves(L: np.ndarray, T_w: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray]:
    """S^-1 T_w^T (n_b, n_w) in C order and S^-1's last column, by LAPACK's potrs with L (L kept)."""
    n_b = len(L)
    rhs = np.zeros((n_b, T_w.shape[0] + 1), order="F")
    rhs[:, :-1] = T_w.T.toarray()
    rhs[-1, -1] = 1.0
    # a C-ordered L is, read in LAPACK's column order, the upper factor U = L^T (S = U^T U): no transposing copy
    lower = L.flags.f_contiguous
    X, info = la.lapack.dpotrs(L if lower else L.T, rhs, lower=int(lower), overwrite_b=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"potrs: illegal argument {-info}")
    return np.ascontiguousarray(X[:, :-1]), X[:, -1].copy()


_SINGULAR = ("model: the stiffness matrix is singular: a body is not held by supports or contact in some "
             "direction (a mechanism)")


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
        ``amplitude`` (k, n_channels) and ``x`` (k, n_x): k states at once, (k, n_dofs), one solve with k
        right-hand sides.
        """
        many = np.ndim(x) == 2
        amplitude, x = np.atleast_2d(amplitude), np.atleast_2d(x)
        n_w = B.shape[0]
        u = np.zeros((len(x), len(self.free) + len(self.prescribed)))
        load = B[:, self.free].T @ x[:, :n_w].T
        u[:, self.free] = amplitude @ self.particular + self.inverse.solve(load).T + x[:, n_w:] @ self.modes.T
        u[:, self.prescribed] = amplitude @ prescribed_values
        return u if many else u[0]

    def displacement_at(self, dofs: np.ndarray, B: sp.csr_matrix, prescribed_values: np.ndarray,
                        amplitude: np.ndarray, x: np.ndarray) -> np.ndarray | None:
        """u [mm] at the dofs ``dofs`` only, (k, len(dofs)) for k states (arguments as :meth:`displacement`), from
        the Schur complements' kept factors (:meth:`GeneralisedInverse.schur_solve`): no interior solve, so no
        MUMPS factor made again. None unless B's columns and every free one of ``dofs`` are among the dofs the
        factorisation eliminated last (or pinned) and those factors are kept; then :meth:`displacement`."""
        inverse, dofs = self.inverse, np.asarray(dofs, dtype=int)
        if inverse.bodies is None:
            return None
        n_dofs = len(self.free) + len(self.prescribed)
        free_at, kept_at = np.full(n_dofs, -1), np.full(len(self.free), -1)
        free_at[self.free] = np.arange(len(self.free))
        kept_at[inverse.keep] = np.arange(len(inverse.keep))
        last_at = np.full(len(inverse.keep) + 1, -1)              # -1 (the extra entry): pinned, K^g gives 0 there
        last_at[inverse.bodies.last] = np.arange(len(inverse.bodies.last))
        B_f = sp.csr_matrix(B)[:, self.free].tocsr()
        loaded = kept_at[np.unique(B_f.indices)]
        wanted = free_at[dofs[free_at[dofs] >= 0]]
        solved = last_at[kept_at[wanted]]
        if np.any(last_at[loaded[loaded >= 0]] < 0) or np.any((kept_at[wanted] >= 0) & (solved < 0)):
            return None
        many = np.ndim(x) == 2
        amplitude, x = np.atleast_2d(amplitude), np.atleast_2d(x)
        n_w = B.shape[0]
        load = (B_f.T @ x[:, :n_w].T)[inverse.keep[inverse.bodies.last]]        # (m, k) on last
        on_last = inverse.schur_solve(load)
        if on_last is None:
            return None
        u = np.zeros((len(x), len(dofs)))
        free, prescribed_at = free_at[dofs] >= 0, np.full(n_dofs, -1)
        prescribed_at[self.prescribed] = np.arange(len(self.prescribed))
        u[:, ~free] = amplitude @ prescribed_values[:, prescribed_at[dofs[~free]]]
        u[:, free] = amplitude @ self.particular[:, wanted] + x[:, n_w:] @ self.modes[wanted].T
        u[:, np.flatnonzero(free)[solved >= 0]] += on_last[solved[solved >= 0]].T
        return u if many else u[0]


class Partition(NamedTuple):
    """The operators of :func:`condense` split into free dofs f and prescribed dofs p."""

    free: np.ndarray
    prescribed: np.ndarray
    K_ff: sp.csr_matrix
    K_fp: sp.csr_matrix
    K_pf: sp.csr_matrix
    K_pp: sp.csr_matrix
    modes: np.ndarray
    B_f: sp.csr_matrix
    B_p: sp.csr_matrix
    O_f: sp.csr_matrix
    O_p: sp.csr_matrix


def partition(K: sp.spmatrix, B: sp.spmatrix, channels: LoadChannels, modes: np.ndarray,
              observe: sp.spmatrix) -> Partition:
    """K, the rigid modes, B and the observation rows split by the channels' prescribed dofs."""
    p = channels.prescribed
    f = np.setdiff1d(np.arange(K.shape[0]), p)
    K = K.tocsr()
    return Partition(f, p, K[f][:, f], K[f][:, p], K[p][:, f], K[p][:, p], modes[f], B[:, f].tocsr(),
                     B[:, p].tocsr(), observe[:, f].tocsr(), observe[:, p].tocsr())


def condense(K: sp.csr_matrix, B: sp.csr_matrix, channels: LoadChannels, modes: np.ndarray,
             observe: sp.csr_matrix, reaction_sums: sp.csr_matrix, dim: int = 2,
             factorisation: str = "auto", last: np.ndarray | None = None) -> Condensed:
    """Condense the model onto the contact pairs.

    Parameters
    ----------
    K : (n_dofs, n_dofs) stiffness; B : (n_w, n_dofs) relative displacement operator
    modes : (n_dofs, m) rigid modes vanishing on prescribed dofs
    observe : (n_obs, n_dofs) observation rows; reaction_sums : (n_reac, n_prescribed) sums of reactions
    factorisation : one of :data:`FACTORISATIONS` (see the module docstring)
    last : dofs that "mumps" eliminates last besides those B and the rows touch, so that
        :meth:`Condensed.displacement_at` gives them from the Schur factors (the interfaces' contact nodes a
        mortar coupling leaves out)
    """
    f, p, K_ff, K_fp, K_pf, K_pp, R, B_f, B_p, O_f, O_p = partition(K, B, channels, modes, observe)
    del K          # the caller's temporary: its partition is all that is used, and the factor needs the memory
    rows = sp.vstack([B_f, O_f]).tocsr()
    name = factorisation_name(factorisation)
    if name == "cholmod":
        inverse = GeneralisedInverse(K_ff, R, last=np.unique(rows.indices), nodes=f // dim)
    elif name == "cholmod_solves":
        inverse = GeneralisedInverse(K_ff, R, last=np.zeros(0, int), nodes=f // dim)
    elif name == "mumps":
        extra = np.zeros(0, int) if last is None else np.searchsorted(f, np.intersect1d(last, f))
        inverse = GeneralisedInverse(K_ff, R, last=np.union1d(rows.indices, extra), solver="mumps")
    else:
        # SuperLU orderings measured here: 2-D 52k dofs COLAMD factors in 0.45 s vs 1.8 s (MMD), same solves;
        # 3-D 17k dofs MMD_AT_PLUS_A solves 363 right-hand sides in 2.1 s vs 13 s (COLAMD)
        inverse = GeneralisedInverse(K_ff, R, "COLAMD" if dim == 2 else "MMD_AT_PLUS_A")
    b = channels.forces[:, f].T - K_fp @ channels.displacements.T          # (n_f, n_channels)
    # the reaction sums' rows S_r K_pf touch every dof next to a supported face: solved for (n_reac columns),
    # not ordered last; before `coupled`, which takes the factor out of CHOLMOD (kept: cholesky.SparseFactor)
    sums_K = (reaction_sums @ K_pf).tocsr()
    solved = inverse.solve(np.hstack([b, sums_K.T.toarray()]))
    Y, X_sums = solved[:, :b.shape[1]], solved[:, b.shape[1]:]
    n_w = B.shape[0]
    coupled = inverse.coupled(rows, n_w)
    if inverse.bodies is not None:
        # MUMPS's factors (5.5 GB on the short 3-D bolt at 1.25 mm) are not needed by the load path: made again if
        # the displacement field is asked for (CHOLMOD's factor is kept); the Schur complements'
        # factors (sum of n_s^2 doubles) are kept: displacements on `last` need no more (Condensed.displacement_at)
        inverse.bodies.free(schur=False)
    W, G = coupled[:n_w], coupled[n_w:]
    W = 0.5 * (W + W.T)
    up = channels.displacements.T
    reac_channels = K_pf @ Y + K_pp @ up - channels.forces[:, p].T
    return Condensed(
        free=f, prescribed=p, modes=R, inverse=inverse, particular=Y.T,
        gap_ops=Affine.sharing((B_f @ Y + B_p @ up).T, W, B_f @ R),
        obs_ops=Affine((O_f @ Y + O_p @ up).T, G, O_f @ R),
        reac_ops=Affine((reaction_sums @ reac_channels).T, (B_f @ X_sums).T - (reaction_sums @ B_p.T).toarray(),
                        reaction_sums @ (K_pf @ R)),
        equilibrium=Affine((R.T @ b).T, (B_f @ R).T, np.zeros((R.shape[1], R.shape[1]))),
    )
