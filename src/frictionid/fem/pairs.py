"""ContactPairs: the discretised contact constraints of a model (frames, weights, gaps, zone shares, B).

Every interface discretisation (node-to-node for conforming meshes, mortar for non-matching meshes)
produces this one object; the solver only ever sees it.

Convention: for pair i with frame rows (n, t1[, t2]), n the outward normal of the target side,
``w[dim*i + k] = frame[i, k] . (u_contact(i) - u_target(i))`` is the relative displacement, ``w = B u``,
and the normal gap is ``g = gap + w_N`` (g >= 0 open). Contact forces are lam (N), lam_N >= 0 in compression,
acting on the contact side as ``+lam`` and on the target side as ``-lam``; the nodal force vector is ``B^T lam``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


@dataclass(frozen=True)
class ContactPairs:
    """Contact constraints of all interfaces.

    Attributes
    ----------
    nodes : (n_pairs,) int
        Contact-side node of each pair.
    position : (n_pairs, dim) [mm]
        Undeformed position of each pair (contact side).
    frames : (n_pairs, dim, dim)
        Rows n, t1[, t2]; n is the outward unit normal of the target side.
    weight : (n_pairs,) [mm^2]
        Tributary area (axisymmetric: whole ring, plane strain: per mm thickness); pressure = lam_N / weight.
    zone_share : (n_pairs, n_zones)
        Area fraction of each zone at the pair (rows sum to 1); mu_i = zone_share[i] @ mu.
    gap : (n_pairs,) [mm]
        Initial normal gap, negative for an interference.
    B : sparse (dim * n_pairs, n_dofs)
        Relative displacement operator, ``w = B u``.
    interface : (n_pairs,) int
        Index of the model interface each pair belongs to.
    facing : (n_pairs,) [deg] or None
        Angle between the contact side's outward normal and the reversed outward normal of the target where the
        pair couples (0: the surfaces face each other exactly); NaN where the discretisation does not give it.
    meshed_gap : (smallest, largest) [mm] or None
        The initial gaps as meshed where the interface set them to zero (``ContactInterface.adjust``), else None.
    """

    nodes: np.ndarray
    position: np.ndarray
    frames: np.ndarray
    weight: np.ndarray
    zone_share: np.ndarray
    gap: np.ndarray
    B: sp.csr_matrix
    interface: np.ndarray
    facing: np.ndarray | None = None
    meshed_gap: tuple[float, float] | None = None

    @property
    def n_pairs(self) -> int:
        return len(self.nodes)

    @property
    def dim(self) -> int:
        return self.frames.shape[1]

    def mu(self, zone_mu: np.ndarray) -> np.ndarray:
        """(n_pairs,) coefficient per pair: the area-weighted mean of the zones it touches."""
        return self.zone_share @ np.asarray(zone_mu, dtype=float)

    @staticmethod
    def concatenate(parts: list["ContactPairs"], n_dofs: int, n_zones: int, dim: int) -> "ContactPairs":
        """All interfaces' pairs as one object (pairs in the order of ``parts``)."""
        if not parts:
            return ContactPairs(np.zeros(0, int), np.zeros((0, dim)), np.zeros((0, dim, dim)), np.zeros(0),
                                np.zeros((0, n_zones)), np.zeros(0), sp.csr_matrix((0, n_dofs)), np.zeros(0, int),
                                np.zeros(0))
        return ContactPairs(
            nodes=np.concatenate([p.nodes for p in parts]),
            position=np.vstack([p.position for p in parts]),
            frames=np.concatenate([p.frames for p in parts]),
            weight=np.concatenate([p.weight for p in parts]),
            zone_share=np.vstack([p.zone_share for p in parts]),
            gap=np.concatenate([p.gap for p in parts]),
            B=sp.vstack([p.B for p in parts]).tocsr(),
            interface=np.concatenate([p.interface for p in parts]),
            facing=np.concatenate([np.full(p.n_pairs, np.nan) if p.facing is None else p.facing for p in parts]),
        )


def tangent_frames(normals: np.ndarray) -> np.ndarray:
    """(n, dim, dim) orthonormal frames with rows n, t1[, t2] from unit normals (n, dim).

    2-D: t1 = n rotated by -90 deg. 3-D: t1 is the unit projection of the global axis least aligned with n.
    """
    normals = np.asarray(normals, dtype=float)
    n, dim = normals.shape
    frames = np.zeros((n, dim, dim))
    frames[:, 0] = normals
    if dim == 2:
        frames[:, 1] = np.column_stack([normals[:, 1], -normals[:, 0]])
        return frames
    axis = np.eye(3)[np.argmin(np.abs(normals), axis=1)]
    t1 = axis - np.sum(axis * normals, axis=1)[:, None] * normals
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    frames[:, 1] = t1
    frames[:, 2] = np.cross(normals, t1)
    return frames


def relative_operator(frames: np.ndarray, contact_nodes: np.ndarray, target_nodes: np.ndarray,
                      target_weights: np.ndarray, n_dofs: int) -> sp.csr_matrix:
    """B with ``w[dim*i+k] = frames[i,k] . (u[contact_nodes[i]] - sum_j target_weights[i,j] u[target_nodes[i,j]])``.

    Parameters
    ----------
    frames : (n_pairs, dim, dim)
    contact_nodes : (n_pairs,) int
    target_nodes : (n_pairs, m) int
        Target nodes each pair is coupled to (m = 1 for node-to-node).
    target_weights : (n_pairs, m)
        Interpolation weights of those target nodes (rows sum to 1).
    """
    n_pairs, dim, _ = frames.shape
    rows, cols, vals = [], [], []
    row = dim * np.arange(n_pairs)
    for k in range(dim):
        for c in range(dim):
            rows.append(row + k)
            cols.append(dim * contact_nodes + c)
            vals.append(frames[:, k, c])
            m = target_nodes.shape[1]
            rows.append(np.repeat(row + k, m))
            cols.append((dim * target_nodes + c).ravel())
            vals.append((-target_weights * frames[:, k, c][:, None]).ravel())
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(dim * n_pairs, n_dofs))
