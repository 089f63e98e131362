"""The elasticity stiffness of a 3-D bolt model: frictionid's kernel (:func:`frictionid.fem.assembly.elasticity`,
through :func:`~frictionid.fem.assembly.stiffness`) against scikit-fem's assembly of the same bilinear form
(tests/test_assembly_chunks.py's ``generic_elasticity``) on the same space and chunks; CPU seconds of each, of the
space, and the largest difference relative to the largest entry.

Run: .venv/bin/python benchmarks/assembly.py   (the M6 of docs/bolt-study.md's "Against CalculiX", flank 1.0 mm,
no window, no jaws; gmsh builds it in about a minute)
"""

import time

import numpy as np
import skfem

import _tests  # noqa: F401  (tests/ importable)
from frictionid.builders.bolt import bolt_model
from frictionid.fem import assembly, incompatible
from frictionid.fem.space import Space
from test_assembly_chunks import generic_elasticity

M6 = {"size": "M6", "model": "3d", "length": 24.0, "thread_length": 9.5, "n_axial": 2, "flank_size": 1.0,
      "contact_size": 2.0, "root_size": 0.25, "mesh_size": 3.0, "forces": [1500.0], "n_increments": 2,
      "cutout": False, "jaws": False}


def generic(space: Space, model) -> object:
    """The stiffness by scikit-fem's form assembly, chunked as :func:`frictionid.fem.assembly.stiffness` chunks."""
    lame = incompatible.cell_lame(model.mesh, model.materials)
    K = None
    for cells in np.array_split(np.arange(len(lame)), max(1, -(-len(lame) // assembly.CHUNK_CELLS))):
        basis = space.basis if len(cells) == len(lame) else space.basis.with_elements(cells)
        q = basis.X.shape[1]
        part = space.to_dofs(skfem.asm(generic_elasticity, basis, lam=np.repeat(lame[cells, :1], q, axis=1),
                                       mu=np.repeat(lame[cells, 1:], q, axis=1)))
        K = part if K is None else K + part
    return K


def main() -> None:
    model = bolt_model(**M6)
    cpu = time.process_time()
    space = Space.build(model.mesh, model.kind, model.element)
    cpu_space = time.process_time() - cpu
    cpu = time.process_time()
    K = assembly.stiffness(space, model)
    cpu_kernel = time.process_time() - cpu
    cpu = time.process_time()
    reference = generic(space, model)
    cpu_generic = time.process_time() - cpu
    difference = abs(K - reference).max() / abs(reference).max()
    print(f"{model.mesh.n_cells:,} {model.mesh.cell_type} cells, {space.n_dofs:,} dofs: space {cpu_space:.1f} s CPU; "
          f"stiffness {cpu_kernel:.1f} s CPU (frictionid's kernel) against {cpu_generic:.1f} s (scikit-fem's form "
          f"assembly), largest difference {difference:.1e} of the largest entry")


if __name__ == "__main__":
    main()
