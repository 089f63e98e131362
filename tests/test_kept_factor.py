"""Displacements after the condensation without a factorisation of the stiffness again: CHOLMOD's factor kept as a
SparseFactor (fem/cholesky.py) serves the small-sliding check and the fields with what the condensation made."""

import pickle

import numpy as np
import pytest
import scipy.sparse as sp

from frictionid.builders.block import block_model
from frictionid.errors import SolverError
from frictionid.fem import cholesky
from frictionid.fem.fields import solution_fields
from frictionid.fem.problem import SLIP_TOLERANCE, Problem
from sliding3d_case import MU

pytestmark = pytest.mark.skipif(not cholesky.available(), reason="kvxopt (CHOLMOD) is not installed")


@pytest.fixture
def factorisations(monkeypatch) -> list:
    """Every CHOLMOD factorisation of a Cholesky made from now on, one entry each."""
    made = []
    original = cholesky.Cholesky._factor
    monkeypatch.setattr(cholesky.Cholesky, "_factor", lambda self: made.append(1) or original(self))
    return made


def _verdict(problem: Problem, solution) -> str:
    try:
        problem.check_small_sliding(solution, SLIP_TOLERANCE)
    except SolverError as error:
        return str(error)
    return "within"


@pytest.mark.parametrize("pull, n_pull", [(0.2, 10), (2.0, 20)])
def test_the_check_and_the_fields_use_the_condensations_factor(factorisations, pull, n_pull):
    """With "cholmod", solve, check and fields make no factor after the build's one (before, the check's
    displacement field factorised the stiffness again). The old path, a fresh factor of the unpickled problem, gives
    the same gap errors (to 1e-9), the same verdict (the 2 mm pull is refused at ratio 0.27, the 0.2 mm one is not)
    and the same fields (to 1e-10 of the largest displacement)."""
    model = block_model(pull=pull, mesh_size=5.0, n_pull=n_pull)
    problem = Problem.build(model, factorisation="cholmod")
    assert len(factorisations) == 1
    solution = problem.solve(MU, max_slip=None)
    found, verdict = problem.gap_errors(solution), _verdict(problem, solution)
    fields = solution_fields(problem, solution)
    assert len(factorisations) == 1
    fresh = pickle.loads(pickle.dumps(problem))           # pickled without any factor: made again at its first solve
    again = fresh.gap_errors(solution)
    assert len(factorisations) == 2
    assert [(f["interface"], f["increment"], f["unmeasured"]) for f in found] == \
        [(f["interface"], f["increment"], f["unmeasured"]) for f in again]
    for a, b in zip(found, again):
        for key in ("mean", "spread", "ratio", "largest"):
            assert a[key] == pytest.approx(b[key], rel=1e-9, abs=1e-15), key
    assert verdict == _verdict(fresh, solution)
    assert (verdict == "within") == (pull < 1) and max(f["ratio"] for f in found) > 0
    for stage, kept in zip(range(model.n_stages), fields.stages):
        whole = fresh.displacement(solution, solution.stage_end(stage))
        np.testing.assert_allclose(kept.displacement, whole, rtol=0, atol=1e-10 * np.abs(whole).max())
    assert np.abs(fields.stages[-1].displacement).max() > 0.5 * pull


def test_the_kept_factor_solves_and_gives_the_same_blocks_before_and_after_scaling(factorisations):
    """SparseFactor's solve equals CHOLMOD's on the same matrix (to 1e-12), and its dense blocks are L's before and
    after the first solve scales its columns (to round-off)."""
    rng = np.random.default_rng(3)
    n = 300
    A = sp.random(n, n, density=0.03, random_state=4)
    K = sp.csc_matrix(A @ A.T + 5.0 * sp.eye(n))
    last = np.sort(rng.choice(n, 60, replace=False))
    kept, reference = (cholesky.Cholesky(K, last, np.arange(n)) for _ in range(2))
    b = rng.normal(size=(n, 3))
    blocks = [np.arange(25), np.arange(25, 60)]
    before = list(kept.trailing(blocks))
    assert kept.factor is None and kept.sparse is not None and len(factorisations) == 2
    x = kept.solve(b)
    np.testing.assert_allclose(x, reference.solve(b), rtol=0, atol=1e-12 * np.abs(x).max())
    np.testing.assert_allclose(kept.solve(b[:, 0]), x[:, 0], rtol=0, atol=1e-14 * np.abs(x).max())
    np.testing.assert_allclose(K @ x, b, rtol=0, atol=1e-12 * np.abs(b).max())
    after = list(kept.trailing(blocks))
    assert len(factorisations) == 2
    for first, second in zip(before, after):
        np.testing.assert_allclose(second, first, rtol=1e-15, atol=0)
    # L_ss L_ss^T is the Schur complement onto `last`; its leading block the first block's L L^T
    S = np.linalg.inv(np.linalg.inv(K.toarray())[np.ix_(last, last)])
    np.testing.assert_allclose(before[0] @ before[0].T, S[:25, :25], rtol=0, atol=1e-10 * np.abs(S).max())


