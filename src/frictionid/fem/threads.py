"""BLAS threads of the dense kernels, chosen for the work: one for the contact solve and for the small dense
blocks of a condensation, BLAS's own default (all cores) for large ones.

Threads gain nothing on products and triangular solves of a few hundred to a couple of thousand unknowns, and
where the cores are shared (another job, or run.workers solves side by side) OpenBLAS's threads, which spin while
they wait for work, cost up to 60x (benchmarks/blas_threads.py, benchmarks/cli_threads.py).
"""

from __future__ import annotations

import contextlib
import functools

from threadpoolctl import ThreadpoolController

#: dense blocks with fewer rows than this are factorised and solved with one BLAS thread
SMALL = 2000


@functools.cache
def _controller() -> ThreadpoolController:
    """The process's thread-pool controller, made once (threadpoolctl's scan of the loaded libraries costs 1-10 ms)."""
    return ThreadpoolController()


def one_blas_thread():
    """A context in which the BLAS libraries run one thread each, restored after it."""
    return _controller().limit(limits=1, user_api="blas")


def blas_threads_for(n: int):
    """The context for dense work on blocks of ``n`` rows: :func:`one_blas_thread` below :data:`SMALL`, else
    BLAS's default."""
    return one_blas_thread() if n < SMALL else contextlib.nullcontext()
