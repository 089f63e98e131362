"""The memory estimate for factorisation "mumps": MUMPS's analysis on K's pattern from the mesh (the same figure
the factorisation's own analysis gives), the contact dofs it puts last, and the refusal it leads to."""

import json
import os
import subprocess
import sys

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
    condensation = mumps_memory.phases(block, memory.contact_pairs(block))["condensation"]
    cholmod = memory.estimate(block, "block", factorisation="cholmod").above
    monkeypatch.setattr(mumps_memory, "analysed", lambda model: (factors + 100e9, entries, analyses))
    assert memory.estimate(block, "block", factorisation="mumps").above == \
        pytest.approx(mumps_memory.SAFETY * (condensation + 100e9), rel=1e-6)
    assert memory.estimate(block, "block", factorisation="cholmod").above == pytest.approx(cholmod, rel=1e-6)


def test_identify_refuses_by_the_mumps_estimate_before_anything_is_condensed(tmp_path, monkeypatch, capsys):
    from frictionid.cli import main
    from frictionid.fem import problem as problem_module
    from helpers import write_config

    (tmp_path / "measured.csv").write_text("point,x,y,z,stage,ux,uy,uz\n" + "".join(
        f"P{k},-5.0,{y},{z},2,0.0,0.0,0.0\n" for k, (y, z) in enumerate([(-2.5, 2.5), (2.5, 5.0), (0.0, 7.5)])))
    config = write_config(tmp_path / "mumps.toml", '[solver]\nfactorisation = "mumps"\nmax_memory = 0.01\n'
                          '[run]\ndir = "runs/mumps"\n',
                          model={"builder": "block", "mesh_size": 5.0, "block_divisions": 2},
                          friction={"zones": dict.fromkeys("ABCD", 0.2)},
                          data={"file": "measured.csv", "observables": ["ux", "uy", "uz"], "stages": [2],
                                "noise": {"u": 0.0005}, "regions": {"*": "block"}},
                          identify="refine_target = 1\n")          # the discretisation control on
    analysed, condensed = [], []
    original = mumps_memory.analysed
    monkeypatch.setattr(mumps_memory, "analysed", lambda model: analysed.append(model) or original(model))
    monkeypatch.setattr(problem_module, "condense", lambda *args, **kwargs: condensed.append(args))
    assert main(["identify", str(config)]) == 2
    err = capsys.readouterr().err
    assert "estimated memory" in err and "of 0.0 GB allowed" in err and "[solver] max_memory" in err, err
    assert "Traceback" not in err
    assert analysed and not condensed        # MUMPS's analysis made the estimate; the control condensed nothing


_MEASURE = """
import json, sys
import numpy as np
from frictionid.builders.block import block_model
from frictionid.fem import memory
from frictionid.fem.problem import Problem
model = block_model(mesh_size=float(sys.argv[1]))
mumps = memory.estimate(model, "block", factorisation="mumps")
cholmod = memory.estimate(model, "block", factorisation="cholmod")
with memory.Peak() as took:
    problem = Problem.build(model, factorisation="mumps")
    problem.solve(np.full(len(model.zone_names), 0.15), sensitivities=True)
print(json.dumps({"nodes": model.mesh.n_nodes, "mumps": mumps.above, "cholmod": cholmod.above,
                  "measured": took.above}))
"""


@pytest.mark.slow          # 11 s CPU: the 3-D block at 0.7 mm (18,729 nodes) built, condensed and solved
def test_the_estimate_is_within_a_factor_of_the_measured_peak():
    if not memory._reset_peak():
        pytest.skip("the peak cannot be measured here (Linux's /proc/self/clear_refs)")
    # a process of its own: its peak is the build's, not the test session's
    done = subprocess.run([sys.executable, "-c", _MEASURE, "0.7"], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert done.returncode == 0, done.stderr[-2000:]
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    # the estimate is 0.98-1.23 times the measured peak on the models of docs/solver.md (1.07 on this one, in its
    # benchmark and here); CHOLMOD's law, which "mumps" used before, 1.9 times it here and 2.2-3.3 on the bolts
    assert 0.9 <= figures["mumps"] / figures["measured"] <= 1.5, figures
    assert figures["cholmod"] / figures["measured"] > 1.5, figures


def test_every_condensation_of_identify_uses_the_configured_factorisation(tmp_path, monkeypatch):
    """The discretisation control's models are condensed with ``[solver] factorisation`` (and estimated with its
    memory law), not with "auto": with "mumps" a 3-D bolt's second condensation by CHOLMOD went past the memory
    the first had been checked against. (The pre-fit's candidate points use the fit's condensation.)"""
    from frictionid.backends import embedded
    from frictionid.cli import main
    from helpers import write_config

    (tmp_path / "measured.csv").write_text("point,x,y,z,stage,ux,uy,uz\n" + "".join(
        f"P{k},-5.0,{y},{z},2,0.0,0.0,0.0\n" for k, (y, z) in enumerate([(-2.5, 2.5), (2.5, 5.0), (0.0, 7.5)])))
    config = write_config(tmp_path / "superlu.toml", '[solver]\nfactorisation = "superlu"\n[run]\ndir = "runs/s"\n',
                          model={"builder": "block", "mesh_size": 5.0, "block_divisions": 2},
                          friction={"zones": dict.fromkeys("ABCD", 0.2)},
                          data={"file": "measured.csv", "observables": ["ux", "uy", "uz"], "stages": [2],
                                "noise": {"u": 0.0005}, "regions": {"*": "block"}},
                          identify="refine_target = 1\nrefine_budget = 1\nsuggestions = 2\nmax_iterations = 1\n")
    used, estimated = [], []
    original_init, original_estimate = embedded.EmbeddedBackend.__init__, memory.estimate

    def init(self, *args, factorisation="auto", **kwargs):
        used.append(factorisation)
        original_init(self, *args, factorisation=factorisation, **kwargs)

    def estimate(model, what, max_memory=None, factorisation="auto", *args, **kwargs):
        estimated.append(factorisation)
        return original_estimate(model, what, max_memory, factorisation, *args, **kwargs)

    monkeypatch.setattr(embedded.EmbeddedBackend, "__init__", init)
    monkeypatch.setattr(memory, "estimate", estimate)
    main(["identify", str(config)])
    assert len(used) >= 2 and set(used) == {"superlu"}, used        # the model, the control's
    assert estimated and set(estimated) == {"superlu"}, estimated
