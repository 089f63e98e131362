"""Experiment design from the linearised model: which points to measure, and which zones the data can separate.

For the weighted sensitivities G_p (rows: the quantities and stages observed at point p, each divided by its
noise; columns: the free zones) the information of a point set S is F(S) = sum_p G_p^T G_p, and
sqrt(diag F^-1) the standard errors a fit to data of that noise would reach (:mod:`.resolution`).

- :func:`select_points` picks n points greedily, each time the one that lowers the criterion most:
  "A" the sum of the predicted variances, "D" -log det F. Before F has full rank both are taken on
  F + delta I with delta a tiny fraction of the candidates' mean information (so the first picks see the
  zones nothing has seen yet).
- :func:`finest_partition` merges zones whose coefficients the data cannot separate: zones sharing one
  coefficient have the summed sensitivity columns, F_merged = M^T F M with M the (zones x groups) indicator
  matrix. Starting from every zone on its own, it merges, one pair at a time, the two groups (neighbours on
  one interface first, at least one of them unresolved) whose merge leaves the fewest unresolved groups, then
  gives up the fewest resolved ones, then has the smallest largest standard error, until every group is
  resolved or nothing is left to merge.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .resolution import predicted_stderr

CRITERIA = ("A", "D")
#: ridge on the information while it is singular, relative to the candidates' mean diagonal information
RIDGE = 1e-9


def _ridge(rows: np.ndarray) -> float:
    scale = float(np.mean(np.einsum("pkz,pkz->z", rows, rows))) / max(len(rows), 1)
    return RIDGE * scale if scale > 0 else RIDGE


def _scores(information: np.ndarray, rows: np.ndarray, criterion: str, delta: float) -> np.ndarray:
    """(n_candidates,) criterion of F + G_p^T G_p + delta I for every candidate p (lower is better)."""
    n = information.shape[0]
    trial = information[None] + np.einsum("pki,pkj->pij", rows, rows) + delta * np.eye(n)[None]
    if criterion == "D":
        sign, logdet = np.linalg.slogdet(trial)
        return np.where(sign > 0, -logdet, np.inf)
    return np.trace(np.linalg.inv(trial), axis1=1, axis2=2)


def select_points(rows: np.ndarray, n: int, criterion: str = "A", base: np.ndarray | None = None) -> list[int]:
    """Indices of ``n`` candidate points chosen greedily (module docstring).

    Parameters
    ----------
    rows : (n_candidates, n_rows, n_free) weighted sensitivities of each candidate point
    n : points to choose (at most the number of candidates)
    criterion : "A" (sum of variances) or "D" (log-determinant)
    base : (n_free, n_free) information of observations kept anyway (planned points), optional

    >>> rows = np.array([[[1.0, 0.0]], [[1.0, 0.01]], [[0.0, 1.0]]])
    >>> select_points(rows, 2)
    [0, 2]
    """
    rows = np.asarray(rows, dtype=float)
    if criterion not in CRITERIA:
        raise InputError(f"design.criterion = {criterion!r} is not one of {list(CRITERIA)}")
    if not 1 <= n <= len(rows):
        raise InputError(f"design.points = {n}: choose between 1 and the {len(rows)} candidate points")
    n_free = rows.shape[2]
    information = np.zeros((n_free, n_free)) if base is None else np.array(base, dtype=float)
    delta = _ridge(rows)
    chosen: list[int] = []
    available = np.ones(len(rows), dtype=bool)
    for _ in range(n):
        score = _scores(information, rows, criterion, delta)
        score[~available] = np.inf
        k = int(np.argmin(score))
        chosen.append(k)
        available[k] = False
        information = information + rows[k].T @ rows[k]
    return chosen


def information_of(rows: np.ndarray, chosen) -> np.ndarray:
    """(n_free, n_free) information of the chosen candidates."""
    picked = np.asarray(rows, dtype=float)[list(chosen)]
    return np.einsum("pki,pkj->ij", picked, picked)


def merged_stderr(information: np.ndarray, groups) -> np.ndarray:
    """Predicted standard error of each group's one coefficient (groups: lists of zone indices).

    >>> merged_stderr(np.array([[1.0, 1.0], [1.0, 1.0]]), [[0, 1]])    # only the sum is seen: it is resolved
    array([0.5])
    """
    indicator = np.zeros((information.shape[0], len(groups)))
    for g, members in enumerate(groups):
        indicator[list(members), g] = 1.0
    return predicted_stderr(indicator.T @ information @ indicator)


@dataclass(frozen=True)
class Partition:
    """Groups of zones (names) that share a coefficient, and the predicted standard error of each group's."""

    groups: tuple[tuple[str, ...], ...]
    stderr: np.ndarray
    tolerance: float

    @property
    def resolved(self) -> np.ndarray:
        return self.stderr <= self.tolerance

    def name(self, group: tuple[str, ...]) -> str:
        return "".join(group) if all(len(z) == 1 for z in group) else "+".join(group)

    def merge_table(self) -> dict[str, list[str]]:
        """The ``[friction] merge`` table that gives this partition (groups of more than one zone)."""
        return {self.name(g): list(g) for g in self.groups if len(g) > 1}

    def as_dict(self) -> dict:
        return {"tolerance": self.tolerance,
                "groups": {self.name(g): {"zones": list(g),
                                          "stderr": float(s) if np.isfinite(s) else None,
                                          "resolved": bool(s <= self.tolerance)}
                           for g, s in zip(self.groups, self.stderr)},
                "merge": self.merge_table()}


def finest_partition(information: np.ndarray, names, tolerance: float, neighbours=None,
                     interface_of=None) -> Partition:
    """The finest grouping of the zones that the information resolves (module docstring).

    ``neighbours``: set of frozenset({i, j}) zone index pairs that touch (merged first); ``interface_of``:
    (n,) interface of each zone (only zones of one interface merge). Both default to "any pair".

    >>> info = np.array([[1e6, 0, 0], [0, 4.0, 3.99], [0, 3.99, 4.0]])   # B and C seen only together
    >>> p = finest_partition(info, ["A", "B", "C"], 0.3)
    >>> p.groups, p.resolved.tolist()
    ((('A',), ('B', 'C')), [True, True])
    """
    n = len(names)
    interface_of = list(interface_of) if interface_of is not None else [0] * n
    groups = [[k] for k in range(n)]

    def touching(a, b) -> bool:
        return neighbours is None or any(frozenset((i, j)) in neighbours for i in a for j in b)

    stderr = merged_stderr(information, groups)
    while len(groups) > 1 and np.any(stderr > tolerance):
        best = None
        pairs = [(a, b) for a, b in itertools.combinations(range(len(groups)), 2)
                 if interface_of[groups[a][0]] == interface_of[groups[b][0]]
                 and (stderr[a] > tolerance or stderr[b] > tolerance)]
        adjacent = [(a, b) for a, b in pairs if touching(groups[a], groups[b])]
        for a, b in adjacent or pairs:
            trial = [g for k, g in enumerate(groups) if k not in (a, b)] + [sorted(groups[a] + groups[b])]
            se = merged_stderr(information, trial)
            consumed = int(stderr[a] <= tolerance) + int(stderr[b] <= tolerance)   # resolved groups given up
            key = (int(np.sum(se > tolerance)), consumed, float(np.max(np.minimum(se, 1e300))))
            if best is None or key < best[0]:
                best = (key, trial, se)
        if best is None:
            break
        order = np.argsort([g[0] for g in best[1]], kind="stable")
        groups = [best[1][k] for k in order]
        stderr = best[2][order]
    return Partition(tuple(tuple(names[k] for k in g) for g in groups), stderr, float(tolerance))
