"""Profile runs (``identify.profile``): a zone's coefficient held at each value of a grid, the others refitted,
and chi-square against the held value.

The profile-likelihood interval of a zone is the set of values whose refitted chi-square exceeds the minimum
by at most chi2_1(0.95) = 3.84 (times s^2 = chi-square / dof when the noise does not explain the misfit, as
for the standard errors). Unlike the linearised interval it follows a curved or one-sided objective: a zone
that ends on a bound gets an interval that stops there, and a zone the data barely see gets one as wide as the
data allow. The grid spans the fitted value +- 4 standard errors within the bounds (the whole bound range when
the standard error is not finite). The refits run on the identification's executor and store, side by side
when it has workers (:func:`frictionid.run.multistart.run_starts`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InputError
from .multistart import run_starts

#: chi-square quantile of one degree of freedom at 95 %
CHI2_95 = 3.841458820694124
#: the grid spans the fitted value +- this many standard errors (within the bounds)
SPAN = 4.0


def profiled_zones(profile, free_names, where: str = "[identify]") -> list[str]:
    """The zones ``identify.profile`` names: a list of free zones, or true for every free zone.

    >>> profiled_zones(True, ("A", "B")), profiled_zones(["B"], ("A", "B")), profiled_zones(False, ("A",))
    (['A', 'B'], ['B'], [])
    """
    if isinstance(profile, bool):
        return list(free_names) if profile else []
    if not isinstance(profile, list) or not all(isinstance(z, str) for z in profile):
        raise InputError(f"{where} identify.profile must be true or a list of free zones, got {profile!r}")
    unknown = [z for z in profile if z not in free_names]
    if unknown:
        raise InputError(f"{where} identify.profile: {unknown} are not free zones; the free zones are "
                         f"{list(free_names)}")
    return list(dict.fromkeys(profile))


def grid(value: float, stderr: float | None, lower: float, upper: float, n: int) -> np.ndarray:
    """(n,) values for a profile: the fitted value +- 4 standard errors within [lower, upper], the fitted value
    included.

    >>> grid(0.3, 0.05, 0.0, 1.0, 5).round(4).tolist()
    [0.1, 0.2, 0.3, 0.4, 0.5]
    >>> grid(0.02, 0.05, 0.0, 1.0, 4).round(4).tolist()
    [0.0, 0.02, 0.0733, 0.1467, 0.22]
    """
    if stderr is None or not np.isfinite(stderr) or stderr <= 0:
        low, high = lower, upper
    else:
        low, high = max(lower, value - SPAN * stderr), min(upper, value + SPAN * stderr)
    return np.unique(np.append(np.linspace(low, high, n), value))


def interval(values: np.ndarray, chi2: np.ndarray, threshold: float, lower: float, upper: float) -> dict:
    """The values whose chi2 - min(chi2) <= threshold, by linear interpolation on the grid; a side reaching a
    bound stops there; a side that does not cross within the grid is ``open`` (the interval goes further).
    The exact interval of the example is 0.5 +- 0.196.

    >>> v = np.linspace(0.0, 1.0, 11)
    >>> r = interval(v, ((v - 0.5) / 0.1) ** 2, 3.84, 0.0, 1.0)
    >>> [round(x, 3) for x in r["interval"]], r["open"]
    ([0.305, 0.695], [False, False])
    """
    ok = np.isfinite(chi2)
    values, delta = values[ok], chi2[ok] - np.min(chi2[ok])
    best = int(np.argmin(delta))
    ends, open_ = [], []
    for step in (-1, 1):
        k = best
        while 0 <= k + step < len(values) and delta[k + step] <= threshold:
            k += step
        if 0 <= k + step < len(values):                     # crosses between k and k + step
            t = (threshold - delta[k]) / (delta[k + step] - delta[k])
            ends.append(float(values[k] + t * (values[k + step] - values[k])))
            open_.append(False)
        else:
            ends.append(float(values[k]))
            open_.append(not np.isclose(values[k], lower if step < 0 else upper, rtol=0, atol=1e-12))
    return {"interval": ends, "open": open_}


def profiles(zones, names, params, fitted_x, stderr, chi2_of, refit, parallel: bool, n_points: int,
             s2: float) -> dict:
    """The profile of each zone in ``zones`` (result.json ``profiles``).

    ``fitted_x`` / ``stderr``: the fit's free values and standard errors (in ``names`` order); ``refit(zone, value,
    x0) -> (x_free_others, objective)`` the others refitted with ``zone`` held at ``value``; ``chi2_of(x_free)``
    chi-square at a point of the full free set; ``s2`` the factor on the 3.84 threshold.
    """
    out = {}
    threshold = CHI2_95 * s2
    for zone in zones:
        k = names.index(zone)
        values = grid(float(fitted_x[k]), stderr[k], float(params.lower[k]), float(params.upper[k]), n_points)
        x0 = np.delete(fitted_x, k)

        def optimise_from(j, point, zone=zone, k=k, x0=x0):
            others = refit(zone, float(point[0]), x0)
            return np.insert(others, k, point[0])

        runs = run_starts(values[:, None], optimise_from, parallel)
        chi2 = np.array([chi2_of(r.outcome) if r.outcome is not None else np.inf for r in runs])
        found = interval(values, chi2, threshold, float(params.lower[k]), float(params.upper[k]))
        out[zone] = {"values": values.tolist(), "chi2": [None if not np.isfinite(c) else float(c) for c in chi2],
                     "others": {names[i]: [None if r.outcome is None else float(r.outcome[i]) for r in runs]
                                for i in range(len(names)) if i != k},
                     "threshold": threshold, **found}
    return out


def held(params, zone: str, value: float, others_start: np.ndarray):
    """The parameters with ``zone`` held at ``value`` and the other free zones starting at ``others_start``."""
    starts = iter(others_start)
    items = tuple(replace(p, value=value, vary=False, min=min(p.min, value), max=max(p.max, value))
                  if p.name == zone else (replace(p, value=float(next(starts))) if p.vary else p)
                  for p in params.items)
    return type(params)(items)


class HeldStore:
    """The run's store seen by a refit with a zone held: its evaluations are keyed by all zones' coefficients
    (the free vector of a refit does not say which value is held) under kinds "held <kind>", apart from the
    identification's own, so that a resumed run replays the profiles too."""

    def __init__(self, store, params):
        self.store, self.params = store, params

    def record(self, x, kind: str, outputs: dict, status: str = "ok", wall_time: float = 0.0) -> None:
        self.store.record(self.params.full(np.asarray(x, dtype=float)), f"held {kind}", outputs, status, wall_time)

    def lookup(self, x, kind: str, status: str = "ok") -> dict | None:
        return self.store.lookup(self.params.full(np.asarray(x, dtype=float)), f"held {kind}", status)

