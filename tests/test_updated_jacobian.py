"""Contact solves by corrections of the model's stuck inverse (fem/updated_jacobian.py) against the previous path,
a fresh dense LU factorisation of the whole Jacobian every Newton step (fem/loadpath.py ``_LINEAR = "dense"``).

The linear solves are checked on their own (any state, held gaps, held tangential directions: J x = b to round-off
of cond(J)), and whole load paths in stick, partial slip, gross slip and lift-off, 2-D and 3-D, sensitivities
included: both paths solve the same equations to the same tolerance, so their results agree to the Newton
tolerance (rtol 1e-10 of the contact forces; in 2-D, where the equations of a state are linear and Newton ends
exactly, to round-off).
"""

import gc
import weakref
from pathlib import Path

import numpy as np
import pytest

from frictionid.builders.block import block_model, block_model_2d
from frictionid.builders.registry import build_model
from frictionid.config import read_config
from frictionid.fem import capacitance, loadpath, updated_jacobian
from frictionid.fem.contact import OPEN, SLIP, STICK, Increment, jacobian, linearise
from frictionid.fem.problem import Problem
from frictionid.fem.updated_jacobian import StuckInverses, UpdatedSolver

from test_held_pairs import symmetric_model
from frictionid.options import ModelSpec
CLAMP = Path(__file__).parent / "fixtures" / "clamp" / "clamp.toml"


def _both(problem, mu, monkeypatch):
    """(dense, updated) solutions with sensitivities."""
    out = []
    for path in ("dense", "updated"):
        monkeypatch.setattr(loadpath, "_LINEAR", path)
        out.append(problem.solve(mu, sensitivities=True))
    return out


def _assert_same(dense, updated, rtol):
    """Every field within ``rtol`` of its largest value; the same contact states."""
    assert np.array_equal(dense.state, updated.state)
    for name in ("lam", "w", "reactions", "d_reactions", "observations", "d_observations"):
        a, b = np.asarray(getattr(dense, name)), np.asarray(getattr(updated, name))
        scale = np.max(np.abs(a), initial=0.0)
        assert np.max(np.abs(a - b), initial=0.0) <= rtol * scale, name


def _phases(state) -> set[str]:
    """The contact phases a solution passes through: stick, partial slip, gross slip, lift-off."""
    seen = set()
    for s in state:
        closed = s != OPEN
        seen |= {"lift-off"} if (~closed).any() else set()
        if np.all(s[closed] == STICK):
            seen.add("stick")
        elif np.all(s[closed] == SLIP):
            seen.add("gross slip")
        else:
            seen.add("partial slip")
    return seen


def _points_2d():
    return np.array([[-5.0, 0.5], [5.0, 1.5], [-7.0, 0.0], [7.0, 0.0]])


@pytest.fixture(scope="module")
def plane_strain():
    model = block_model_2d(pull=0.1, height=4.0, mesh_size=2.0, contact_size=1.0, n_zones=2, n_press=2, n_pull=8)
    return Problem.build(model, points=_points_2d(), quantities=("ux", "uy"),
                         regions=["block", "block", "base", "base"])


def test_plane_strain_path_stick_partial_and_gross_slip_same_as_dense(plane_strain, monkeypatch):
    dense, updated = _both(plane_strain, [0.3, 0.2], monkeypatch)
    assert {"stick", "partial slip", "gross slip"} <= _phases(dense.state)
    _assert_same(dense, updated, rtol=1e-12)        # piecewise linear in 2-D: Newton ends exactly
    assert updated.n_newton.sum() < dense.n_newton.sum()     # the state predictor starts gross slip right


def test_block_3d_with_lift_off_same_as_dense(monkeypatch):
    problem = Problem.build(block_model(mesh_size=2.5), points=np.array([[-5.0, 0.0, 0.5], [0.0, -5.0, 1.5]]),
                            quantities=("ux", "uy", "uz"), regions=["block", "block"])
    dense, updated = _both(problem, [0.3, 0.2, 0.4, 0.25], monkeypatch)
    assert {"stick", "partial slip", "lift-off"} <= _phases(dense.state)
    assert np.any((dense.state == SLIP).sum(axis=1) == (dense.state != OPEN).sum(axis=1))   # gross slip too
    _assert_same(dense, updated, rtol=1e-9)         # 3-D slip is nonlinear: Newton stops at rtol 1e-10


