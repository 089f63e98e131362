"""Axisymmetry with twist ("axisymmetric_twist", as Abaqus CGAX): contact pairs with the circumferential tangent.

A model of revolution about y (x = r) whose displacement has a circumferential component u_t, independent of theta:
three components per node (u_r, u_y, u_t), strains e_rr, e_yy, e_tt = u_r / r, e_ry and the torsion shears
e_rt = (du_t/dr - u_t/r) / 2, e_yt = du_t/dy / 2 (tensor shears; :func:`frictionid.fem.assembly.torsion_shears`).
The direction t = r x y is +z on the x-y plane at x > 0; a positive u_t = r phi turns a body by phi about -y.

Contact pairs of such a model are the pairs of its (r, y) section with a second tangent, the circumferential one:
frames (n, t1, t) with n and t1 in the (r, y) plane, so friction acts in the section and around the axis like a
3-D pair with two tangents, and the Coulomb disc bounds the resultant of both. Weights, gaps and zone shares are
those of the section's pairs (whole ring). A helical interface (a thread, :attr:`ContactInterface.lead`) keeps its
rings but tilts each pair's normal by the local lead angle: turning the nut then closes the flank gap by the lead
per turn, and the normal force has the circumferential component of the helicoid's normal (the P / (2 pi) term
of the tightening torque). Circumferential sliding does not change a pair's partners (rings are invariant under
turning), so it is not bounded by the small-sliding check, only the slip along t1 in the section is.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .pairs import ContactPairs


def helical_normals(normals: np.ndarray, radius: np.ndarray, lead: np.ndarray) -> np.ndarray:
    """(n, 3) unit normals (r, y, t) of helicoids whose (r, y) sections have the unit normals ``normals`` (n, 2).

    A right-hand helicoid of lead L [mm per turn] is y = f(r) - L theta / (2 pi) in this kind's theta (t = r x y
    turns about -y), so its normal is (n_r, n_y, n_y L / (2 pi r)), normalised; L = 0 leaves (n_r, n_y, 0).

    >>> np.round(helical_normals(np.array([[0.0, 1.0]]), np.array([10.0]), np.array([2 * np.pi])), 6).tolist()
    [[0.0, 0.995037, 0.099504]]
    """
    out = np.column_stack([normals, normals[:, 1] * lead / (2 * np.pi * radius)])
    return out / np.linalg.norm(out, axis=1)[:, None]


def on_helicoid(normals: np.ndarray, points: np.ndarray, lead: float) -> np.ndarray:
    """(n, 3) unit normals of a 3-D helicoid about the y axis of lead L [mm per turn] (right-hand for L > 0, the
    sense of :func:`helical_normals`): ``normals`` (n, 3) with their component along the helix through each of
    ``points`` (n, 3), h = r e_t - L / (2 pi) e_y (e_t = (-z, 0, x) / r), removed.

    >>> np.round(on_helicoid(np.array([[0.0, 1.0, 0.0]]), np.array([[10.0, 0.0, 0.0]]), 2 * np.pi), 6).tolist()
    [[0.0, 0.995037, 0.099504]]
    """
    points = np.asarray(points, dtype=float)
    helix = np.column_stack([-points[:, 2], np.full(len(points), -lead / (2 * np.pi)), points[:, 0]])
    helix /= np.linalg.norm(helix, axis=1)[:, None]
    out = normals - np.sum(normals * helix, axis=1)[:, None] * helix
    return out / np.linalg.norm(out, axis=1)[:, None]


def with_circumferential_tangent(pairs: ContactPairs, n_nodes: int, lead: np.ndarray | None = None) -> ContactPairs:
    """Pairs of an (r, y) section (frames (n_pairs, 2, 2), B on two components per node) lifted to three
    components per node: frames (n, t1, t2), B (3 n_pairs, 3 n_nodes).

    Without a lead t2 = t, the circumferential direction; with ``lead`` (n_pairs,) [mm per turn] the normal is
    the helicoid's (:func:`helical_normals`), t1 stays the section's tangent (normal to it) and t2 = t1 x n is
    the helix direction; the initial gap is measured along the tilted normal.

    Each pair's rows of B are ``frame_k . sum_j c_j u_j`` (node-to-node: c = +1 contact, -1 target; mortar:
    its segment weights), so the node coefficients come back as c_j = sum_k,c frame[k, c] B[2i + k, 2j + c] / 2
    and the lifted rows are ``frame3_k . sum_j c_j u_j``.
    """
    n_pairs = pairs.n_pairs
    B = sp.coo_matrix(pairs.B)
    pair, k, node, c = B.row // 2, B.row % 2, B.col // 2, B.col % 2
    coefficient = sp.csr_matrix((pairs.frames[pair, k, c] * B.data / 2.0, (pair, node)), shape=(n_pairs, n_nodes))
    coefficient.sum_duplicates()
    lead = np.zeros(n_pairs) if lead is None else np.asarray(lead, dtype=float)
    normal = helical_normals(pairs.frames[:, 0], pairs.position[:, 0], lead)
    frames = np.zeros((n_pairs, 3, 3))
    frames[:, 0] = normal
    frames[:, 1, :2] = pairs.frames[:, 1]
    frames[:, 2] = np.cross(frames[:, 1], normal)
    coo = coefficient.tocoo()
    rows, cols, values = [], [], []
    for k in range(3):
        for c in range(3):
            rows.append(3 * coo.row + k)
            cols.append(3 * coo.col + c)
            values.append(frames[coo.row, k, c] * coo.data)
    lifted = sp.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(3 * n_pairs, 3 * n_nodes))
    lifted.eliminate_zeros()
    return ContactPairs(nodes=pairs.nodes, position=pairs.position, frames=frames, weight=pairs.weight,
                        zone_share=pairs.zone_share, gap=pairs.gap * np.sum(normal[:, :2] * pairs.frames[:, 0], axis=1),
                        B=lifted, interface=pairs.interface, facing=pairs.facing)
