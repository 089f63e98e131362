"""BLAS threads of the dense kernels, chosen for the work: one for the contact solve and for the small dense
blocks of a condensation, BLAS's own default (all cores) for large ones; inside a contact solve, the threads the
process had before it for the factorisations of :data:`LARGE` rows or more (the stuck inverse, capacitance
matrices).

Threads gain nothing on products and triangular solves of a few hundred to a couple of thousand unknowns, and
where the cores are shared (another job, or run.workers solves side by side) OpenBLAS's threads, which spin while
they wait for work, cost up to 60x (benchmarks/blas_threads.py, benchmarks/cli_threads.py). Factorisations of
thousands of rows are another matter: on this 2-core machine idle, the stuck inverse and capacitance LUs took 0.55
to 0.66 of one thread's wall time with BLAS's default at n_w 3,000 to 9,000; with a second process keeping one
core busy, 1.40 to 1.82 times at 3,000, 0.80 to 1.16 at 6,000 and 0.87 to 0.96 at 9,000
(``benchmarks/blas_threads.py --dense N``).
"""

from __future__ import annotations

import contextlib
import functools

from threadpoolctl import ThreadpoolController

#: dense blocks with fewer rows than this are factorised and solved with one BLAS thread
SMALL = 2000
#: inside a contact solve, dense factorisations of at least this many rows take the threads the process had
#: before the solve (module docstring: from about 6,000 rows they pay idle and cost little with a core busy)
LARGE = 6000

#: OpenBLAS 0.3.30 and 0.3.31 (the scipy and numpy wheels) crash (SIGSEGV) in a threaded Cholesky factorisation
#: (potrf, and potri after it) of n rows once n^2 / threads passes about 1.2e8: measured on this machine, 2 threads
#: 15,500 rows fine and 15,800 crash, 3 threads 17,000 / 20,000, 4 threads 20,000 / 24,000, one thread 24,000 fine
#: (OpenBLAS issue #2562 reports it for 2 threads at 32,768; the 2-thread case is tests/test_blas_threads.py's slow
#: test). From half that bound :func:`cholesky_threads` runs the factorisation on one thread.
CHOLESKY_THREADED_MAX = 6e7

#: the BLAS thread counts in force before each :func:`one_blas_thread` entered and not yet left, innermost last
_outside: list[int] = []


@functools.cache
def _controller() -> ThreadpoolController:
    """The process's thread-pool controller, made once (threadpoolctl's scan of the loaded libraries costs 1-10 ms)."""
    return ThreadpoolController()


def _blas_threads() -> int:
    """The largest thread count of the BLAS libraries loaded (1 without any)."""
    return max((d["num_threads"] for d in _controller().info() if d["user_api"] == "blas"), default=1)


@contextlib.contextmanager
def one_blas_thread():
    """A context in which the BLAS libraries run one thread each, restored after it; :func:`large_kernel`
    inside it gives a large factorisation the threads from before it."""
    before = _blas_threads()
    with _controller().limit(limits=1, user_api="blas"):
        _outside.append(before)
        try:
            yield
        finally:
            _outside.pop()


def large_kernel(n: int):
    """The context for a dense factorisation of ``n`` rows inside :func:`one_blas_thread`: from :data:`LARGE`
    rows the BLAS threads from before that context, else (and outside it) no change."""
    if n < LARGE or not _outside or _outside[-1] <= 1:
        return contextlib.nullcontext()
    return _controller().limit(limits=_outside[-1], user_api="blas")


def cholesky_threads(n: int):
    """The context for a dense Cholesky factorisation or inversion (potrf, potri) of ``n`` rows: one BLAS thread
    where n^2 / threads reaches :data:`CHOLESKY_THREADED_MAX` (OpenBLAS's threaded potrf crashes beyond about
    twice that), else no change."""
    threads = _blas_threads()
    return one_blas_thread() if threads > 1 and n * n / threads >= CHOLESKY_THREADED_MAX else \
        contextlib.nullcontext()


def blas_threads_for(n: int):
    """The context for dense work on blocks of ``n`` rows: :func:`one_blas_thread` below :data:`SMALL`, else
    BLAS's default."""
    return one_blas_thread() if n < SMALL else contextlib.nullcontext()