def test_held_tangential_directions_same_as_dense(monkeypatch):
    """The quarter block: pairs on its symmetry planes have held tangential directions (projectors E)."""
    problem = Problem.build(symmetric_model(3, False))
    dense, updated = _both(problem, [0.3, 0.45], monkeypatch)
    assert problem.pairs.n_pairs and _has_held_directions(problem)
    _assert_same(dense, updated, rtol=1e-9)


def _has_held_directions(problem) -> bool:
    """Whether some pair of ``problem`` has a held tangential direction."""
    return loadpath.LoadPathSolver(problem.condensed, problem.pairs).free_T is not None


def _random_states(problem, seed, n_states=6):
    """(P, Q, state) of linearisations at random contact forces: open, stick and slip pairs mixed (the load
    offsets w so that w is about zero: a pair sticks where |lam_T| < mu lam_N, |lam_T| chosen below and above)."""
    rng = np.random.default_rng(seed)
    solver = loadpath.LoadPathSolver(problem.condensed, problem.pairs)
    n_pairs, dim = problem.pairs.n_pairs, problem.pairs.dim
    mu = np.full(n_pairs, 0.3)
    while n_states:
        x = rng.normal(scale=10.0, size=solver.Wfull.shape[1])
        lam = x[:n_pairs * dim].reshape(n_pairs, dim)
        lam[:, 0] = np.abs(lam[:, 0]) * rng.choice([-0.2, 1.0], n_pairs, p=[0.3, 0.7])     # some open
        lam[:, 1:] *= rng.choice([0.01, 1.0], (n_pairs, 1))                                 # some stuck
        inc = Increment(rng.normal(scale=1e-6, size=n_pairs * dim) - solver.Wfull @ x,
                        np.zeros((n_pairs, dim - 1)), np.zeros(problem.condensed.n_modes))
        lin = linearise(x, inc, solver.Wfull, solver.Wa_T, problem.pairs.gap, mu, solver.r, solver.free_T)
        if np.linalg.cond(jacobian(lin.P, lin.Q, solver.Wfull, solver.Wa_T)) < 1e8:     # J regular
            n_states -= 1
            yield lin.P, lin.Q, lin.state


@pytest.mark.parametrize("case", ["plane strain", "quarter 3-D"])
def test_corrected_solves_satisfy_the_jacobian(case, plane_strain):
    problem = plane_strain if case == "plane strain" else Problem.build(symmetric_model(3, False))
    solver = loadpath.LoadPathSolver(problem.condensed, problem.pairs)
    inverses = loadpath.stuck_inverses(problem.condensed, problem.pairs)
    rng = np.random.default_rng(1)
    # J0 holding a random third of the pairs open: the branch of pairs whose J0 rows are identity rows
    some_open = StuckInverses(solver.Wfull, solver.Wa_T, solver.r, solver.free_T,
                              rng.random(problem.pairs.n_pairs) < 0.3)
    seen = set()
    for source in (inverses, some_open):
        updated = UpdatedSolver(source)
        for P, Q, state in _random_states(problem, seed=2):
            seen |= set(np.unique(state).tolist())
            J = jacobian(P, Q, solver.Wfull, solver.Wa_T)
            b = rng.normal(size=(len(J), 3))
            x = updated(P, Q, b, check=False)
            scale = np.abs(J).max() * np.abs(x).max()
            assert np.abs(J @ x - b).max() <= 1e-11 * scale
            assert np.allclose(updated.product(P, Q, x), J @ x, rtol=0, atol=1e-12 * scale)
    assert seen == {OPEN, STICK, SLIP}
    assert updated.n_dense == 0


