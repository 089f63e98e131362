"""MUMPS through ctypes: the Schur complement onto chosen dofs and solves with K, against dense linear algebra."""

import numpy as np
import pytest
import scipy.sparse as sp

from frictionid.fem import mumps_schur

pytestmark = pytest.mark.skipif(not mumps_schur.available(), reason="python-mumps (MUMPS) is not installed")


def spd(n=240, seed=0):
    """A sparse symmetric positive definite matrix (n, n) with a few hundred off-diagonal entries."""
    A = sp.random(n, n, density=0.02, random_state=seed)
    chain = sp.diags([-1.0, 4.0, -1.0], [-1, 0, 1], shape=(n, n))       # connected: one body
    return (A @ A.T + chain).tocsr()


def dense_schur(K, s):
    i = np.setdiff1d(np.arange(K.shape[0]), s)
    return K[np.ix_(s, s)] - K[np.ix_(s, i)] @ np.linalg.solve(K[np.ix_(i, i)], K[np.ix_(i, s)])


@pytest.mark.parametrize("ordering", ["auto", "metis", "amd"])
def test_schur_complement_and_solves(ordering):
    K = spd()
    rng = np.random.default_rng(1)
    s = rng.choice(K.shape[0], 30, replace=False)             # not sorted: the factor keeps this order
    factor = mumps_schur.SchurFactor(K, s, ordering)
    L, S = factor.schur_factor(), dense_schur(K.toarray(), s)
    assert np.allclose(np.triu(L, 1), 0.0)
    np.testing.assert_allclose(L @ L.T, S, rtol=0, atol=1e-12 * np.abs(S).max())
    assert factor.stats.schur_size == 30 and factor.stats.factor_entries > 0
    b = rng.normal(size=(K.shape[0], 3))
    expected = np.linalg.solve(K.toarray(), b)
    np.testing.assert_allclose(factor.solve(b), expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    np.testing.assert_allclose(factor.solve(b[:, 1]), expected[:, 1], rtol=0, atol=1e-12 * np.abs(expected).max())


def test_bodies_are_factorised_apart():
    """A block-diagonal K: one factor per block, the Schur blocks in the order of ``last``; a body without Schur
    dofs is only solved with."""
    K1, K2, K3 = spd(120, 1), spd(90, 2), spd(60, 3)
    K = sp.block_diag([K1, K2, K3]).tocsr()
    last = np.array([3, 50, 119, 125, 200])                  # three dofs in the first block, two in the second
    bodies = mumps_schur.BodySchur(K, last)
    assert [len(f.schur_dofs) for f in bodies.factors] == [3, 2, 0]
    S = dense_schur(K.toarray(), last)
    for block, factor in zip(bodies.blocks, bodies.factors):
        if len(block):
            L = factor.schur_factor()
            np.testing.assert_allclose(L @ L.T, S[np.ix_(block, block)], rtol=0, atol=1e-12 * np.abs(S).max())
    b = np.random.default_rng(4).normal(size=K.shape[0])
    expected = np.linalg.solve(K.toarray(), b)
    np.testing.assert_allclose(bodies.solve(b), expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    bodies.free()                                            # the factors made again at the next solve
    assert all(f.schur_cholesky is None for f in bodies.factors)
    np.testing.assert_allclose(bodies.solve(b), expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_a_body_without_interior():
    """Every dof a Schur dof (MUMPS asks for an interior): S = K, by a dense Cholesky factor."""
    K = spd(20)
    factor = mumps_schur.SchurFactor(K, np.arange(20)[::-1])
    L = factor.schur_factor()
    np.testing.assert_allclose(L @ L.T, K.toarray()[::-1, ::-1], rtol=0, atol=1e-12 * abs(K).max())
    b = np.arange(20.0)
    np.testing.assert_allclose(factor.solve(b), np.linalg.solve(K.toarray(), b), rtol=1e-12)


def test_a_matrix_that_is_not_positive_definite_is_refused():
    K = sp.diags([2.0, -1.0, 3.0]).tocsr()
    with pytest.raises(mumps_schur.MumpsError, match="not positive definite"):
        mumps_schur.SchurFactor(K, np.array([2]))          # the interior (MUMPS's INFOG(12))
    with pytest.raises(mumps_schur.MumpsError, match="not positive definite"):
        mumps_schur.SchurFactor(K, np.array([1]))          # the Schur complement
    with pytest.raises(mumps_schur.MumpsError, match="INFOG"):
        mumps_schur.SchurFactor(sp.diags([2.0, 0.0, 3.0]).tocsr(), np.array([2]))      # a zero pivot
