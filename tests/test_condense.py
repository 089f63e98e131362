"""Condensation: the CHOLMOD path (Schur complement from the factor's trailing block) gives SuperLU's operators."""

import pickle

import numpy as np
import pytest
import scipy.sparse as sp

from frictionid.builders.block import block_model, block_model_2d
from frictionid.errors import InputError
from frictionid.fem import cholesky, condense as condense_module, mumps_schur, problem as problem_module
from frictionid.fem.condense import GeneralisedInverse, condense
from frictionid.fem.problem import Problem

pytestmark = pytest.mark.skipif(not cholesky.available(), reason="kvxopt (CHOLMOD) is not installed")

OPERATORS = ("gap_ops", "obs_ops", "reac_ops", "equilibrium")


def _inputs(model, n_obs=7, seed=0):
    """What Problem.build passes to condense for ``model`` with ``n_obs`` random sparse observation rows."""
    n_dofs = model.mesh.n_nodes * model.dim
    observe = sp.random(n_obs, n_dofs, density=4.0 / n_dofs, random_state=seed, format="csr")
    captured = {}

    def capture(*args, **kwargs):
        captured["args"] = args
        return condense(*args, **kwargs)

    original, problem_module.condense = problem_module.condense, capture
    try:
        problem = Problem.build(model, observe=observe)
    finally:
        problem_module.condense = original
    return problem, captured["args"]


def reaction_terms(condensed, args) -> float:
    """Largest sum of the magnitudes of the nodal reactions that a reaction sum of a channel adds up [N]: the
    scale of its round-off (a channel of a self-equilibrated load has reaction sums that vanish)."""
    K, channels, sums = args[0].tocsr(), args[2], args[5]
    f, p = condensed.free, condensed.prescribed
    terms = abs(sums) @ (abs(K[p][:, f]) @ abs(condensed.particular.T) + abs(K[p][:, p]) @ abs(channels.displacements.T)
                         + abs(channels.forces[:, p].T))
    return float(np.max(terms, initial=0.0))


def relative_difference(a, b, reaction_floor: float) -> float:
    """Largest difference between the operators of ``a`` and ``b``, relative to each operator's largest entry;
    the reactions' channels relative to ``reaction_floor`` at least (:func:`reaction_terms`)."""
    worst = 0.0
    for name in OPERATORS:
        for part in ("channels", "on_lam", "on_alpha"):
            x, y = getattr(getattr(a, name), part), getattr(getattr(b, name), part)
            assert x.shape == y.shape
            floor = reaction_floor if (name, part) == ("reac_ops", "channels") else 0.0
            if x.size and max(np.abs(x).max(), floor) > 0:
                worst = max(worst, np.abs(x - y).max() / max(np.abs(x).max(), floor))
    return max(worst, np.abs(a.particular - b.particular).max() / np.abs(a.particular).max())


MODELS = {
    # graded hexahedra with incompatible modes (statically condensed per cell), a floating block: rigid modes
    "3-D incompatible": lambda: block_model(mesh_size=2.5),
    "3-D standard": lambda: block_model(mesh_size=5.0, element="standard"),
    "plane strain": lambda: block_model_2d(mesh_size=2.0),
}


@pytest.fixture(scope="module", params=sorted(MODELS))
def both(request):
    problem, args = _inputs(MODELS[request.param]())
    return problem, args, condense(*args, factorisation="superlu"), condense(*args, factorisation="cholmod")


def test_cholmod_gives_superlus_operators(both):
    """The acceptance: the same condensed operators as the SuperLU path to 1e-10 (relative to each operator's
    largest entry, the reactions' channels relative to the nodal reactions they add up); benchmarks/condensation.py
    measured at most 9e-13 on the 3-D block at 2.4k-24k dofs."""
    _, args, lu, chol = both
    assert chol.inverse.cholesky is not None and lu.inverse.cholesky is None
    assert chol.obs_ops.on_lam.shape == (7, args[1].shape[0])
    assert relative_difference(lu, chol, reaction_terms(lu, args)) < 1e-10


def test_cholmod_solves_no_column_of_the_operators(monkeypatch):
    """The Schur path is taken: the per-column solves (with their progress bar) are never started."""
    _, args = _inputs(block_model(mesh_size=5.0))

    def refuse(*_args, **_kwargs):
        raise AssertionError("condensed by solves")

    monkeypatch.setattr(condense_module, "bar", refuse)
    assert condense(*args, factorisation="cholmod").gap_ops.on_lam.shape == (args[1].shape[0],) * 2
    with pytest.raises(AssertionError, match="condensed by solves"):
        condense(*args, factorisation="superlu")