def test_fields_after_a_predict_at_the_same_mu_solve_nothing_again(monkeypatch):
    """The embedded backend's fields reuse the solution of its last predict at the same coefficients (simulate's
    solve, a fit's last solve at its answer): no forward solve, the fields of a solve; at other coefficients one."""
    from frictionid.backends.embedded import EmbeddedBackend
    from sliding3d_case import POINTS, QUANTITIES, REGIONS
    backend = EmbeddedBackend(block_model(mesh_size=5.0), POINTS, QUANTITIES, REGIONS, keep=False)
    solves = []
    original = Problem._solve
    monkeypatch.setattr(Problem, "_solve", lambda self, *a, **k: solves.append(1) or original(self, *a, **k))
    mu = np.asarray(MU, dtype=float)
    backend.predict(mu, sensitivities=True)
    assert len(solves) == 1
    reused = backend.fields(mu.copy())
    assert len(solves) == 1
    solved = solution_fields(backend.problem, backend.problem.solve(mu))
    for a, b in zip(reused.stages, solved.stages):
        for key in ("displacement", "pressure", "traction", "slip", "gap", "state"):
            np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)
    other = backend.fields(0.5 * mu)
    assert len(solves) == 3
    assert np.abs(other.stages[-1].traction - reused.stages[-1].traction).max() > 1.0


def test_with_mumps_the_field_factorises_the_interiors_alone_once(monkeypatch):
    """"mumps" frees its factors of the interiors before the condensation's dense part and keeps the Schur
    complements' Cholesky factors: the whole field then factorises each body's interior alone (no Schur complement
    made again, nor its dense factor; once, kept for the next field) and equals SuperLU's field to 1e-10 of its
    largest value."""
    from frictionid.fem import mumps_schur
    if not mumps_schur.available():
        pytest.skip("python-mumps (MUMPS) is not installed")
    made = []
    original = mumps_schur.SchurFactor._factor_timed
    monkeypatch.setattr(mumps_schur.SchurFactor, "_factor_timed",
                        lambda self: made.append(len(self.schur_dofs)) or original(self))
    model = block_model(mesh_size=5.0)
    problem = Problem.build(model, factorisation="mumps")
    n_bodies = len(made)
    assert n_bodies == 2 and min(made) > 0
    solution = problem.solve(MU, max_slip=None)
    ends = [solution.stage_end(stage) for stage in range(model.n_stages)]
    field = problem.displacement(solution, ends)
    assert made[n_bodies:] == [0] * n_bodies                   # each body's interior, without a Schur complement
    np.testing.assert_array_equal(problem.displacement(solution, ends), field)
    assert len(made) == 2 * n_bodies
    expected = Problem.build(model, factorisation="superlu").displacement(solution, ends)
    np.testing.assert_allclose(field, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    # a right-hand side with interior loads too: K^-1 b through the interior factor against a direct solve
    factor = problem.condensed.inverse.bodies.factors[0]
    K = sp.coo_matrix((factor._data, (factor._rows - 1, factor._cols - 1)), shape=(factor.n,) * 2).tocsr()
    K = K + sp.triu(K.T, 1)
    b = np.random.default_rng(5).normal(size=(factor.n, 2))
    x = factor.solve(b)
    np.testing.assert_allclose(K @ x, b, rtol=0, atol=1e-9 * np.abs(b).max())


def test_a_new_condensation_frees_the_kept_builds_factors(monkeypatch, factorisations):
    """The session's kept builds (backends/embedded.py) hold no factor beside a new condensation: their kept
    factors are freed first, and made again where a field is asked of them."""
    from frictionid.backends import embedded
    monkeypatch.setattr(embedded, "_RECENT", {})
    first = embedded.EmbeddedBackend(block_model(mesh_size=5.0), None, ()).problem
    assert first.condensed.inverse.cholesky.sparse is not None
    solution = first.solve(MU, max_slip=None)
    kept = first.displacement(solution)
    embedded.EmbeddedBackend(block_model(mesh_size=5.0, pull=0.1), None, (), keep=False)
    assert first.condensed.inverse.cholesky.sparse is None and len(factorisations) == 2
    np.testing.assert_allclose(first.displacement(solution), kept, rtol=0, atol=1e-12 * np.abs(kept).max())
    assert len(factorisations) == 3
