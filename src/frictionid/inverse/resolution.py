"""Resolution before fitting: which zones the planned observations can resolve, and which added ones would.

The weighted Jacobian J = W df/dmu (rows scaled by 1 / sigma) at the start coefficients gives the Fisher
information F = J^T J of a linearised fit. Its inverse is the covariance the fit would reach with noise of the
stated size, so sqrt(diag F^-1) is the standard error each zone can be expected to get *before* anything is
fitted. A zone whose predicted standard error exceeds a tolerance is reported as not resolved by the data,
and candidate observations (other points, quantities, stages) are ranked by how much they would lower the
unresolved zones' standard errors (greedy A-optimal design).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: relative eigenvalue floor of the information matrix: directions below it count as unseen
RCOND = 1e-12


def predicted_stderr(information: np.ndarray) -> np.ndarray:
    """(n,) sqrt(diag F^-1) of an information matrix (n, n); inf where a zone lies in its null space.

    Directions with eigenvalues at most RCOND times the largest count as unseen. A zone is blind (inf) when its
    share of them would dominate its variance even at that floor, sum_unseen v^2 / (RCOND top) > sum_seen v^2 / w:
    a zone whose share of an unseen direction is a trace (a well-seen bearing next to thread zones that only
    their sum is seen of) keeps its standard error from the seen directions.

    >>> predicted_stderr(np.diag([4.0, 0.0]))
    array([0.5, inf])
    >>> predicted_stderr(np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 4.0]]))
    array([inf, inf, 0.5])
    """
    w, v = np.linalg.eigh(np.asarray(information, dtype=float))
    top = max(w.max(initial=0.0), 0.0)
    if top <= 0:
        return np.full(len(w), np.inf)
    seen = w > RCOND * top
    variance = (v[:, seen] ** 2) @ (1.0 / w[seen])
    unseen = (v[:, ~seen] ** 2).sum(axis=1) / (RCOND * top)
    blind = unseen > variance
    return np.where(blind, np.inf, np.sqrt(variance))


@dataclass(frozen=True)
class Resolution:
    """What a weighted Jacobian says about each free zone before fitting.

    Attributes
    ----------
    names : free zone names
    singular_values : (n,) of the weighted Jacobian, descending; directions : (n, n) right singular vectors
    stderr : (n,) predicted standard errors at the stated noise (inf: the data do not see the zone)
    correlation : (n, n) correlation of the predicted covariance (nan where a zone is not seen)
    tolerance : the largest standard error counted as resolved
    """

    names: tuple[str, ...]
    singular_values: np.ndarray
    directions: np.ndarray
    stderr: np.ndarray
    correlation: np.ndarray
    tolerance: float

    @property
    def resolved(self) -> np.ndarray:
        """(n,) bool: predicted standard error within the tolerance."""
        return self.stderr <= self.tolerance

    @property
    def unresolved_names(self) -> tuple[str, ...]:
        return tuple(n for n, ok in zip(self.names, self.resolved) if not ok)

    def as_dict(self) -> dict:
        """JSON-ready summary (None for infinite or undefined numbers)."""
        def clean(a):
            return [None if not np.isfinite(v) else float(v) for v in np.ravel(a)]
        n = len(self.names)
        return {"tolerance": self.tolerance, "singular_values": clean(self.singular_values),
                "stderr": dict(zip(self.names, clean(self.stderr))),
                "resolved": dict(zip(self.names, map(bool, self.resolved))),
                "correlation": [clean(self.correlation[i]) for i in range(n)],
                "directions": {name: clean(self.directions[i]) for i, name in enumerate(self.names)}}


def resolution(jacobian: np.ndarray, names, tolerance: float) -> Resolution:
    """Resolution of the free zones from the weighted Jacobian (n_obs, n_free) of the planned observations."""
    jacobian = np.asarray(jacobian, dtype=float)
    information = jacobian.T @ jacobian
    stderr = predicted_stderr(information)
    _, s, vt = np.linalg.svd(jacobian, full_matrices=False)
    finite = np.isfinite(stderr)
    correlation = np.full(information.shape, np.nan)
    if finite.any():
        covariance = np.linalg.pinv(information[np.ix_(finite, finite)], rcond=RCOND)
        se = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            correlation[np.ix_(finite, finite)] = covariance / np.outer(se, se)
    return Resolution(tuple(names), s, vt.T, stderr, correlation, float(tolerance))


@dataclass(frozen=True)
class Addition:
    """One candidate observation group chosen by :func:`suggest`, and the standard errors once it is added."""

    label: str
    stderr: np.ndarray


def suggest(jacobian: np.ndarray, candidates, tolerance: float, max_additions: int = 5) -> list[Addition]:
    """Greedily pick candidate observation groups that most lower the unresolved zones' standard errors.

    Parameters
    ----------
    jacobian : (n_obs, n_free) weighted Jacobian of the planned observations
    candidates : iterable of (label, (m, n_free) weighted Jacobian rows of that group, e.g. one point at one stage)
    tolerance : standard error counted as resolved
    max_additions : at most this many groups are proposed

    Returns the chosen groups in order, each with the predicted standard errors after adding it and all
    before it; empty when every zone is resolved already or no candidate helps.
    """
    information = np.asarray(jacobian, dtype=float).T @ np.asarray(jacobian, dtype=float)
    target = predicted_stderr(information) > tolerance
    pool = [(label, np.atleast_2d(np.asarray(rows, dtype=float))) for label, rows in candidates]
    chosen: list[Addition] = []
    while target.any() and pool and len(chosen) < max_additions:
        current = _score(predicted_stderr(information), target, tolerance)
        scores = [_score(predicted_stderr(information + rows.T @ rows), target, tolerance) for _, rows in pool]
        best = int(np.argmin(scores))
        if not scores[best] < current - 1e-9:
            break
        label, rows = pool.pop(best)
        information = information + rows.T @ rows
        stderr = predicted_stderr(information)
        chosen.append(Addition(label, stderr))
        target = target & (stderr > tolerance)
    return chosen


def _score(stderr: np.ndarray, target: np.ndarray, tolerance: float) -> float:
    """Sum over the target zones of log(max(stderr, tolerance)); unseen zones count as a large constant."""
    capped = np.maximum(np.where(np.isfinite(stderr), stderr, 1e6), tolerance)
    return float(np.sum(np.log(capped[target])))
