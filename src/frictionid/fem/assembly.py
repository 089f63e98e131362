"""Assembly of the stiffness matrix, the load channels and the prescribed dofs of a model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import skfem
from skfem.helpers import ddot, sym_grad, trace

from ..errors import InputError
from ..model import Displacement, Model, Pressure, Rotation
from ..model.model import AXISYMMETRIC_KINDS, component_index
from . import incompatible
from .space import Space


@skfem.BilinearForm
def _axisymmetric(u, v, w):
    # hoop strain u_r / r; whole-ring energy (2 pi r)
    r = w.x[0]
    eu, ev = sym_grad(u), sym_grad(v)
    hu, hv = u[0] / r, v[0] / r
    return 2.0 * np.pi * r * (w.lam * (trace(eu) + hu) * (trace(ev) + hv) + 2.0 * w.mu * (ddot(eu, ev) + hu * hv))


@skfem.BilinearForm
def _axisymmetric_twist(u, v, w):
    # u = (u_r, u_y, u_t) independent of theta: the in-plane terms of _axisymmetric plus the torsion shears
    # e_rt = (du_t/dr - u_t/r) / 2, e_yt = du_t/dy / 2 (tensor shears; isotropy decouples them from the rest)
    r = w.x[0]
    eu, ev = in_plane_strain(u), in_plane_strain(v)
    hu, hv = u[0] / r, v[0] / r
    tu, tv = torsion_shears(u, r), torsion_shears(v, r)
    return 2.0 * np.pi * r * (w.lam * (trace(eu) + hu) * (trace(ev) + hv)
                              + 2.0 * w.mu * (ddot(eu, ev) + hu * hv + 2.0 * (tu[0] * tv[0] + tu[1] * tv[1])))


def in_plane_strain(u) -> np.ndarray:
    """(2, 2, ...) symmetric gradient of the (r, y) components of a 3-component field on a 2-D mesh."""
    g = u.grad
    return np.array([[g[0][0], 0.5 * (g[0][1] + g[1][0])], [0.5 * (g[0][1] + g[1][0]), g[1][1]]])


def torsion_shears(u, r) -> tuple:
    """(e_rt, e_yt): tensor shears of the circumferential displacement u_t (component 2) at radius r."""
    return 0.5 * (u.grad[2][0] - u[2] / r), 0.5 * u.grad[2][1]


#: cells per assembly chunk beyond which the stiffness is summed chunk by chunk: a chunk's element matrices are
#: held at once (scikit-fem's form assembly 64 kB per tetra10 cell at its peak, :func:`elasticity` 62 kB: 150,000
#: cells in one go would take over 9 GB); smaller meshes are assembled in one call
CHUNK_CELLS = 20_000

FORMS = {"axisymmetric": _axisymmetric, "axisymmetric_twist": _axisymmetric_twist}


def stiffness(space: Space, model: Model) -> sp.csr_matrix:
    """Global stiffness (n_dofs, n_dofs) [N/mm] in frictionid dof numbering, of the space's element technology
    (incompatible modes condensed per cell, :mod:`frictionid.fem.incompatible`)."""
    per_cell = incompatible.cell_lame(model.mesh, model.materials)          # (n_cells, 2)
    if space.element == "incompatible":
        return incompatible.stiffness(model.mesh, per_cell)
    form = FORMS.get(model.kind)
    n_cells = len(per_cell)
    K = None
    for cells in np.array_split(np.arange(n_cells), max(1, -(-n_cells // CHUNK_CELLS))):
        if form is None:
            part = elasticity(space, cells, per_cell[cells])
        else:
            basis = space.basis if len(cells) == n_cells else space.basis.with_elements(cells)
            n_qp = basis.X.shape[1]
            part = space.to_dofs(skfem.asm(form, basis, lam=np.repeat(per_cell[cells, :1], n_qp, axis=1),
                                           mu=np.repeat(per_cell[cells, 1:], n_qp, axis=1)))
        K = part if K is None else K + part
    return K


def elasticity(space: Space, cells: np.ndarray, lame: np.ndarray) -> sp.csr_matrix:
    """Stiffness of isotropic linear elasticity (3-D, plane strain) of ``cells`` with their Lame constants
    ``lame`` (n, 2) [MPa], in frictionid dof numbering: the bilinear form lam tr(e(u)) tr(e(v)) + 2 mu e(u) : e(v)
    on the space's quadrature, the element matrices all at once from the scalar shape functions' gradients.

    With g_a the gradient of scalar shape function a and A_aibj = int g_a,i g_b,j, the block of nodes a, b and
    components i, j is lam A_aibj + mu (A_ajbi + delta_ij sum_k A_akbk). scikit-fem's generic form assembly of the
    same form evaluates it pair of vector functions by pair: on the 3-D M6 bolt (24,935 tetra10 cells) 13.0 s CPU
    against 2.9 s, equal to 1.5e-16 of the largest entry (benchmarks/assembly.py; tests/test_assembly_chunks.py
    checks every cell type against it).
    """
    basis = space.scalar if len(cells) == space.mesh.n_cells else space.scalar.with_elements(cells)
    dim, n = space.n_components, basis.Nbfun
    grads = np.stack([basis.basis[a][0].grad for a in range(n)])                      # (a, i, c, q)
    g = np.ascontiguousarray(grads.transpose(2, 3, 0, 1)).reshape(len(cells), -1, n * dim)    # (c, q, a i)
    A = np.matmul((g * basis.dx[:, :, None]).transpose(0, 2, 1), g).reshape(len(cells), n, dim, n, dim)
    shared = np.einsum("caibi->cab", A)
    K = lame[:, 0, None, None, None, None] * A + lame[:, 1, None, None, None, None] * A.transpose(0, 1, 4, 3, 2)
    for i in range(dim):
        K[:, :, i, :, i] += lame[:, 1, None, None] * shared
    nodes = space.node_of[basis.element_dofs].T                                       # (c, a)
    dofs = (dim * nodes[:, :, None] + np.arange(dim)).reshape(len(cells), n * dim)
    rows = np.repeat(dofs, n * dim, axis=1)
    cols = np.tile(dofs, (1, n * dim))
    return sp.csr_matrix((K.ravel(), (rows.ravel(), cols.ravel())), shape=(space.n_dofs, space.n_dofs))


@dataclass(frozen=True)
class LoadChannels:
    """The loads of a model as unit channels scaled by per-stage amplitudes.

    Attributes
    ----------
    forces : (n_channels, n_dofs) [N]
        Nodal force vector of each channel at unit amplitude (zero for displacement channels).
    prescribed : (n_prescribed,) int
        All prescribed dofs (supports, driven boundaries, axis nodes' radial dof).
    displacements : (n_channels, n_prescribed) [mm]
        Prescribed values of each channel at unit amplitude.
    amplitudes : (n_stages, n_channels)
        Channel amplitudes at the end of each stage.
    names : channel labels, e.g. "Pressure(block_top)".
    """

    forces: np.ndarray
    prescribed: np.ndarray
    displacements: np.ndarray
    amplitudes: np.ndarray
    names: tuple[str, ...]


def _prescribed_dofs(space: Space, model: Model) -> dict[int, object]:
    """Prescribed dof -> owner (None for a zero support, the Displacement load for a driven one).

    Prescriptions of one dof by several boundaries must agree: a support and a displacement that stays zero
    (the dof stays held at zero), two displacements of equal values (the later one drives it); others are an
    :class:`InputError` naming both boundaries and the node.
    """
    dim, owner, named = space.n_components, {}, {}
    for support in model.supports:
        nodes = model.mesh.boundary_nodes(support.boundary)
        for c in support.components:
            for dof in dim * nodes + component_index(c, dim, f"support on {support.boundary!r}"):
                owner[int(dof)] = None
                named.setdefault(int(dof), f"support {support.boundary!r}")
    if model.kind in AXISYMMETRIC_KINDS:
        points = model.mesh.points
        scale = np.ptp(points[:, 1]) or 1.0
        for node in np.flatnonzero(np.abs(points[:, 0]) <= 1e-9 * scale):
            owner[int(dim * node)] = None
            named.setdefault(int(dim * node), "the axis (u_r = 0)")
    for load in model.loads:
        if not isinstance(load, (Displacement, Rotation)):
            continue
        c = component_index(load.component, dim, f"{type(load).__name__} on {load.boundary!r}")
        zero = not np.any(np.asarray(load.values, dtype=float))
        nodes = model.mesh.boundary_nodes(load.boundary)
        components = load.components(model.kind) if isinstance(load, Rotation) else (c,)
        for dof in np.concatenate([dim * nodes + k for k in components]):
            dof = int(dof)
            if dof not in owner:
                owner[dof], named[dof] = load, f"{type(load).__name__.lower()} on {load.boundary!r}"
            elif owner[dof] is None and zero:
                continue                                      # held at zero either way
            elif owner[dof] is None or type(owner[dof]) is not type(load) or owner[dof].values != load.values:
                held = "at zero" if owner[dof] is None else f"at {list(owner[dof].values)}"
                raise InputError(f"model: node {dof // dim} at {np.round(model.mesh.points[dof // dim], 6).tolist()}"
                                 f", component {'xyz'[c] if c < 3 else c}: {named[dof]} holds it {held}, the "
                                 f"{type(load).__name__.lower()} on {load.boundary!r} prescribes "
                                 f"{list(load.values)}; boundaries that share nodes must prescribe the same values")
            else:
                owner[dof] = load
    return owner


def _surface_force(space: Space, load) -> np.ndarray:
    basis = space.facet_basis(load.boundary)
    ring = space.ring
    if isinstance(load, Pressure):
        # pressure pushes into the body: traction = -p n (outward n)
        return space.to_dofs(skfem.asm(skfem.LinearForm(
            lambda v, w: -ring(w.x) * sum(v[c] * w.n[c] for c in range(space.dim))), basis))
    c = component_index(load.component, space.n_components, f"SurfaceForce on {load.boundary!r}")
    area = skfem.asm(skfem.Functional(lambda w: ring(w.x)), basis)
    return space.to_dofs(skfem.asm(skfem.LinearForm(lambda v, w: ring(w.x) * v[c] / area), basis))


def load_channels(space: Space, model: Model) -> LoadChannels:
    """Unit load channels, prescribed dofs and per-stage amplitudes of a model."""
    owner = _prescribed_dofs(space, model)
    prescribed = np.array(sorted(owner), dtype=np.int64)
    position = {dof: i for i, dof in enumerate(prescribed)}
    forces, displacements, amplitudes, names = [], [], [], []
    for load in model.loads:
        f = np.zeros(space.n_dofs)
        up = np.zeros(len(prescribed))
        if isinstance(load, Displacement):
            up[[position[d] for d, o in owner.items() if o is load]] = 1.0
        elif isinstance(load, Rotation):
            dofs = np.array([d for d, o in owner.items() if o is load])
            up[[position[d] for d in dofs]] = load.unit(model.mesh.points[dofs // space.n_components],
                                                        dofs % space.n_components, model.kind)
        else:
            f = _surface_force(space, load)
        forces.append(f)
        displacements.append(up)
        amplitudes.append(np.asarray(load.values, dtype=float))
        names.append(f"{type(load).__name__}({load.boundary})")
    n = len(forces)
    return LoadChannels(
        forces=np.array(forces).reshape(n, space.n_dofs),
        prescribed=prescribed,
        displacements=np.array(displacements).reshape(n, len(prescribed)),
        amplitudes=np.array(amplitudes).reshape(n, model.n_stages).T,
        names=tuple(names))
