"""BLAS threads chosen for the work (fem/threads.py): one inside a contact solve and for small condensation
blocks, whatever the process's setting, and the setting restored afterwards."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from frictionid.builders.block import block_model_2d
from frictionid.fem import loadpath
from frictionid.fem.problem import Problem
from frictionid.fem.threads import (CHOLESKY_THREADED_MAX, LARGE, SMALL, blas_threads_for, cholesky_threads,
                                    large_kernel, one_blas_thread)


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


def test_large_cholesky_factorisations_take_one_thread_where_threaded_openblas_crashes():
    """From n^2 / threads = CHOLESKY_THREADED_MAX rows a Cholesky factorisation runs on one thread, below it on
    the threads in force; inside a solve's large_kernel too."""
    bound = int(np.ceil(np.sqrt(2 * CHOLESKY_THREADED_MAX)))              # 10,955 rows at 2 threads
    with threadpool_limits(2, user_api="blas"):
        with cholesky_threads(bound - 1):
            assert _threads() == {2}
        with cholesky_threads(bound):
            assert _threads() == {1}
        with one_blas_thread(), large_kernel(bound), cholesky_threads(bound):
            assert _threads() == {1}
        assert _threads() == {2}
    with threadpool_limits(4, user_api="blas"), cholesky_threads(bound):
        assert _threads() == {4}


@pytest.mark.slow          # 2 GB, about 30 s of one thread's CPU
def test_a_cholesky_factorisation_of_15800_rows_at_two_threads_completes():
    """OpenBLAS's threaded potrf crashes (SIGSEGV) at 15,800 rows with 2 threads, as BLAS's default on a 2-core
    machine (measured; fem/threads.py): inside cholesky_threads it completes. In a child process, since the
    crash would take the test runner with it."""
    code = textwrap.dedent("""
        import numpy as np, scipy.linalg as la
        from threadpoolctl import threadpool_limits
        from frictionid.fem.threads import cholesky_threads
        n = 15800
        A = np.asfortranarray(np.eye(n) * n + np.tril(np.full((n, n), 1e-3)))
        with threadpool_limits(2, user_api="blas"), cholesky_threads(n):
            c, info = la.lapack.dpotrf(A, lower=1, clean=0, overwrite_a=1)
        print(info, np.isfinite(np.diag(c)).all())
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0 and done.stdout.split() == ["0", "True"], (done.returncode, done.stderr[-500:])