@pytest.mark.parametrize("case", ["plane strain", "quarter 3-D"])
def test_a_few_changed_pairs_update_the_capacitance_factorisation(case, plane_strain, monkeypatch):
    """From a factorised state, pairs that open, stick or take another state's rows are solved by an update of
    that factorisation (fem/capacitance.py): J x = b to the round-off of a fresh one. (The random states open a
    third of the pairs: the stuck inverse is not switched to their open pairs here, so that the updates meet
    open rows too.)"""
    monkeypatch.setattr(updated_jacobian, "SWITCH_FRACTION", np.inf)
    problem = plane_strain if case == "plane strain" else Problem.build(symmetric_model(3, False))
    solver = loadpath.LoadPathSolver(problem.condensed, problem.pairs)
    inverses = loadpath.stuck_inverses(problem.condensed, problem.pairs)
    updated = UpdatedSolver(inverses)
    rng = np.random.default_rng(4)
    states = _random_states(problem, seed=5, n_states=2)
    (P_base, Q_base, _), (P_other, Q_other, _) = next(states), next(states)
    b = rng.normal(size=(solver.Wfull.shape[1], 2))
    updated(P_base, Q_base, b, check=False)
    s = inverses.base
    opened = (np.broadcast_to(np.eye(problem.pairs.dim), P_base.shape), np.zeros_like(Q_base))
    for k, (P_to, Q_to) in enumerate((opened, (s.P0, s.Q0), (P_other, Q_other))):     # open, stick, other rows
        differ = np.flatnonzero(np.any((P_base != P_to) | (Q_base != Q_to), axis=(1, 2)))
        some = rng.choice(differ, 2, replace=False)
        P, Q = P_base.copy(), Q_base.copy()
        P[some], Q[some] = P_to[some], Q_to[some]
        x = updated(P, Q, b, check=False)
        J = jacobian(P, Q, solver.Wfull, solver.Wa_T)
        assert np.abs(J @ x - b).max() <= 1e-11 * np.abs(J).max() * np.abs(x).max(), k
        assert (updated.n_factorisations, updated.n_updates) == (1, k + 1)


def test_the_capacitance_factorisation_is_reused_for_the_same_rows(plane_strain):
    solver = loadpath.LoadPathSolver(plane_strain.condensed, plane_strain.pairs)
    updated = UpdatedSolver(loadpath.stuck_inverses(plane_strain.condensed, plane_strain.pairs))
    P, Q, _ = next(_random_states(plane_strain, seed=3))
    b = np.arange(len(solver.Wfull) + plane_strain.condensed.n_modes, dtype=float)
    first = updated(P, Q, b)
    again = updated(P.copy(), Q.copy(), b)
    assert updated.n_factorisations == 1
    assert np.array_equal(first, again)


def test_the_same_replaced_rows_after_a_switch_of_inverses_read_the_new_inverse(plane_strain):
    """A state with slipping pairs (rows K against the stuck inverse), then the same state with a third of the
    other pairs open: the solver switches to the inverse holding those open, against which the replaced rows are
    the same K, and must not reuse what it kept for K from the other inverse (J x = b to round-off)."""
    solver = loadpath.LoadPathSolver(plane_strain.condensed, plane_strain.pairs)
    inverses = loadpath.stuck_inverses(plane_strain.condensed, plane_strain.pairs)
    updated = UpdatedSolver(inverses)
    n_pairs = plane_strain.pairs.n_pairs
    s = inverses.base
    slipping, opened = np.arange(0, n_pairs, 3), np.setdiff1d(np.arange(n_pairs), np.arange(0, n_pairs, 3))[::2]
    P, Q = s.P0.copy(), s.Q0.copy()
    P[slipping, 1, :] = [-0.3, 1.0]                      # 2-D slip rows, slip direction +1, mu 0.3
    Q[slipping, 1, :] = [0.3 * solver.r, 0.0]
    P_open, Q_open = P.copy(), Q.copy()
    P_open[opened], Q_open[opened] = np.eye(2), 0.0
    b = np.random.default_rng(7).normal(size=(solver.Wfull.shape[1], 2))
    for P_, Q_ in ((P, Q), (P_open, Q_open), (P, Q)):
        x = updated(P_, Q_, b, check=False)
        J = jacobian(P_, Q_, solver.Wfull, solver.Wa_T)
        assert np.abs(J @ x - b).max() <= 1e-11 * np.abs(J).max() * np.abs(x).max()
    assert updated.n_switches == 2


