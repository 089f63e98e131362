"""The stiffness assembled chunk by chunk (large meshes) equals the one-call assembly."""

from dataclasses import replace

import skfem

from frictionid.fem import assembly
from frictionid.fem.assembly import stiffness
from frictionid.fem.space import Space


def test_chunked_stiffness_equals_one_call(block3d, monkeypatch):
    """The 3-D block in standard hexahedra, in 7-cell chunks against one call: its two materials (epoxy plate,
    aluminium block) show a chunk given other cells' Lame constants."""
    model = replace(block3d, element="standard")
    space = Space.build(model.mesh, model.kind, model.element)
    whole = stiffness(space, model)
    calls = []
    asm = skfem.asm
    monkeypatch.setattr(assembly.skfem, "asm", lambda *a, **k: calls.append(1) or asm(*a, **k))
    monkeypatch.setattr(assembly, "CHUNK_CELLS", 7)
    chunked = stiffness(space, model)
    assert len(calls) == -(-len(model.mesh.cells) // 7) > 1
    difference = abs(chunked - whole).max()
    assert difference <= 1e-12 * abs(whole).max()
