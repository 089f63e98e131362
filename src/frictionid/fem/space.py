"""Space: the scikit-fem basis of a model's mesh and the map from its dofs to frictionid's node-major dofs.

frictionid numbers dofs node-major, ``dof = dim * node + component``, with nodes as in :class:`Mesh`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import meshio
import numpy as np
import skfem
from skfem.io.meshio import from_meshio

from ..errors import InputError
from ..model import Mesh
from ..model.model import AXISYMMETRIC_KINDS, check_element, n_components

ELEMENTS = {
    "triangle": skfem.ElementTriP1,
    "triangle6": skfem.ElementTriP2,
    "quad": skfem.ElementQuad1,
    "quad9": skfem.ElementQuad2,
    "tetra": skfem.ElementTetP1,
    "tetra10": skfem.ElementTetP2,
    "hexahedron": skfem.ElementHex1,
    "hexahedron27": skfem.ElementHex2,
}
#: quadrature order of the stiffness: exact for affine cells (tensor Gauss 2^d for Q1, 3^d for Q2);
#: axisymmetric models get one order more for the 1/r hoop terms
INTORDER = {"triangle": 2, "triangle6": 4, "quad": 3, "quad9": 5,
            "tetra": 2, "tetra10": 4, "hexahedron": 3, "hexahedron27": 5}
N_CORNERS = {"line": 2, "line3": 2, "triangle": 3, "triangle6": 3, "quad": 4, "quad9": 4}


#: how far outside the reference simplex (in reference coordinates) an unclipped inverse-map point may land
INSIDE_TOL = 1e-8


class _FacetMapping(skfem.MappingIsoparametric):
    """The isoparametric map with its inverse (facet quadrature points -> cell reference coordinates) by Newton's
    method as scikit-fem's, but

    - stopped at 1e-10 instead of scikit-fem's absolute 1e-12: for 0.1 mm quadratic cells 180 mm from the origin
      (an M30 bolt model) round-off stalls the Newton update at about 1.1e-12 and FacetBasis raised;
    - started, on triangles and tetrahedra, from the inverse of the straight cell through the corners instead of
      0.5 in every reference coordinate, which lies outside the reference tetrahedron: there a curved cell's
      quadratic map can fold, and Newton did not converge on valid tetra10 cells whose mid-side nodes lie on a
      curved face (the 3-D bolt's helical flanks);
    - each step clipped to the unit cube, which keeps the iterates out of the region where the map folds; where
      that stalls (a valid but strongly curved cell whose straight inverse lies far outside, so that the clip holds
      the iterate at a corner: a sliver tetrahedron made valid by its curved mid-side nodes at the 3-D bolt's
      roots), the cell's points are solved again from the same start without the clip and accepted only if they
      land in the reference tetrahedron (within :data:`INSIDE_TOL`)."""

    def invF(self, x, tind=None, newton_max_iters=50, newton_tol=1e-10):
        X0 = self._straight_inverse(x, tind)
        if X0 is None:
            return super().invF(x, tind=tind, newton_max_iters=newton_max_iters, newton_tol=newton_tol)
        X, done = self._newton(x, tind, X0, newton_max_iters, newton_tol, clip=True)
        if not done.all():
            cells = (np.arange(x.shape[1]) if tind is None else np.asarray(tind))[~done]
            Y, free_done = self._newton(x[:, ~done], cells, X0[:, ~done], newton_max_iters, newton_tol, clip=False)
            inside = (Y.min(axis=0) > -INSIDE_TOL).all(axis=1) & (Y.sum(axis=0) < 1 + INSIDE_TOL).all(axis=1)
            if not (free_done & inside).all():
                raise Exception(f"Newton iteration didn't converge up to TOL={newton_tol}")
            X[:, ~done] = Y
        return X

    def _newton(self, x, tind, X, max_iters, tol, clip):
        """Newton's iterates of invF from X, clipped to the unit cube after each step or not, and per cell
        whether its last step was below ``tol``."""
        for _ in range(max_iters):
            dX = np.einsum("ijkl,jkl->ikl", self.invDF(X, tind), x - self.F(X, tind))
            X = np.clip(X + dX, 0.0, 1.0) if clip else X + dX
            done = np.linalg.norm(dX, 1, (0, 2)) < tol
            if done.all():
                break
        return X, done

    def _straight_inverse(self, x, tind):
        """(dim, n_cells, n_points) reference coordinates of x (dim, n_cells, n_points) in the straight simplices
        through the cells' corners, or None for other cells."""
        dim = self.mesh.dim()
        if self.mesh.t.shape[0] != dim + 1:
            return None
        corners = self.mesh.p[:, self.mesh.t if tind is None else self.mesh.t[:, tind]]   # (dim, dim + 1, n)
        edges = np.moveaxis(corners[:, 1:] - corners[:, :1], -1, 0)                      # (n, dim, dim)
        local = np.linalg.solve(edges, np.moveaxis(x - corners[:, 0, :, None], 1, 0))     # (n, dim, n_points)
        return np.moveaxis(local, 0, 1)


def _local_permutation(mesh: Mesh, basis: skfem.CellBasis) -> np.ndarray:
    """perm[e, j]: position in cell e's node list of the basis' local dof j, found by matching coordinates.

    scikit-fem may reorder a cell's vertices (orientation), so the permutation is per cell.
    """
    dofs = basis.element_dofs
    locs = basis.doflocs[:, dofs].transpose(2, 1, 0)            # (n_cells, n_local, dim)
    nodes = mesh.points[mesh.cells]                            # (n_cells, n_local, dim)
    distance = np.linalg.norm(locs[:, :, None, :] - nodes[:, None, :, :], axis=-1)
    perm = distance.argmin(axis=2)                             # (n_cells, n_local)
    size = np.linalg.norm(np.ptp(nodes, axis=1), axis=1)[:, None]
    if np.any(distance.min(axis=2) > 1e-8 * size):
        raise InputError("mesh: cell node order is not the one expected for "
                         f"{mesh.cell_type} cells (gmsh/meshio order)")
    return perm


@dataclass(frozen=True)
class Space:
    """A vector H1 space on the mesh (isoparametric Lagrange elements of the mesh's order).

    Attributes
    ----------
    mesh : the frictionid mesh
    skmesh : the scikit-fem mesh
    basis : vector basis, scalar : scalar basis of the same element
    dof_of : (basis.N,) frictionid dof of each scikit-fem vector dof
    node_of : (scalar.N,) frictionid node of each scikit-fem scalar dof
    kind : "3d" | "plane_strain" | "axisymmetric" | "axisymmetric_twist" (three components per node on the 2-D
        mesh: u_r, u_y, u_t)
    element : "standard" | "incompatible" (linear hexahedra with incompatible modes, see
        :mod:`frictionid.fem.incompatible`; ``basis`` still spans the nodal dofs)
    """

    mesh: Mesh
    skmesh: skfem.Mesh
    basis: skfem.CellBasis
    scalar: skfem.CellBasis
    dof_of: np.ndarray
    node_of: np.ndarray
    kind: str = "3d"
    element: str = "standard"

    def __reduce__(self):
        """Pickled as what builds it: the bases' quadrature data are most of its size and cheap to rebuild."""
        return type(self).build, (self.mesh, self.kind, self.element)

    @classmethod
    def build(cls, mesh: Mesh, kind: str | None = None, element: str = "standard") -> "Space":
        """The space of a mesh; ``kind`` ("3d" | "plane_strain" | "axisymmetric") defaults by dimension,
        ``element`` is the element technology (:data:`frictionid.model.model.ELEMENTS`)."""
        check_element(element, mesh.cell_type, "space")
        lagrange = ELEMENTS[mesh.cell_type]()
        skmesh = from_meshio(meshio.Mesh(np.asarray(mesh.points), [(mesh.cell_type, np.asarray(mesh.cells))]))
        kind = kind or ("3d" if mesh.dim == 3 else "plane_strain")
        intorder = INTORDER[mesh.cell_type] + (kind in AXISYMMETRIC_KINDS)
        dim = n_components(kind, mesh.dim)
        scalar = skfem.Basis(skmesh, lagrange, intorder=intorder)
        basis = skfem.Basis(skmesh, skfem.ElementVector(lagrange, dim=dim), intorder=intorder)
        perm = _local_permutation(mesh, scalar)
        node_of = np.empty(scalar.N, dtype=np.int64)
        node_of[scalar.element_dofs] = np.take_along_axis(mesh.cells, perm, axis=1).T
        dof_of = np.empty(basis.N, dtype=np.int64)
        for c in range(dim):
            dof_of[basis.element_dofs[c::dim]] = dim * node_of[scalar.element_dofs] + c
        return cls(mesh, skmesh, basis, scalar, dof_of, node_of, kind, element)

    @property
    def dim(self) -> int:
        """Dimension of the mesh (of points and normals)."""
        return self.mesh.dim

    @property
    def n_components(self) -> int:
        """Displacement components per node, the stride of frictionid's node-major dofs."""
        return n_components(self.kind, self.mesh.dim)

    def ring(self, x: np.ndarray) -> np.ndarray:
        """Measure factor at quadrature points x (dim, ...): 2 pi r for axisymmetric models, else 1.

        Multiplying integrands by it makes every axisymmetric force and area a whole-ring (360 deg) quantity.
        """
        return 2 * np.pi * x[0] if self.kind in AXISYMMETRIC_KINDS else np.ones_like(x[0])

    @property
    def n_dofs(self) -> int:
        return self.n_components * self.mesh.n_nodes

    def to_dofs(self, matrix):
        """A scikit-fem assembled sparse matrix or vector renumbered to frictionid dofs."""
        if np.ndim(matrix) == 1:
            out = np.zeros(self.n_dofs)
            out[self.dof_of] = matrix
            return out
        coo = matrix.tocoo()
        import scipy.sparse as sp
        return sp.csr_matrix((coo.data, (self.dof_of[coo.row], self.dof_of[coo.col])),
                             shape=(self.n_dofs, self.n_dofs))

    def nodal(self, vector: np.ndarray) -> np.ndarray:
        """A scikit-fem scalar dof vector as a per-node array (n_nodes,)."""
        out = np.zeros(self.mesh.n_nodes)
        out[self.node_of] = vector
        return out

    @cached_property
    def _facet_index(self) -> dict:
        vertex_of_node = np.full(self.mesh.n_nodes, -1, dtype=np.int64)
        vertex_of_node[self.node_of[self.scalar.nodal_dofs[0]]] = np.arange(self.scalar.nodal_dofs.shape[1])
        keys = np.sort(self.skmesh.facets, axis=0).T
        return {"vertex_of_node": vertex_of_node, "facet": {tuple(k): i for i, k in enumerate(keys.tolist())}}

    def facets(self, name: str) -> np.ndarray:
        """scikit-fem facet indices of the named boundary."""
        facets = self.mesh.boundary(name)
        corners = self._facet_index["vertex_of_node"][facets[:, :N_CORNERS[self.mesh.facet_type]]]
        lookup = self._facet_index["facet"]
        try:
            return np.array([lookup[tuple(sorted(c))] for c in corners.tolist()], dtype=np.int64)
        except KeyError:
            raise InputError(f"mesh: boundary {name!r} has a facet that is not a face of any cell") from None

    def facet_basis(self, name: str, vector: bool = True) -> skfem.FacetBasis:
        """Facet basis (outward normals of the adjacent cell) on the named boundary."""
        element = self.basis.elem if vector else self.scalar.elem
        mesh = self.skmesh
        mapping = None if mesh.affine else _FacetMapping(mesh, mesh.elem(), mesh.bndelem)
        return skfem.FacetBasis(mesh, element, mapping=mapping, facets=self.facets(name),
                                intorder=2 * self.scalar.elem.maxdeg + 1)
