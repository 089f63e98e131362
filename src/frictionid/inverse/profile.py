"""Profile runs (``identify.profile``): a zone's coefficient held at each value of a grid, the others refitted,
and chi-square against the held value.

The profile-likelihood interval of a zone is the set of values whose refitted chi-square exceeds the minimum
by at most chi2_1(0.95) = 3.84 (times s^2 = chi-square / dof when the noise does not explain the misfit, as
for the standard errors). Unlike the linearised interval it follows a curved or one-sided objective: a zone
that ends on a bound gets an interval that stops there, and a zone the data barely see gets one as wide as the
data allow. The grid spans the fitted value +- 4 standard errors within the bounds (the whole bound range when
the standard error is not finite). The refits run on the identification's executor and store, side by side
when it has workers (:func:`frictionid.inverse.multistart.run_starts`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InputError
from .multistart import run_starts

#: chi-square quantile of one degree of freedom at 95 %
CHI2_95 = 3.841458820694124
#: 95 % quantile of the likelihood ratio of a parameter on a bound: a 50:50 mixture of 0 and chi-square with one
#: degree of freedom (Self & Liang, JASA 82 (1987) 605-610), i.e. chi2_1(0.90): the one-sided 95 % level
CHI2_BOUND_95 = 2.705543454095404
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
        values, chi2, others = _profile(zone, names, params, fitted_x, stderr, chi2_of, refit, parallel, n_points)
        found = interval(values, chi2, threshold, float(params.lower[k]), float(params.upper[k]))
        out[zone] = {"values": values.tolist(), "chi2": [None if not np.isfinite(c) else float(c) for c in chi2],
                     "others": others, "threshold": threshold, **found}
    return out


def _profile(zone, names, params, fitted_x, stderr, chi2_of, refit, parallel: bool, n_points: int):
    """The grid of ``zone``'s held values, the refitted chi-square at each (inf where the refit failed) and
    the others' refitted values ({name: [value or None]})."""
    k = names.index(zone)
    values = grid(float(fitted_x[k]), stderr[k], float(params.lower[k]), float(params.upper[k]), n_points)
    x0 = np.delete(fitted_x, k)

    def optimise_from(j, point):
        return np.insert(refit(zone, float(point[0]), x0), k, point[0])

    runs = run_starts(values[:, None], optimise_from, parallel)
    chi2 = np.array([chi2_of(r.outcome) if r.outcome is not None else np.inf for r in runs])
    others = {names[i]: [None if r.outcome is None else float(r.outcome[i]) for r in runs]
              for i in range(len(names)) if i != k}
    return values, chi2, others


def bound_checks(zones, names, params, fitted_x, stderr, limit: float, chi2_of, refit, parallel: bool,
                 n_points: int, s2: float, systematic=None) -> dict:
    """The profile-likelihood check of each zone in ``zones`` (claimed on a bound): {zone: :func:`bound_verdict`}.

    Arguments as for :func:`profiles`; ``limit`` is the largest standard error of a claimed zone
    (identify.resolution); ``systematic``: (n_free,) the systematic part of each zone's standard error (the
    model error's, in ``names`` order; None: 0), which the profile of the weighted chi-square does not hold.
    """
    out = {}
    for zone in zones:
        k = names.index(zone)
        lower, upper = float(params.lower[k]), float(params.upper[k])
        on = np.array(fitted_x, dtype=float)
        on[k] = lower if abs(on[k] - lower) <= abs(upper - on[k]) else upper       # the grid starts on it
        values, chi2, _ = _profile(zone, names, params, on, stderr, chi2_of, refit, parallel, n_points)
        out[zone] = bound_verdict(values, chi2, float(on[k]), CHI2_BOUND_95 * s2, limit,
                                  0.0 if systematic is None else float(systematic[k] or 0.0))
    return out


def bound_verdict(values: np.ndarray, chi2: np.ndarray, bound: float, threshold: float, limit: float,
                  systematic: float = 0.0) -> dict:
    """Does the profile from a bound exclude the interior? (result.json ``parameters.<zone>.bound_check``)

    A zone fitted on its bound is claimed when (1) no held value refits to a lower chi-square than the bound's
    (by more than 1e-6 of it: else the bound is not the data's best value), (2) the refitted chi-square rises
    by ``threshold`` (the one-sided 95 % level CHI2_BOUND_95 times s^2) within the grid, and (3) where it does,
    the one-sided interval [bound, bound +- half] is no wider than that of a zone with standard error ``limit``
    (1.645 limit). ``half`` is the profile's half-width h and the ``systematic`` standard error (the model
    error's, which a profile of the weighted chi-square does not see) in quadrature, hypot(h, 1.645
    systematic): with h = 1.645 s for a statistical standard error s, (3) is then the rule a zone inside its
    bounds is claimed by, hypot(s, systematic) <= limit. ``passed`` says whether all hold, ``why`` which did not.

    >>> v = np.linspace(0.0, 0.08, 9)
    >>> check = bound_verdict(v, 100 + (v / 0.01) ** 2, 0.0, CHI2_BOUND_95, 0.02)
    >>> round(check["interval"][1], 4), check["passed"]          # exact: sqrt(2.706) 0.01 = 0.0164
    (0.0157, True)
    >>> bound_verdict(v, 100 - v, 0.0, CHI2_BOUND_95, 0.02)["why"][:45]
    'the profile falls into the interior: chi-squa'
    """
    order = np.argsort(values)
    values, chi2 = np.asarray(values, dtype=float)[order], np.asarray(chi2, dtype=float)[order]
    ok = np.isfinite(chi2)
    side = 1 if abs(values[0] - bound) <= abs(values[-1] - bound) else 0        # the interior's side of the list
    at = int(np.argmin(np.abs(values - bound)))
    base = chi2[at]
    width = float(np.max(np.abs(values - bound)))
    found = interval(values[ok], chi2[ok], threshold, -np.inf, np.inf)      # the grid's far end: still open
    end, inward = found["interval"][side], found["open"][side]
    lowest = int(np.argmin(np.where(ok, chi2, np.inf)))
    dips = bool(chi2[lowest] < base - 1e-6 * max(abs(base), 1.0))
    profiled = float(abs(end - bound))
    half = float(np.hypot(profiled, 1.645 * systematic))
    beyond = (f"the profile excludes the interior only beyond {profiled:.3g} from the bound" if half == profiled
              else f"the profile excludes the interior beyond {profiled:.3g} from the bound, {half:.3g} with the "
              f"systematic part {systematic:.3g} of its standard error counted")
    why = (f"the profile falls into the interior: chi-square {chi2[lowest]:.6g} at {values[lowest]:.4g} < "
           f"{base:.6g} on the bound" if dips else
           f"the profile does not rise by {threshold:.3g} within {width:.3g} of the bound: the data do not exclude "
           "the interior" if inward else
           f"{beyond} (> 1.645 x {limit:g})" if half > 1.645 * limit else "")
    return {"level": 0.95, "threshold": float(threshold), "values": values.tolist(),
            "chi2": [None if not np.isfinite(c) else float(c) for c in chi2], "systematic": float(systematic),
            "interval": sorted([float(bound), float(bound + (half if side else -half))]), "passed": not why,
            "why": why}



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

