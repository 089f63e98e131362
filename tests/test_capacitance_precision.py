"""Capacitance factorisations in single precision with solves refined against C in double (fem/capacitance.py
``PRECISION = "mixed"``) against double factorisations: a solve's backward error that of a double LU solve, and
whole 3-D load paths (stick, partial slip, gross slip, lift-off; sensitivities included) equal to the Newton
tolerance with the same Newton iterations."""

import numpy as np
import pytest

from frictionid.builders.block import block_model
from frictionid.fem import capacitance, updated_jacobian
from frictionid.fem.problem import Problem

from test_updated_jacobian import _assert_same, _phases


def _backward_error(C, x, v) -> float:
    """max |C x - v| / (|C| |x| + |v|) over the columns (maximum norms, as the refinement's test)."""
    scale = np.abs(C).sum(axis=1).max() * np.abs(x).max(axis=0) + np.abs(v).max(axis=0)
    return float(np.max(np.abs(C @ x - v).max(axis=0) / scale))


def test_a_single_factorisation_solves_to_the_backward_error_of_a_double_one():
    rng = np.random.default_rng(0)
    k = capacitance.SINGLE_MIN_ROWS + 100
    C = rng.normal(size=(k, k)) + 3.0 * np.sqrt(k) * np.eye(k)
    single = capacitance.Fresh.factorise(np.arange(k), None, None, C)
    assert single.single and "_double" not in single.__dict__
    v = rng.normal(size=(k, 3))
    x = single.solve(v)
    assert "_double" not in single.__dict__                    # refined, not factorised again in double
    assert _backward_error(C, x, v) <= capacitance.REFINE_RTOL
    unrefined = single.precondition(v)
    assert _backward_error(C, unrefined, v) > 1e3 * capacitance.REFINE_RTOL     # single precision alone is not
    exact = np.linalg.solve(C, v)
    assert np.abs(x - exact).max() <= 1e-12 * np.abs(exact).max()
    assert np.abs(single.solve(v[:, 0]) - exact[:, 0]).max() <= 1e-12 * np.abs(exact).max()     # one column
    assert single.transposed                         # a C-ordered C: its transpose factorised, solved transposed
    columns = capacitance.Fresh.factorise(np.arange(k), None, None, np.asfortranarray(C))
    assert columns.single and not columns.transposed
    assert np.abs(columns.solve(v) - exact).max() <= 1e-12 * np.abs(exact).max()
    assert columns.rcond() == pytest.approx(1.0 / np.linalg.cond(C, 1), rel=0.5)
    assert single.rcond() == pytest.approx(1.0 / np.linalg.cond(C, np.inf), rel=0.5)


def test_a_matrix_too_ill_conditioned_for_single_precision_is_factorised_in_double():
    rng = np.random.default_rng(1)
    k = capacitance.SINGLE_MIN_ROWS + 100
    Q, _ = np.linalg.qr(rng.normal(size=(k, k)))
    C = Q @ np.diag(np.logspace(0, -8, k)) @ Q.T               # cond 1e8: single precision cannot hold it
    fresh = capacitance.Fresh.factorise(np.arange(k), None, None, C)
    assert not fresh.single
    v = rng.normal(size=k)
    assert _backward_error(C, fresh.solve(v)[:, None], v[:, None]) <= capacitance.REFINE_RTOL


def test_a_stalled_refinement_solves_by_a_double_factorisation(monkeypatch):
    monkeypatch.setattr(capacitance, "MAX_REFINE", 0)
    rng = np.random.default_rng(2)
    k = capacitance.SINGLE_MIN_ROWS
    C = rng.normal(size=(k, k)) + 3.0 * np.sqrt(k) * np.eye(k)
    fresh = capacitance.Fresh.factorise(np.arange(k), None, None, C)
    v = rng.normal(size=k)
    x = fresh.solve(v)
    assert fresh.single and not fresh.__dict__["_double"].single
    assert _backward_error(C, x[:, None], v[:, None]) <= capacitance.REFINE_RTOL


def test_block_3d_path_with_single_factorisations_same_as_double(monkeypatch):
    """The 3-D block's whole path with every capacitance matrix factorised in single precision (the thresholds
    lowered: its matrices have 150 to 230 rows) and the iterated solves preconditioned by single factors, against
    double factorisations: every field within 1e-10 of its largest value, the same states and Newton iterations."""
    monkeypatch.setattr(updated_jacobian, "ITERATE_MIN_ROWS", 0)
    monkeypatch.setattr(capacitance, "SINGLE_MIN_ROWS", 0)
    problem = Problem.build(block_model(mesh_size=2.5), points=np.array([[-5.0, 0.0, 0.5], [0.0, -5.0, 1.5]]),
                            quantities=("ux", "uy", "uz"), regions=["block", "block"])
    made = []
    factorise = capacitance.Fresh.factorise.__func__

    def spied(cls, *args):
        made.append(factorise(cls, *args))
        return made[-1]
    monkeypatch.setattr(capacitance.Fresh, "factorise", classmethod(spied))
    out = {}
    for precision in ("double", "mixed"):
        monkeypatch.setattr(capacitance, "PRECISION", precision)
        made.clear()
        out[precision] = problem.solve([0.3, 0.2, 0.4, 0.25], sensitivities=True)
        singles = sum(f.single for f in made)
        assert (singles >= 5) if precision == "mixed" else (singles == 0 and len(made) >= 5)
    assert {"stick", "partial slip", "lift-off"} <= _phases(out["double"].state)
    assert np.array_equal(out["double"].n_newton, out["mixed"].n_newton)
    _assert_same(out["double"], out["mixed"], rtol=1e-10)