@pytest.fixture(scope="module")
def clamp():
    return Problem.build(build_model(read_config(CLAMP).model_spec))


def test_clamp_fixture_gross_slip_pull_force_is_sum_mu_n(clamp):
    """The benchmark's clamp (builder "mesh", gmsh .geo): at the end every pair slips or is open, and the strip's
    pull force equals sum mu_z N_z over the six zones (NUMERICS.md 5.1)."""
    mu = np.array([0.15, 0.2, 0.25, 0.18, 0.22, 0.3])
    solution = clamp.solve(mu)
    assert clamp.model.mesh.n_nodes > 6000 and len(clamp.model.zone_names) == 6
    last = solution.state[-1]
    assert np.all(last[last != OPEN] == SLIP)
    pull = solution.reactions[-1][list(solution.reaction_labels).index("strip_end.x")]
    expected = mu @ solution.zone_normal_force[-1]
    assert abs(abs(pull) - expected) <= 1e-8 * expected


def test_clamp_same_as_dense(clamp, monkeypatch):
    """cond(J0) is 1e6 here, so the contact forces are determined to about 1e-16 x 1e6 of their largest value."""
    dense, updated = _both(clamp, np.array([0.15, 0.2, 0.25, 0.18, 0.22, 0.3]), monkeypatch)
    assert {"partial slip", "gross slip", "lift-off"} <= _phases(dense.state)     # the press already slips at the pad edges
    _assert_same(dense, updated, rtol=1e-9)


def _random_operators(n_pairs, m, seed):
    """(Wfull, Wa_T): a random symmetric positive definite W (n_w = 3 n_pairs) bordered by m floating modes."""
    rng = np.random.default_rng(seed)
    n_w = 3 * n_pairs
    X = rng.normal(size=(n_w, n_w))
    W = X @ X.T / n_w + 0.1 * np.eye(n_w)
    Wa = rng.normal(size=(n_w, m))
    return np.hstack([W, Wa]), Wa.T.copy()


@pytest.mark.parametrize("m", [0, 2])
@pytest.mark.parametrize("n_open", [0, 7])
def test_cholesky_stuck_inverse_is_the_inverse_of_j0(m, n_open):
    """A from the Cholesky factor of r W_CC and the border's Schur complement (every branch: no body floating or
    m = 2, no pair or 7 of 40 held open) against J0^-1 by LU: the same to round-off of cond(J0)."""
    n_pairs, r = 40, 3.0
    Wfull, Wa_T = _random_operators(n_pairs, m, seed=m + n_open)
    open_pairs = np.zeros(n_pairs, dtype=bool)
    open_pairs[np.random.default_rng(1).choice(n_pairs, n_open, replace=False)] = True
    A = updated_jacobian.symmetric_inverse(Wfull, Wa_T, r, open_pairs, 3)
    P0, Q0 = np.zeros((n_pairs, 3, 3)), np.broadcast_to(r * np.eye(3), (n_pairs, 3, 3)).copy()
    P0[open_pairs], Q0[open_pairs] = np.eye(3), 0.0
    J0 = jacobian(P0, Q0, Wfull, Wa_T)
    assert A.flags.f_contiguous
    assert np.abs(A @ J0 - np.eye(len(J0))).max() <= 1e-12 * np.linalg.cond(J0)
    assert np.abs(A - np.linalg.inv(J0)).max() <= 1e-13 * np.linalg.cond(J0) * np.abs(A).max()


