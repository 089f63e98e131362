"""The coefficient shift: what a cross-check's differences between the backends mean for identified coefficients.

The coefficients a fit with CalculiX would reach on data made by the embedded backend (or on measured data both
fit equally well), minus the embedded fit's, to first order in the differences (Gauss-Newton step from the
embedded solution, weighted by the stated noise):

    delta_mu = -(A^T A)^-1 A^T r,    A = W df_embedded/dmu,    r = W (f_calculix - f_embedded)

with the embedded backend's analytic sensitivities, so one ccx run replaces a finite-difference identification
with ccx (checked against such identifications in docs/calculix.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..backends.comparison import CrossCheck
from ..errors import InputError
from .observations import FORCE, noise_of
from .resolution import predicted_stderr


@dataclass(frozen=True)
class CoefficientShift:
    """What a cross-check's differences mean for an identification with a given observation set and noise.

    Attributes
    ----------
    stages : 1-based stages whose observations count; quantities : the counted quantities (and "force");
        n_rows : how many rows count
    noise : standard deviation of each counted quantity used as weight (nan: per row, from the data file)
    shift : (n_zones,) calculix fit - embedded fit, linearised; nan for a zone the rows do not resolve
    stderr : (n_zones,) the embedded fit's standard errors at that noise (inf: not resolved)
    rms : RMS of the weighted differences (in noise units)
    """

    stages: tuple[int, ...]
    quantities: tuple[str, ...]
    n_rows: int
    noise: dict
    shift: np.ndarray
    stderr: np.ndarray
    rms: float


def coefficient_shift(check: CrossCheck, noise: dict, stages=None,
                      quantities: tuple[str, ...] | None = None, force: str | None = None) -> CoefficientShift:
    """The linearised coefficient shift of :class:`CoefficientShift` from the rows of ``quantities`` (default:
    all of the cross-check's) at every point and ``stages`` (1-based; default all), plus the reaction labelled
    ``force`` (the machine force) when given.

    Raises
    ------
    InputError
        When a counted quantity has no stated noise in ``noise`` (data.noise) or a stage does not exist.
    """
    n_stages = len(check.embedded)
    stages = tuple(range(1, n_stages + 1)) if stages is None else tuple(stages)
    bad = [s for s in stages if not isinstance(s, int) or not 1 <= s <= n_stages]
    if bad:
        raise InputError(f"data.stages: {bad} not among the model's stages 1..{n_stages}")
    quantities = check.quantities if quantities is None else tuple(quantities)
    sigma = {q: noise_of(q, noise) for q in quantities + ((FORCE,) if force else ())}
    missing = [q for q, value in sigma.items() if value is None]
    if missing:
        raise InputError(f"data.noise: no standard deviation for {missing}; the coefficient shift weighs every "
                         "observation by its noise, e.g. noise = { u = 0.0005, e = 1e-5, force = 1.0 }")
    n_q, n_point_rows = len(check.quantities), check.embedded.shape[1]
    rows = [(p * n_q + check.quantities.index(q), sigma[q]) for p in range(len(check.points)) for q in quantities]
    if force:
        rows.append((n_point_rows + check.reaction_labels.index(force), sigma[FORCE]))
    column, weight = (np.array(v) for v in zip(*rows))
    stage = np.repeat(np.array(stages) - 1, len(rows))
    return _shift(check, stage, np.tile(column, len(stages)), np.tile(weight, len(stages)),
                  quantities + ((FORCE,) if force else ()), sigma)


def observed_shift(check: CrossCheck, observations) -> CoefficientShift:
    """The coefficient shift from exactly the rows and standard deviations an identification fits
    (:class:`~frictionid.inverse.observations.Observations` on the cross-check's points and quantities)."""
    n_point_rows = len(observations.points) * len(observations.quantities)
    if observations.quantities != check.quantities or n_point_rows != check.embedded.shape[1]:
        raise ValueError("the observations are not on the cross-check's points and quantities")
    reaction = [check.reaction_labels.index(label) for label in observations.reactions]
    column = np.array([row if row < n_point_rows else n_point_rows + reaction[row - n_point_rows]
                       for row in observations.row])
    kinds = np.where(observations.point < 0, FORCE, observations.quantity).astype(str)
    noise = {}
    for q in dict.fromkeys(kinds):
        values = np.unique(observations.sigma[kinds == q])
        noise[str(q)] = float(values[0]) if len(values) == 1 else float("nan")      # nan: from the file, per row
    return _shift(check, observations.stage, column, observations.sigma, tuple(noise), noise)


def _shift(check: CrossCheck, stage: np.ndarray, column: np.ndarray, sigma: np.ndarray,
           quantities: tuple[str, ...], noise: dict) -> CoefficientShift:
    """Shift from rows (0-based stage, column of [point rows | reactions], sigma)."""
    embedded = np.concatenate([check.embedded, check.reactions_embedded], axis=1)
    calculix = np.concatenate([check.calculix, check.reactions_calculix], axis=1)
    derivatives = np.concatenate([check.derivatives_embedded, check.reaction_derivatives_embedded], axis=1)
    a = derivatives[stage, column] / sigma[:, None]
    r = (calculix[stage, column] - embedded[stage, column]) / sigma
    stderr = predicted_stderr(a.T @ a)
    seen = np.isfinite(stderr)
    shift = np.full(len(stderr), np.nan)
    if seen.any():
        shift[seen] = -np.linalg.lstsq(a[:, seen], r, rcond=None)[0]
    return CoefficientShift(tuple(int(s) + 1 for s in np.unique(stage)), quantities, len(r), noise, shift,
                            stderr, float(np.sqrt(np.mean(r ** 2))))
