"""The embedded backend: the condensed frictional-contact solver of frictionid.fem."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..fem.problem import Problem
from ..model import Model


@dataclass(frozen=True)
class Prediction:
    """Observation rows at the end of each stage, and their derivatives with respect to every zone.

    values : (n_stages, n_rows); derivatives : (n_stages, n_rows, n_zones) or None. Rows: the point rows
    (point-major, ``n_points * n_quantities``), then one row per requested reaction sum [N].
    """

    values: np.ndarray
    derivatives: np.ndarray | None


_RECENT: dict = {}
#: condensations kept for reuse: an identification's and its pre-fit candidates' (see :func:`_built`)
N_KEPT = 2


def _built(model: Model, points, quantities: tuple[str, ...], regions, keep: bool = True) -> Problem:
    """Problem.build, reusing a recent build when model and observation points are the same in content.

    Runs of one session (a study's several identifications, an example's methods) share the condensation;
    at most :data:`N_KEPT` builds are kept, so memory holds few factorisations besides the ones in use.
    ``keep=False``: a one-off build (e.g. a refined mesh for an error estimate) that uses a kept build if there
    is one but neither stores itself nor pushes a kept build out.
    """
    key = (model.fingerprint(), None if points is None else np.asarray(points, dtype=float).tobytes(),
           quantities, None if regions is None else tuple(regions))
    if key in _RECENT:
        _RECENT[key] = _RECENT.pop(key)                        # most recently used last
        return _RECENT[key]
    if not keep:
        return Problem.build(model, points=points, quantities=quantities, regions=regions)
    while len(_RECENT) >= N_KEPT:
        _RECENT.pop(next(iter(_RECENT)))
    _RECENT[key] = Problem.build(model, points=points, quantities=quantities, regions=regions)
    return _RECENT[key]


class EmbeddedBackend:
    """Condenses the model once; each :meth:`predict` is one load path with optional sensitivities.

    ``reactions``: labels of reaction sums ("boundary.axis", e.g. "block_top.y", the machine force of the
    block test) appended as rows after the point rows; none by default. ``keep``: whether the condensation is
    kept for reuse by later backends of the same session (see :func:`_built`).
    """

    name = "embedded"
    has_sensitivities = True

    def __init__(self, model: Model, points: np.ndarray, quantities: tuple[str, ...], regions=None,
                 reactions: tuple[str, ...] = (), keep: bool = True):
        self.model = model
        points = None if points is None or len(points) == 0 or not quantities else points
        self.problem = _built(model, points, tuple(quantities), regions, keep)
        unknown = [r for r in reactions if r not in self.problem.reaction_labels]
        if unknown:
            raise InputError(f"model: no reaction {unknown}; the model's reactions are "
                             f"{list(self.problem.reaction_labels)}")
        self.reactions = tuple(reactions)
        self._reaction_rows = [self.problem.reaction_labels.index(r) for r in self.reactions]

    def predict(self, mu: np.ndarray, sensitivities: bool = False) -> Prediction:
        solution = self.problem.solve(mu, sensitivities=sensitivities)
        ends = [solution.stage_end(s) for s in range(self.model.n_stages)]
        values = np.hstack([solution.observations[ends], solution.reactions[ends][:, self._reaction_rows]])
        derivatives = None
        if solution.d_observations is not None:
            derivatives = np.concatenate([solution.d_observations[ends],
                                          solution.d_reactions[ends][:, self._reaction_rows]], axis=1)
        return Prediction(values, derivatives)

    def contact_states(self, mu: np.ndarray) -> list[dict[str, dict[str, float]]]:
        """Per stage end: each zone's area fractions open / stick / slip and its normal force [N] at ``mu``."""
        solution = self.problem.solve(mu)
        out = []
        for stage in range(self.model.n_stages):
            end = solution.stage_end(stage)
            states = solution.zone_state(end)
            normal = solution.zone_normal_force[end]
            out.append({zone: {**states[zone], "normal_force": float(normal[z])}
                        for z, zone in enumerate(solution.zone_names)})
        return out
