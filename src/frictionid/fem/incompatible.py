"""Hex8 with incompatible modes (Wilson's bubbles, Taylor's correction; CalculiX/Abaqus C3D8I): element matrices
condensed per cell, and the internal modes' displacement and gradient at points.

Each linear hexahedron gets the bubbles ``P_i = 1 - xi_i^2`` (i = 1..3) in each displacement component: 9
internal dofs ``alpha`` that no other cell sees, eliminated per cell (static condensation):

    K = K_uu - K_ua K_aa^-1 K_au,        alpha = -R u_e,   R = K_aa^-1 K_au.

Taylor's correction (Taylor, Beresford & Wilson, IJNME 10 (1976) 1211-1219) evaluates the modes' gradients with
the Jacobian at the cell centre, ``grad P_i = (det J0 / det J) J0^-T dP_i/dxi``; their integral over any cell is
then zero, so a linear displacement field leaves ``alpha = 0`` and the element passes the patch test.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
import scipy.sparse as sp

#: natural coordinates in [-1, 1]^3 of the corners of a hexahedron in meshio (VTK) order, which is CalculiX's
CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)
#: 2 x 2 x 2 Gauss points (weights 1): the rule of space.INTORDER["hexahedron"] (degree 3)
GAUSS = CORNERS / np.sqrt(3.0)
N_NODES, N_MODES, DIM = 8, 3, 3
N_U, N_A = DIM * N_NODES, DIM * N_MODES
#: cells per batch of element matrices: bounds the temporary arrays to about 60 MB
BATCH = 2000


def trilinear(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shape functions (n, 8) and their natural derivatives (n, 8, 3) at natural coordinates xi (n, 3).

    >>> N, dN = trilinear(np.zeros((1, 3)))
    >>> N.round(3).tolist()
    [[0.125, 0.125, 0.125, 0.125, 0.125, 0.125, 0.125, 0.125]]
    """
    factors = 1.0 + CORNERS[None, :, :] * xi[:, None, :]                  # (n, 8, 3)
    N = factors.prod(axis=2) / 8.0
    dN = np.empty(factors.shape)
    for j in range(DIM):
        others = [i for i in range(DIM) if i != j]
        dN[:, :, j] = CORNERS[None, :, j] * factors[:, :, others].prod(axis=2) / 8.0
    return N, dN


