"""Point observation operators: displacement and strain components at arbitrary points as sparse matrices."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..errors import InputError
from . import incompatible
from .locate import cell_nodes, checked_points, locate, reference_basis
from .space import Space

#: quantities each model kind can observe; "ezz" of plane strain is identically zero
QUANTITIES = {
    "3d": ("ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz"),
    "plane_strain": ("ux", "uy", "exx", "eyy", "ezz", "exy"),
    "axisymmetric": ("ux", "uy", "exx", "eyy", "ezz", "exy"),
    # on the x-y plane (x = r > 0, z = 0) the circumferential direction is +z: uz = u_t, eyz = e_yt, exz = e_rt
    "axisymmetric_twist": ("ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz"),
}
_AXIS = {"x": 0, "y": 1, "z": 2}
#: window shapes: the distance each measures (scipy's Minkowski p): a square / cube (max-norm), a circle / ball
SHAPES = {"square": np.inf, "circle": 2.0}


@dataclass(frozen=True)
class StrainWindow:
    """A DIC strain window in the model's frame: ``size`` [mm] the side of the square (cube) or the diameter of
    the circle (ball) centred on each point (see :func:`window_gradients`). A plain number as ``window`` is a
    square of that side. ``observed``: the rows (``point * n_quantities + quantity`` of :func:`point_operator`)
    whose values are fitted; a strain the window cannot give is an error only there (a face's points observe its
    in-plane strains). None: every row."""

    size: float
    shape: str = "square"
    observed: tuple[int, ...] | None = None

    def __post_init__(self):
        size = self.size
        if isinstance(size, bool) or not isinstance(size, (int, float)) or not np.isfinite(size) or size <= 0:
            raise InputError(f"data.strain_window: must be a positive length [mm], got {size!r}")
        if self.shape not in SHAPES:
            raise InputError(f"data.strain_window_shape: {self.shape!r} is not one of {', '.join(SHAPES)}")
        object.__setattr__(self, "size", float(size))
        if self.observed is not None:
            object.__setattr__(self, "observed", tuple(sorted({int(r) for r in self.observed})))

    def with_observed(self, rows) -> "StrainWindow":
        """This window for the observed ``rows`` only (see ``observed``)."""
        return StrainWindow(self.size, self.shape, tuple(rows))

    def needed(self, n_points: int, n_quantities: int) -> np.ndarray:
        """(n_points, n_quantities) bool: the rows whose values are fitted."""
        if self.observed is None:
            return np.ones((n_points, n_quantities), dtype=bool)
        mask = np.zeros(n_points * n_quantities, dtype=bool)
        rows = np.asarray(self.observed, dtype=np.int64)
        mask[rows[rows < mask.size]] = True
        return mask.reshape(n_points, n_quantities)

    def describe(self) -> str:
        return f"{self.size:g} mm" + ("" if self.shape == "square" else " (a circle's diameter)")

    @classmethod
    def of(cls, window) -> "StrainWindow | None":
        """``window`` as a StrainWindow: None, a number (a square of that side [mm]) or a StrainWindow."""
        return window if window is None or isinstance(window, cls) else cls(window)


def point_operator(space: Space, points, quantities: Sequence[str],
                   regions: Sequence[str | None] | None = None, materials: Mapping | None = None,
                   window: float | None = None) -> sp.csr_matrix:
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
        u_r = 0 there as symmetry requires), "exy" = e_ry = (du_r/dy + du_y/dr) / 2. Axisymmetric with twist
        adds, as seen on the x-y plane: "uz" = u_t, "eyz" = e_yt = du_t/dy / 2, "exz" = e_rt =
        (du_t/dr - u_t/r) / 2 (0 on the axis).
    regions : sequence of (str or None), optional
        ``regions[i]`` restricts point i to the cells of that mesh region (needed where two bodies touch
        and a point lies on both surfaces); None allows any cell.
    materials : mapping region name -> Material, optional
        Needed (only) when ``space.element`` is "incompatible": the condensed internal modes, which add
        displacement inside a cell (none at its nodes) and strain, are recovered from the nodal dofs through
        the cell's stiffness (:mod:`frictionid.fem.incompatible`).
    window : float [mm] or StrainWindow, optional
        DIC strain window (virtual strain gauge): each strain component at point i is the one of the
        least-squares plane fit of the model's displacements at the points themselves within the window,
        filtered as DIC filters the measured strains (see :func:`window_gradients`); displacements stay
        pointwise. A number is a square of that side; :class:`StrainWindow` also gives a circle and the rows
        observed: a strain row that is not observed and whose gradient the window does not span is taken at
        the point (pointwise), not refused. None: strains at the points.

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
    pointwise = _located_operator(space, quantities, points, cells, reference, materials)
    strains = [q for q in quantities if q[0] == "e" and not (q == "ezz" and space.kind == "plane_strain")]
    window = StrainWindow.of(window)
    if window is None or not strains:
        return pointwise
    if space.kind == "axisymmetric_twist":
        raise InputError("data.strain_window: not available for an axisymmetric model with twist yet; observe "
                         "pointwise strains")
    if "ezz" in strains and space.kind == "axisymmetric":
        raise InputError("data.strain_window: the hoop strain 'ezz' of an axisymmetric model is not a gradient in "
                         "the measured plane and no DIC strain window applies to it; observe exx, eyy, exy")
    displacements = ("ux", "uy", "uz")[:space.dim]
    moved = _located_operator(space, displacements, points, cells, reference, materials)
    rows = [moved[k::space.dim] for k in range(space.dim)]                     # (n, n_dofs) per component
    groups = None if regions is None else [str(r) for r in regions]
    gradient, spanned = window_gradients(points, window.size, groups, window.shape)
    needed = window.needed(len(points), len(quantities))
    parts = []
    for q, name in enumerate(quantities):
        if name not in strains:
            parts.append(pointwise[q::len(quantities)])
            continue
        a, b = _AXIS[name[1]], _AXIS[name[2]]
        given = spanned[:, a] & spanned[:, b]
        missing = np.flatnonzero(~given & needed[:, q])
        if missing.size:
            i = missing[0]
            raise InputError(f"data.strain_window = {window.describe()}: {name} at point {i} "
                             f"{np.round(points[i], 6).tolist()} needs the displacement's gradient along "
                             f"{'xyz'[a]}{'' if a == b else ' and ' + 'xyz'[b]}, which the "
                             f"{len(gradient[0][i].indices)} point(s) within its window do not span "
                             f"({missing.size} point(s) like it); a wider window or other strain components")
        windowed = 0.5 * (gradient[b] @ rows[a] + gradient[a] @ rows[b])
        if not given.all():                       # rows not observed: at the point where the window cannot give them
            windowed = sp.diags(given.astype(float)) @ windowed \
                + sp.diags((~given).astype(float)) @ pointwise[q::len(quantities)]
        parts.append(windowed)
    stacked = sp.vstack(parts, format="csr")                                    # quantity-major
    n = len(points)
    order = (np.arange(len(quantities))[None, :] * n + np.arange(n)[:, None]).ravel()
    return stacked[order]


def window_gradients(points, window: float, groups: Sequence | None = None, shape: str = "square"):
    """Least-squares gradient over a DIC strain window, as a linear map of values at the points themselves.

    The window of point i holds the points j (of its group) with ``max_k |x_jk - x_ik| <= window / 2``: a square
    (cube) of side ``window`` centred on it, the strain window of a DIC program's strain computation (subsets on a
    grid, a plane fitted to their displacements); with ``shape = "circle"`` those with ``|x_j - x_i| <= window /
    2``: a circle (ball) of diameter ``window``, as DICe's VSG selects its subsets. The plane
    f(x) = c + g . (x - m) (m the window points' mean)
    fitted to values f_j by least squares has the gradient g = (D^T D)^+ D^T f with D the rows x_j - m: linear in
    the values, ``g_a(i) = sum_j C_a[i, j] f_j``. Directions the window's points do not span (the normal of a
    face they lie on) get no gradient; ``spanned`` says which axes are spanned (to 1e-6).

    A linear field is reproduced exactly; for f = x^3 sampled at x_i + s k (k = -m..m) the slope is
    3 x_i^2 + s^2 sum k^4 / sum k^2, the windowed value of its quadratic derivative.

    Parameters
    ----------
    points : (n, dim) [mm]
    window : float [mm], > 0
    groups : (n,) labels, optional: a window holds only points of its own group (e.g. region or view)
    shape : "square" (default) or "circle"

    Returns
    -------
    gradient : list of dim scipy.sparse.csr_matrix (n, n) [1/mm], C_a
    spanned : (n, dim) bool

    >>> C, spanned = window_gradients([[0.0], [1.0], [2.0]], 2.0)
    >>> (C[0] @ np.array([1.0, 3.0, 5.0])).tolist(), spanned.ravel().tolist()
    ([2.0, 2.0, 2.0], [True, True, True])
    """
    points = np.asarray(points, dtype=float)
    n, dim = points.shape
    if isinstance(window, bool) or not isinstance(window, (int, float)) or not np.isfinite(window) or window <= 0:
        raise InputError(f"data.strain_window: must be a positive length [mm], got {window!r}")
    if shape not in SHAPES:
        raise InputError(f"data.strain_window_shape: {shape!r} is not one of {', '.join(SHAPES)}")
    label = np.zeros(n, dtype=np.int64) if groups is None else np.unique(np.asarray(groups, dtype=str),
                                                                         return_inverse=True)[1].ravel()
    pair_i, pair_j = [], []
    for group in np.unique(label):
        members = np.flatnonzero(label == group)
        tree = cKDTree(points[members])
        close = tree.sparse_distance_matrix(tree, window / 2 * (1 + 1e-12), p=SHAPES[shape],
                                            output_type="ndarray")
        pair_i.append(members[close["i"]])
        pair_j.append(members[close["j"]])
        pair_i.append(members)                                 # each point is in its own window (distance 0)
        pair_j.append(members)
    pair_i, pair_j = np.concatenate(pair_i), np.concatenate(pair_j)
    pair_i, pair_j = np.unique(np.column_stack([pair_i, pair_j]), axis=0).T
    count = np.bincount(pair_i, minlength=n)
    mean = np.zeros((n, dim))
    np.add.at(mean, pair_i, points[pair_j])
    mean /= count[:, None]
    offset = points[pair_j] - mean[pair_i]                                           # rows of D
    moment = np.zeros((n, dim, dim))
    np.add.at(moment, pair_i, offset[:, :, None] * offset[:, None, :])               # D^T D
    w, v = np.linalg.eigh(moment)
    seen = w > 1e-10 * np.maximum(w.max(axis=1, keepdims=True), 1e-300)
    inverse = np.einsum("nak,nk,nbk->nab", v, np.where(seen, 1.0 / np.where(seen, w, 1.0), 0.0), v)
    projector = np.einsum("nak,nk,nbk->nab", v, seen.astype(float), v)
    spanned = np.abs(np.diagonal(projector, axis1=1, axis2=2) - 1.0) <= 1e-6
    weights = np.einsum("pab,pb->pa", inverse[pair_i], offset)                       # (pairs, dim)
    gradient = [sp.csr_matrix((weights[:, a], (pair_i, pair_j)), shape=(n, n)) for a in range(dim)]
    return gradient, spanned


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
    """The rows of :func:`point_operator` for points already located in ``cells`` at ``reference``.

    Each row has the dofs of its point's cell only: the rows are written straight into CSR arrays as blocks
    (n_points, n_quantities, n_local, dim), without a COO sort, with 32-bit indices where they fit (1e5 points
    with six quantities, 14.4 million entries, in a few tenths of a second)."""
    phi, grad, det = _shape_functions(space, cells, reference)
    nodes = space.node_of[space.scalar.element_dofs[:, cells]].T              # (n, n_local)
    n_points, n_local = nodes.shape
    dim = space.n_components
    if space.element == "incompatible":
        block = _internal_modes(space, materials, quantities, cells, phi, nodes, det)
    else:
        block = np.zeros((n_points, len(quantities), n_local, dim))
    for q, name in enumerate(quantities):
        for component, coefficient in _terms(space, name, points, phi, grad):
            block[:, q, :, component] += coefficient
    row_length = n_local * dim
    index = np.int32 if max(block.size, space.n_dofs) < np.iinfo(np.int32).max else np.int64
    local = (dim * nodes[:, :, None] + np.arange(dim)).astype(index).reshape(n_points, 1, row_length)
    columns = np.repeat(local, len(quantities), axis=1).ravel()                # a writable array of its own
    shape = (n_points * len(quantities), space.n_dofs)
    operator = sp.csr_matrix((block.ravel(), columns, np.arange(0, block.size + 1, row_length, dtype=index)),
                             shape=shape)
    operator.eliminate_zeros()
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
    """Shape function values (n, n_local), physical gradients (n, n_local, dim) [1/mm] and the Jacobian's
    determinant det(dx/dX) (n,) of the element map at located points."""
    cell_xyz = cell_nodes(space)[cells]
    phi, dphi = reference_basis(space, reference)
    jacobian = np.einsum("nka,nkb->nab", cell_xyz, dphi)
    # grad_x phi = J^-T grad_X phi
    grad = np.linalg.solve(np.swapaxes(jacobian, 1, 2), np.swapaxes(dphi, 1, 2))
    return phi, np.swapaxes(grad, 1, 2), np.linalg.det(jacobian)


def _terms(space: Space, name: str, points: np.ndarray, phi: np.ndarray, grad: np.ndarray):
    """(component, coefficients (n, n_local)) pairs whose sum over nodes gives quantity `name`."""
    if name[0] == "u":
        return [(_AXIS[name[1]], phi)]
    a, b = _AXIS[name[1]], _AXIS[name[2]]
    if a == b == 2 and space.kind == "plane_strain":
        return []
    if a == b == 2 and space.kind in ("axisymmetric", "axisymmetric_twist"):
        return [(0, _hoop(space, points, phi, grad))]
    if b == 2 and space.kind == "axisymmetric_twist":
        return [(2, 0.5 * (grad[:, :, a] - (_hoop(space, points, phi, grad) if a == 0 else 0.0)))]
    if a == b:
        return [(a, grad[:, :, a])]
    return [(a, 0.5 * grad[:, :, b]), (b, 0.5 * grad[:, :, a])]


def _internal_modes(space: Space, materials, quantities, cells, phi, nodes, det) -> np.ndarray:
    """The condensed incompatible modes' share of the rows at the located points: (n, n_quantities, 8, 3) on
    the cells' nodal dofs (node in ``nodes``' order, component).

    Per point the modes P_i = 1 - xi_i^2 and their gradients in Taylor's form (:func:`incompatible.gradients`),
    grad P_i = (det J0 / det J) (-2 xi_i) J0^-1[i, :], the centre's Jacobian J0 once per cell (the ratio of
    determinants is that of the scikit-fem map, ``det`` at the points: the two maps differ by an affine map of
    the reference cube, whose determinant cancels); per cell the recovery alpha = -R u_e. A quantity's row is
    then sum_i c_i(point) A_i(cell) with c_i = P_i (displacements) or
    (det J0 / det J) (-2 xi_i) (strains) and A_i the cell's (24,) recovery rows (for a strain combined with
    J0^-1): one matrix product per cell for all its points and quantities."""
    if materials is None:
        raise InputError("point operator: a space with element 'incompatible' needs `materials` (the internal "
                         "modes are recovered from the nodal dofs through each cell's stiffness)")
    corners = space.mesh.cells[cells]                                        # (n, 8) meshio order
    # the scikit-fem and the natural parametrisation are trilinear maps of the same corners that differ by a
    # symmetry of the cube (an affine map), so interpolating the corners' natural coordinates is exact
    position = np.argmax(corners[:, None, :] == nodes[:, :, None], axis=2)     # meshio corner of each local node
    xi = np.einsum("nj,njd->nd", phi, incompatible.CORNERS[position])
    # the recovery alpha = -R u_e belongs to the cell: once per distinct cell (a full field has hundreds of
    # points in one), its dofs put in the cell's local node order
    first, which = np.unique(cells, return_index=True, return_inverse=True)[1:]
    which = np.ravel(which)
    xyz = space.mesh.points[corners[first]]                                  # (cell, 8, 3)
    lame = incompatible.cell_lame(space.mesh, materials)[cells[first]]
    _, R = incompatible.condensed(incompatible.element_matrices(xyz, lame))
    alpha = -R.reshape(len(first), incompatible.N_MODES, space.dim, incompatible.N_NODES, space.dim)
    alpha = np.take_along_axis(alpha, position[first][:, None, None, :, None], axis=3).reshape(
        len(first), incompatible.N_MODES, space.dim, incompatible.N_U)        # (cell, mode, component, dof)
    centre = np.einsum("cka,kb->cab", xyz, incompatible.trilinear(np.zeros((1, space.dim)))[1][0])
    inverse0 = np.linalg.inv(centre)                                         # (cell, mode i, x)
    _, dphi0 = reference_basis(space, space.scalar.elem.refdom.p.mean(axis=1)[:, None])
    det0 = np.linalg.det(np.einsum("cka,kb->cab", cell_nodes(space)[cells[first]], dphi0[0]))
    gradient_weight = (det0[which] / det)[:, None] * (-2.0 * xi)             # (n, mode)
    coefficient = np.empty((len(cells), len(quantities), incompatible.N_MODES))
    rows = np.empty((len(first), len(quantities), incompatible.N_MODES, incompatible.N_U))
    for q, name in enumerate(quantities):
        a = _AXIS[name[1]]
        if name[0] == "u":
            coefficient[:, q], rows[:, q] = 1.0 - xi ** 2, alpha[:, :, a]
        else:
            b = _AXIS[name[2]]
            coefficient[:, q] = gradient_weight
            rows[:, q] = 0.5 * (inverse0[:, :, b, None] * alpha[:, :, a] + inverse0[:, :, a, None] * alpha[:, :, b])
    out = np.empty((len(cells), len(quantities), incompatible.N_U))
    order = np.argsort(which, kind="stable")
    bounds = np.searchsorted(which[order], np.arange(len(first) + 1))
    for k in range(len(first)):                  # per cell: one batched product for all its points and quantities
        at = order[bounds[k]:bounds[k + 1]]
        out[at] = np.matmul(coefficient[at].transpose(1, 0, 2), rows[k]).transpose(1, 0, 2)
    return out.reshape(len(cells), len(quantities), incompatible.N_NODES, space.dim)


def _hoop(space: Space, points: np.ndarray, phi: np.ndarray, grad: np.ndarray) -> np.ndarray:
    """Coefficients of e_thetatheta = u_r / r; on the axis its limit du_r/dr (u_r = 0 there by symmetry)."""
    r = points[:, 0]
    on_axis = r <= 1e-9 * np.ptp(space.mesh.points, axis=0).max()
    safe_r = np.where(on_axis, 1.0, r)
    return np.where(on_axis[:, None], grad[:, :, 0], phi / safe_r[:, None])
