"""Solution: the results of one forward solve at every nominal increment of the load path."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contact import SLIP, STICK
from .pairs import ContactPairs

STATE_NAMES = ("open", "stick", "slip")


class ExpandedRows:
    """Observation rows (n_inc, n_obs[, n_zones]) kept as values on fewer dofs (n_inc, n_kept[, n_zones]) and an
    expansion (n_obs, n_kept), expanded when indexed: a full field's rows at every increment and their
    sensitivities would take hundreds of MB, and only the stage ends are read. ``rows[ends]`` and
    ``np.asarray(rows)`` give plain arrays."""

    def __init__(self, kept: np.ndarray, expand):
        self.kept, self.expand = kept, expand

    @property
    def shape(self) -> tuple[int, ...]:
        return (self.kept.shape[0], self.expand.shape[0]) + self.kept.shape[2:]

    @property
    def ndim(self) -> int:
        return self.kept.ndim

    def __len__(self) -> int:
        return self.kept.shape[0]

    def _expanded(self, kept: np.ndarray) -> np.ndarray:
        """(..., n_kept[, n_zones]) with the increment axis first -> (..., n_obs[, n_zones])."""
        if kept.ndim == self.kept.ndim - 1:
            return self._expanded(kept[None])[0]
        return np.stack([self.expand @ k for k in kept]) if len(kept) else np.zeros((0,) + self.shape[1:])

    def __getitem__(self, index):
        first, rest = (index[0], index[1:]) if isinstance(index, tuple) else (index, ())
        out = self._expanded(self.kept[first])
        return out[(slice(None),) * (out.ndim - self.kept.ndim + 1) + rest] if rest else out

    def __array__(self, dtype=None, copy=None):
        out = self._expanded(self.kept)
        return out if dtype is None else out.astype(dtype)


@dataclass(frozen=True)
class Solution:
    """Forward solve results; index 0 of every per-increment array is the first increment.

    Attributes
    ----------
    mu : (n_zones,) zone coefficients used
    zone_names, observation_labels, reaction_labels : names of the columns below
    stage : (n_inc,) stage index of each increment; amplitude : (n_inc, n_channels)
    lam : (n_inc, n_pairs, dim) [N] contact force on the contact side in the pair frame (N, T1[, T2])
    alpha : (n_inc, m) rigid-mode amplitudes of floating bodies
    w : (n_inc, n_pairs, dim) [mm] relative displacement (normal gap change, tangential)
    state : (n_inc, n_pairs) 0 open, 1 stick, 2 slip
    observations : (n_inc, n_obs); reactions : (n_inc, n_reac) [N]
    d_observations : (n_inc, n_obs, n_zones) or None; d_reactions : (n_inc, n_reac, n_zones) or None
        (NaN in the columns of the zones a solve took no sensitivities to: ``Problem.solve``'s ``sensitivities``)
        (observations and d_observations are :class:`ExpandedRows` for a problem that condensed the observed
        dofs instead of the rows: index them, e.g. ``[ends]``, or take ``np.asarray``)
    n_newton : (n_inc,) Newton iterations; n_cuts : (n_inc,) increment cuts
    pairs : the contact pairs (positions, frames, weights, zone shares)
    interface_forces : (n_inc, n_interface_dofs) [N] or None
        Finite sliding (fem/sliding.py): the contact forces on the interface dofs (``Problem.interface_dofs``),
        ``lam`` being in the frames of each increment's coupling; None for small sliding.
    d_x : (n_inc, n_pairs * dim + m, n_zones) or None
        The sensitivities of (lam, alpha) with respect to the zone coefficients (small sliding with
        sensitivities; None otherwise): with the condensation they give the sensitivities of the displacement
        field, so of any point's quantities (:meth:`Problem.point_sensitivities`).
    """

    mu: np.ndarray
    zone_names: tuple[str, ...]
    observation_labels: tuple[str, ...]
    reaction_labels: tuple[str, ...]
    stage: np.ndarray
    amplitude: np.ndarray
    lam: np.ndarray
    alpha: np.ndarray
    w: np.ndarray
    state: np.ndarray
    observations: np.ndarray
    reactions: np.ndarray
    d_observations: np.ndarray | None
    d_reactions: np.ndarray | None
    n_newton: np.ndarray
    n_cuts: np.ndarray
    pairs: ContactPairs
    interface_forces: np.ndarray | None = None
    d_x: np.ndarray | None = None

    @property
    def n_increments(self) -> int:
        return len(self.stage)

    def __repr__(self) -> str:
        mu = ", ".join(f"{name}={value:.4g}" for name, value in zip(self.zone_names, self.mu))
        return (f"Solution({mu}; {self.n_increments} increments, {self.pairs.n_pairs} contact pairs, "
                f"{self.observations.shape[1]} observations, {self.reactions.shape[1]} reactions, sensitivities "
                f"{'yes' if self.d_observations is not None else 'no'})")

    def stage_end(self, stage: int) -> int:
        """Index of the last increment of a stage (0-based stage index)."""
        hits = np.flatnonzero(self.stage == stage)
        if not hits.size:
            raise IndexError(f"no stage {stage}")
        return int(hits[-1])

    @property
    def gap(self) -> np.ndarray:
        """(n_inc, n_pairs) [mm] current normal gap."""
        return self.pairs.gap + self.w[:, :, 0]

    @property
    def pressure(self) -> np.ndarray:
        """(n_inc, n_pairs) [MPa] contact pressure lam_N / tributary area."""
        return self.lam[:, :, 0] / self.pairs.weight

    @property
    def traction(self) -> np.ndarray:
        """(n_inc, n_pairs, dim - 1) [MPa] tangential traction."""
        return self.lam[:, :, 1:] / self.pairs.weight[:, None]

    @property
    def slip(self) -> np.ndarray:
        """(n_inc, n_pairs, dim - 1) [mm] accumulated tangential relative displacement since the start."""
        return self.w[:, :, 1:]

    @property
    def zone_normal_force(self) -> np.ndarray:
        """(n_inc, n_zones) [N] normal force per zone (border pairs shared by area)."""
        return self.lam[:, :, 0] @ self.pairs.zone_share

    @property
    def zone_tangential_force(self) -> np.ndarray:
        """(n_inc, n_zones, dim) [N] tangential force per zone, a vector in the global frame.

        Summed as vectors: pair frames may differ from pair to pair (their t1 is any unit vector normal to n),
        so components in the pair frames cannot be added.
        """
        tangential = np.einsum("ipk,pkd->ipd", self.lam[:, :, 1:], self.pairs.frames[:, 1:, :])
        return np.einsum("ipd,pz->izd", tangential, self.pairs.zone_share)

    def zone_state(self, increment: int = -1) -> dict[str, dict[str, float]]:
        """Area fraction of each zone that is open, sticking and slipping at an increment."""
        share = self.pairs.zone_share * self.pairs.weight[:, None]
        state = self.state[increment]
        return {zone: {name: float(share[state == k, z].sum() / share[:, z].sum())
                       for k, name in enumerate(STATE_NAMES)}
                for z, zone in enumerate(self.zone_names)}

    def stick_thresholds(self, movable=None) -> np.ndarray:
        """(n_zones,) [-] per zone whose pairs stick along the whole load path, the smallest coefficient at which
        they all still stick: from there up the path, and every output, are the same (a stuck pair's equations do
        not contain mu; its force must only stay within mu times its normal force). NaN for a zone that slips at
        some increment or is never closed, and for the zones not ``movable`` ((n_zones,) bool, default all).

        The zones are lowered one after the other in their order, each with the ones before it at their
        thresholds, so that pairs on a border between two stuck zones (sharing their coefficients by area) stay
        stuck with all of them lowered at once.
        """
        share = self.pairs.zone_share
        mu = np.asarray(self.mu, dtype=float).copy()
        normal = self.lam[:, :, 0]
        tangential = np.linalg.norm(self.lam[:, :, 1:], axis=2)   # with a held direction's force: never too low
        stuck = self.state == STICK
        movable = np.ones(len(mu), bool) if movable is None else np.asarray(movable, bool)
        out = np.full(len(mu), np.nan)
        for z in np.flatnonzero(movable):
            mine = share[:, z] > 0
            closed = stuck[:, mine]
            if not closed.any() or (self.state[:, mine] == SLIP).any():
                continue
            others = share[mine] @ mu - share[mine, z] * mu[z]
            ratio = tangential[:, mine] / np.where(closed, normal[:, mine], 1.0)
            need = np.where(closed, (ratio - others) / share[mine, z], -np.inf)
            out[z] = mu[z] = min(max(float(need.max()), 0.0), mu[z])
        return out
