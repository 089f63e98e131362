"""Uniform subdivision of a user's mesh: every cell split into 2^dim children of its own type, groups carried over.

Each cell (and each boundary facet) is split in its reference element: a line into 2, a triangle into 4 at its
edge midpoints, a tetrahedron into 4 corner tetrahedra and the inner octahedron into 4 around one diagonal, a
quadrilateral or hexahedron into 4 or 8 halves of itself. A child's nodes are placed by the parent's own
shape functions (so quadratic cells keep their curved geometry) and named by where they lie: the parent's
corners and their linear weights there. A node on an edge or a face shared by two cells gets the same name
from both and is made once, while bodies in contact, which have their own corners at the interface, keep their
own nodes. The parent's nodes keep their numbers; new nodes follow them.

The node order of quadratic cells (where each mid-edge, mid-face and centre node sits) is read from the mesh's
geometry (the most common position among its cells), so gmsh's and Abaqus' orders are both understood.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from ..errors import InputError
from ..model.mesh import FACET_TYPE

#: corners of each linear reference element in [0, 1]^d, meshio order
CORNERS = {
    "line": ((0,), (1,)),
    "triangle": ((0, 0), (1, 0), (0, 1)),
    "quad": ((0, 0), (1, 0), (1, 1), (0, 1)),
    "tetra": ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "hexahedron": ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)),
}
#: the linear type and polynomial degree of each cell or facet type
SHAPE = {"line": ("line", 1), "line3": ("line", 2), "triangle": ("triangle", 1), "triangle6": ("triangle", 2),
         "quad": ("quad", 1), "quad9": ("quad", 2), "tetra": ("tetra", 1), "tetra10": ("tetra", 2),
         "hexahedron": ("hexahedron", 1), "hexahedron27": ("hexahedron", 2)}
_SIMPLEX = ("line", "triangle", "tetra")
#: linear weights are stored as integers of this resolution (multiples of 1/4 per axis, cubed, are exact)
_WEIGHT_SCALE = 4096
#: corners of the children in the parent's reference element (midpoints of the simplex edges by name)
_TRIANGLE = ("a", "ab", "ca"), ("ab", "b", "bc"), ("ca", "bc", "c"), ("bc", "ca", "ab")
_TETRA = (("a", "ab", "ac", "ad"), ("ab", "b", "bc", "bd"), ("ac", "bc", "c", "cd"), ("ad", "bd", "cd", "d"),
          ("ac", "bd", "ab", "bc"), ("ac", "bd", "bc", "cd"), ("ac", "bd", "cd", "ad"), ("ac", "bd", "ad", "ab"))


def _simplex_point(name: str, corners: np.ndarray) -> np.ndarray:
    return corners["abcd".index(name[0])] if len(name) == 1 else corners[["abcd".index(c) for c in name]].mean(0)


def children_corners(linear: str) -> np.ndarray:
    """(n_children, n_corners, d) corners of the children in the reference element, each oriented like the parent
    (the corner lists above are; tests/test_subdivide.py checks every child's orientation).

    >>> children_corners("line").tolist()
    [[[0.0], [0.5]], [[0.5], [1.0]]]
    """
    corners = np.array(CORNERS[linear], dtype=float)
    if linear in ("triangle", "tetra"):
        return np.array([[_simplex_point(n, corners) for n in child]
                         for child in (_TRIANGLE if linear == "triangle" else _TETRA)])
    offsets = itertools.product((0.0, 0.5), repeat=corners.shape[1])
    return np.array([np.array(offset) + corners / 2 for offset in offsets])


def linear_weights(linear: str, xi: np.ndarray) -> np.ndarray:
    """(m, n_corners) weights of the corners at reference points xi (m, d): barycentric or multilinear."""
    xi = np.atleast_2d(np.asarray(xi, dtype=float))
    if linear in _SIMPLEX:
        return np.column_stack([1.0 - xi.sum(axis=1), xi])
    corners = np.array(CORNERS[linear])
    return np.prod(np.where(corners[None, :, :] == 1, xi[:, None, :], 1.0 - xi[:, None, :]), axis=2)


def _monomials(linear: str, degree: int, xi: np.ndarray) -> np.ndarray:
    d = xi.shape[1]
    powers = [e for e in itertools.product(range(degree + 1), repeat=d)
              if linear not in _SIMPLEX or sum(e) <= degree]
    return np.stack([np.prod(xi ** np.array(e), axis=1) for e in powers], axis=1)


def shape_functions(kind: str, template: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """(m, n_nodes) Lagrange shape functions of a cell type with nodes at ``template`` (n_nodes, d), at xi."""
    linear, degree = SHAPE[kind]
    basis = _monomials(linear, degree, template)
    return _monomials(linear, degree, np.atleast_2d(xi)) @ np.linalg.inv(basis)


def node_template(kind: str, points: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """(n_nodes, d) reference coordinates of each node of ``kind``'s node order, read from the elements'
    geometry (the most common rounded position per node among up to 200 elements)."""
    linear, degree = SHAPE[kind]
    corners = np.array(CORNERS[linear], dtype=float)
    if degree == 1:
        return corners
    sample = points[elements[:200]]                          # (n, n_nodes, dim)
    n_corners = len(corners)
    xi = np.full(sample.shape[:2] + (corners.shape[1],), 0.5)
    for _ in range(12):                                      # Newton on the corners' multilinear map
        weights = linear_weights(linear, xi.reshape(-1, corners.shape[1])).reshape(xi.shape[:2] + (n_corners,))
        mapped = np.einsum("enc,ecx->enx", weights, sample[:, :n_corners])
        jac = _jacobian(linear, xi, sample[:, :n_corners])      # (n, n_nodes, dim, d)
        delta = np.einsum("enij,enj->eni", np.linalg.pinv(jac), sample - mapped)
        xi = xi + delta
    rounded = np.round(xi * degree) / degree
    template = np.empty((elements.shape[1], corners.shape[1]))
    for j in range(elements.shape[1]):
        values, counts = np.unique(rounded[:, j], axis=0, return_counts=True)
        template[j] = values[np.argmax(counts)]
    expected = {tuple(np.array(e) / degree) for e in itertools.product(range(degree + 1), repeat=corners.shape[1])
                if linear not in _SIMPLEX or sum(e) <= degree}
    if (not np.allclose(template[:n_corners], corners) or len({tuple(t) for t in template}) != len(template)
            or {tuple(t) for t in template} != expected):
        raise InputError(f"mesh refinement: the node order of the {kind} cells is not one frictionid knows (its "
                         "mid-edge, mid-face and centre nodes are not where a quadratic cell has them)")
    return template


def _jacobian(linear: str, xi: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """d x / d xi of the corners' multilinear map, by central differences (exact for a multilinear map)."""
    d, h = xi.shape[-1], 1e-6
    columns = []
    for a in range(d):
        step = np.zeros(d)
        step[a] = h
        plus = linear_weights(linear, (xi + step).reshape(-1, d)).reshape(xi.shape[:2] + (-1,))
        minus = linear_weights(linear, (xi - step).reshape(-1, d)).reshape(xi.shape[:2] + (-1,))
        columns.append(np.einsum("enc,ecx->enx", (plus - minus) / (2 * h), corners))
    return np.stack(columns, axis=-1)


def _keys(corner_ids: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(n_el, m, 16) names of the points with linear ``weights`` (m, n_corners) in elements with corner node ids
    (n_el, n_corners): the pairs (corner id, weight) of the nonzero weights, sorted by id, padded with -1."""
    n_el, m = len(corner_ids), len(weights)
    w = np.rint(weights * _WEIGHT_SCALE).astype(np.int64)
    ids = np.broadcast_to(corner_ids[:, None, :], (n_el, m, corner_ids.shape[1])).astype(np.int64)
    w = np.broadcast_to(w[None], ids.shape)
    ids = np.where(w > 0, ids, np.iinfo(np.int64).max)
    order = np.argsort(ids, axis=2)
    ids, w = np.take_along_axis(ids, order, 2), np.take_along_axis(w, order, 2)
    ids, w = np.where(w > 0, ids, -1), np.where(w > 0, w, -1)
    pad = 8 - ids.shape[2]
    pairs = np.stack([ids, w], axis=3).reshape(n_el, m, -1)
    return np.concatenate([pairs, np.full((n_el, m, 2 * pad), -1, np.int64)], axis=2)


def _split(kind: str, template: np.ndarray, elements: np.ndarray):
    """The children of ``elements`` as (n_el, n_children, n_nodes) indices into their points' reference
    coordinates (m, d), and those coordinates."""
    linear, _ = SHAPE[kind]
    refs = np.array([linear_weights(linear, template) @ child for child in children_corners(linear)])
    xi, index = np.unique(np.round(refs.reshape(-1, refs.shape[-1]), 9), axis=0, return_inverse=True)
    return index.reshape(refs.shape[:2]), xi


def subdivide(points: np.ndarray, cell_type: str, cells: np.ndarray, facets: dict, node_sets: dict):
    """One uniform subdivision (module docstring).

    Parameters
    ----------
    points : (n_nodes, dim) [mm]; cell_type : meshio name; cells : (n_cells, n_cell_nodes)
    facets : name -> (n, n_facet_nodes) boundary facets of type FACET_TYPE[cell_type]
    node_sets : name -> node indices

    Returns
    -------
    points, cells, children (n_cells, n_children) the child cells of each cell, facets, node_sets
    """
    linear, _ = SHAPE[cell_type]
    template = node_template(cell_type, points, cells)
    local, xi = _split(cell_type, template, cells)
    n_corners = len(CORNERS[linear])
    keys = _keys(cells[:, :n_corners], linear_weights(linear, xi))            # (n_cells, m, 16)
    unique, first, inverse = np.unique(keys.reshape(-1, keys.shape[2]), axis=0, return_index=True,
                                       return_inverse=True)
    inverse = inverse.reshape(keys.shape[:2])
    ids = np.full(len(unique), -1, np.int64)
    own = [int(np.flatnonzero(np.all(np.isclose(xi, node), axis=1))[0]) for node in template]
    ids[inverse[:, own]] = cells                                          # the parent's nodes keep their numbers
    new = ids < 0
    ids[new] = len(points) + np.arange(new.sum())
    shape = shape_functions(cell_type, template, xi)                      # (m, n_nodes)
    cell_of, point_of = np.divmod(first[new], len(xi))
    added = np.einsum("kn,knx->kx", shape[point_of], points[cells[cell_of]])
    out_points = np.concatenate([points, added])
    node_of = ids[inverse]                                                # (n_cells, m)
    out_cells = node_of[:, local].reshape(-1, cells.shape[1])
    children = np.arange(len(out_cells)).reshape(len(cells), -1)
    lookup = {row.tobytes(): i for row, i in zip(unique, ids)}
    out_facets = {name: _facet_children(FACET_TYPE[cell_type], points, f, lookup, name)
                  for name, f in facets.items()}
    corner_ids = unique[new][:, 0::2]
    out_sets = {name: np.concatenate([nodes, ids[new][np.all(np.isin(corner_ids, nodes) | (corner_ids < 0),
                                                                  axis=1)]])
                for name, nodes in node_sets.items()}
    return out_points, out_cells, children, out_facets, out_sets


def _facet_children(kind: str, points: np.ndarray, facets: np.ndarray, lookup: dict, name: str) -> np.ndarray:
    """The children of boundary facets, their nodes those the cells' subdivision made."""
    facets = np.asarray(facets)
    if len(facets) == 0:
        return facets.reshape(0, facets.shape[1] if facets.ndim == 2 else 0)
    linear, _ = SHAPE[kind]
    template = node_template(kind, points, facets)
    local, xi = _split(kind, template, facets)
    keys = _keys(facets[:, :len(CORNERS[linear])], linear_weights(linear, xi))
    try:
        node_of = np.array([[lookup[k.tobytes()] for k in row] for row in keys])
    except KeyError:
        raise InputError(f"mesh refinement: boundary {name!r} has facets that are no cell's face") from None
    return node_of[:, local].reshape(-1, facets.shape[1])


def subdivided(source, times: int):
    """A :class:`~frictionid.builders.mesh.MeshFile` subdivided ``times`` times: regions, boundaries and node sets
    carried over (a new node joins a node set when every corner it lies between is in it)."""
    points, cells = source.points, source.cells
    regions, boundaries, node_sets = dict(source.regions), dict(source.boundaries), dict(source.node_sets)
    for _ in range(times):
        points, cells, children, boundaries, node_sets = subdivide(points, source.cell_type, cells, boundaries,
                                                                   node_sets)
        regions = {name: children[np.asarray(index)].ravel() for name, index in regions.items()}
    return replace(source, points=points, cells=cells, regions=regions, boundaries=boundaries, node_sets=node_sets)
