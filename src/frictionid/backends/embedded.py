"""The embedded backend: the condensed frictional-contact solver of frictionid.fem."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fem.problem import Problem
from ..model import Model


@dataclass(frozen=True)
class Prediction:
    """Observation rows at the end of each stage, and their derivatives with respect to every zone.

    values : (n_stages, n_rows); derivatives : (n_stages, n_rows, n_zones) or None
    """

    values: np.ndarray
    derivatives: np.ndarray | None


class EmbeddedBackend:
    """Condenses the model once; each :meth:`predict` is one load path with optional sensitivities."""

    name = "embedded"
    has_sensitivities = True

    def __init__(self, model: Model, points: np.ndarray, quantities: tuple[str, ...], regions=None):
        self.model = model
        self.problem = Problem.build(model, points=points, quantities=quantities, regions=regions)

    def predict(self, mu: np.ndarray, sensitivities: bool = False) -> Prediction:
        solution = self.problem.solve(mu, sensitivities=sensitivities)
        ends = [solution.stage_end(s) for s in range(self.model.n_stages)]
        derivatives = None if solution.d_observations is None else solution.d_observations[ends]
        return Prediction(solution.observations[ends], derivatives)
