"""The discretisation error the control leaves in the fitted model, and what it does to the coefficients.

The discretisation control (:mod:`.discretisation_control`) splits the model's error at the start values into one
term per refinement direction, e_d = D_d 2^p / (2^p - 1) from the difference D_d = f_h - f_d to the model refined
by 2 in direction d, and fits the refinement k (one factor per direction) whose predicted error

    delta = sum_d e_d / k_d^p            (model minus converged, per observation, signed)

is within its target (a band refined inside a uniform direction: :func:`combined`; where the chosen model's actual
change does not confirm a kind's prediction, the error as given less that change). That remaining error is
systematic: it is the same in every replicate of the data, and a part of it along the sensitivities is absorbed by
the coefficients without leaving a misfit, so neither the chi-square test nor the statistical standard error sees
it. Linearised, the fit on the refined model is off by

    bias = -(J^T W J)^-1 J^T W delta

(:func:`~.adequacy.bias_shift` of the weighted Jacobian and delta / sigma, with the opposite sign: the fit moves the
coefficients to cancel the model's excess).

The estimate's own uncertainty is in its order p: the control's orders (displacements and forces 1, strains 1.77;
:func:`~.model_error.convergence_orders`) are a bound or a mean, and the 3-D block's face displacements converge at
observed orders 0.3-0.8 on coarse meshes. So delta is also evaluated at half the orders (slower convergence: with
k = 2 the remaining error 2.4 times the order-1 value), and each coefficient's systematic error is the larger
magnitude of the two biases (:func:`systematic`). The identification adds it to the statistical standard error in
quadrature and claims no zone whose systematic error exceeds its statistical standard error
(:func:`frictionid.inverse.uncertainty.estimate`): its interval would then rest on an estimate known only to a
factor of about 2.

Both deltas are at the start values, as the control's decision is: they depend on the model, the observation
layout and the stated noise, not on the measured values. Where the control runs again at the fitted values
(:mod:`.discretisation_refit`) the identification replaces them by its estimate there, for the model it fitted last.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .adequacy import bias_shift

#: the alternative orders are the control's times this (module docstring)
SLOW_ORDER = 0.5


@dataclass(frozen=True)
class RemainingError:
    """Per observation (n_obs,), signed, in the observations' units: the control's predicted error of the model it
    fits (``nominal``, at its orders) and the same at ``SLOW_ORDER`` times them (``slow``)."""

    nominal: np.ndarray
    slow: np.ndarray
    #: the control's convergence order per quantity kind
    orders: dict = field(default_factory=dict)

    def summary(self, sigma: np.ndarray, kinds: np.ndarray) -> dict:
        """RMS in noise levels per kind of both predictions, for the record."""
        out = {}
        for name, values in (("nominal", self.nominal), ("slow", self.slow)):
            ratio = np.abs(values) / sigma
            out[name] = {k: round(float(np.sqrt(np.mean(ratio[kinds == k] ** 2))), 3)
                         for k in dict.fromkeys(kinds.tolist())}
        return out


def combined(terms, factors, orders, within=None):
    """The predicted error sum_d e_d / k_d^p of the refinement ``factors`` from the directional terms ``terms``
    (e_d, (n_obs,) each) at orders ``orders`` (n_obs,).

    ``within[d]`` (None: every direction is independent) names the direction whose region direction d's lies in:
    a local refinement (a band around the contact edges) inside a uniform one. Its term e_l is that band's part
    of the uniform direction's e_u (both measured from a refinement by 2 of the model as given), the band's
    element size is divided by both factors, the rest by the uniform one's only:

        (e_u - sum_l e_l) / k_u^p + sum_l e_l / (k_u k_l)^p

    >>> e = [np.array([3.0]), np.array([2.0])]                  # the band holds 2 of the uniform direction's 3
    >>> float(combined(e, [1, 2], np.array([1.0]), [None, 0])[0]), float(combined(e, [2, 1], np.array([1.0]))[0])
    (2.0, 3.5)
    """
    within = within or [None] * len(terms)
    total = 0.0
    for d, (term, k) in enumerate(zip(terms, factors)):
        size = float(k) * (1.0 if within[d] is None else float(factors[within[d]]))
        inner = sum((terms[j] for j in range(len(terms)) if within[j] == d), np.zeros_like(term))
        total = total + (np.asarray(term, dtype=float) - inner) / size ** orders
    return total


def remaining(differences, factors, orders: np.ndarray, kind_orders: dict | None = None,
              within=None) -> RemainingError:
    """The predicted error after refining by ``factors`` (one per direction) from the directional differences
    ``differences`` (coarse minus direction-refined-by-2 values, (n_obs,) each) with per-observation orders
    ``orders`` (n_obs,); ``within`` as :func:`combined`'s.

    >>> r = remaining([np.array([1.0])], [2], np.array([1.0]))     # e = 2 D at order 1, halved by k = 2
    >>> float(r.nominal[0]), round(float(r.slow[0]), 3)            # order 0.5: 2^.5/(2^.5 - 1)/2^.5 D
    (1.0, 2.414)
    """
    def at(p):
        gain = 2.0 ** p
        return combined([np.asarray(d, dtype=float) * gain / (gain - 1.0) for d in differences], factors, p, within)

    orders = np.asarray(orders, dtype=float)
    return RemainingError(at(orders), at(SLOW_ORDER * orders), dict(kind_orders or {}))


def bias(jac: np.ndarray, weight: np.ndarray, delta: np.ndarray, inner=None) -> np.ndarray:
    """(n_free,) the linearised offset of the fitted coefficients (fitted minus those of the converged model)
    that a model error ``delta`` (n_obs,, model minus converged) causes; ``jac`` the weighted Jacobian (n_obs,
    n_free), ``weight`` (n_obs,) the weights 1 / sigma (with any robust weights' square roots); nan for zones on a
    bound or not seen.

    >>> jac = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]])
    >>> bias(jac, np.ones(3), jac @ np.array([0.1, -0.2])).round(12).tolist()
    [-0.1, 0.2]
    """
    return -bias_shift(jac, np.asarray(weight, dtype=float) * np.asarray(delta, dtype=float), inner)


def systematic(jac: np.ndarray, weight: np.ndarray, error: RemainingError, inner=None) -> tuple[np.ndarray,
                                                                                               np.ndarray]:
    """(bias at the control's orders, systematic standard error) per free zone: the bias of :func:`bias` of the
    nominal prediction, and the larger magnitude of the nominal and the slow one's (0 where not known)."""
    nominal = bias(jac, weight, error.nominal, inner)
    slow = bias(jac, weight, error.slow, inner)
    size = np.fmax(np.abs(nominal), np.abs(slow))
    return nominal, np.nan_to_num(size, nan=0.0)
