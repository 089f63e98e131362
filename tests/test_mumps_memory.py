"""The memory estimate for factorisation "mumps": MUMPS's analysis on K's pattern from the mesh (the same figure
the factorisation's own analysis gives), the contact dofs it puts last, and the refusal it leads to."""

import numpy as np
import pytest
import scipy.sparse as sp

from frictionid.builders.block import block_model
from frictionid.fem import memory, mumps_memory, mumps_schur
from frictionid.fem.problem import Problem, model_space, stiffness

pytestmark = pytest.mark.skipif(not mumps_schur.available(), reason="python-mumps (MUMPS) is not installed")


@pytest.fixture(scope="module")
def block():
    return block_model(mesh_size=2.0)


def test_analysis_alone_predicts_what_the_factorisation_reports(block):
    K = stiffness(model_space(block), block).tocsr()
    K = (K + 1e-3 * K.diagonal().max() * sp.identity(K.shape[0])).tocsr()   # unsupported: made definite
    s = np.arange(0, K.shape[0], 7)
    alone = mumps_schur.analyse(K, s)
    made = mumps_schur.SchurFactor(K, s).stats
    assert alone.estimated_mb == made.estimated_mb > 0          # INFOG(17) of the same analysis
    assert alone.factor_entries == made.factor_entries > 0      # INFOG(20) estimated = INFOG(29) made (no pivoting)
    assert alone.schur_size == len(s)


def test_the_pattern_from_the_cells_is_the_stiffness_pattern(block):
    K = stiffness(model_space(block), block).tocsr()
    lower, body = mumps_memory.stiffness_pattern(block, 3)
    assembled = sp.tril(K).tocsr()
    assembled.data[:] = 1.0
    pattern = lower.copy()
    pattern.data[:] = 1.0
    assert (assembled != pattern).nnz == 0
    assert len(np.unique(body)) == 2                            # block and plate
    # symmetric positive definite, as MUMPS's analysis of SYM = 1 expects of it
    full = (lower + sp.tril(lower, -1).T).toarray()
    assert np.linalg.eigvalsh(full[:300, :300]).min() > 0


def test_the_dofs_put_last_are_those_the_contact_rows_touch(block):
    problem = Problem.build(block)
    touched = np.unique(problem.pairs.B.indices // 3)
    estimated = mumps_memory.contact_nodes(block)
    assert np.isin(touched, estimated).all()
    # not the whole plate top: the block's footprint and a ring of facets around it
    plate_top = block.mesh.boundary_nodes(block.interfaces[0].target)
    assert len(estimated) < len(touched) + 0.5 * len(plate_top)


def test_the_estimate_for_mumps_is_made_of_mumps_analysis(block, monkeypatch):
    factors, entries, analyses = mumps_memory.analysed(block)
    before = memory.estimate(block, "block", factorisation="mumps").above
    cholmod = memory.estimate(block, "block", factorisation="cholmod").above
    monkeypatch.setattr(mumps_memory, "analysed", lambda model: (factors + 100e9, entries, analyses))
    assert memory.estimate(block, "block", factorisation="mumps").above == \
        pytest.approx(before + mumps_memory.SAFETY * 100e9, rel=1e-3)
    assert memory.estimate(block, "block", factorisation="cholmod").above == pytest.approx(cholmod, rel=1e-3)