def test_cholesky_stuck_inverse_refuses_an_indefinite_block():
    """A W that is not positive definite (a negative eigenvalue) leaves J0 to the LU path: None."""
    Wfull, Wa_T = _random_operators(10, 0, seed=3)
    Wfull[0, 0] = -1.0
    assert updated_jacobian.symmetric_inverse(Wfull, Wa_T, 1.0, np.zeros(10, dtype=bool), 3) is None


def test_no_closed_pair_and_an_empty_factor_print_nothing(capfd):
    """Every pair held open (a meshed gap before the load closes it): the LU path decides, and the empty factor
    gives an empty inverse, without LAPACK's "DPOTRI parameter number 4 had an illegal value" on the console."""
    from frictionid.fem.cholesky import inverse

    Wfull, Wa_T = _random_operators(10, 0, seed=3)
    assert updated_jacobian.symmetric_inverse(Wfull, Wa_T, 1.0, np.ones(10, dtype=bool), 3) is None
    assert inverse(np.zeros((0, 0), order="F")).shape == (0, 0)
    assert capfd.readouterr().out == ""


def test_block_3d_path_with_the_cholesky_inverse_same_as_with_lu(monkeypatch):
    """The whole load path of the 3-D block (three floating modes; stick, partial slip, gross slip and lift-off),
    sensitivities included, with the stuck inverse from the Cholesky factor against the one from LU: equal to
    1e-10 of each field's largest value (they differ by round-off of A only)."""
    problem = Problem.build(block_model(mesh_size=2.5), points=np.array([[-5.0, 0.0, 0.5], [0.0, -5.0, 1.5]]),
                            quantities=("ux", "uy", "uz"), regions=["block", "block"])
    c = problem.condensed
    assert c.n_modes == 3
    assert updated_jacobian.symmetric_inverse(c.gap_ops.full, c.equilibrium.on_lam, loadpath.contact_scale(c),
                                              np.zeros(problem.pairs.n_pairs, dtype=bool), 3) is not None
    out = {}
    for stuck in ("lu", "auto"):
        monkeypatch.setattr(updated_jacobian, "STUCK", stuck)
        problem.__dict__.pop("_stuck_inverses", None)
        out[stuck] = problem.solve([0.3, 0.2, 0.4, 0.25], sensitivities=True)
        made = problem._stuck_inverses.base
        J0 = jacobian(made.P0, made.Q0, problem.condensed.gap_ops.full, problem.condensed.equilibrium.on_lam)
        assert np.abs(made.A @ J0 - np.eye(len(J0))).max() <= 1e-10
    assert {"stick", "partial slip", "lift-off"} <= _phases(out["lu"].state)
    assert np.any((out["lu"].state == SLIP).sum(axis=1) == (out["lu"].state != OPEN).sum(axis=1))
    _assert_same(out["lu"], out["auto"], rtol=1e-10)


def test_gmres_preconditioned_by_a_nearby_factorisation_solves_to_the_backward_error_of_lu():
    """C = C1 + a 2 % perturbation of every entry, GMRES preconditioned by C1's LU: C x = v to 1e-13 (|C| |x| +
    |v|) in a few iterations; a perturbation as large as C1 itself does not converge in MAX_KRYLOV: None."""
    rng = np.random.default_rng(0)
    k = 300
    C1 = rng.normal(size=(k, k)) + np.sqrt(k) * np.eye(k)
    base = capacitance.Fresh.factorise(np.arange(k), None, None, C1)
    v = rng.normal(size=k)
    C = C1 + 0.02 * rng.normal(size=(k, k))
    x, n = capacitance.gmres(C, v, base.solve)
    assert 0 < n < capacitance.MAX_KRYLOV
    assert np.abs(C @ x - v).max() <= 1e-13 * (np.abs(C).sum(axis=1).max() * np.abs(x).max() + np.abs(v).max())
    far, n = capacitance.gmres(C1 + 3.0 * rng.normal(size=(k, k)), v, base.solve)
    assert far is None and n == capacitance.MAX_KRYLOV


