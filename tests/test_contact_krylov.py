"""The contact solve that never forms W (fem/condense_implicit.py, fem/contact_krylov.py) against the dense path
(fem/condense.py and the stuck inverses of fem/updated_jacobian.py, themselves checked against a dense LU of the
Jacobian in tests/test_updated_jacobian.py and against central differences in tests/test_solver.py).

Both paths solve the same Alart-Curnier equations to the same Newton tolerance (rtol 1e-10 of the contact forces);
the implicit path's Newton systems by GMRES to a relative residual of 1e-12, and its contact scale r is the mean
diagonal of W over a sample of pairs, so Newton may take another path to another point within that tolerance:
fields, reactions and sensitivities agree to 1e-8 of their largest value (measured: 1e-13 to 2e-12 on the blocks,
1.4e-9 on the clamp's contact forces).
"""

import numpy as np
import pytest

from frictionid.builders.block import block_model, block_model_2d
from frictionid.builders.registry import build_model
from frictionid.errors import InputError
from frictionid.fem import contact_krylov
from frictionid.fem import mumps_schur
from frictionid.fem.condense_implicit import is_implicit
from frictionid.fem.contact import OPEN, SLIP, STICK, Increment, jacobian, linearise
from frictionid.fem.loadpath import LoadPathSolver
from frictionid.fem.problem import Problem
from frictionid.options import ModelSpec

from clamp_case import model_options, write_clamp
from test_held_pairs import symmetric_model
FIELDS = ("lam", "w", "reactions", "d_reactions", "observations", "d_observations")


def _both(model, mu, **build):
    """(dense, implicit) problems and their solutions with sensitivities."""
    problems = [Problem.build(model, contact=contact, **build) for contact in ("dense", "implicit")]
    assert not is_implicit(problems[0].condensed) and is_implicit(problems[1].condensed)
    return problems, [p.solve(mu, sensitivities=True) for p in problems]


def _assert_same(dense, implicit, rtol=1e-8):
    """The same contact states; every field within ``rtol`` of its largest value."""
    assert np.array_equal(dense.state, implicit.state)
    for name in FIELDS:
        a, b = getattr(dense, name), getattr(implicit, name)
        if a is None:
            continue
        a, b = np.asarray(a), np.asarray(b)
        assert np.max(np.abs(a - b), initial=0.0) <= rtol * np.max(np.abs(a), initial=0.0), name


def _phases(state) -> set[str]:
    seen = set()
    for s in state:
        closed = s != OPEN
        seen |= {"lift-off"} if (~closed).any() else set()
        seen.add("stick" if np.all(s[closed] == STICK) else "gross slip" if np.all(s[closed] == SLIP)
                 else "partial slip")
    return seen


def test_plane_strain_stick_partial_and_gross_slip_same_as_dense():
    model = block_model_2d(pull=0.1, height=4.0, mesh_size=2.0, contact_size=1.0, n_zones=2, n_press=2, n_pull=8)
    points = np.array([[-5.0, 0.5], [5.0, 1.5], [-7.0, 0.0], [7.0, 0.0]])
    (_, implicit), (dense, solved) = _both(model, [0.3, 0.2], points=points, quantities=("ux", "uy"),
                                          regions=["block", "block", "base", "base"])
    assert {"stick", "partial slip", "gross slip"} <= _phases(dense.state)
    _assert_same(dense, solved)
    # the preconditioner is exact for the 2-D rows but for the friction coupling: a few iterations per solve
    assert implicit._krylov.n_iterations <= 10 * implicit._krylov.n_calls


def test_block_3d_lift_off_and_slip_same_as_dense():
    model = block_model(mesh_size=2.5)
    (_, implicit), (dense, solved) = _both(model, [0.3, 0.2, 0.4, 0.25],
                                          points=np.array([[-5.0, 0.0, 0.5], [0.0, -5.0, 1.5]]),
                                          quantities=("ux", "uy", "uz"), regions=["block", "block"])
    assert {"stick", "partial slip", "lift-off"} <= _phases(dense.state)
    _assert_same(dense, solved)
    assert implicit._krylov.n_iterations <= 15 * implicit._krylov.n_calls


def test_floating_body_and_held_tangential_directions_same_as_dense():
    """The quarter block: its block floats vertically (a rigid mode, the bordered solve) and pairs on the symmetry
    planes have held tangential directions."""
    (implicit, _), (dense, solved) = _both(symmetric_model(3, False), [0.3, 0.45])
    assert implicit.condensed.n_modes > 0
    assert LoadPathSolver(implicit.condensed, implicit.pairs).free_T is not None
    _assert_same(dense, solved)


def test_clamp_same_as_dense(tmp_path):
    """The clamp (builder "mesh" on a CalculiX deck, six zones, 2-D, the upper pad floating vertically), pressed,
    then pulled to gross slip; at 0.5 mm elements (a coarser mesh than the benchmark's .geo clamp)."""
    model = build_model(ModelSpec.from_table(model_options(write_clamp(tmp_path / "clamp.inp", size=0.5), one_target=False)))
    mu = np.array([0.15, 0.2, 0.25, 0.18, 0.22, 0.3])
    (dense_problem, _), (dense, solved) = _both(model, mu)
    assert dense_problem.condensed.n_modes > 0
    assert {"partial slip", "gross slip"} <= _phases(dense.state)
    _assert_same(dense, solved)