def test_cholmod_solves_gives_superlus_operators_by_solves(monkeypatch):
    """"cholmod_solves": CHOLMOD's factor with no dofs ordered last, the operators by solves in blocks of
    columns (the progress bar runs), equal to SuperLU's to 1e-10."""
    _, args = _inputs(block_model(mesh_size=5.0, element="standard"))
    reference = condense(*args, factorisation="superlu")
    blocks = []
    real = condense_module.bar
    monkeypatch.setattr(condense_module, "bar", lambda *a, **k: blocks.append(a[1]) or real(*a, **k))
    got = condense(*args, factorisation="cholmod_solves")
    assert got.inverse.cholesky is not None and len(got.inverse.cholesky.last) == 0
    assert blocks == [-(-args[1].shape[0] // condense_module._BLOCK)]
    assert relative_difference(reference, got, reaction_terms(reference, args)) < 1e-10


def test_the_displacement_field_after_the_factor_was_dropped(both):
    """Condensing takes the factor out of CHOLMOD (kvxopt's getfactor) and keeps it as a SparseFactor, which the
    field solves with; unpickled, without it, the field makes CHOLMOD's factor again."""
    problem, args, lu, chol = both
    assert chol.inverse.cholesky.factor is None and chol.inverse.cholesky.sparse is not None
    rng = np.random.default_rng(1)
    n_w, m = args[1].shape[0], chol.n_modes
    x, amplitude = rng.normal(size=n_w + m), rng.normal(size=args[2].amplitudes.shape[1])
    expected = lu.displacement(args[1], args[2].displacements, amplitude, x)
    got = chol.displacement(args[1], args[2].displacements, amplitude, x)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    again = pickle.loads(pickle.dumps(chol)).displacement(args[1], args[2].displacements, amplitude, x)
    np.testing.assert_allclose(again, got, rtol=0, atol=1e-12 * np.abs(got).max())


def test_a_factor_in_another_order_is_caught_and_solved_for(monkeypatch):
    """If CHOLMOD did not keep the requested order, the trailing block is not the Schur complement's factor: the
    one-column check notices and the operators come from solves."""
    _, args = _inputs(block_model(mesh_size=5.0))
    reference = condense(*args, factorisation="superlu")
    real = cholesky.Cholesky.trailing
    monkeypatch.setattr(cholesky.Cholesky, "trailing",
                        lambda self, blocks=None: (np.flip(block) for block in real(self, blocks)))
    got = condense(*args, factorisation="cholmod")
    assert relative_difference(reference, got, reaction_terms(reference, args)) < 1e-10


def test_auto_takes_cholmod_and_superlu_where_kvxopt_is_missing(monkeypatch):
    assert condense_module.factorisation_name("auto") == "cholmod"
    monkeypatch.setattr(cholesky, "available", lambda: False)
    assert condense_module.factorisation_name("auto") == "superlu"
    with pytest.raises(InputError, match="`factorisation` 'cholmod' needs the kvxopt package"):
        condense_module.factorisation_name("cholmod")


def test_mumps_without_the_wheel_is_named(monkeypatch):
    monkeypatch.setattr(mumps_schur, "available", lambda: False)
    with pytest.raises(InputError, match=r"`factorisation` 'mumps' needs the python-mumps wheel"):
        condense_module.factorisation_name("mumps")
    assert condense_module.factorisation_name("auto") == "cholmod"          # "auto" never takes MUMPS


def test_an_unknown_factorisation_is_named():
    with pytest.raises(InputError, match=r"`factorisation` must be one of 'auto', 'cholmod', 'superlu', 'cholmod_solves', "
                                         r"'mumps', got 'lu'"):
        condense_module.factorisation_name("lu")


def test_a_singular_stiffness_is_a_mechanism_with_either_factorisation():
    K = sp.diags([2.0, 1.0, 0.0, 3.0]).tocsr()
    for last in (None, np.array([3])):
        with pytest.raises(InputError, match="mechanism"):
            GeneralisedInverse(K, np.zeros((4, 0)), last=last, nodes=np.arange(4))
    if mumps_schur.available():
        with pytest.raises(InputError, match="mechanism"):
            GeneralisedInverse(K, np.zeros((4, 0)), last=np.array([3]), solver="mumps")


needs_mumps = pytest.mark.skipif(not mumps_schur.available(), reason="python-mumps (MUMPS) is not installed")


@needs_mumps
@pytest.mark.parametrize("name", sorted(MODELS))
def test_mumps_gives_superlus_and_cholmods_operators(name, monkeypatch):
    """"mumps": each body's Schur complement from MUMPS's factorisation, the operators from its Cholesky factor
    (no column solved for: the progress bar of the solves never starts), equal to SuperLU's and CHOLMOD's to 1e-10
    (measured 5e-14 at most); the displacement field by MUMPS's reduction and expansion, also after pickling."""
    problem, args = _inputs(MODELS[name]())
    reference, chol = condense(*args, factorisation="superlu"), condense(*args, factorisation="cholmod")

    def refuse(*_args, **_kwargs):
        raise AssertionError("condensed by solves")

    monkeypatch.setattr(condense_module, "bar", refuse)
    got = condense(*args, factorisation="mumps")
    assert got.inverse.bodies is not None and got.inverse.cholesky is None and got.inverse.lu is None
    assert len(got.inverse.bodies.factors) == 2                   # the two bodies, each with its own Schur block
    assert relative_difference(reference, got, reaction_terms(reference, args)) < 1e-10
    assert relative_difference(chol, got, reaction_terms(chol, args)) < 1e-10
    rng = np.random.default_rng(2)
    x = rng.normal(size=args[1].shape[0] + got.n_modes)
    amplitude = rng.normal(size=args[2].amplitudes.shape[1])
    expected = reference.displacement(args[1], args[2].displacements, amplitude, x)
    field = got.displacement(args[1], args[2].displacements, amplitude, x)
    np.testing.assert_allclose(field, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    again = pickle.loads(pickle.dumps(got)).displacement(args[1], args[2].displacements, amplitude, x)
    np.testing.assert_allclose(again, field, rtol=0, atol=1e-12 * np.abs(field).max())


def test_w_is_held_once_with_floating_bodies_and_after_pickling():
    """With floating bodies (the 3-D block: three modes) gap_ops.on_lam and on_alpha are views of gap_ops.full,
    not a second copy of W, and stay so after a pickle round trip (a worker's copy), with the same values."""
    condensed = Problem.build(block_model(mesh_size=2.5)).condensed
    ops = condensed.gap_ops
    n_w = ops.on_lam.shape[1]
    assert condensed.n_modes == 3
    assert ops.full.shape == (n_w, n_w + 3)
    assert np.shares_memory(ops.on_lam, ops.full) and np.shares_memory(ops.on_alpha, ops.full)
    again = pickle.loads(pickle.dumps(condensed)).gap_ops
    for name in ("on_lam", "on_alpha", "full", "channels"):
        assert np.array_equal(getattr(again, name), getattr(ops, name)), name
    assert np.shares_memory(again.on_lam, again.full)
    assert np.array_equal(again.on_lam @ np.arange(n_w), ops.on_lam @ np.arange(n_w))


@pytest.mark.parametrize("order", ["F", "C"])
def test_the_inverse_from_a_cholesky_factor_is_the_full_symmetric_inverse(order):
    """cholesky.inverse (LAPACK's potri, the condensation's S^-1 per body) from a lower factor in either memory
    order: the whole symmetric inverse, to 1e-12 of its largest entry (both triangles: potri fills one)."""
    rng = np.random.default_rng(3)
    X = rng.normal(size=(1100, 1100))                     # more than one block of cholesky.symmetrise
    S = X @ X.T + 1100 * np.eye(1100)
    L = np.array(np.linalg.cholesky(S), order=order)
    got = cholesky.inverse(L)
    expected = np.linalg.inv(S)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    np.testing.assert_array_equal(L, np.array(np.linalg.cholesky(S), order=order))      # L kept


@pytest.mark.parametrize("order", ["F", "C"])
@pytest.mark.parametrize("n_contact", [60, 500])
def test_products_on_a_schur_block_are_t_s_inverse_t_contact(order, n_contact, monkeypatch):
    """The condensation's dense part per body, out += T S^-1 T_w^T (T the rows touching the body, T_w its first
    n_w contact rows), from a lower factor L of S in either memory order: to 1e-12 of its largest entry against the
    dense product, with S^-1's last column. With few contact rows (60 of 900 dofs: a dense DIC field's observation
    dofs join the block) by solves with L, S^-1 never formed (potri, made to fail here, is not called); with 500 by
    S^-1. Rows that do not touch the body stay zero."""
    rng = np.random.default_rng(7)
    n_b, n_w, n_obs = 900, n_contact, 300
    X = rng.normal(size=(n_b, n_b))
    S = X @ X.T + n_b * np.eye(n_b)
    L = np.array(np.linalg.cholesky(S), order=order)
    T = sp.random(n_w + n_obs + 5, n_b, density=0.02, random_state=3, format="lil")
    T[n_w + 2] = 0                                                           # an observation row off this body
    T[3] = 0                                                                 # a contact row off this body
    T = T.tocsr()
    if n_contact < n_b // 3:
        monkeypatch.setattr(cholesky, "inverse", lambda *args: pytest.fail("S^-1 formed"))
    out = np.zeros((T.shape[0], n_w))
    last = condense_module._add_products(out, T, L, False, n_w)
    S_inv = np.linalg.inv(S)
    expected = T @ S_inv @ T[:n_w].T.toarray()
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    np.testing.assert_allclose(last, S_inv[:, -1], rtol=0, atol=1e-12 * np.abs(S_inv).max())
    assert not out[n_w + 2].any() and not out[:, 3].any()
