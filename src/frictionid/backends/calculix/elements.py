"""CalculiX element types, node orders and face numbers for each frictionid cell type and model kind.

Node orders: meshio (VTK) and CalculiX (Abaqus) agree on the corners and edge mid-nodes of every type used here;
"hexahedron27" and "quad9" have no CalculiX counterpart and are written as their serendipity elements
(C3D20 / CPE8 / CAX8) without the face and centre nodes, whose displacements are interpolated back
(:func:`fill_dropped_nodes`).
"""

from __future__ import annotations

import numpy as np

from ...errors import InputError

#: CalculiX element type per model kind and meshio cell type
ELEMENT_TYPE = {
    "3d": {"hexahedron": "C3D8", "hexahedron27": "C3D20", "tetra": "C3D4", "tetra10": "C3D10"},
    "plane_strain": {"triangle": "CPE3", "triangle6": "CPE6", "quad": "CPE4", "quad9": "CPE8"},
    "axisymmetric": {"triangle": "CAX3", "triangle6": "CAX6", "quad": "CAX4", "quad9": "CAX8"},
}
#: CalculiX type of each cell type with element technology "incompatible" (frictionid.fem.incompatible)
INCOMPATIBLE_TYPE = {"hexahedron": "C3D8I"}
#: number of leading meshio nodes of a cell that CalculiX keeps
N_KEPT = {"hexahedron": 8, "hexahedron27": 20, "tetra": 4, "tetra10": 10,
          "triangle": 3, "triangle6": 6, "quad": 4, "quad9": 8}
#: corner nodes (0-based, CalculiX order) of faces S1, S2, ... (CalculiX manual, section 6.2 / 6.7)
FACES = {
    "hex": ((0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)),
    "tet": ((0, 1, 2), (0, 3, 1), (1, 3, 2), (2, 3, 0)),
    "tri": ((0, 1), (1, 2), (2, 0)),
    "quad": ((0, 1), (1, 2), (2, 3), (3, 0)),
}
SHAPE = {"hexahedron": "hex", "hexahedron27": "hex", "tetra": "tet", "tetra10": "tet",
         "triangle": "tri", "triangle6": "tri", "quad": "quad", "quad9": "quad"}
#: node permutation reversing the orientation of a 2-D cell (clockwise -> counter-clockwise)
REVERSED_2D = {"triangle": [0, 2, 1], "triangle6": [0, 2, 1, 5, 4, 3],
               "quad": [0, 3, 2, 1], "quad9": [0, 3, 2, 1, 7, 6, 5, 4, 8]}


def element_type(kind: str, cell_type: str, element: str = "standard") -> str:
    """CalculiX element type of a model kind, meshio cell type and element technology (Model.element).

    CalculiX 2.20's C3D8I takes the incompatible modes' gradients with the centre Jacobian but without Taylor's
    factor det J0 / det J: on parallelepiped cells (every cell of the block builder) it is frictionid's element
    to round-off; on distorted cells the two differ (it fails the patch test, frictionid's does not).

    >>> element_type("3d", "hexahedron", "incompatible")
    'C3D8I'
    """
    if element == "incompatible":
        return INCOMPATIBLE_TYPE[cell_type]
    if kind not in ELEMENT_TYPE:
        raise InputError(f"the CalculiX backend cannot write a model of kind {kind!r}: CalculiX has no "
                         "axisymmetric element with twist (Abaqus CGAX); use backend 'embedded'")
    return ELEMENT_TYPE[kind][cell_type]


def calculix_cells(points: np.ndarray, cell_type: str, cells: np.ndarray) -> np.ndarray:
    """(n_cells, n_kept) node indices in CalculiX order; 2-D cells turned counter-clockwise (CalculiX needs it)."""
    cells = np.array(cells)
    if points.shape[1] == 2:
        a, b, c = (points[cells[:, k]] for k in (0, 1, 2))
        area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        cells[area < 0] = cells[area < 0][:, REVERSED_2D[cell_type]]
    return cells[:, :N_KEPT[cell_type]]


def face_lookup(cell_type: str, cells: np.ndarray) -> dict[frozenset, tuple[int, int]]:
    """Corner-node set of every cell face -> (cell index, face number 1..n) in CalculiX numbering."""
    out = {}
    for face_number, corners in enumerate(FACES[SHAPE[cell_type]], start=1):
        for cell, nodes in enumerate(cells[:, corners].tolist()):
            out[frozenset(nodes)] = (cell, face_number)
    return out


def dropped_nodes(cell_type: str, cells: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The nodes CalculiX does not have, each as a fixed combination of kept nodes of one of its cells.

    Returns groups ``(nodes (n,), masters (n, k), weights (k,))`` with ``u[nodes] = u[masters] @ weights``:
    serendipity shape functions at a face centre weigh the face's corners -1/4 and its edge mid-nodes 1/2; at
    the centre of the 20-node brick corners -1/4 and edge mid-nodes 1/4. Each dropped node appears once.
    """
    cells = np.asarray(cells)
    face = np.array([-0.25] * 4 + [0.5] * 4)
    if cell_type == "quad9":
        return [_unique(cells[:, 8], cells[:, :8], face)]
    if cell_type != "hexahedron27":
        return []
    nodes = np.concatenate([cells[:, 20 + k] for k in range(6)])
    masters = np.concatenate([cells[:, list(corners) + list(edges)] for corners, edges in _HEX27_FACES])
    centre = np.array([-0.25] * 8 + [0.25] * 12)
    return [_unique(nodes, masters, face), _unique(cells[:, 26], cells[:, :20], centre)]


def _unique(nodes: np.ndarray, masters: np.ndarray, weights: np.ndarray):
    nodes, first = np.unique(nodes, return_index=True)
    return nodes, masters[first], weights


def fill_dropped_nodes(cell_type: str, cells: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Nodal values (n_nodes, k) with the nodes CalculiX did not have interpolated (:func:`dropped_nodes`)."""
    values = np.array(values, dtype=float)
    for nodes, masters, weights in dropped_nodes(cell_type, cells):
        values[nodes] = np.einsum("nk...,k->n...", values[masters], weights)
    return values


def lump_dropped_forces(cell_type: str, cells: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """Nodal forces (n_nodes, dim) with those on dropped nodes moved to their masters (virtual work of
    :func:`fill_dropped_nodes`' constraint, so the loads' resultant and work are kept)."""
    forces = np.array(forces, dtype=float)
    for nodes, masters, weights in dropped_nodes(cell_type, cells):
        np.add.at(forces, masters, weights[None, :, None] * forces[nodes][:, None, :])
        forces[nodes] = 0.0
    return forces


# VTK triquadratic hexahedron face nodes 20..25: faces x-, x+, y-, y+, z-, z+ as (corners, edge mid-nodes)
_HEX27_FACES = (
    ((0, 3, 7, 4), (11, 19, 15, 16)),
    ((1, 2, 6, 5), (9, 18, 13, 17)),
    ((0, 1, 5, 4), (8, 17, 12, 16)),
    ((3, 2, 6, 7), (10, 18, 14, 19)),
    ((0, 1, 2, 3), (8, 9, 10, 11)),
    ((4, 5, 6, 7), (12, 13, 14, 15)),
)