def _random_states(problem, n_states=4, seed=2):
    """(P, Q) of linearisations at random contact forces: open, stuck and slipping pairs mixed."""
    rng = np.random.default_rng(seed)
    solver = LoadPathSolver(problem.condensed, problem.pairs)
    n_pairs, dim = problem.pairs.n_pairs, problem.pairs.dim
    seen = set()
    while n_states:
        x = rng.normal(scale=10.0, size=solver.Wfull.shape[1])
        lam = x[:n_pairs * dim].reshape(n_pairs, dim)
        lam[:, 0] = np.abs(lam[:, 0]) * rng.choice([-0.2, 1.0], n_pairs, p=[0.3, 0.7])
        lam[:, 1:] *= rng.choice([0.01, 1.0], (n_pairs, 1))
        inc = Increment(rng.normal(scale=1e-6, size=n_pairs * dim) - solver.Wfull @ x,
                        np.zeros((n_pairs, dim - 1)), np.zeros(problem.condensed.n_modes))
        lin = linearise(x, inc, solver.Wfull, solver.Wa_T, problem.pairs.gap, np.full(n_pairs, 0.3), solver.r,
                        solver.free_T)
        if np.linalg.cond(jacobian(lin.P, lin.Q, solver.Wfull, solver.Wa_T)) < 1e8:
            n_states -= 1
            seen |= set(np.unique(lin.state).tolist())
            yield lin.P, lin.Q
    assert seen == {OPEN, STICK, SLIP}


def test_gmres_solves_satisfy_the_dense_jacobian():
    """Random mixed states of the quarter block: the implicit solver's J^-1 b satisfies the dense path's J
    (from the dense W) to 1e-10 of |J| |x|, its product J x equals the dense J x."""
    model = symmetric_model(3, False)
    dense, implicit = (Problem.build(model, contact=c) for c in ("dense", "implicit"))
    W = dense.condensed.gap_ops.full
    Wa_T = dense.condensed.equilibrium.on_lam
    krylov = implicit._krylov
    rng = np.random.default_rng(1)
    for P, Q in _random_states(dense):
        J = jacobian(P, Q, W, Wa_T)
        b = rng.normal(size=len(J))
        x = krylov(P, Q, b)
        scale = np.abs(J).max() * np.abs(x).max()
        assert np.abs(J @ x - b).max() <= 1e-10 * scale
        assert np.abs(krylov.product(P, Q, x) - J @ x).max() <= 1e-10 * scale


def test_a_solve_that_does_not_converge_is_nan(monkeypatch):
    """Newton and the predictors read NaN as a failed step: a GMRES run stopped early returns NaN, not a poor x."""
    model = symmetric_model(3, False)
    problem = Problem.build(model, contact="implicit")
    monkeypatch.setattr(contact_krylov, "MAX_ITERATIONS", 2)
    P, Q = next(_random_states(Problem.build(model, contact="dense")))
    x = problem._krylov(P, Q, np.ones(problem.condensed.gap_ops.full.shape[1]))
    assert np.all(np.isnan(x))


def test_unknown_contact_solve_names_the_argument():
    with pytest.raises(InputError, match="`contact` must be one of 'auto', 'dense', 'implicit', got 'sparse'"):
        Problem.build(block_model_2d(mesh_size=4.0, contact_size=2.0), contact="sparse")


def test_memory_estimate_counts_a_second_factor_instead_of_dense_blocks(monkeypatch):
    """Above IMPLICIT_ABOVE contact dofs the estimate carries no dense contact blocks but the penalised factor,
    counted as a second factorisation of the stiffness."""
    from frictionid.fem import condense_implicit, memory
    model = block_model(mesh_size=5.0)
    dense = memory.estimate(model, "model")
    monkeypatch.setattr(condense_implicit, "IMPLICIT_ABOVE", 0)
    implicit = memory.estimate(model, "model")
    factor = memory.condensation_bytes(implicit.n_dofs, 3)
    assert implicit.needed - dense.needed == pytest.approx(factor - memory.contact_bytes(
        memory.contact_pairs(model), 3), rel=0.05)


@pytest.mark.skipif(not mumps_schur.available(), reason="the python-mumps wheel is not installed")
def test_implicit_path_says_it_does_not_use_mumps(caplog):
    """MUMPS gives the dense path its Schur complements; the implicit path solves with K's factor instead, and
    says which one it took when "mumps" was asked for."""
    model = block_model_2d(pull=0.1, height=4.0, mesh_size=2.0, contact_size=1.0, n_zones=2, n_press=2, n_pull=2)
    with caplog.at_level("WARNING", logger="frictionid.fem.condense_implicit"):
        asked = Problem.build(model, contact="implicit", factorisation="mumps")
    assert "factorisation 'mumps' is for the dense contact operators" in caplog.text
    plain = Problem.build(model, contact="implicit")
    np.testing.assert_allclose(asked.solve([0.3, 0.2]).lam, plain.solve([0.3, 0.2]).lam, rtol=0, atol=1e-9)
