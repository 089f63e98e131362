"""Axisymmetry with twist ("axisymmetric_twist", as Abaqus CGAX): contact pairs with the circumferential tangent.

A model of revolution about y (x = r) whose displacement has a circumferential component u_t, independent of theta:
three components per node (u_r, u_y, u_t), strains e_rr, e_yy, e_tt = u_r / r, e_ry and the torsion shears
e_rt = (du_t/dr - u_t/r) / 2, e_yt = du_t/dy / 2 (tensor shears; :func:`frictionid.fem.assembly.torsion_shears`).
The direction t = r x y is +z on the x-y plane at x > 0; a positive u_t = r phi turns a body by phi about -y.

Contact pairs of such a model are the pairs of its (r, y) section with a second tangent, the circumferential one:
frames (n, t1, t) with n and t1 in the (r, y) plane, so friction acts in the section and around the axis like a
3-D pair with two tangents, and the Coulomb disc bounds the resultant of both. Weights, gaps and zone shares are
those of the section's pairs (whole ring).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .pairs import ContactPairs


def with_circumferential_tangent(pairs: ContactPairs, n_nodes: int) -> ContactPairs:
    """Pairs of an (r, y) section (frames (n_pairs, 2, 2), B on two components per node) lifted to three
    components per node: frames (n, t1, t), B (3 n_pairs, 3 n_nodes).

    Each pair's rows of B are ``frame_k . sum_j c_j u_j`` (node-to-node: c = +1 contact, -1 target; mortar:
    its segment weights), so the node coefficients come back as c_j = sum_k,c frame[k, c] B[2i + k, 2j + c] / 2
    and the circumferential row is ``sum_j c_j u_t,j``.
    """
    n_pairs = pairs.n_pairs
    B = sp.coo_matrix(pairs.B)
    pair, k = B.row // 2, B.row % 2
    node, c = B.col // 2, B.col % 2
    coefficient = sp.csr_matrix((pairs.frames[pair, k, c] * B.data / 2.0, (pair, node)), shape=(n_pairs, n_nodes))
    coefficient.sum_duplicates()
    in_plane = sp.csr_matrix((B.data, (3 * pair + k, 3 * node + c)), shape=(3 * n_pairs, 3 * n_nodes))
    coo = coefficient.tocoo()
    around = sp.csr_matrix((coo.data, (3 * coo.row + 2, 3 * coo.col + 2)), shape=(3 * n_pairs, 3 * n_nodes))
    frames = np.zeros((n_pairs, 3, 3))
    frames[:, :2, :2] = pairs.frames
    frames[:, 2, 2] = 1.0
    return ContactPairs(nodes=pairs.nodes, position=pairs.position, frames=frames, weight=pairs.weight,
                        zone_share=pairs.zone_share, gap=pairs.gap, B=(in_plane + around).tocsr(),
                        interface=pairs.interface)
