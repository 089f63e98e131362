"""The stiffness assembled chunk by chunk (large meshes) equals the one-call assembly; the elasticity kernel
equals scikit-fem's assembly of the same form."""

from dataclasses import replace

import numpy as np
import pytest
import skfem
from skfem.helpers import ddot, sym_grad, trace

from frictionid.fem import assembly
from frictionid.fem.assembly import elasticity, stiffness
from frictionid.fem.space import Space
from test_subdivide import MESHES


def test_chunked_stiffness_equals_one_call(block3d, monkeypatch):
    """The 3-D block in standard hexahedra, in 7-cell chunks against one call: its two materials (epoxy plate,
    aluminium block) show a chunk given other cells' Lame constants."""
    model = replace(block3d, element="standard")
    space = Space.build(model.mesh, model.kind, model.element)
    whole = stiffness(space, model)
    calls = []
    kernel = assembly.elasticity
    monkeypatch.setattr(assembly, "elasticity", lambda *a, **k: calls.append(1) or kernel(*a, **k))
    monkeypatch.setattr(assembly, "CHUNK_CELLS", 7)
    chunked = stiffness(space, model)
    assert len(calls) == -(-len(model.mesh.cells) // 7) > 1
    difference = abs(chunked - whole).max()
    assert difference <= 1e-12 * abs(whole).max()


@skfem.BilinearForm
def generic_elasticity(u, v, w):
    """scikit-fem's own evaluation of the form the product's kernel assembles."""
    eu, ev = sym_grad(u), sym_grad(v)
    return w.lam * trace(eu) * trace(ev) + 2.0 * w.mu * ddot(eu, ev)


@pytest.mark.parametrize("kind", list(MESHES))
def test_elasticity_kernel_is_scikit_fems_form_on_every_cell_type(kind):
    """Curved cells (every node moved by up to 3 % of the smallest edge, so the quadratic cells' mid-side nodes
    leave their edges), a Lame pair per cell, in two chunks: equal to scikit-fem's assembly of the same form."""
    mesh = MESHES[kind]()
    rng = np.random.default_rng(7)
    edge = np.linalg.norm(mesh.points[mesh.cells[:, 1]] - mesh.points[mesh.cells[:, 0]], axis=1).min()
    mesh = replace(mesh, points=mesh.points + rng.uniform(-0.03, 0.03, mesh.points.shape) * edge)
    space = Space.build(mesh)
    lame = rng.uniform(1e3, 5e4, (mesh.n_cells, 2))
    n_qp = space.basis.X.shape[1]
    expected = space.to_dofs(skfem.asm(generic_elasticity, space.basis, lam=np.repeat(lame[:, :1], n_qp, axis=1),
                                       mu=np.repeat(lame[:, 1:], n_qp, axis=1)))
    halves = np.array_split(np.arange(mesh.n_cells), 2)
    K = sum(elasticity(space, cells, lame[cells]) for cells in halves)
    assert abs(K - expected).max() <= 1e-12 * abs(expected).max()
