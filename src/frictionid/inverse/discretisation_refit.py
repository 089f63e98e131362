"""The discretisation control again at the fitted values, and the refinement a refit continues on.

The control (:mod:`.discretisation_control`) estimates the model's error at the start values. Where the fit ends
the error can be much larger: the 3-D block's machine force is mu times the total normal force on any mesh in
gross slip, so its estimate at start values 0.1 is zero, and its face displacements' estimate there was 0.70
noise levels RMS against 1.99 at the truth. So after the fit the same splitting estimate is made again at the
fitted coefficients: the model as given (``identify.refine_target``'s reference, the first control's) refined by 2
in each direction on its own, solved at the fitted mu, and the refinement fitted (factors k per direction) is
predicted and checked there as before the fit (:func:`frictionid.inverse.discretisation_control._checked`, the
actual change of the fitted model's values from the model as given at the fitted mu). When that remaining error is
within the target in every quantity kind nothing more happens. Otherwise the cheapest refinement at least as fine
as the fitted one in every direction (factors up to 2^``refine_budget``, within ``max_memory``) whose prediction
at the fitted values is within the target (else the one with the smallest worst-kind error) is built, and the fit continues from the fitted values on it; at most :data:`MAX_ROUNDS` rounds,
and none when the choice stays the fitted model.

Each round costs the directional condensations again (they are not kept through the fit: on the dense 3-D block
they peaked at 0.8-3.6 GB each), and one solve of each at the fitted mu. Every directional difference is kept in
the run's store under the kind ``discretisation estimate: <direction>`` at the fitted coefficients (all zones) as
soon as it is made, and the round's choice under ``discretisation refit choice``, so that ``--resume`` reads them
instead of solving them again; the refit's own evaluations are stored under ``refit <digest of its [model] table>
<kind>`` (:class:`PhaseStore`), apart from the first fit's, whose coefficients are keyed alike but solved on
another mesh.
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from dataclasses import dataclass

import numpy as np

from ..builders.registry import build_model
from ..options import ModelSpec
from .discretisation_control import (TooLarge, _checked, _choose, _factors_text, _rms_text, combined,
                                     directional, directions, kind_rms, refinement, values, within)
from .model_error import ELEMENT_ORDER, convergence_orders, observation_kinds
from .remaining_error import RemainingError, remaining

log = logging.getLogger(__name__)

#: refits after the first fit at most (each one a fit on a finer model and, after it, an estimate again)
MAX_ROUNDS = 2
ESTIMATE, CHOICE = "discretisation estimate", "discretisation refit choice"


class StoredEstimate:
    """The directional differences at ``mu`` (all zones' coefficients) kept in the run's store as they are made
    (the ``memo`` of :func:`frictionid.inverse.discretisation_control.directional`)."""

    def __init__(self, store, mu):
        self.store, self.mu = store, np.asarray(mu, dtype=float)

    def get(self, name: str):
        found = None if self.store is None else self.store.lookup(self.mu, f"{ESTIMATE}: {name}")
        return None if found is None else (found["difference"], json.loads(str(found["step"])))

    def put(self, name: str, difference: np.ndarray, step: dict) -> None:
        if self.store is not None:
            self.store.record(self.mu, f"{ESTIMATE}: {name}", {"difference": np.asarray(difference, dtype=float),
                                                               "step": np.array(json.dumps(step))},
                              wall_time=step["seconds"])

    def values(self, name: str, solve) -> np.ndarray:
        """A model's values at ``mu`` kept under ``name``, else ``solve()``'s, kept."""
        found = None if self.store is None else self.store.lookup(self.mu, f"{ESTIMATE}: {name}")
        if found is not None:
            return found["values"]
        begun = time.perf_counter()
        made = np.asarray(solve(), dtype=float)
        if self.store is not None:
            self.store.record(self.mu, f"{ESTIMATE}: {name}", {"values": made},
                              wall_time=time.perf_counter() - begun)
        return made


class PhaseStore:
    """The run's store seen by the fit on a refined model: its evaluations under kinds ``"<phase> <kind>"``, apart
    from the first fit's (same coefficients, another mesh), so that a resumed run replays each phase's own."""

    def __init__(self, store, phase: str):
        self.store, self.phase = store, phase

    def record(self, x, kind: str, outputs: dict, status: str = "ok", wall_time: float = 0.0) -> None:
        self.store.record(x, f"{self.phase} {kind}", outputs, status, wall_time)

    def lookup(self, x, kind: str, status: str = "ok") -> dict | None:
        return self.store.lookup(x, f"{self.phase} {kind}", status)


def phase(options: ModelSpec) -> str:
    """The store phase of a fit on the [model] ``options``: "refit" and a digest of the table.

    >>> phase(ModelSpec.from_table({"builder": "block2d", "mesh_size": 0.5}))
    'refit 53144995197d'
    """
    text = json.dumps(options.table(), sort_keys=True, default=str)
    return "refit " + hashlib.sha256(text.encode()).hexdigest()[:12]


@dataclass(frozen=True)
class Decision:
    """One round of the control at the fitted values: the ``record`` (result.json ``model.discretisation.
    at_fitted`` entry), the refinement to refit on (``factors``, ``options``, ``model``; None: no refit), and what
    :meth:`remaining_of` needs to make the refined model's remaining error."""

    record: dict
    factors: tuple | None = None
    options: ModelSpec | None = None
    model: object = None
    remaining: RemainingError | None = None
    split: tuple | None = None

    def remaining_of(self, fine: np.ndarray, observations) -> tuple[RemainingError, dict]:
        """The refined model's remaining error at the fitted values, checked against its actual change (its values
        ``fine`` (n_obs,) at the fitted mu against the model as given's), and the check's record."""
        differences, orders, kind_orders, nested, coarse = self.split
        left = remaining(differences, self.factors, orders, kind_orders, nested)
        before = remaining(differences, [1] * len(differences), orders, kind_orders, nested)
        return _checked(left, before, coarse - fine, observations.sigma, observation_kinds(observations))


def at_fitted(given_options: ModelSpec, given_model, observations, mu, current: tuple, current_values: np.ndarray,
              target: float, budget: int = 2, max_memory: float | None = None, window=None,
              factorisation: str = "auto", store=None, progress=None, index: int = 1,
              scale: float = 1.0) -> Decision:
    """The control's estimate at the fitted coefficients ``mu`` (all zones) for the refinement ``current`` of
    ``given_options`` (the model fitted, with values ``current_values`` (n_obs,) at ``mu``), and the finer
    refinement to refit on when that is beyond ``target`` (module docstring); round ``index`` in the progress
    lines and the record; ``scale`` the first control's measured / estimated memory (its ``memory_scale``).
    Directional differences and the choice are kept in ``store`` (:class:`StoredEstimate`): a resumed run reads
    them, so that it refits on the model the interrupted one chose."""
    progress = progress or (lambda text: None)
    begun, obs, kinds = time.perf_counter(), observations, observation_kinds(observations)
    names, nested = directions(given_options), within(given_options)
    orders = convergence_orders(ELEMENT_ORDER[given_model.mesh.cell_type])
    p = np.array([orders[k] for k in kinds])
    memo = StoredEstimate(store, mu)
    refined = any(k != 1 for k in current)
    progress(f"discretisation control at the fitted values (round {index}): the model's error there by refining it "
             f"in each of {len(names)} direction(s) again")
    coarse = memo.values("as given", lambda: values(given_model, obs, mu, window, factorisation=factorisation)) \
        if refined else current_values
    record = {"round": index, "fitted_factors": dict(zip(names, current))}
    try:
        differences, terms, sizes, steps = directional(given_options, given_model, obs, mu, coarse, window,
                                                       max_memory, factorisation, progress, [scale], memo)
    except TooLarge as exc:
        progress(f"discretisation control at the fitted values: {exc}; no refit")
        return Decision({**record, "status": "skipped", "why": str(exc),
                         "seconds": round(time.perf_counter() - begun, 1)})
    before = remaining(differences, [1] * len(names), p, orders, nested)
    now = remaining(differences, current, p, orders, nested)
    check = None
    if refined:
        now, check = _checked(now, before, coarse - current_values, obs.sigma, kinds)
    given = kind_rms(np.abs(before.nominal) / obs.sigma, kinds)
    fitted = kind_rms(np.abs(now.nominal) / obs.sigma, kinds)
    record.update(directions=steps, error_as_given=given, error_fitted=fitted, check=check)
    progress(f"discretisation control at the fitted values: estimated error as given {_rms_text(given)}, of the "
             f"model fitted ({_factors_text(names, current)}) {_rms_text(fitted)} noise levels RMS")
    if max(fitted.values()) <= target:
        record.update(status="within target", seconds=round(time.perf_counter() - begun, 1))
        progress(f"discretisation control at the fitted values: within the target {target:g}; no refit "
                 f"({record['seconds']:.1f} s)")
        return Decision(record, remaining=now)
    factors, options, model, rms = _chosen(given_options, given_model, terms, sizes, p, obs, target, budget,
                                           max_memory, scale, factorisation, current, store, mu)
    record.update(factors=dict(zip(names, factors)), predicted_error=rms,
                  seconds=round(time.perf_counter() - begun, 1))
    if tuple(factors) == tuple(current):
        record["status"] = "no finer model"
        progress(f"discretisation control at the fitted values: beyond the target {target:g}, but no refinement at "
                 f"least as fine in every direction, within refine_budget and max_memory, is predicted closer; no refit "
                 f"({record['seconds']:.1f} s)")
        return Decision(record, remaining=now)
    record.update(status="refit", options=options.table(), n_nodes=int(model.mesh.n_nodes))
    progress(f"discretisation control at the fitted values: beyond the target {target:g}; refitting on "
             f"{_factors_text(names, factors)} ({model.mesh.n_nodes:,} nodes), predicted {_rms_text(rms)} noise "
             f"levels RMS ({record['seconds']:.1f} s)")
    return Decision(record, tuple(factors), options, model, now, (differences, p, orders, nested, coarse))


def _chosen(given_options, given_model, terms, sizes, p, obs, target, budget, max_memory, scale, factorisation,
            current, store, mu):
    """(factors, options, model, predicted rms per kind) of the round's choice: the one kept in ``store`` at
    ``mu``, else :func:`_choose`'s, then kept (its memory check reads the process's memory, which a resumed run
    does not share)."""
    kept = None if store is None else store.lookup(mu, CHOICE)
    if kept is None:
        chosen = _choose(given_options, given_model, terms, sizes, 2.0 ** p, obs.sigma, observation_kinds(obs),
                         target, max_memory, range(1, 2 ** budget + 1), scale, factorisation, floor=current)
        if store is not None:
            store.record(mu, CHOICE, {"factors": np.array(chosen[0], dtype=float)})
        return chosen
    factors = tuple(int(k) for k in kept["factors"])
    rms = kind_rms(np.abs(combined(terms, factors, p, within(given_options))) / obs.sigma, observation_kinds(obs))
    if factors == tuple(current):
        return factors, None, None, rms
    options = refinement(given_options, factors)
    return factors, options, build_model(options, "[model] (refined at the fitted values)"), rms
