"""The start of a Gauss-Newton fit moved to the stick thresholds of the zones that stick along the whole load
path at the configured start (option ``stick_start`` of "trf" and "lm", :mod:`.optimisers`)."""

from __future__ import annotations

import logging

import numpy as np

from .iterates import Iterates

log = logging.getLogger(__name__)

#: a zone moved to its stick threshold starts this fraction above it (the solves' round-off must not make it slip)
STICK_MARGIN = 1e-6


def stick_start(iterates: Iterates, x0: np.ndarray) -> tuple[np.ndarray, str]:
    """The start with every free zone that sticks along the whole load path at ``x0`` lowered to its stick
    threshold (``LeastSquares.stick_floor``, within the bounds), and what was done, for the run's message.

    Such a zone's Jacobian column is zero at the start, so a Gauss-Newton step cannot move it, and the
    optimiser creeps it down only as the others make it slip; at its threshold the outputs are the same, and
    the next steps of the others show its effect. Asked only where a column of the start's Jacobian is zero;
    the move is taken only where the objective there is that of x0 (to 1e-9). It costs one forward solve (the
    thresholds) and the moved start's Jacobian."""
    problem = iterates.problem
    columns = np.linalg.norm(iterates.jacobian(x0), axis=0)       # the optimiser's first Jacobian: no extra solve
    flat = columns <= 1e-12 * max(columns.max(initial=0.0), np.finfo(float).tiny)
    floor = problem.stick_floor(x0) if flat.any() else None
    if floor is None:
        return x0, ""
    target = np.maximum(floor * (1 + STICK_MARGIN), problem.lower)
    lowered = flat & np.isfinite(floor) & (target < x0)
    if not lowered.any():
        return x0, ""
    start = np.where(lowered, target, x0)
    before, after = iterates.objective(x0), iterates.objective(start)   # a failed solve there: inf, not taken
    names = ", ".join(f"{problem.names[k]} {x0[k]:.4g} -> {start[k]:.4g}" for k in np.flatnonzero(lowered))
    if not abs(after - before) <= 1e-9 * max(abs(before), np.finfo(float).tiny):
        log.info("stick thresholds not used: the objective moved from %.10g to %.10g (%s)", before, after, names)
        return x0, ""
    log.info("zones sticking along the whole load path started at their stick thresholds: %s", names)
    return start, f"started at the stick thresholds of the zones that stick along the whole load path ({names}); "
