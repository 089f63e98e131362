"""Progress bars of long loops (condensation blocks, finite-difference columns): shown on stderr inside
:func:`shown` (the command line), silent elsewhere (the Python interface is quiet by default); the fit's
one line per iteration (:func:`iteration_lines`)."""

from __future__ import annotations

import contextvars
import sys
from contextlib import contextmanager

import numpy as np
from tqdm import tqdm

_SHOWN = contextvars.ContextVar("frictionid_progress_shown", default=False)


@contextmanager
def shown(enabled: bool = True):
    """Within this block, :func:`bar` draws (when ``enabled``); the command line runs its commands inside it."""
    token = _SHOWN.set(enabled)
    try:
        yield
    finally:
        _SHOWN.reset(token)


def bar(iterable, total: int, description: str, minimum: int = 2):
    """``iterable`` wrapped in a bar on stderr, drawn once the loop has run 2 s and erased when done; a plain
    iterable outside :func:`shown`, for fewer than ``minimum`` items, or when stderr is not a terminal (a log
    file gets no bar lines).

    >>> list(bar(range(3), 3, "columns"))
    [0, 1, 2]
    """
    if not _SHOWN.get() or total < minimum or not sys.stderr.isatty():
        return iterable
    return tqdm(iterable, total=total, desc=description, leave=False, file=sys.stderr, dynamic_ncols=True,
                mininterval=0.5, delay=2.0)


def iteration_lines(echo, on_iteration=None):
    """The optimiser's callback: one line per iteration with the objective, the step and the coefficients to
    ``echo``, then ``on_iteration``."""
    previous = {}

    def progress(iteration, mu, objective, evaluator):
        if on_iteration is not None:
            on_iteration(iteration, mu, objective, evaluator)
        step = "" if "mu" not in previous else f"  step={np.max(np.abs(mu - previous['mu'])):.2e}"
        previous["mu"] = np.array(mu)
        values = "  ".join(f"{name}={value:.4f}" for name, value in zip(evaluator.params.names, mu))
        echo(f"iter {iteration:3d}  J={objective:.6e}{step}  {values}  (solves {evaluator.n_forward} + "
             f"{evaluator.n_sensitivity} with sensitivities, {evaluator.n_replayed} replayed)")
    return progress
