"""Point observation operators: displacement and strain components at arbitrary points as sparse matrices."""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from . import incompatible
from .locate import cell_nodes, checked_points, locate, reference_basis
from .space import Space

#: quantities each model kind can observe; "ezz" of plane strain is identically zero
QUANTITIES = {
    "3d": ("ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz"),
    "plane_strain": ("ux", "uy", "exx", "eyy", "ezz", "exy"),
    "axisymmetric": ("ux", "uy", "exx", "eyy", "ezz", "exy"),
}
_AXIS = {"x": 0, "y": 1, "z": 2}


def point_operator(space: Space, points, quantities: Sequence[str],
                   regions: Sequence[str | None] | None = None, materials: Mapping | None = None) -> sp.csr_matrix:
    """Sparse matrix evaluating displacement and strain components at points from a frictionid dof vector.

    Parameters
    ----------
    space : Space
        The model's space; ``space.kind`` decides how strains are formed.
    points : (n, dim) [mm]
        Undeformed coordinates in the mesh's frame (axisymmetric: x = r >= 0, y = axis).
    quantities : sequence of str
        Any of "ux", "uy", "uz" [mm] and the small-strain tensor components "exx", "eyy", "ezz", "exy",
        "eyz", "exz" (tensor shear, exy = gamma_xy / 2). Plane strain: "ezz" is a zero row; "uz", "eyz",
        "exz" are errors. Axisymmetric (x = r, y = axis): "ux" = u_r, "exx" = du_r/dr, "ezz" = u_r / r
        (hoop strain; on the axis, r <= 1e-9 of the mesh extent, its limit du_r/dr, which assumes
        u_r = 0 there as symmetry requires), "exy" = e_ry = (du_r/dy + du_y/dr) / 2.
    regions : sequence of (str or None), optional
        ``regions[i]`` restricts point i to the cells of that mesh region (needed where two bodies touch
        and a point lies on both surfaces); None allows any cell.
    materials : mapping region name -> Material, optional
        Needed (only) when ``space.element`` is "incompatible": the condensed internal modes, which add
        displacement inside a cell (none at its nodes) and strain, are recovered from the nodal dofs through
        the cell's stiffness (:mod:`frictionid.fem.incompatible`).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (n * len(quantities), space.n_dofs)
        Row ``i * len(quantities) + q`` is quantity ``quantities[q]`` at point i (point-major).

    Raises
    ------
    InputError
        For an unknown quantity, a badly shaped point array, an unknown region, or a point outside the mesh
        (or outside its region) by more than :data:`~.locate.SURFACE_TOL` of the nearest cell's size, naming the point index,
        its coordinates and its distance.

    Examples
    --------
    >>> H = point_operator(space, [[1.0, 2.0]], ["uy", "eyy"])   # doctest: +SKIP
    >>> uy, eyy = H @ u                                            # doctest: +SKIP
    """
    quantities = _checked_quantities(space.kind, quantities)
    points = checked_points(space, points)
    cells, reference = locate(space, points, regions)
    return _located_operator(space, quantities, points, cells, reference, materials)


def cell_centre_operator(space: Space, quantities: Sequence[str], materials: Mapping | None = None):
    """:func:`point_operator` at the centre of every cell (the image of its reference element's centroid).

    Returns
    -------
    operator : scipy.sparse.csr_matrix, shape (n_cells * len(quantities), space.n_dofs), cell-major
    centres : (n_cells, dim) [mm] the points evaluated

    Examples
    --------
    >>> H, centres = cell_centre_operator(space, ["exx", "eyy"])   # doctest: +SKIP
    >>> strains = (H @ u).reshape(len(centres), 2)                  # doctest: +SKIP
    """
    quantities = _checked_quantities(space.kind, quantities)
    n_cells = space.mesh.n_cells
    centroid = space.scalar.elem.refdom.p.mean(axis=1)
    reference = np.repeat(centroid[:, None], n_cells, axis=1)
    cells = np.arange(n_cells)
    phi, _ = reference_basis(space, reference)
    centres = np.einsum("nk,nkd->nd", phi, cell_nodes(space))
    return _located_operator(space, quantities, centres, cells, reference, materials), centres