def test_gmres_solves_columns_together_as_each_alone_with_one_pass_per_iteration():
    """Several right-hand sides (the sensitivities' n_z) iterate together: each column to the same backward error
    in the same iterations as alone (to one, from round-off in the single-precision preconditioner), with one
    preconditioner application of the block per iteration instead of one per column and iteration."""
    rng = np.random.default_rng(2)
    k, n = 300, 5
    C1 = rng.normal(size=(k, k)) + np.sqrt(k) * np.eye(k)
    base = capacitance.Fresh.factorise(np.arange(k), None, None, C1)
    C = C1 + 0.02 * rng.normal(size=(k, k))
    V = rng.normal(size=(k, n)) * np.logspace(0, 3, n)          # columns of other sizes converge apart
    calls = []

    def counted(v):
        calls.append(v.shape)
        return base.precondition(v)
    X, iterations = capacitance.gmres(C, V, counted)
    together = len(calls)
    calls.clear()
    alone = [capacitance.gmres(C, V[:, j], counted) for j in range(n)]
    scale = np.abs(C).sum(axis=1).max() * np.abs(X).max(axis=0) + np.abs(V).max(axis=0)
    assert np.all(np.abs(C @ X - V).max(axis=0) <= 1e-13 * scale)
    assert np.all(np.abs(iterations - [a[1] for a in alone]) <= 1) and iterations.min() > 2
    np.testing.assert_allclose(X, np.column_stack([a[0] for a in alone]), rtol=0, atol=1e-11 * np.abs(X).max())
    assert together <= iterations.max() + 3 and len(calls) >= iterations.sum()


def test_an_iterated_capacitance_that_does_not_converge_is_factorised():
    rng = np.random.default_rng(1)
    k = 200
    C1 = rng.normal(size=(k, k)) + np.sqrt(k) * np.eye(k)
    C = C1 + 3.0 * rng.normal(size=(k, k))
    iterated = capacitance.Iterated(np.arange(k), None, None, C,
                                    capacitance.Fresh.factorise(np.arange(k), None, None, C1))
    v = rng.normal(size=(k, 2))
    x = iterated.solve(v)
    assert iterated.fell_back and iterated.fallback is not None
    assert np.abs(C @ x - v).max() <= 1e-12 * np.abs(C).max() * np.abs(x).max()


def test_block_3d_path_with_iterated_capacitance_solves_same_as_factorised(monkeypatch):
    """The 3-D block's whole path (stick, partial slip, gross slip, lift-off), sensitivities included: the
    capacitance matrices whose rows keep their pairs but turn their slip directions solved by GMRES on a kept
    factorisation, against each factorised afresh (ITERATE "never"): equal to 1e-10 of each field's largest
    value, with iterated solves taking part (the block's matrices have fewer rows than ITERATE_MIN_ROWS: the
    threshold is lowered here)."""
    monkeypatch.setattr(updated_jacobian, "ITERATE_MIN_ROWS", 0)
    problem = Problem.build(block_model(mesh_size=2.5), points=np.array([[-5.0, 0.0, 0.5], [0.0, -5.0, 1.5]]),
                            quantities=("ux", "uy", "uz"), regions=["block", "block"])
    calls = []
    gmres = capacitance.gmres

    def counted(*args, **kwargs):
        x, n = gmres(*args, **kwargs)
        calls.append(x is not None)
        return x, n
    monkeypatch.setattr(capacitance, "gmres", counted)
    out = {}
    for iterate in ("never", "auto"):
        monkeypatch.setattr(updated_jacobian, "ITERATE", iterate)
        out[iterate] = problem.solve([0.3, 0.2, 0.4, 0.25], sensitivities=True)
        assert (len(calls) > 0) == (iterate == "auto")
    assert sum(calls) >= 5
    assert {"stick", "partial slip", "lift-off"} <= _phases(out["never"].state)
    _assert_same(out["never"], out["auto"], rtol=1e-10)


