"""DaskExecutor: forward solves as tasks of a Dask distributed cluster (run.scheduler).

The backend reaches every worker once, as a worker plugin: the scheduler hands it to each worker that joins,
so a worker restarted after a crash can solve again without the client sending anything. A task lost with its
worker is run again by the scheduler, at most run.retries times (distributed.scheduler.allowed-failures); a
task that raises is retried as often (``retries=``). Workers of a remote cluster need frictionid (and ccx for
the calculix backend) installed as on the client.
"""

from __future__ import annotations

import logging
import uuid

import dask
from distributed import Client, LocalCluster, as_completed
from distributed.diagnostics.plugin import WorkerPlugin

from ..errors import InputError, SolverError
from .solve import CONNECT_TIMEOUT, LOCAL, WorkerLost, solve

log = logging.getLogger(__name__)
_BACKENDS: dict[str, object] = {}   # on a worker: backends handed over by the plugin, by token


def _solve_on_worker(token: str, mu, sensitivities: bool | tuple[int, ...]):
    return solve(_BACKENDS[token], mu, sensitivities)


class _BackendPlugin(WorkerPlugin):
    """Worker plugin that leaves the backend on every worker (also on workers that join later)."""

    def __init__(self, backend, token: str):
        self.backend, self.token, self.name = backend, token, f"frictionid-backend-{token}"

    def setup(self, worker=None) -> None:
        _BACKENDS[self.token] = self.backend

    def teardown(self, worker=None) -> None:
        _BACKENDS.pop(self.token, None)


class DaskExecutor:
    """Solves on a Dask cluster: an existing one (``scheduler`` = "tcp://host:port") or a LocalCluster of
    ``workers`` processes with one thread each (``scheduler`` = "local")."""

    parallel = True

    def __init__(self, backend, scheduler: str, workers: int = 1, retries: int = 2, where: str = "[run]"):
        self.scheduler, self.retries, self._cluster, self._token = scheduler, int(retries), None, uuid.uuid4().hex
        # read by the scheduler when it is made: a LocalCluster's here, a remote one's from its own config
        with dask.config.set({"distributed.scheduler.allowed-failures": self.retries}):
            if scheduler == LOCAL:
                _quiet()
                self._cluster = LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True,
                                             dashboard_address=":0", scheduler_kwargs={"dashboard": False},
                                             silence_logs=logging.ERROR)   # no dashboard, its port free
                self.client = Client(self._cluster)
            else:
                self.client = _connect(scheduler, where)
        try:
            self.n_workers = len(self.client.scheduler_info()["workers"])
            if self.n_workers == 0:
                raise InputError(f"{where} run.scheduler = {scheduler!r}: the scheduler has no workers")
            self._plugin = _BackendPlugin(backend, self._token)
            self.client.register_plugin(self._plugin, name=self._plugin.name)
        except BaseException:
            self.close()
            raise
        log.info("Dask: %s", self.describe())

    def start(self) -> None:
        """The cluster runs from construction on."""

    def submit(self, mu, sensitivities: bool | tuple[int, ...]):
        return self.client.submit(_solve_on_worker, self._token, mu, sensitivities, pure=False,
                                  retries=self.retries, key=f"frictionid-solve-{uuid.uuid4().hex}")

    def result(self, task):
        """(prediction or failure message, wall time [s]); SolverError when the task was lost too often."""
        try:
            return task.result()
        except Exception as exc:
            raise self._lost(exc) from exc

    def completed(self, tasks):
        """(index into ``tasks``, result) of each task as it finishes."""
        index = {task.key: k for k, task in enumerate(tasks)}
        for task in as_completed(tasks):
            yield index[task.key], self.result(task)

    def _lost(self, exc: Exception) -> Exception:
        if isinstance(exc, SolverError):
            return exc
        allowed = (f"run.retries = {self.retries}" if self.scheduler == LOCAL else
                   f"retries = {self.retries} for errors, the scheduler's distributed.scheduler.allowed-failures "
                   "for lost workers")
        return WorkerLost(f"run.scheduler = {self.scheduler!r}: a forward solve did not come back "
                          f"({type(exc).__name__}: {exc}) after the retries allowed ({allowed}). Every finished "
                          "solve is in the run store: continue with --resume")

    def close(self) -> None:
        """Leave a remote cluster as found (plugin removed); stop a local one."""
        client, cluster = getattr(self, "client", None), self._cluster
        if client is not None and cluster is None and getattr(self, "_plugin", None) is not None:
            try:
                client.unregister_worker_plugin(self._plugin.name)
            except Exception as exc:     # the cluster may be gone already; nothing of ours is left there then
                log.info("Dask: plugin not removed (%s)", exc)
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        self.client, self._cluster = None, None

    def describe(self) -> str:
        where = "a LocalCluster" if self.scheduler == LOCAL else f"the cluster at {self.scheduler}"
        return f"{self.n_workers} Dask workers in {where}"


def _quiet() -> None:
    """The cluster's INFO lines (each worker's start and stop) kept out of the run's output; warnings stay."""
    for name in ("distributed", "bokeh"):
        if logging.getLogger(name).getEffectiveLevel() < logging.WARNING:
            logging.getLogger(name).setLevel(logging.WARNING)


def _connect(scheduler: str, where: str):
    try:
        return Client(scheduler, timeout=f"{CONNECT_TIMEOUT}s")
    except (OSError, TimeoutError) as exc:
        raise InputError(f"{where} run.scheduler = {scheduler!r}: no Dask scheduler answered within "
                         f"{CONNECT_TIMEOUT:g} s ({exc}); start one (dask scheduler) or use \"local\"") from None
