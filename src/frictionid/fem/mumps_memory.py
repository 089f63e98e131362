"""How much memory a condensation with ``[solver] factorisation = "mumps"`` takes, estimated before assembly.

The largest part is MUMPS's, and MUMPS says what it will be: its analysis (JOB = 1; K's pattern, the ordering and
the Schur dofs, no numerical work) returns INFOG(17), the estimated size [MB] of all MUMPS's internal data for the
in-core factorisation (the MUMPS 5.2.1 user's guide; in the sequential library INFOG(16) = INFOG(17)). The
centralised Schur complement (ICNTL(19) = 1) is an array the caller allocates (fem/mumps_schur.py), not MUMPS's:
8 m^2 bytes per body on top. :func:`mumps_bytes` runs that analysis per body on K's pattern made from the mesh's
cells (:func:`stiffness_pattern`) with the contact nodes' dofs last (:func:`contact_nodes`), as fem/condense.py
will factorise them; fem/condense.py holds every body's factor until the dense part.

Measured against the factorisations that followed (benchmarks/mumps_memory.py, INFOG(17) of the analysis here
against INFOG(22), the memory the factorisation used): the short M20 bolt's bolt body 3,477 against 3,332 MB, the
M6 bolt's 568 against 594 MB. The analysis here leaves the supports' dofs in K and no observation dofs last (the
ten points add a few hundred to the bolt's 4,353 Schur dofs), so it differs from the run by a few per cent.

Beside MUMPS the build holds the finite element space (the scalar and vector bases' values at every quadrature
point of every cell: :data:`SPACE_FIXED` + :data:`SPACE_CELL_BYTES` per cell) and copies of K (12 bytes per stored
entry: the partition into free and prescribed dofs, the factor's input, each body's block and its lower triangle
as MUMPS takes it). :func:`phases` estimates the three peaks of a build and its first solve:

- assembly: the space, one chunk of element matrices (:data:`CHUNK_CELL_BYTES` per cell of a chunk of
  :data:`frictionid.fem.assembly.CHUNK_CELLS` at most), the entries of all chunks before they are summed
  (:data:`ASSEMBLY_CELL_BYTES` per cell) and K;
- condensation: the space, :data:`K_COPIES` copies of K and MUMPS's part above;
- solve (the first, with sensitivities): the space, :data:`K_KEPT` copies of K, :data:`SOLVE_CONTACT_WORDS`
  n_w^2 doubles of dense contact operators (W, the stuck Jacobian's factor and inverse, the sensitivities') and
  the Schur complements' Cholesky factors, which the condensation keeps (8 m^2 bytes per body). The small-sliding
  check after it takes the interfaces' displacements from those factors where the interfaces' dofs are among the
  Schur dofs (the 3-D bolts); where they are not (the 3-D block's plate top reaches beyond the contact) it makes
  MUMPS's factors again to recover the displacement field (0.23-0.86 GB above the solved problem on the 3-D
  block); its peak stayed below the condensation's measured peak (docs/solver.md).

The estimate is :data:`SAFETY` times the largest. The constants are the largest of what the phases measured
(``benchmarks/mumps_memory.py``; resident memory sampled per phase, above the process before, this machine) on
two 3-D bolts (tetra10): M6 with two engaged pitches (34,635 nodes, 21,306 cells; condensation 1.92 GB, MUMPS
0.85 GB of it) and the short M20 (131,896 nodes, 84,345 cells; condensation 7.76 GB, MUMPS 4.45 GB of it); the
hexahedra's on the 3-D block at 0.7 and 0.5 mm (its assembly with incompatible modes holds about 50 kB per cell of
the whole mesh: 2.10 GB at 33,000 cells). Checked, not fitted, on other models: docs/solver.md.
"""

from __future__ import annotations

import weakref

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .assembly import CHUNK_CELLS

