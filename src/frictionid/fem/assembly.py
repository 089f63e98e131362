"""Assembly of the stiffness matrix, the load channels and the prescribed dofs of a model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import skfem
from skfem.helpers import ddot, sym_grad, trace

from ..errors import InputError
from ..model import Displacement, Model, Pressure
from ..model.model import component_index
from . import incompatible
from .space import Space


@skfem.BilinearForm
def _elasticity(u, v, w):
    eu, ev = sym_grad(u), sym_grad(v)
    return w.lam * trace(eu) * trace(ev) + 2.0 * w.mu * ddot(eu, ev)


@skfem.BilinearForm
def _axisymmetric(u, v, w):
    # hoop strain u_r / r; whole-ring energy (2 pi r)
    r = w.x[0]
    eu, ev = sym_grad(u), sym_grad(v)
    hu, hv = u[0] / r, v[0] / r
    return 2.0 * np.pi * r * (w.lam * (trace(eu) + hu) * (trace(ev) + hv) + 2.0 * w.mu * (ddot(eu, ev) + hu * hv))


def stiffness(space: Space, model: Model) -> sp.csr_matrix:
    """Global stiffness (n_dofs, n_dofs) [N/mm] in frictionid dof numbering, of the space's element technology
    (incompatible modes condensed per cell, :mod:`frictionid.fem.incompatible`)."""
    per_cell = incompatible.cell_lame(model.mesh, model.materials)          # (n_cells, 2)
    if space.element == "incompatible":
        return incompatible.stiffness(model.mesh, per_cell)
    n_qp = space.basis.X.shape[1]
    lam = np.repeat(per_cell[:, :1], n_qp, axis=1)
    mu = np.repeat(per_cell[:, 1:], n_qp, axis=1)
    form = _axisymmetric if model.kind == "axisymmetric" else _elasticity
    return space.to_dofs(skfem.asm(form, space.basis, lam=lam, mu=mu))


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
    """Prescribed dof -> owner (None for a zero support, the Displacement load for a driven one)."""
    dim, owner = space.dim, {}
    for support in model.supports:
        nodes = model.mesh.boundary_nodes(support.boundary)
        for c in support.components:
            for dof in dim * nodes + component_index(c, dim, f"support on {support.boundary!r}"):
                owner[int(dof)] = None
    if model.kind == "axisymmetric":
        points = model.mesh.points
        scale = np.ptp(points[:, 1]) or 1.0
        for node in np.flatnonzero(np.abs(points[:, 0]) <= 1e-9 * scale):
            owner[int(dim * node)] = None
    for load in model.loads:
        if not isinstance(load, Displacement):
            continue
        c = component_index(load.component, dim, f"Displacement on {load.boundary!r}")
        for dof in dim * model.mesh.boundary_nodes(load.boundary) + c:
            previous = owner.get(int(dof), load)
            if previous is not load and (previous is None or previous.values != load.values):
                raise InputError(f"model: dof {int(dof)} (node {int(dof) // dim}, component {c}) on boundary "
                                 f"{load.boundary!r} is also held by another support or displacement with "
                                 "different values")
            owner[int(dof)] = load
    return owner


def _surface_force(space: Space, load) -> np.ndarray:
    basis = space.facet_basis(load.boundary)
    ring = space.ring
    if isinstance(load, Pressure):
        # pressure pushes into the body: traction = -p n (outward n)
        return space.to_dofs(skfem.asm(skfem.LinearForm(lambda v, w: -ring(w.x) * skfem.helpers.dot(v, w.n)), basis))
    c = component_index(load.component, space.dim, f"SurfaceForce on {load.boundary!r}")
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