def test_a_solver_with_iterated_solves_is_freed_without_the_garbage_collector(plane_strain, monkeypatch):
    """Each solve makes its own UpdatedSolver, holding k x k arrays: it keeps KEEP_BASES fresh factorisations as
    bases, no more, and no reference cycle may keep it (and them) alive after the solve until the garbage
    collector runs (two n_w = 9,000 solves passed 8.9 GB with one)."""
    monkeypatch.setattr(updated_jacobian, "ITERATE_MIN_ROWS", 0)
    monkeypatch.setattr(updated_jacobian, "SWITCH_FRACTION", np.inf)     # the random state opens a third
    inverses = loadpath.stuck_inverses(plane_strain.condensed, plane_strain.pairs)
    solver = UpdatedSolver(inverses)
    P, Q, _ = next(_random_states(plane_strain, seed=3))
    b = np.ones(len(P) * 2 + plane_strain.condensed.n_modes)
    solver(P, Q, b)
    changed = np.any((P != inverses.base.P0) | (Q != inverses.base.Q0), axis=(1, 2))
    P2 = P.copy()
    P2[changed] *= 1.0 + 1e-3                    # the same rows, other values: an iterated solve
    solver(P2, Q, b)
    assert solver.n_iterated == 1
    base = solver._base
    P4 = P.copy()
    P4[changed] *= 1.0 - 1e-3
    assert solver.rcond(P4, Q) > 0.0             # a predictor's estimate factorises its matrix ...
    solver(P4, Q, b)
    assert solver.n_iterated == 2 and solver._base is base      # ... without making it the base
    for P3, Q3, _ in _random_states(plane_strain, seed=9, n_states=2):    # other rows: fresh factorisations
        solver(P3, Q3, b)
        assert len(solver._bases) == updated_jacobian.KEEP_BASES
    gc.disable()
    try:
        freed = weakref.ref(solver)
        del solver
        assert freed() is None
    finally:
        gc.enable()