#: [bytes] the finite element space's part that does not grow with the cells (measured: module docstring)
SPACE_FIXED = 0.1e9
#: [bytes] per cell of the finite element space (both bases' values at the quadrature points), per cell type
SPACE_CELL_BYTES = {"tetra10": 16.8e3, "hexahedron": 7.0e3}
#: [bytes] per cell of one chunk of the stiffness's assembly (the chunk's element matrices: measured with
#: scikit-fem's assembly; frictionid's kernel, fem/assembly.py's ``elasticity``, peaks at 62 kB per tetra10 cell)
CHUNK_CELL_BYTES = {"tetra10": 64e3, "hexahedron": 0.0}
#: [bytes] per cell of the whole mesh held while the stiffness is assembled (the chunks' entries before summing)
ASSEMBLY_CELL_BYTES = {"tetra10": 8e3, "hexahedron": 50e3}
#: copies of K (12 bytes per stored entry, both triangles) held beside MUMPS's factors while condensing
K_COPIES = 6.5
#: copies of K held by the condensed problem during its first solve
K_KEPT = 6.3
#: dense (n_w, n_w) arrays of doubles the first solve with sensitivities holds at once (n_w = 3 n_c): the solve's
#: own arrays peaked at 4.9-5.2 n_w^2 doubles above the built problem (traced), its resident peak less the space
#: and K_KEPT copies of K at 5.1-8.8 on the 3-D block at 0.5 mm (n_w 1,323; two runs, 0.05 GB apart) and 5.5-7.2
#: on two M6 bolts (n_w 2,499-2,751; benchmarks/mumps_memory.py, docs/solver.md); 10 is 14 % above the largest
SOLVE_CONTACT_WORDS = 10
#: margin on the estimate (the largest phase against the measured peak: 0.87-1.17 on the models of docs/solver.md)
SAFETY = 1.05

#: [id(model)] -> (MUMPS's bytes, stored entries of K) of a model analysed before (:func:`condensation_bytes`)
_ANALYSED: dict = {}


def stiffness_pattern(model, n_components: int) -> tuple[sp.csr_matrix, np.ndarray]:
    """K's pattern from the mesh's cells alone (no assembly): its lower triangle (n_dofs, n_dofs) with values of a
    symmetric positive definite matrix of that pattern (a graph Laplacian plus the identity, coupled weakly
    between a node's components), and (n_nodes,) the body of each node: the connected parts of the cells' graph."""
    cells = model.mesh.cells
    n = model.mesh.n_nodes
    incidence = sp.csr_matrix((np.ones(cells.size, dtype=np.float32), cells.ravel(),
                               np.arange(0, cells.size + 1, cells.shape[1])), shape=(len(cells), n))
    nodes = (incidence.T @ incidence).tocsr()
    _, body = connected_components(nodes, directed=False)
    nodes.data[:] = -1.0
    nodes.setdiag(0.0)
    nodes.eliminate_zeros()
    nodes = nodes + sp.diags(np.asarray(-nodes.sum(axis=1)).ravel() + 1.0)
    coupling = np.eye(n_components) + 0.1 * (np.ones((n_components,) * 2) - np.eye(n_components))
    return sp.tril(sp.kron(nodes, coupling, format="csr"), format="csr"), body


def contact_nodes(model) -> np.ndarray:
    """The nodes the contact rows will touch, before the pairs are made: the zones' nodes and the target's nodes
    within the zones' largest facet edge of them (a node-to-node partner, or a mortar segment's nodes under it)."""
    mesh, found = model.mesh, [np.zeros(0, dtype=int)]
    for interface in model.interfaces:
        if not interface.zones:
            continue
        facets = np.concatenate([mesh.boundary(z) for z in interface.zones])
        zone = np.unique(facets)
        reach = np.linalg.norm(mesh.points[facets[:, 1]] - mesh.points[facets[:, 0]], axis=1).max()
        target = mesh.boundary_nodes(interface.target)
        near = cKDTree(mesh.points[zone]).query(mesh.points[target], distance_upper_bound=reach)[0]
        found += [zone, target[np.isfinite(near)]]
    return np.unique(np.concatenate(found))


