"""Multi-start: the same identification from several start points (identify.starts, identify.seed), the best
one reported and every one listed.

The starts share one evaluator, so one store and one executor: with a parallel executor the starts run side by
side in threads of the client, each waiting for its own solves, and every solve is stored as it arrives.

>>> import numpy as np
>>> start_points(3, np.array([0.1, 0.1]), np.zeros(2), np.ones(2), seed=0).round(4).tolist()
[[0.1, 0.1], [0.637, 0.2698], [0.041, 0.0165]]
"""

from __future__ import annotations

import concurrent.futures
import logging
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError, SolverError
from ..run.solve import WorkerLost

log = logging.getLogger(__name__)
#: starts optimised side by side at most (threads of the client waiting for their solves)
MAX_CONCURRENT = 16


def start_points(starts, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray, seed: int = 0,
                 names: tuple[str, ...] = (), where: str = "[identify]") -> np.ndarray:
    """(n_starts, n_free) start points: for a number N, the configured start ``x0`` then N - 1 points drawn
    uniformly within the bounds (numpy default_rng(seed), rounded to 1e-4); for a list, its entries (each a
    list of n_free values or a table zone -> value, unnamed zones at ``x0``); a start outside the bounds is
    an InputError."""
    n_free = len(x0)
    if isinstance(starts, int) and not isinstance(starts, bool):
        if starts < 1:
            raise InputError(f"{where} identify.starts must be at least 1 or a list of start points, got {starts}")
        if starts > 1 and not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
            raise InputError(f"{where} identify.starts = {starts} draws start points within the bounds; give "
                             "finite friction.bounds or a list of start points")
        drawn = np.random.default_rng(seed).uniform(lower, upper, (starts - 1, n_free)).round(4)
        return np.vstack([x0[None, :], np.clip(drawn, lower, upper)])
    points = [_start(entry, x0, names, where) for entry in starts]
    if not points:
        raise InputError(f"{where} identify.starts is an empty list; give at least one start point")
    points = np.array(points)
    outside = np.any((points < lower) | (points > upper), axis=1)
    if outside.any():
        k = int(np.argmax(outside))
        raise InputError(f"{where} identify.starts: start {k + 1} {points[k].tolist()} is outside the bounds")
    return points


def _start(entry, x0: np.ndarray, names: tuple[str, ...], where: str) -> np.ndarray:
    if isinstance(entry, dict):
        unknown = sorted(set(entry) - set(names))
        if unknown or not all(_number(v) for v in entry.values()):
            raise InputError(f"{where} identify.starts: {entry!r} must map free zones {list(names)} to numbers")
        return np.array([float(entry.get(name, v)) for name, v in zip(names, x0)])
    if isinstance(entry, list) and len(entry) == len(x0) and all(_number(v) for v in entry):
        return np.array(entry, dtype=float)
    raise InputError(f"{where} identify.starts: {entry!r} must be a list of {len(x0)} numbers (one per free zone "
                     f"{list(names)}) or a table zone = value")


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class Start:
    """One start of a multi-start run: its start point x0 (n_free,), the optimiser's outcome, or the message of
    the SolverError that ended it (``outcome`` None)."""

    index: int
    x0: np.ndarray
    outcome: object | None
    error: str = ""


def run_starts(points: np.ndarray, optimise_from, parallel: bool) -> list[Start]:
    """``optimise_from(k, x0) -> OptimiseResult`` for every start point; side by side in threads when the
    executor behind it is ``parallel``, else one after the other. Results are independent of the order. A start
    whose solver fails is listed as failed; a solve lost with its workers (:class:`WorkerLost`) stops the run."""
    def run(k: int) -> Start:
        try:
            return Start(k, points[k], optimise_from(k, points[k]))
        except WorkerLost:
            raise
        except SolverError as exc:
            log.warning("start %d from %s failed: %s", k + 1, points[k].tolist(), exc)
            return Start(k, points[k], None, str(exc))

    if not parallel or len(points) == 1:
        return [run(k) for k in range(len(points))]
    pool = concurrent.futures.ThreadPoolExecutor(min(len(points), MAX_CONCURRENT), "frictionid-start")
    try:
        return list(pool.map(run, range(len(points))))
    finally:
        # not waiting: on Ctrl-C or a lost solve the caller stops the executor, which ends the other starts
        pool.shutdown(wait=False, cancel_futures=True)


def best(starts: list[Start]) -> Start:
    """The start with the lowest final objective (the first of equals); SolverError when every start failed."""
    finished = [s for s in starts if s.outcome is not None]
    if not finished:
        raise SolverError("every start failed: " + "; ".join(f"start {s.index + 1}: {s.error}" for s in starts))
    return min(finished, key=lambda s: (s.outcome.objective, s.index))


def summary(starts: list[Start], chosen: Start, full, names: tuple[str, ...]) -> list[dict]:
    """result.json's "starts": per start its initial and final coefficients (all zones, via ``full``),
    objective, status, iterations, and which one is reported."""
    rows = []
    for s in starts:
        row = {"start": s.index + 1, "initial": dict(zip(names, map(float, full(s.x0)))),
               "best": s is chosen}
        if s.outcome is None:
            row.update(status="failed", message=s.error)
        else:
            row.update(value=dict(zip(names, map(float, full(s.outcome.x)))), objective=float(s.outcome.objective),
                       status=s.outcome.status, n_iterations=int(s.outcome.n_iterations))
        rows.append(row)
    return rows


def optimise_starts(problem, optimise, evaluator, store, starts, seed, lines, echo) -> tuple[object, list[dict]]:
    """The fit of ``problem`` (a :class:`~frictionid.inverse.least_squares.LeastSquares` on ``evaluator``) by
    ``optimise(problem)`` from its start, or with identify.starts (``starts``, ``seed``: :func:`start_points`)
    the fits from every start (side by side on a parallel executor, each shown through ``lines(echo)``, see
    :func:`frictionid.progress.iteration_lines`) and the best of them, whose iterations are then stored as the
    run's; the optimiser's result and the list of starts for result.json ([] for one start)."""
    params = evaluator.params
    points = start_points(starts, params.x0, params.lower, params.upper, int(seed), params.free_names)
    if len(points) == 1 and np.array_equal(points[0], params.x0):
        return optimise(problem), []
    echo(f"{len(points)} starts ({evaluator.executor.describe()})")

    def optimise_from(k, x0):
        shown = lines(lambda text: echo(f"start {k + 1}: {text}"))
        quiet = replace(problem, x0=x0, progress=lambda i, x, objective: shown(i, params.full(x), objective,
                                                                              evaluator))
        return optimise(quiet)

    evaluator.executor.start()
    runs = run_starts(points, optimise_from, evaluator.executor.parallel)
    chosen = best(runs)
    for i, (x, objective) in enumerate(zip(chosen.outcome.history_x, chosen.outcome.history_objective)):
        store.record_iteration(i, x, objective)
    echo(f"best: start {chosen.index + 1} of {len(points)}, J={chosen.outcome.objective:.6e}")
    return chosen.outcome, summary(runs, chosen, params.full, params.names)
