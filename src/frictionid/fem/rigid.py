"""Bodies of a mesh and the rigid-body modes left free by the supports (bodies held only by contact)."""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..model import Mesh
from ..model.model import n_components


def bodies(mesh: Mesh) -> np.ndarray:
    """(n_nodes,) index of the connected body (cells sharing nodes) each node belongs to."""
    n_cells, n_per = mesh.cells.shape
    incidence = sp.csr_matrix((np.ones(mesh.cells.size), (np.repeat(np.arange(n_cells), n_per), mesh.cells.ravel())),
                              shape=(n_cells, mesh.n_nodes))
    _, labels = connected_components(incidence.T @ incidence, directed=False)
    return labels


def _candidate_modes(points: np.ndarray, kind: str) -> np.ndarray:
    """(n, n_components, k) rigid displacement modes of a point cloud: translations, then rotations about its
    centre; of revolution: the axial translation (and the turn about the axis, u_t = r, with twist)."""
    n, dim = points.shape
    x = points - points.mean(axis=0)
    if kind in ("axisymmetric", "axisymmetric_twist"):
        modes = np.zeros((n, n_components(kind, dim), 1 + (kind == "axisymmetric_twist")))
        modes[:, 1, 0] = 1.0
        if kind == "axisymmetric_twist":
            modes[:, 2, 1] = points[:, 0]
        return modes
    translations = np.broadcast_to(np.eye(dim), (n, dim, dim))
    if dim == 2:
        rotation = np.stack([-x[:, 1], x[:, 0]], axis=1)[:, :, None]
    else:
        rotation = np.stack([np.cross(np.eye(3)[a], x) for a in range(3)], axis=2)
    return np.concatenate([translations, rotation], axis=2)


def free_rigid_modes(mesh: Mesh, kind: str, prescribed: np.ndarray) -> np.ndarray:
    """(n_dofs, m) rigid modes that vanish on every prescribed dof: the kernel of the free-free stiffness.

    Each column is supported on one body and scaled to unit length.
    """
    dim = n_components(kind, mesh.dim)
    label = bodies(mesh)
    is_prescribed = np.zeros(dim * mesh.n_nodes, dtype=bool)
    is_prescribed[prescribed] = True
    columns = []
    for body in range(label.max() + 1):
        nodes = np.flatnonzero(label == body)
        dofs = (dim * nodes[:, None] + np.arange(dim)).ravel()
        modes = _candidate_modes(mesh.points[nodes], kind).reshape(len(dofs), -1)
        fixed = modes[is_prescribed[dofs]]
        kernel = la.null_space(fixed, rcond=1e-10) if len(fixed) else np.eye(modes.shape[1])
        for vector in (modes @ kernel).T:
            column = np.zeros(dim * mesh.n_nodes)
            column[dofs] = vector / np.linalg.norm(vector)
            columns.append(column)
    return np.array(columns).reshape(-1, dim * mesh.n_nodes).T