def mumps_bytes(model, observed_nodes=()) -> tuple[float, int, list]:
    """What MUMPS's factorisations of the model's condensation will hold [bytes]: per body MUMPS's analysis
    (:func:`frictionid.fem.mumps_schur.analyse`, INFOG(17)) with its contact nodes' and ``observed_nodes``' dofs
    last, plus the body's dense Schur complement (8 m^2 bytes); all bodies at once. Also K's stored entries (both
    triangles) and the :class:`~frictionid.fem.mumps_schur.Analysis` of each body."""
    from .mumps_schur import analyse

    n_components = 3 if model.kind in ("3d", "axisymmetric_twist") else 2
    lower, body = stiffness_pattern(model, n_components)
    last = np.zeros(model.mesh.n_nodes, dtype=bool)
    last[contact_nodes(model)] = True
    last[np.asarray(observed_nodes, dtype=int)] = True
    total, analyses = 0.0, []
    for b in range(body.max() + 1):
        nodes = np.flatnonzero(body == b)
        dofs = (n_components * nodes[:, None] + np.arange(n_components)).ravel()
        schur = np.flatnonzero(np.repeat(last[nodes], n_components))
        analyses.append(analyse(lower[dofs][:, dofs], schur))      # its lower triangle is all MUMPS reads
        total += analyses[-1].estimated_mb * 1e6 + 8.0 * len(schur) ** 2
    return total, 2 * lower.nnz - lower.shape[0], analyses


def analysed(model) -> tuple[float, int, list]:
    """:func:`mumps_bytes` of ``model`` (no observed nodes), analysed once per model object."""
    key = id(model)
    if key not in _ANALYSED:
        _ANALYSED[key] = mumps_bytes(model)
        weakref.finalize(model, _ANALYSED.pop, key, None)
    return _ANALYSED[key]


def phases(model, n_pairs: int, grown: float = 1.0) -> dict:
    """[bytes] estimated peak of each phase of a "mumps" build and its first solve above what the process holds
    before, without :data:`SAFETY` (module docstring): "assembly", "condensation" and "solve" (with the dense
    contact blocks of ``n_pairs`` pairs, :func:`frictionid.fem.memory.contact_bytes`). A model not built yet,
    ``grown`` times this one's nodes (``n_pairs`` already grown): MUMPS's part grows by ``grown`` ** 1.3
    (frictionid.fem.memory's 3-D law), the space, the cells and K by ``grown``."""
    factors, entries, analyses = analysed(model)
    cells, cell_type = model.mesh.n_cells * grown, model.mesh.cell_type
    space = SPACE_FIXED + _per_cell(SPACE_CELL_BYTES, cell_type) * cells
    chunk = cells / np.ceil(cells / CHUNK_CELLS) if cells else 0.0       # fem/assembly.py's equal chunks
    K = 12.0 * entries * grown
    dim = 3 if model.kind in ("3d", "axisymmetric_twist") else 2
    n_w = dim * n_pairs
    # the Schur dofs are on surfaces: their number grows by grown ** ((dim - 1) / dim), the factors by its square
    schur = 8.0 * sum(a.schur_size ** 2 for a in analyses) * grown ** (2 * (dim - 1) / dim)
    return {"assembly": space + _per_cell(CHUNK_CELL_BYTES, cell_type) * chunk
            + _per_cell(ASSEMBLY_CELL_BYTES, cell_type) * cells + K,
            "condensation": space + K_COPIES * K + factors * grown ** 1.3,
            "solve": space + K_KEPT * K + SOLVE_CONTACT_WORDS * 8.0 * n_w ** 2 + schur}


def _per_cell(table: dict, cell_type: str) -> float:
    """A per-cell figure of ``table``; for a cell type not measured, the largest measured."""
    return table.get(cell_type, max(table.values()))


def peak_bytes(model, n_pairs: int, grown: float = 1.0) -> float:
    """Estimated peak of a "mumps" build of ``model`` and its first solve above what the process holds before
    [bytes]: :data:`SAFETY` times the largest of its :func:`phases`."""
    return SAFETY * max(phases(model, n_pairs, grown).values())
