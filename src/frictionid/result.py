"""IdentificationResult: an identification's outcome (result.json) as a read-only object with a report, and the
building of result.json from a fit (or from a run that stopped)."""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np

from .inverse.statistics import contact_reasons, fit_statistics, point_misfit

if TYPE_CHECKING:
    from .run.store import RunStore


def _frozen(value):
    """Read-only views of nested dicts and lists (tuples), so that a result cannot be changed in place."""
    if isinstance(value, dict):
        return MappingProxyType({k: _frozen(v) for k, v in value.items()})
    if isinstance(value, list):
        return tuple(_frozen(v) for v in value)
    return value


def _thawed(value):
    if isinstance(value, Mapping):
        return {k: _thawed(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_thawed(v) for v in value]
    return copy.copy(value)


@dataclass(frozen=True)
class IdentificationResult(Mapping):
    """The outcome of an identification: the content of its result.json (docs/results.md), read-only.

    Read it as a mapping (``result["fit"]["reduced_chi2"]``, every key of result.json) or through the
    attributes below; :meth:`fit_report` gives the text report, :meth:`to_dict` a plain, mutable copy.

    Attributes
    ----------
    status : "converged" | "max_iterations" | "interrupted" | "failed"
    coefficients : zone -> identified (or held) coefficient
    stderr : free zone -> standard error (None where it cannot be estimated)
    ci95 : free zone -> (low, high) 95 % interval within the bounds
    identifiable : free zone -> whether the data resolve it
    message, method, n_iterations : the optimiser's message, method and iteration count
    n_solves : counts of solves ("forward", "sensitivities", "replayed")
    objective, chi2, n_obs : the final objective, chi-square and number of observations (None for a run that
        stopped before its fit was assessed)
    run_dir : folder with result.json, history, plots and report.html (None when not kept)

    Examples
    --------
    >>> result = IdentificationResult({"status": "converged", "parameters": {
    ...     "A": {"value": 0.29, "fixed": False, "stderr": 0.042, "ci95": [0.21, 0.37], "identifiable": False},
    ...     "B": {"value": 0.158, "fixed": False, "stderr": 0.014, "ci95": [0.13, 0.19], "identifiable": True}}})
    >>> result.status, result.coefficients["B"], result.ci95["B"], result.identifiable
    ('converged', 0.158, (0.13, 0.19), {'A': False, 'B': True})

    ``IdentificationResult.read("runs/first")`` reads the result.json of a run folder.
    """

    data: Mapping
    run_dir: Path | None = None

    def __post_init__(self):
        object.__setattr__(self, "data", _frozen(dict(self.data)))

    @classmethod
    def read(cls, path) -> "IdentificationResult":
        """The result of a finished run from its result.json (or the run folder holding it)."""
        path = Path(path)
        path = path / "result.json" if path.is_dir() else path
        return cls(json.loads(path.read_text()), path.parent)

    def __getitem__(self, key):
        return self.data[key]

    def __iter__(self):
        return iter(self.data)

    def __len__(self) -> int:
        return len(self.data)

    @property
    def status(self) -> str:
        return self.data["status"]

    @property
    def coefficients(self) -> dict[str, float]:
        return {name: p["value"] for name, p in self.data["parameters"].items()}

    def _free(self, key: str) -> dict:
        return {name: p.get(key) for name, p in self.data["parameters"].items() if not p["fixed"]}

    @property
    def stderr(self) -> dict[str, float | None]:
        return self._free("stderr")

    @property
    def ci95(self) -> dict[str, tuple[float, float] | None]:
        return self._free("ci95")

    @property
    def identifiable(self) -> dict[str, bool | None]:
        return self._free("identifiable")

    @property
    def message(self) -> str:
        return self.data.get("message", "")

    @property
    def method(self) -> str:
        return self.data["method"]

    @property
    def n_iterations(self) -> int:
        return int(self.data["n_iterations"])

    @property
    def n_solves(self) -> dict[str, int]:
        """Solves run: "forward", "sensitivities" (forward + sensitivities), "replayed" (from the store)."""
        return {"forward": int(self.data["n_forward_solves"]),
                "sensitivities": int(self.data["n_sensitivity_solves"]), "replayed": int(self.data["n_replayed"])}

    @property
    def objective(self) -> float | None:
        """The final objective (None for a run that stopped before its result)."""
        objective = self.data.get("objective")
        return None if objective is None else float(objective["final"])

    @property
    def chi2(self) -> float | None:
        fit = self.data.get("fit")
        return None if fit is None else fit["chi2"]

    @property
    def n_obs(self) -> int | None:
        fit = self.data.get("fit")
        return None if fit is None else int(fit["n_obs"])

    def to_dict(self) -> dict:
        """A plain, mutable copy: exactly what result.json holds."""
        return _thawed(self.data)

    def fit_report(self) -> str:
        """The text report the command line prints: fit statistics, adequacy, coefficients with intervals and
        verdicts, identifiability, correlations."""
        from .report.tables import result_summary

        return result_summary(self.to_dict())

    def __repr__(self) -> str:
        values = ", ".join(f"{name}={value:.4g}" for name, value in self.coefficients.items())
        return f"IdentificationResult(status={self.status!r}, {values})"


def fit_result(config, setup, evaluator, problem, outcome, report, wall: float, error=None,
               mode: tuple[str, str] | None = None) -> dict:
    """result.json of a finished fit (docs/results.md): the coefficients with their statistics at ``outcome.x``
    (:func:`~frictionid.inverse.statistics.fit_statistics`), the fit's adequacy, observations and misfit per
    point, the model error (``error``, if estimated, and ``mode``: the mode used and why,
    :func:`~frictionid.inverse.discretisation.used_mode`; default the configured one), the data's frames and
    files, identifiability with the prefit ``report``, the counts of solves and the history."""
    requested = config.identify.model_error
    mode = mode or (requested, f'identify.model_error = "{requested}"')
    params, obs = setup.parameters, evaluator.obs          # obs.sigma with the model error, if included
    free = list(params.free_names)
    stats = fit_statistics(evaluator, problem, outcome.x, config.identify.resolution, error,
                           setup.remaining_error)
    r, f, weights, adequacy, unc = stats.r, stats.f, stats.weights, stats.adequacy, stats.uncertainty
    why = contact_reasons(evaluator.backend, params.full(outcome.x), sorted(set(obs.stage.tolist())), free, unc)
    parameters = {}
    for p in params.items:
        entry = {"value": p.value, "initial": p.value, "fixed": not p.vary}
        if p.vary:
            k = free.index(p.name)
            stderr = unc.stderr[k]
            entry.update(value=float(outcome.x[k]), bounds=[p.min, p.max],
                         stderr=None if np.isnan(stderr) else float(stderr),
                         ci95=None if np.isnan(stderr) else [float(v) for v in unc.ci95[k]],
                         at_bound=bool(unc.at_bound[k]), identifiable=bool(unc.identifiable[k]))
            if why[k]:
                entry["why"] = why[k]
            if stats.systematic is not None:
                entry["stderr_systematic"] = float(stats.systematic[k])
            if stats.discretisation_bias is not None:
                entry["discretisation_bias"] = None if not np.isfinite(stats.discretisation_bias[k]) else \
                    float(stats.discretisation_bias[k])
        parameters[p.name] = entry
    return {
        "status": outcome.status, "message": outcome.message, "method": config.identify.method,
        "jacobian": config.identify.jacobian, "backend": config.solver.backend, "parameters": parameters,
        "objective": {"initial": float(outcome.history_objective[0]), "final": float(outcome.objective)},
        "fit": {"n_obs": obs.n_obs, "chi2": unc.chi2, "dof": unc.dof, "noise_known": obs.noise_known,
                "error_scale": float(np.sqrt(unc.scale)), **adequacy.as_dict(free),
                "loss": problem.loss, "n_downweighted": int(np.sum(weights < 0.5)),
                "rms_residual": float(np.sqrt(np.mean((f - obs.y) ** 2))),
                "points": point_misfit(obs, r),
                "observations": [{"label": label, "measured": float(y), "model": float(v),
                                  "sigma": float(s) if obs.noise_known else None}
                                 for label, y, v, s in zip(obs.labels, obs.y, f, obs.sigma)],
                "model_error": {"mode": mode[0], "requested": requested, "why": mode[1]} if error is None else {
                    "mode": mode[0], "requested": requested, "why": mode[1], **error.as_dict(),
                    "shift": {name: None if not np.isfinite(v) else float(v)
                              for name, v in zip(free, stats.model_shift)}}},
        "model": {**(setup.model_options.table() if setup.model_options else {}),
                  "contact": [entry.as_dict() for entry in setup.contact], "discretisation": setup.discretisation},
        "data": data_section(setup.frames, obs, setup.window, setup.files),
        "identifiability": {"singular_values": unc.singular_values.tolist(),
                            "directions": {name: unc.directions[i].tolist() for i, name in enumerate(free)},
                            "correlation": np.where(np.isnan(unc.correlation), None, unc.correlation).tolist(),
                            "message": unc.message, "prefit": report.as_dict()},
        "n_iterations": int(outcome.n_iterations), "n_forward_solves": evaluator.n_forward,
        "n_sensitivity_solves": evaluator.n_sensitivity, "n_replayed": evaluator.n_replayed,
        "n_failed_solves": evaluator.n_failed, "wall_time_s": wall,
        "history": {"objective": outcome.history_objective.tolist(),
                    "coefficients": [params.full(x).tolist() for x in outcome.history_x]},
    }


def data_section(frames, obs, window=None, files=()) -> dict:
    """result.json's ``data``: the frame of each file that has one (given or fitted, with its residual), the
    reference points displacements are fitted relative to ([data] relative_to), the strain window of the fit
    (size, shape, origin: [data] strain_window or the exports' headers with their pixel sizes) and how each DIC
    export was read (``files``: format, stage, coordinates as written or converted from deformed positions,
    strain measure, rows, valid points, dropped rows by reason)."""
    minus = np.full(obs.n_obs, -1) if obs.minus_row is None else obs.minus_row
    n_quantities = max(len(obs.quantities), 1)
    return {"frames": [{k: v for k, v in f.items() if k != "line"} for f in frames],
            "relative_to": sorted({obs.point_labels[m // n_quantities] for m in minus[minus >= 0]}),
            **({} if window is None else {"strain_window": window.as_dict()}), "files": list(files)}


def stopped_result(config, setup, evaluator, iterations, status: str, message: str, wall: float) -> dict:
    """result.json of a run that did not finish: the last stored iterate of ``iterations`` (the start when
    none), the counts, the reason."""
    x = iterations[-1].x if iterations else setup.parameters.x0
    mu = setup.parameters.full(np.asarray(x))
    return {"status": status, "message": message, "method": config.identify.method,
            "jacobian": config.identify.jacobian, "backend": config.solver.backend,
            "parameters": {p.name: {"value": float(v), "initial": p.value, "fixed": not p.vary,
                                    **({"bounds": [p.min, p.max]} if p.vary else {})}
                           for p, v in zip(setup.parameters.items, mu)},
            "n_iterations": len(iterations) - 1 if iterations else 0, "n_forward_solves": evaluator.n_forward,
            "n_sensitivity_solves": evaluator.n_sensitivity, "n_replayed": evaluator.n_replayed,
            "wall_time_s": wall,
            **({"model": {"discretisation": setup.discretisation}} if setup.discretisation else {})}


def solve_timings(store: RunStore, backend_s: float | None = None) -> dict:
    """result.json's ``timings``: the backend's set-up time [s] (model condensed, or ccx checked) and, per kind
    of evaluation in the store ("forward", "forward+sensitivities", "held ...", "refit <digest> ...",
    "discretisation estimate: ..."), the count and the wall times [s] of its successful solves as measured where
    they ran (in a worker process with run.workers; replayed evaluations keep the time of the run that made them)."""
    walls: dict[str, list[float]] = {}
    for evaluation in store.evaluations():
        if evaluation.status == "ok":
            walls.setdefault(evaluation.kind, []).append(evaluation.wall_time)
    return {"backend_s": None if backend_s is None else float(backend_s),
            "solves": {kind: {"n": len(w), "median_s": float(np.median(w)), "min_s": float(np.min(w)),
                              "max_s": float(np.max(w)), "total_s": float(np.sum(w))}
                       for kind, w in walls.items()}}
