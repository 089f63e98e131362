"""What a backend is: the :class:`Backend` protocol every forward solver meets, and the :class:`Prediction` it
returns (observation rows at each stage end, with their derivatives when it has sensitivities)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np


@dataclass(frozen=True)
class Prediction:
    """Observation rows at the end of each stage, and their derivatives with respect to every zone.

    values : (n_stages, n_rows); derivatives : (n_stages, n_rows, n_zones) or None. Rows: the point rows
    (point-major, ``n_points * n_quantities``), then one row per requested reaction sum [N].
    """

    values: np.ndarray
    derivatives: np.ndarray | None


@runtime_checkable
class Backend(Protocol):
    """A forward solver of one model at fixed observation points.

    ``name`` is its [solver] backend name; ``has_sensitivities`` whether :meth:`predict` can give derivatives
    (analytic Jacobians; without them identify.jacobian must be a finite difference). A backend may also offer
    ``contact_states(mu)`` (per stage end, each zone's open / stick / slip fractions and normal force) and
    ``fields(mu)`` (the fields written to VTU) and ``stick_thresholds(mu, movable)`` (per zone that sticks along
    the whole load path, the lowest coefficient with the same outputs) and ``check_sliding(mu)`` (raises
    SolverError when the solution at mu lies beyond the backend's small-sliding range); callers look for them with
    ``getattr``.
    """

    name: str
    has_sensitivities: bool
    model: object

    def predict(self, mu: np.ndarray, sensitivities=False) -> Prediction:
        """The observation rows at the zone coefficients ``mu`` (n_zones,), with derivatives if asked:
        ``sensitivities`` True (to every zone), or the indices of the zones they are needed for (a fit's free
        zones; a backend may leave the others' columns NaN, or give them too)."""
        ...


class BackendFactory(Protocol):
    """Makes a backend with sensitivities for a model and a set of observation points (e.g. the pre-fit's
    candidate points): ``factory(model, points (n, dim) [mm], quantities, regions)``."""

    def __call__(self, model, points: np.ndarray, quantities: tuple[str, ...], regions) -> Backend:
        ...