def _located_operator(space: Space, quantities: tuple[str, ...], points: np.ndarray, cells: np.ndarray,
                      reference: np.ndarray, materials) -> sp.csr_matrix:
    """The rows of :func:`point_operator` for points already located in ``cells`` at ``reference``."""
    phi, grad = _shape_functions(space, cells, reference)
    nodes = space.node_of[space.scalar.element_dofs[:, cells]].T
    n_points = len(nodes)
    rows, cols, values = [], [], []
    for q, name in enumerate(quantities):
        for component, coefficient in _terms(space, name, points, phi, grad):
            rows.append(np.broadcast_to((np.arange(n_points) * len(quantities) + q)[:, None], nodes.shape))
            cols.append(space.dim * nodes + component)
            values.append(coefficient)
    shape = (n_points * len(quantities), space.n_dofs)
    operator = sp.csr_matrix(shape) if not rows else sp.csr_matrix(
        (np.concatenate(values, axis=None), (np.concatenate(rows, axis=None), np.concatenate(cols, axis=None))),
        shape=shape)
    if space.element == "incompatible":
        operator = operator + _internal_modes(space, materials, quantities, cells, phi, nodes)
    return operator


def _checked_quantities(kind: str, quantities) -> tuple[str, ...]:
    if isinstance(quantities, str):
        quantities = [quantities]
    quantities = tuple(quantities)
    if not quantities:
        raise InputError("point operator: `quantities` must name at least one quantity")
    allowed = QUANTITIES[kind]
    for name in quantities:
        if name not in allowed:
            raise InputError(f"point operator: quantity {name!r} is not available for a {kind} model; "
                             f"expected one of {list(allowed)}")
    return quantities


def _shape_functions(space: Space, cells: np.ndarray, reference: np.ndarray):
    """Shape function values (n, n_local) and physical gradients (n, n_local, dim) [1/mm] at located points."""
    cell_xyz = cell_nodes(space)[cells]
    phi, dphi = reference_basis(space, reference)
    jacobian = np.einsum("nka,nkb->nab", cell_xyz, dphi)
    # grad_x phi = J^-T grad_X phi
    grad = np.linalg.solve(np.swapaxes(jacobian, 1, 2), np.swapaxes(dphi, 1, 2))
    return phi, np.swapaxes(grad, 1, 2)


def _terms(space: Space, name: str, points: np.ndarray, phi: np.ndarray, grad: np.ndarray):
    """(component, coefficients (n, n_local)) pairs whose sum over nodes gives quantity `name`."""
    if name[0] == "u":
        return [(_AXIS[name[1]], phi)]
    a, b = _AXIS[name[1]], _AXIS[name[2]]
    if a == b == 2 and space.kind == "plane_strain":
        return []
    if a == b == 2 and space.kind == "axisymmetric":
        return [(0, _hoop(space, points, phi, grad))]
    if a == b:
        return [(a, grad[:, :, a])]
    return [(a, 0.5 * grad[:, :, b]), (b, 0.5 * grad[:, :, a])]


def _internal_modes(space: Space, materials, quantities, cells, phi, nodes) -> sp.csr_matrix:
    """Rows of the condensed incompatible modes at the located points, in the cells' nodal dofs."""
    if materials is None:
        raise InputError("point operator: a space with element 'incompatible' needs `materials` (the internal "
                         "modes are recovered from the nodal dofs through each cell's stiffness)")
    corners = space.mesh.cells[cells]                                        # (n, 8) meshio order
    # the scikit-fem and the natural parametrisation are trilinear maps of the same corners that differ by a
    # symmetry of the cube (an affine map), so interpolating the corners' natural coordinates is exact
    position = np.argmax(corners[:, None, :] == nodes[:, :, None], axis=2)
    xi = np.einsum("nj,njd->nd", phi, incompatible.CORNERS[position])
    lame = incompatible.cell_lame(space.mesh, materials)[cells]
    U, D = incompatible.internal_fields(space.mesh.points[corners], lame, xi)
    axes = [[_AXIS[c] for c in q[1:]] for q in quantities]
    values = np.stack([U[:, a[0]] if q[0] == "u" else 0.5 * (D[:, a[0], a[1]] + D[:, a[1], a[0]])
                       for q, a in zip(quantities, axes)], axis=1)          # (n, n_quantities, 24)
    rows = np.broadcast_to(np.arange(values.shape[0] * values.shape[1]).reshape(values.shape[:2] + (1,)),
                           values.shape)
    cols = np.broadcast_to(incompatible.cell_dofs(corners)[:, None, :], values.shape)
    return sp.csr_matrix((values.ravel(), (rows.ravel(), cols.ravel())),
                         shape=(values.shape[0] * values.shape[1], space.n_dofs))


def _hoop(space: Space, points: np.ndarray, phi: np.ndarray, grad: np.ndarray) -> np.ndarray:
    """Coefficients of e_thetatheta = u_r / r; on the axis its limit du_r/dr (u_r = 0 there by symmetry)."""
    r = points[:, 0]
    on_axis = r <= 1e-9 * np.ptp(space.mesh.points, axis=0).max()
    safe_r = np.where(on_axis, 1.0, r)
    return np.where(on_axis[:, None], grad[:, :, 0], phi / safe_r[:, None])
