"""Refits with one zone held, on an identification's evaluator, store and executor: the profiles of
``identify.profile`` and the profile-likelihood check of every zone claimed on a bound (result.json
``parameters.<zone>.bound_check``, :func:`frictionid.inverse.profile.bound_verdict`)."""

from __future__ import annotations

import numpy as np

from ..options import IdentifyOptions
from .evaluator import Evaluator
from .fitting import make_evaluator, make_least_squares
from . import profile


class HeldRefits:
    """The refits of an identification: ``optimise(problem)`` runs its optimiser on a least-squares problem;
    ``ident`` is its [identify] options. The refits' iterations are not the run's history; their solves count as
    its work, and are stored (a resumed run replays them)."""

    def __init__(self, evaluator: Evaluator, params, store, ident: IdentifyOptions, optimise):
        self.evaluator, self.params, self.store, self.ident, self.optimise = evaluator, params, store, ident, optimise
        self.names = list(params.free_names)

    def refit(self, zone: str, value: float, x0) -> np.ndarray:
        """The other free zones refitted from x0 with ``zone`` held at ``value``."""
        ident, evaluator, obs = self.ident, self.evaluator, self.evaluator.obs
        held = profile.held(self.params, zone, value, x0)
        sub = make_evaluator(evaluator.backend, obs, held, profile.HeldStore(self.store, held), ident,
                             evaluator.executor, np.delete(evaluator.prior, self.names.index(zone)),
                             sensitive=self.params.free)
        problem = make_least_squares(sub, ident)
        x = self.optimise(problem).x
        evaluator.count(sub)
        return x

    def chi2_of(self, x) -> float:
        r = self.evaluator.residuals(x)[:self.evaluator.obs.n_obs]
        return float(r @ r)

    def _fitted(self, result: dict):
        return (np.array([result["parameters"][z]["value"] for z in self.names]),
                [result["parameters"][z]["stderr"] for z in self.names], float(result["fit"]["error_scale"]) ** 2)

    def profiles(self, zones, result: dict) -> dict:
        """identify.profile: result.json ``profiles`` of ``zones`` (:func:`frictionid.inverse.profile.profiles`)."""
        fitted, stderr, s2 = self._fitted(result)
        return profile.profiles(zones, self.names, self.params, fitted, stderr, self.chi2_of, self.refit,
                                self.evaluator.executor.parallel, self.ident.profile_points, s2)

    def check_bounds(self, result: dict, echo=lambda text: None) -> None:
        """Every zone claimed on a bound gets its check in ``parameters.<zone>.bound_check``; one that fails it
        is not claimed (``why`` says which condition failed), one that passes gets the profile's one-sided
        interval as ci95."""
        zones = [z for z, p in result["parameters"].items() if p.get("at_bound") and p.get("identifiable")]
        if not zones:
            return
        echo(f"bound check of {', '.join(zones)} (claimed on a bound): {self.ident.profile_points} "
             "refits each ...")
        fitted, stderr, s2 = self._fitted(result)
        systematic = [result["parameters"][z].get("stderr_systematic") for z in self.names]
        checks = profile.bound_checks(zones, self.names, self.params, fitted, stderr,
                                      self.ident.resolution, self.chi2_of, self.refit,
                                      self.evaluator.executor.parallel, self.ident.profile_points, s2, systematic)
        for zone, check in checks.items():
            entry = result["parameters"][zone]
            entry["bound_check"] = check
            if check["passed"]:
                entry["ci95"] = check["interval"]
            else:
                entry.update(identifiable=False, why=f"on its bound, but {check['why']}")