def test_a_singular_state_predictor_is_not_tried_again_for_the_same_states(plane_strain, monkeypatch):
    """A state predictor found singular (its capacitance matrix's condition estimate, a factorisation) is not made
    again in later increments with the same contact states: every predictor made singular here, it is estimated
    once per distinct state, and the solution is the one that estimates it every increment (Newton starts from
    the previous solution either way; the secant start is switched off, so that each increment makes its stick
    predictor, whose estimate is never remembered)."""
    monkeypatch.setattr(loadpath, "SECANT", False)
    estimates, states = [], []
    monkeypatch.setattr(UpdatedSolver, "rcond", lambda self, P, Q: estimates.append(1) or 0.0)
    original = loadpath.LoadPathSolver._predictor

    def predictor(self, inc, held, mu=None, path=None):
        if path is not None:
            states.append(path.state.tobytes())
        return original(self, inc, held, mu, path)

    monkeypatch.setattr(loadpath.LoadPathSolver, "_predictor", predictor)
    remembered = plane_strain.solve([0.3, 0.2], sensitivities=True)
    n_stick = len(remembered.n_newton)                    # one stick predictor per increment, never remembered
    assert len(states) > len(set(states))                 # the same states met again (gross slip)
    assert len(estimates) == n_stick + len(set(states))

    class Forgetful(set):
        def add(self, item):
            pass

    init = loadpath.LoadPathSolver.__init__

    def forgetful_init(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.singular_states = Forgetful()

    monkeypatch.setattr(loadpath.LoadPathSolver, "__init__", forgetful_init)
    estimates.clear(), states.clear()
    every = plane_strain.solve([0.3, 0.2], sensitivities=True)
    assert len(estimates) == n_stick + len(states) > n_stick + len(set(states))
    _assert_same(every, remembered, rtol=0.0)


def test_where_the_state_predictor_is_singular_newton_starts_from_the_secant(plane_strain, monkeypatch):
    """Where the state predictor is singular (here made so for every state: in 3-D gross slip the floating bodies'
    tangential motion leaves it singular, docs/bolt-study.md) Newton starts from the last two increments' secant
    where the load moves on along the same direction (the pull ramped, the press held), not from the stick
    predictor: fewer Newton iterations, the same solution (2-D: to round-off). (In 2-D gross slip the replaced
    rows stay, so the factorisations are the same; in 3-D each Newton step from the stick predictor factorises.)"""
    monkeypatch.setattr(loadpath.LoadPathSolver, "_predictor",
                        _singular_state_predictor(loadpath.LoadPathSolver._predictor))
    secants = []
    original = loadpath.LoadPathSolver._secant
    monkeypatch.setattr(loadpath.LoadPathSolver, "_secant",
                        staticmethod(lambda *args: secants.append(original(*args)) or secants[-1]))
    out = {}
    for secant in (False, True):
        monkeypatch.setattr(loadpath, "SECANT", secant)
        out[secant] = plane_strain.solve([0.3, 0.2], sensitivities=True)
    made = [x for x in secants if x is not None]
    # asked for at every increment (2 press, 8 pull); made where the last increment went the same way: not at the
    # first (none behind) nor at the first pull increment (the load turns from pressing to pulling)
    assert len(secants) == 10 and len(made) == 8
    assert {"gross slip"} <= _phases(out[True].state)
    assert out[True].n_newton.sum() < out[False].n_newton.sum()
    _assert_same(out[False], out[True], rtol=1e-12)


def _singular_state_predictor(predictor):
    """LoadPathSolver._predictor with every state predictor (``path`` given) singular."""
    def singular(self, inc, held, mu=None, path=None):
        return None if path is not None else predictor(self, inc, held)
    return singular


def _counted_solvers(monkeypatch) -> list:
    """The UpdatedSolvers made from now on (their counts of factorisations)."""
    made = []
    init = UpdatedSolver.__init__

    def counted(self, *args, **kwargs):
        init(self, *args, **kwargs)
        made.append(self)
    monkeypatch.setattr(UpdatedSolver, "__init__", counted)
    return made


@pytest.mark.slow
def test_3d_bolt_in_gross_slip_starts_its_second_increment_from_the_secant(monkeypatch):
    """The 3-D M6 bolt of tests/fixtures/bolt3d_calculix (1,467 pairs, four floating bodies; 1,500 N in two
    increments): in gross slip its state predictor is singular, and the stick predictor's Newton path factorised a
    new capacitance matrix at almost every step (7 steps in the second increment, 12 factorisations in all). Under
    the proportional load the secant start is the second increment's solution: no Newton step, fewer
    factorisations, the same contact forces, observations and sensitivities to 1e-8 of their largest (Newton's
    rtol 1e-10; measured 1e-13)."""
    from fixtures.bolt3d_calculix import MU, OPTIONS, generate, stored_model
    calculix = generate.calculix
    points, regions = calculix.observed(OPTIONS)
    problem = Problem.build(stored_model(calculix.layout_of(OPTIONS)), factorisation="mumps", points=points,
                            quantities=("ux", "uy", "uz"), regions=regions)
    solvers = _counted_solvers(monkeypatch)
    out, factorisations = {}, {}
    for secant in (False, True):
        monkeypatch.setattr(loadpath, "SECANT", secant)
        solvers.clear()
        out[secant] = problem.solve(np.full(problem.model.n_zones, MU), sensitivities=True)
        factorisations[secant] = sum(s.n_factorisations for s in solvers)
    old, new = out[False], out[True]
    closed = old.state[-1] != OPEN
    assert np.all(old.state[-1][closed] == SLIP) and closed.sum() > 1000          # gross slip
    assert old.n_newton[1] >= 5 and new.n_newton[1] == 0
    assert factorisations[True] <= factorisations[False] - 4
    assert np.array_equal(old.state, new.state)
    for name in ("lam", "w", "reactions", "observations", "d_observations"):
        a, b = np.asarray(getattr(old, name)), np.asarray(getattr(new, name))
        assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max(), name
    # the machine force is prescribed: its sensitivities are round-off, compared with the force itself
    assert np.abs(old.d_reactions - new.d_reactions).max() <= 1e-8 * np.abs(old.reactions).max()
