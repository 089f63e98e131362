"""Central differences, the reference every sensitivity is checked against."""

from __future__ import annotations

import numpy as np


def central_difference(f, x: np.ndarray, h: float, columns=None) -> np.ndarray:
    """(f(x + h e_k) - f(x - h e_k)) / 2h for every k (or the k of ``columns``), stacked on a last axis: shape
    f(x).shape + (number of columns,).

    >>> central_difference(lambda x: np.array([x[0] ** 2, x[0] * x[1]]), np.array([1.0, 2.0]), 1e-3).round(9)
    array([[2., 0.],
           [2., 1.]])
    """
    x = np.asarray(x, dtype=float)
    differences = []
    for k in range(len(x)) if columns is None else columns:
        step = np.zeros_like(x)
        step[k] = h
        differences.append((np.asarray(f(x + step)) - np.asarray(f(x - step))) / (2 * h))
    return np.stack(differences, axis=-1)


def check_sensitivities(problem, mu, h: float = 1e-6):
    """The solution of ``problem`` at ``mu`` with sensitivities, after asserting its reaction derivatives equal
    central differences (rtol 1e-6, atol 1e-6 of the largest)."""
    solution = problem.solve(mu, sensitivities=True)
    central = central_difference(lambda m: problem.solve(m).reactions, mu, h)
    for zone in range(len(mu)):
        np.testing.assert_allclose(solution.d_reactions[:, :, zone], central[..., zone], rtol=1e-6,
                                   atol=1e-6 * np.abs(central[..., zone]).max())
    return solution
