"""Evaluator: zone coefficients -> weighted residuals and their Jacobian, every forward solve stored first.

Residual rows: w (f(mu) - y) for the observations, then sqrt(tikhonov) (x - prior) and the paper's penalty
for leaving [lower, upper], sqrt(penalty) * distance outside. Coefficients below zero (possible only for the
unbounded gradient descent of the paper) are evaluated at zero by the forward model, which has no meaning
for them; the penalty is what keeps a run from going there.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import replace

import numpy as np

from ..backends.base import Backend
from ..errors import SolverError
from ..progress import bar
from ..run.executor import make_executor
from .observations import Observations
from .parameters import Parameters

log = logging.getLogger(__name__)
JACOBIANS = ("analytic", "forward", "central")


class Evaluator:
    """Backs a :class:`~frictionid.inverse.least_squares.LeastSquares` with a backend and a run store.

    Counts forward solves (``n_forward``) and solves with sensitivities (``n_sensitivity``) actually run,
    and evaluations recovered from the store of an earlier (interrupted) run (``n_replayed``). Within a run,
    repeated requests for the same point are served from memory and counted nowhere. Solves run on
    ``executor`` (:mod:`frictionid.run.executor`; default: this process, or ``workers`` forked processes);
    the evaluator may be shared by threads (multi-start), each waiting for its own solves.
    """

    def __init__(self, backend: Backend, observations: Observations, parameters: Parameters, store=None,
                 jacobian: str = "analytic", step: float = 1e-4, tikhonov: float = 0.0, prior=None,
                 penalty: float = 0.0, workers: int = 1, executor=None, sensitive=None):
        self.backend, self.obs, self.params, self.store = backend, observations, parameters, store
        #: (n_zones,) bool: the zones each solve with sensitivities takes them to (default the free ones; a refit
        #: with a zone held asks for the identification's free zones, so that the refits of different held zones,
        #: which share their stored evaluations, each find the columns they need)
        self.sensitive = np.asarray(parameters.free if sensitive is None else sensitive, dtype=bool)
        self.jacobian_kind, self.step = jacobian, step
        self.tikhonov, self.penalty = tikhonov, penalty
        self.prior = parameters.x0 if prior is None else np.broadcast_to(np.asarray(prior, float), parameters.x0.shape)
        self.n_forward = self.n_sensitivity = self.n_replayed = self.n_failed = 0
        self._memo: dict[tuple[bytes, bool], tuple] = {}
        self.executor = executor if executor is not None else make_executor(backend, max(int(workers), 1))
        self.workers = self.executor.n_workers
        self._lock = threading.Lock()
        self._floor_lock = threading.Lock()

    def _predict(self, x: np.ndarray, sensitivities: bool):
        """(f (n_obs,), df/dmu (n_obs, n_zones) or None) at free coefficients x, from the store if known.

        A forward solve that fails anywhere but at the start gives f = inf: the optimiser rejects that trial
        step (a shorter Armijo step, a smaller trust region) instead of the run ending. Failures are stored
        (status "failed") and replayed on resume like any other evaluation.
        """
        x = np.asarray(x, dtype=float)
        for key in ((x.tobytes(), sensitivities), (x.tobytes(), True)):
            if key in self._memo:
                return self._memo[key]
        kind = "forward+sensitivities" if sensitivities else "forward"
        stored = self._stored(x, kind)
        if sensitivities and stored is not None and stored.get("dfdmu") is not None and \
                not np.isfinite(stored["dfdmu"][:, self.params.free]).all():
            stored = None           # solved without some of these zones' sensitivities: solve again
        if stored is not None:
            self.n_replayed += 1
            self._memo[(x.tobytes(), sensitivities)] = stored["f"], stored.get("dfdmu")
            return self._memo[(x.tobytes(), sensitivities)]
        mu = np.maximum(self.params.full(x), 0.0)
        # derivatives for the free zones only: the held zones' columns are never read
        wanted = tuple(np.flatnonzero(self.sensitive).tolist()) if sensitivities else False
        prediction, wall = self.executor.result(self.executor.submit(mu, wanted))
        if isinstance(prediction, str) and np.array_equal(x, self.params.x0):
            raise SolverError(prediction)
        return self._keep(x, sensitivities, prediction, wall)

    def _keep(self, x: np.ndarray, sensitivities: bool, prediction, wall: float):
        """Count, store and memoise one solve at x: a Prediction, or the message of a failed solve (f = inf)."""
        kind = "forward+sensitivities" if sensitivities else "forward"
        failed = isinstance(prediction, str)
        if failed:
            log.warning("forward solve failed at mu = %s (f = inf there): %s",
                        np.maximum(self.params.full(x), 0.0).tolist(), prediction)
        f = np.full(self.obs.n_obs, np.inf) if failed else self.obs.predicted(prediction.values)
        dfdmu = None if failed or prediction.derivatives is None else self.obs.derivatives(prediction.derivatives)
        with self._lock:
            if failed:
                self.n_failed += 1
            if sensitivities:
                self.n_sensitivity += 1
            else:
                self.n_forward += 1
        if self.store is not None:
            outputs = {"f": f} if dfdmu is None else {"f": f, "dfdmu": dfdmu}
            self.store.record(x, kind, outputs, status="failed" if failed else "ok", wall_time=wall)
        self._memo[(x.tobytes(), sensitivities)] = f, dfdmu
        return f, dfdmu

    def _stored(self, x: np.ndarray, kind: str) -> dict | None:
        """A stored evaluation at x: a successful one of ``kind``, or a failed one of any kind."""
        if self.store is None:
            return None
        found = self.store.lookup(x, kind)
        return found if found is not None else self.store.lookup(x, "forward", status="failed")

    def reweigh(self, sigma: np.ndarray) -> None:
        """Weight the observations by new standard deviations (n_obs,) from here on (e.g. with the model
        error as extra variance); the solves done so far stay valid."""
        self.obs = replace(self.obs, sigma=np.asarray(sigma, dtype=float))

    def model_values(self, x: np.ndarray) -> np.ndarray:
        """(n_obs,) model values f(mu) at free coefficients x."""
        return self._predict(x, self.jacobian_kind == "analytic")[0]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        f = self.model_values(x)
        rows = [self.obs.weight * (f - self.obs.y)]
        if self.tikhonov > 0:
            rows.append(np.sqrt(self.tikhonov) * (x - self.prior))
        if self.penalty > 0:
            outside = np.maximum(self.params.lower - x, 0) + np.maximum(x - self.params.upper, 0)
            rows.append(np.sqrt(self.penalty) * outside)
        return np.concatenate(rows)

    def stick_floor(self, x: np.ndarray) -> np.ndarray | None:
        """(n_free,) per free coefficient whose zone sticks along the whole load path at x, the lowest value it
        can take with every residual the same (its stick threshold, the zones lowered together), NaN for the
        others; None where the backend cannot tell or the residuals contain mu itself (Tikhonov). One forward
        solve, counted in ``n_forward`` and not stored (it is made again on resume)."""
        thresholds = getattr(self.backend, "stick_thresholds", None)
        if thresholds is None or self.tikhonov > 0:
            return None
        try:
            with self._floor_lock:        # the backend's own process; starts of a multi-start run take turns
                floor = thresholds(np.maximum(self.params.full(np.asarray(x, float)), 0.0), self.params.free)
        except SolverError as error:
            log.info("no stick thresholds: the solve failed (%s)", error)
            return None
        finally:
            with self._lock:
                self.n_forward += 1
        return np.asarray(floor, dtype=float)[self.params.free]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """d residuals / dx (n_res, n_free) by the configured method."""
        x = np.asarray(x, dtype=float)
        if self.jacobian_kind == "analytic":
            dfdmu = self._predict(x, True)[1][:, self.params.free]
        else:
            dfdmu = self._finite_differences(x)
        blocks = [self.obs.weight[:, None] * dfdmu]
        eye = np.eye(len(x))
        if self.tikhonov > 0:
            blocks.append(np.sqrt(self.tikhonov) * eye)
        if self.penalty > 0:
            sign = np.where(x < self.params.lower, -1.0, np.where(x > self.params.upper, 1.0, 0.0))
            blocks.append(np.sqrt(self.penalty) * eye * sign)
        return np.vstack(blocks)

    def _finite_differences(self, x: np.ndarray) -> np.ndarray:
        """Forward (the paper's) or central differences with step max(step |x|, step) per coefficient.

        With a parallel executor the perturbed points are solved at once, each stored as it arrives.
        """
        h = self.step * np.maximum(np.abs(x), 1.0)
        steps = np.diag(h)
        points = [x + e for e in steps] + ([] if self.jacobian_kind == "forward" else [x - e for e in steps])
        if self.executor.parallel:
            self.solve_all(points)
        columns = bar(range(len(x)), len(x), f"{self.jacobian_kind}-difference Jacobian")
        return np.column_stack([self._difference(x, steps[k], h[k]) for k in columns])

    def _difference(self, x: np.ndarray, e: np.ndarray, h: float) -> np.ndarray:
        """One Jacobian column: forward or central; where a perturbed solve failed, the other side's one-sided
        difference (the failure is stored like any other); where both sides failed, a SolverError."""
        up = self.model_values(x + e)
        down = self.model_values(x - e) if self.jacobian_kind == "central" or not np.all(np.isfinite(up)) else None
        if np.all(np.isfinite(up)):
            if down is not None and np.all(np.isfinite(down)):
                return (up - down) / (2 * h)
            return (up - self.model_values(x)) / h
        if down is not None and np.all(np.isfinite(down)):
            log.warning("finite differences: the solve at +h failed, column taken backward at mu = %s",
                        np.maximum(self.params.full(x), 0.0).tolist())
            return (self.model_values(x) - down) / h
        raise SolverError(f"finite differences: the forward solves on both sides of mu = "
                          f"{np.maximum(self.params.full(x), 0.0).tolist()} failed (step {h:g}); see the log")

    def solve_all(self, points: list[np.ndarray]) -> None:
        """Forward solves at free coefficients ``points`` not known yet, on the executor at once; each one is
        recorded and memoised as it arrives (in any order: a point's result does not depend on it)."""
        missing, seen = [], set()
        for p in points:
            key = p.tobytes()
            if key not in seen and (key, False) not in self._memo and self._stored(p, "forward") is None:
                missing.append(p)
                seen.add(key)
        if len(missing) < 2:
            return
        tasks = [self.executor.submit(np.maximum(self.params.full(p), 0.0), False) for p in missing]
        done = self.executor.completed(tasks)
        for k, (prediction, wall) in bar(done, len(missing), f"{len(missing)} solves on {self.workers} workers"):
            self._keep(missing[k], False, prediction, wall)

    def count(self, other: "Evaluator") -> None:
        """Add the solves of ``other`` (e.g. a refit sharing this evaluator's executor) to this one's counts."""
        with self._lock:
            for counter in ("n_forward", "n_sensitivity", "n_replayed", "n_failed"):
                setattr(self, counter, getattr(self, counter) + getattr(other, counter))

    def close(self) -> None:
        """Stop the executor's workers, if any."""
        self.executor.close()
