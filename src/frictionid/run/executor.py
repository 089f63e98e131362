"""Executors: where independent forward solves run: here, in forked worker processes, or on a Dask cluster.

Every executor runs the same function (:func:`solve`) on the same backend, so a solve gives the same bits
wherever it runs; callers record each result as it arrives (``completed`` yields in arrival order), so a client
that dies loses no finished solve.

>>> from frictionid.run.executor import SerialExecutor
>>> class Twice:
...     def predict(self, mu, sensitivities=False):
...         return 2 * mu
>>> executor = SerialExecutor(Twice())
>>> [(k, value) for k, (value, seconds) in executor.completed([executor.submit(1.0, False)])]
[(0, 2.0)]
"""

from __future__ import annotations

import concurrent.futures
import logging
import multiprocessing
import re

from ..errors import InputError
from .solve import LOCAL, solve

log = logging.getLogger(__name__)
_ADDRESS = re.compile(r"^(tcp|tls)://[^\s:/]+:\d{1,5}$")
_BACKEND = None   # the backend a forked worker process inherits (fork start method: nothing is pickled)


def _solve_forked(mu, sensitivities: bool | tuple[int, ...]):
    return solve(_BACKEND, mu, sensitivities)


def _adopt(backend) -> None:
    global _BACKEND
    _BACKEND = backend


class SerialExecutor:
    """Solves in the calling process, one at a time, when its result is asked for."""

    n_workers, parallel = 1, False

    def __init__(self, backend):
        self.backend = backend

    def start(self) -> None:
        """Nothing to start."""

    def submit(self, mu, sensitivities: bool | tuple[int, ...]):
        return lambda: solve(self.backend, mu, sensitivities)

    def result(self, task):
        """(prediction or failure message, wall time [s]) of one submitted solve."""
        return task()

    def completed(self, tasks):
        """(index into ``tasks``, result) of each task as it finishes (here: in order)."""
        for k, task in enumerate(tasks):
            yield k, task()

    def close(self) -> None:
        """Nothing to stop."""

    def describe(self) -> str:
        return "1 worker (this process)"


class ProcessExecutor(SerialExecutor):
    """``n_workers`` forked processes of this machine (run.workers > 1 without run.scheduler)."""

    parallel = True

    def __init__(self, backend, n_workers: int):
        super().__init__(backend)
        self.n_workers, self._pool = int(n_workers), None

    def start(self) -> None:
        """Fork the workers now (from the calling thread; forking while other threads run is unsafe)."""
        if self._pool is None:
            self._pool = concurrent.futures.ProcessPoolExecutor(
                self.n_workers, multiprocessing.get_context("fork"), initializer=_adopt, initargs=(self.backend,))
            self._pool.submit(int).result()     # a fork pool starts all its processes at the first task

    def submit(self, mu, sensitivities: bool | tuple[int, ...]):
        self.start()
        return self._pool.submit(_solve_forked, mu, sensitivities)

    def result(self, task):
        return task.result()

    def completed(self, tasks):
        index = {id(task): k for k, task in enumerate(tasks)}
        for task in concurrent.futures.as_completed(tasks):
            yield index[id(task)], task.result()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def describe(self) -> str:
        return f"{self.n_workers} local processes"


def check_scheduler(scheduler, where: str = "[run]") -> None:
    """InputError unless run.scheduler is "local" or a Dask scheduler address such as "tcp://host:8786"."""
    if scheduler is None or scheduler == LOCAL:
        return
    if not isinstance(scheduler, str) or not _ADDRESS.match(scheduler):
        raise InputError(f'{where} run.scheduler = {scheduler!r} is not "local" (a Dask cluster of run.workers '
                         'processes on this machine) or the address of a Dask scheduler, "tcp://host:port"')


def make_executor(backend, workers: int = 1, scheduler: str | None = None, retries: int = 2,
                  where: str = "[run]"):
    """The executor of run.workers / run.scheduler / run.retries for ``backend``.

    Raises
    ------
    InputError
        A malformed or unreachable run.scheduler, or dask[distributed] not installed.
    """
    check_scheduler(scheduler, where)
    if scheduler is not None:
        try:
            from .cluster import DaskExecutor
        except ImportError:
            raise InputError(f"{where} run.scheduler = {scheduler!r} needs Dask: pip install 'dask[distributed]'"
                             ) from None

        return DaskExecutor(backend, scheduler, int(workers), int(retries), where)
    return SerialExecutor(backend) if int(workers) <= 1 else ProcessExecutor(backend, int(workers))
