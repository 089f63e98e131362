"""One forward solve as every executor runs it, and what executors share: the scheduler names and the error of a
solve lost with its worker (:mod:`frictionid.run.executor` and :mod:`frictionid.run.cluster` both import this,
so neither imports the other at module level)."""

from __future__ import annotations

import time

from ..errors import SolverError

#: run.scheduler value that starts a Dask LocalCluster with run.workers processes
LOCAL = "local"
#: seconds to wait for a Dask scheduler to answer before run.scheduler is called unreachable
CONNECT_TIMEOUT = 10.0


class WorkerLost(SolverError):
    """A solve that did not come back from its worker (after the allowed retries): the run stops, resumable;
    unlike a solve that failed to converge, it says nothing about the coefficients."""


def solve(backend, mu, sensitivities: bool | tuple[int, ...]):
    """One forward solve: (the backend's Prediction, or the message of its SolverError; wall time [s])."""
    start = time.perf_counter()
    try:
        prediction = backend.predict(mu, sensitivities)
    except SolverError as exc:
        prediction = str(exc)
    return prediction, time.perf_counter() - start