def bubbles(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Incompatible modes ``1 - xi_i^2`` (n, 3) and their natural derivatives (n, 3, 3) at xi (n, 3)."""
    derivatives = np.zeros(xi.shape + (DIM,))
    for i in range(DIM):
        derivatives[:, i, i] = -2.0 * xi[:, i]
    return 1.0 - xi ** 2, derivatives


def _jacobian(xyz: np.ndarray, dN: np.ndarray) -> np.ndarray:
    """dx/dxi (n, 3, 3) of the trilinear map of cells with corners xyz (n, 8, 3) [mm]."""
    return np.einsum("nka,nkb->nab", xyz, dN)


def _physical(jacobian: np.ndarray, natural: np.ndarray) -> np.ndarray:
    """Gradients (n, k, 3) from natural derivatives (n, k, 3): grad_x = J^-T grad_xi."""
    return np.swapaxes(np.linalg.solve(np.swapaxes(jacobian, 1, 2), np.swapaxes(natural, 1, 2)), 1, 2)


def gradients(xyz: np.ndarray, xi: np.ndarray):
    """Nodal and internal-mode functions and their physical gradients in cells xyz (n, 8, 3) [mm] at xi (n, 3).

    Returns
    -------
    N : (n, 8) shape functions; grad_N : (n, 8, 3) [1/mm]
    P : (n, 3) incompatible modes; grad_P : (n, 3, 3) [1/mm], Taylor's form (det J0 / det J) J0^-T dP/dxi
    det : (n,) det J [mm^3]
    """
    N, dN = trilinear(xi)
    jacobian = _jacobian(xyz, dN)
    det = np.linalg.det(jacobian)
    centre = _jacobian(xyz, trilinear(np.zeros((len(xyz), DIM)))[1])
    P, dP = bubbles(xi)
    grad_P = (np.linalg.det(centre) / det)[:, None, None] * _physical(centre, dP)
    return N, _physical(jacobian, dN), P, grad_P, det


def element_matrices(xyz: np.ndarray, lame: np.ndarray) -> np.ndarray:
    """Stiffness (n_cells, 33, 33) [N/mm] of nodal and internal dofs: rows 3 k + c (node k, component c),
    then 24 + 3 i + c (mode i, component c). xyz (n_cells, 8, 3) [mm], lame (n_cells, 2) [MPa]."""
    n = len(xyz)
    _, grad_N, _, grad_P, det = gradients(np.repeat(xyz, len(GAUSS), axis=0), np.tile(GAUSS, (n, 1)))
    G = np.concatenate([grad_N, grad_P], axis=1).reshape(n, len(GAUSS), N_NODES + N_MODES, DIM)
    weight = np.abs(det).reshape(n, len(GAUSS))
    lam, mu = weight * lame[:, :1], weight * lame[:, 1:]
    # sigma(g_p e_c) : eps(g_r e_d) = lam g_pc g_rd + mu (g_p . g_r delta_cd + g_pd g_rc)
    K = np.einsum("eq,eqpc,eqrd->epcrd", lam, G, G) + np.einsum("eq,eqpd,eqrc->epcrd", mu, G, G)
    K += np.einsum("eq,eqpj,eqrj->epr", mu, G, G)[:, :, None, :, None] * np.eye(DIM)[None, None, :, None, :]
    size = DIM * (N_NODES + N_MODES)
    return K.reshape(n, size, size)


def condensed(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Condensed stiffness (n, 24, 24) [N/mm] and recovery R (n, 9, 24), ``alpha = -R u_e``, of element
    matrices K (n, 33, 33) from :func:`element_matrices`."""
    K_ua, K_aa = K[:, :N_U, N_U:], K[:, N_U:, N_U:]
    R = np.linalg.solve(K_aa, np.swapaxes(K_ua, 1, 2))
    K_c = K[:, :N_U, :N_U] - K_ua @ R
    return 0.5 * (K_c + np.swapaxes(K_c, 1, 2)), R


def cell_lame(mesh, materials: Mapping) -> np.ndarray:
    """(n_cells, 2) Lame constants (lambda, mu) [MPa] of each cell's region material."""
    lame = np.array([materials[name].lame for name in mesh.region_names])
    return lame[mesh.cell_region]


def cell_dofs(cells: np.ndarray) -> np.ndarray:
    """(n, 24) frictionid dofs (node-major, 3 node + c) of hexahedra cells (n, 8) in :func:`element_matrices`' order."""
    return (DIM * cells[:, :, None] + np.arange(DIM)).reshape(len(cells), N_U)


def stiffness(mesh, lame: np.ndarray) -> sp.csr_matrix:
    """Global condensed stiffness (n_dofs, n_dofs) [N/mm] of a linear hexahedral mesh in frictionid dofs.

    Parameters
    ----------
    mesh : Mesh
        Cell type "hexahedron".
    lame : (n_cells, 2) [MPa]
        (lambda, mu) of each cell, see :func:`cell_lame`.
    """
    cells = np.asarray(mesh.cells)
    n_dofs = DIM * mesh.n_nodes
    rows, cols, values = [], [], []
    for start in range(0, len(cells), BATCH):
        part = cells[start:start + BATCH]
        K_c, _ = condensed(element_matrices(mesh.points[part], lame[start:start + BATCH]))
        dofs = cell_dofs(part)
        rows.append(np.broadcast_to(dofs[:, :, None], K_c.shape).ravel())
        cols.append(np.broadcast_to(dofs[:, None, :], K_c.shape).ravel())
        values.append(K_c.ravel())
    return sp.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(n_dofs, n_dofs))


def internal_fields(xyz: np.ndarray, lame: np.ndarray, xi: np.ndarray,
                    cell: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Displacement and displacement gradient of the condensed internal modes per unit nodal dof of the cell.

    Parameters
    ----------
    xyz : (n, 8, 3) [mm]
        Corners of the cell holding each point, meshio order.
    lame : (n, 2) [MPa]
        (lambda, mu) of that cell.
    xi : (n, 3)
        Natural coordinates of each point in its cell.
    cell : (n,) int, optional
        An id of the cell holding each point (e.g. its index in the mesh): the recovery ``alpha = -R u_e``,
        which depends on the cell only, is then computed once per distinct cell (a full field puts hundreds of
        points in one cell). Without it, once per point.

    Returns
    -------
    U : (n, 3, 24)
        ``u_c(point) += U[:, c] @ u_e`` (u_e the cell's dofs as in :func:`cell_dofs`); zero at the nodes.
    D : (n, 3, 3, 24) [1/mm]
        ``du_c/dx_j(point) += D[:, c, j] @ u_e``.
    """
    first, which = (np.arange(len(xyz)), np.arange(len(xyz))) if cell is None else \
        np.unique(np.asarray(cell), return_index=True, return_inverse=True)[1:]
    _, R = condensed(element_matrices(xyz[first], lame[first]))
    alpha = -R.reshape(len(first), N_MODES, DIM, N_U)[np.ravel(which)]      # (n, mode, component, dof)
    _, _, P, grad_P, _ = gradients(xyz, xi)
    return np.einsum("ni,nicu->ncu", P, alpha), np.einsum("nij,nicu->ncju", grad_P, alpha)
