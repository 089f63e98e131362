"""BLAS threads chosen for the work (fem/threads.py): one inside a contact solve and for small condensation
blocks, whatever the process's setting, and the setting restored afterwards."""

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from frictionid.builders.block import block_model_2d
from frictionid.fem import loadpath
from frictionid.fem.problem import Problem
from frictionid.fem.threads import LARGE, SMALL, blas_threads_for, large_kernel, one_blas_thread


def _threads() -> set[int]:
    """Thread counts of the threaded BLAS libraries loaded (kvxopt's OpenBLAS is built without threads)."""
    return {d["num_threads"] for d in threadpool_info()
            if d["user_api"] == "blas" and d.get("threading_layer") != "disabled"}


def test_a_solve_runs_one_blas_thread_and_restores_the_setting(monkeypatch):
    problem = Problem.build(block_model_2d(mesh_size=4.0))
    seen = []
    step = loadpath.LoadPathSolver.step

    def spy(self, *args, **kwargs):
        seen.append(_threads())
        return step(self, *args, **kwargs)

    monkeypatch.setattr(loadpath.LoadPathSolver, "step", spy)
    with threadpool_limits(2, user_api="blas"):               # as BLAS's default on a 2-core machine
        before = _threads()
        solution = problem.solve(np.full(problem.model.n_zones, 0.2), sensitivities=True)
        assert _threads() == before == {2}
    assert seen and all(s == {1} for s in seen)
    assert np.isfinite(solution.observations).all()


def test_small_condensation_blocks_take_one_thread_large_ones_the_default():
    with threadpool_limits(2, user_api="blas"):
        with blas_threads_for(SMALL - 1):
            assert _threads() == {1}
        with blas_threads_for(SMALL):
            assert _threads() == {2}
        assert _threads() == {2}


def test_large_factorisations_in_a_solve_take_the_threads_from_before_it():
    with threadpool_limits(2, user_api="blas"):
        with large_kernel(LARGE):                               # outside a solve: no change
            assert _threads() == {2}
        with one_blas_thread():
            with large_kernel(LARGE - 1):
                assert _threads() == {1}
            with large_kernel(LARGE):
                assert _threads() == {2}
            assert _threads() == {1}
        assert _threads() == {2}
    with threadpool_limits(1, user_api="blas"):                 # a process held to one thread stays there
        with one_blas_thread(), large_kernel(LARGE):
            assert _threads() == {1}
