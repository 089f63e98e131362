"""The fit's two working objects made in one place from the [identify] options: the :class:`Evaluator`
(residuals and Jacobian backed by a backend and a run store) and the :class:`LeastSquares` problem an optimiser
sees, for the identification and for its refits with a zone held."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..backends.base import Backend
from ..options import IdentifyOptions
from .evaluator import Evaluator
from .least_squares import LeastSquares
from .observations import Observations
from .parameters import Parameters


def make_evaluator(backend: Backend, observations: Observations, parameters: Parameters, store, ident: IdentifyOptions,
                   executor=None, prior=None, sensitive=None) -> Evaluator:
    """The evaluator of ``parameters``' free coefficients with identify.jacobian, step, tikhonov, penalty and
    prior (``prior`` given: instead of identify.prior, e.g. a refit's with the held zone left out); ``sensitive``:
    as :class:`Evaluator`'s."""
    return Evaluator(backend, observations, parameters, store, ident.jacobian, ident.step,
                     ident.tikhonov, ident.prior if prior is None else prior,
                     ident.penalty, executor=executor, sensitive=sensitive)


def make_least_squares(evaluator: Evaluator, ident: IdentifyOptions, on_iteration: Callable = lambda *args: None,
                       x0: np.ndarray | None = None, stick_floor: bool = False) -> LeastSquares:
    """The least-squares problem of ``evaluator``'s free coefficients within their bounds, from ``x0`` (default
    the parameters' start), with identify.power, loss and loss_scale; ``on_iteration(iteration, x, objective)``
    after each iteration; with ``stick_floor`` the evaluator's stick thresholds, from which the Gauss-Newton
    methods start (the fit from the configured starts; refits start at fitted points)."""
    params = evaluator.params
    return LeastSquares(evaluator.residuals, evaluator.jacobian, params.x0 if x0 is None else x0, params.lower,
                        params.upper, params.free_names, ident.power, on_iteration,
                        evaluator.obs.noise_known, ident.loss, ident.loss_scale,
                        evaluator.stick_floor if stick_floor else None)


def recorded(evaluator: Evaluator, store, progress: Callable, offset: int = 0) -> Callable:
    """An ``on_iteration`` that stores each iteration once (numbered from ``offset``: a refit continues the
    numbers of the fit before it) and then calls ``progress(iteration, mu, objective, evaluator)`` with every
    zone's coefficient mu."""
    done = {row["iteration"] for row in store.iterations()}

    def on_iteration(iteration, x, objective):
        iteration += offset
        if iteration not in done:
            store.record_iteration(iteration, x, objective)
            done.add(iteration)
        progress(iteration, evaluator.params.full(x), objective, evaluator)

    return on_iteration
