"""The discretisation control before a fit: the model's error at the start values per quantity kind, and the
builder's mesh refined in the direction the error comes from until it is below ``identify.refine_target`` noise
levels RMS per quantity kind, within ``[solver] max_memory``.

The error is estimated by splitting extrapolation (Richardson per refinement direction of a multi-parameter
discretisation; C. B. Liem, T. Lu, T. M. Shih, The Splitting Extrapolation Method, World Scientific 1995): a builder's mesh has independent size parameters
(:func:`directions`; the 3-D block: the divisions of the contact footprint, which set the element size at the
contact edges, the layers, which set it across the interface, and inside each a band of fixed width where the
error of a contact edge sits: the intervals within 1 mm of the footprint's edges, ``edge_splits``, and the layers
within 1 mm of the interface, ``interface_splits``, :class:`frictionid.builders.block_mesh.Bands`), and its error
is taken as a sum of one term per region, f(h_1, h_2) = f + C_1 h_1^p + C_2 h_2^p. One condensation per
direction, refined by 2 in that direction only, gives each term, e_d = (f_h - f_d) 2^p / (2^p - 1), with the
orders of :func:`frictionid.inverse.model_error.convergence_orders` (displacements and forces 1, strains 1.77:
the contact edges' singularity caps them). Each directional model is 1.3-2.6 times the model's size, where the
uniform halving is 4-5 times (3-D block: 37,872 nodes, more than 7 GB with a dense DIC grid), so the estimate fits
in memory where Richardson from the uniform halving does not.

The refinement (k_1, k_2, ...) then has the predicted error sum_d e_d / k_d^p, a band's element size divided by its
own factor and its uniform direction's (:func:`frictionid.inverse.remaining_error.combined`). Where every quantity
kind is within the target at k = 1 nothing changes; otherwise the cheapest refinement (k_d from 1 to
2^``identify.refine_budget``, size predicted from the directional models' sizes) whose prediction is within the
target in every kind is built and fitted, after :func:`frictionid.fem.memory.check`, the memory law scaled by the
largest ratio of measured to estimated peak of the control's own builds (:class:`frictionid.fem.memory.Peak`) (no
refinement is left out for its element length against the slip: the small-sliding check,
:meth:`frictionid.fem.problem.Problem.check_small_sliding`, measures the pairing's gap error, a property of the
solution, on the fitted answer); when none is, the one with the smallest largest-kind error that fits in memory,
and the record says the target was not reached. A model that cannot be refined (a model object, another backend) is fitted as it is, and
the record says why.

The choice is checked: the chosen model is solved at the start values, and in a quantity kind where its actual
change from the model as given misses the predicted change by more than half, the remaining error of that kind is
the error as given less the actual change (:func:`_checked`), and the target counts as reached only if that is
within it.

After the fit the identification makes the estimate again at the fitted values and refits on a finer model where
it asks for one (:mod:`.discretisation_refit`, with :func:`directional` and :func:`_choose`'s ``floor``).

``identify.refine_target = 0`` switches the control off. The record goes to result.json (``model.discretisation``)
and one line per phase to the run's progress.
"""

from __future__ import annotations

import itertools
import logging
import time
from dataclasses import dataclass

import numpy as np

from ..backends.embedded import EmbeddedBackend
from ..builders.block import block_layout
from ..builders.registry import _default, build_model, refined
from ..fem import memory
from ..fem.locate import PointsOutside
from ..options import ModelSpec
from .model_error import ELEMENT_ORDER, convergence_orders, observation_kinds
from .remaining_error import RemainingError, combined, remaining

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Control:
    """What the control decided: the [model] table and model to fit, and the record for result.json."""

    options: ModelSpec | None
    model: object
    record: dict
    #: the error the fitted model keeps, per observation (:mod:`.remaining_error`); None when the control did not run
    remaining: RemainingError | None = None
    #: the same prediction for the model as given (its change to ``remaining`` is what the refinement should move)
    given: RemainingError | None = None
    #: (terms e_d per direction, per-observation orders, within) of the prediction, for :meth:`predicted`
    split: tuple | None = None

    def predicted(self, factors) -> np.ndarray:
        """(n_obs,) the control's error (model minus converged, at its orders) after refining by ``factors``."""
        terms, orders, nested = self.split
        return combined(terms, factors, orders, nested)


class TooLarge(Exception):
    """A directional model's condensation would take more than ``[solver] max_memory``: not built."""


#: a refinement's prediction holds in a quantity kind when it misses the actual change (RMS) by at most this
#: fraction of the predicted change or by at most CHECK_FLOOR noise levels RMS (:func:`_checked`)
CHECK_TOLERANCE, CHECK_FLOOR = 0.5, 0.1
#: the 3-D block's refinement directions and, per direction, the one whose region its band lies in (None: the whole
#: mesh in that coordinate)
BLOCK_DIRECTIONS = {"footprint divisions": None, "interface layers": None, "footprint edges": 0, "interface band": 1}


def directions(spec: ModelSpec) -> list[str]:
    """The refinement directions of a [model]'s builder.

    >>> directions(ModelSpec("block")), directions(ModelSpec("block2d"))
    (['footprint divisions', 'interface layers', 'footprint edges', 'interface band'], ['element sizes'])
    """
    return list(BLOCK_DIRECTIONS) if spec.builder == "block" else ["element sizes"]


def within(spec: ModelSpec) -> list:
    """Per :func:`directions` entry the index of the direction whose region its band lies in, or None
    (:func:`frictionid.inverse.remaining_error.combined`)."""
    return list(BLOCK_DIRECTIONS.values()) if spec.builder == "block" else [None]


def refinement(spec: ModelSpec, factors: tuple[int, ...]) -> ModelSpec:
    """The [model] refined by ``factors`` (one per :func:`directions` entry; 1: unchanged).

    block: ``block_divisions`` times the first (every interval across the footprint split), the layers
    (``mesh_size``, the footprint kept) divided by the second, ``edge_splits`` times the third (the intervals
    within ``edge_band`` of the footprint's edges), ``interface_splits`` times the fourth (the layers within
    ``interface_band`` of the interface); others: every size divided (:func:`frictionid.builders.registry.refined`).

    >>> refinement(ModelSpec.from_table({"builder": "block", "mesh_size": 1.0}), (2, 1, 1, 1)).table()
    {'builder': 'block', 'mesh_size': 1.0, 'block_divisions': 20}
    >>> refinement(ModelSpec.from_table({"builder": "block"}), (1, 1, 4, 2)).table()
    {'builder': 'block', 'mesh_size': 1.0, 'block_divisions': 10, 'edge_splits': 4, 'interface_splits': 2}
    """
    if spec.builder == "block":
        size = float(spec.option("mesh_size", _default("block", spec.table(), "mesh_size")))
        divisions = spec.option("block_divisions") or 2 * max(1, round(5.0 / size))
        bands = {name: spec.option(name, 1) * k for name, k in zip(("edge_splits", "interface_splits"), factors[2:])
                 if k != 1 or spec.option(name) is not None}
        return spec.with_options(mesh_size=size / factors[1], block_divisions=divisions * factors[0], **bands)
    return spec if factors[0] == 1 else refined(spec, factors[0])


def kind_rms(in_noise: np.ndarray, kinds: np.ndarray) -> dict:
    """RMS of ``in_noise`` per quantity kind, {"u": ..., "e": ..., "force": ...} (the kinds observed)."""
    return {k: float(np.sqrt(np.mean(in_noise[kinds == k] ** 2))) for k in dict.fromkeys(kinds.tolist())}


def values(model, observations, mu, window=None, keep: bool = False, factorisation: str = "auto") -> np.ndarray:
    """(n_obs,) the model's values of the observations at ``mu`` (one condensation, ``[solver] factorisation``,
    and one solve)."""
    obs = observations
    try:
        backend = EmbeddedBackend(model, obs.points, obs.quantities, obs.point_regions, obs.reactions, keep=keep,
                                  window=window, factorisation=factorisation)
    except PointsOutside as exc:
        raise exc.named(obs.point_labels, obs.source) from None
    return obs.predicted(backend.predict(mu).values)


def _skipped(target, why: str, progress) -> dict:
    lead = "" if why.startswith("discretisation control:") else "discretisation control: "
    progress(f"{lead}{why}; the model is fitted as it is")
    return {"target": target, "status": "skipped", "why": why, "seconds": 0.0}


def control(model_options: ModelSpec | None, model, observations, mu, target: float, budget: int = 2,
            max_memory: float | None = None, progress=None, window=None, backend: str = "embedded",
            factorisation: str = "auto") -> Control:
    """The model to fit: ``model`` itself, or the cheapest refinement of it whose predicted error at ``mu`` (all
    zones, model order) is within ``target`` noise levels RMS in every quantity kind (module docstring).

    ``budget``: the factors per direction go up to 2^budget (``identify.refine_budget``); ``factorisation``:
    ``[solver] factorisation``, for the condensations and their memory estimates; ``window``: the fit's
    strain window (:class:`frictionid.fem.points.StrainWindow`), so that the error is the
    error of what is fitted; ``progress`` gets one line per phase. The record says what was done and its cost.

    Raises
    ------
    InputError
        When a directional model's condensation would exceed ``max_memory`` (:func:`frictionid.fem.memory.check`).
    """
    progress = progress or (lambda text: None)
    if not target > 0:
        return Control(model_options, model, {"target": target, "status": "off", "seconds": 0.0})
    if backend != "embedded" or model_options is None or model_options.builder not in \
            ("block", "block2d", "bolt", "mesh"):
        why = f"backend {backend!r} (the estimate needs the embedded backend)" if backend != "embedded" else \
            "the model is not a builder's [model] table frictionid can refine"
        return Control(model_options, model, _skipped(target, why, progress))
    start = time.perf_counter()
    names, kinds, nested = directions(model_options), observation_kinds(observations), within(model_options)
    orders = convergence_orders(ELEMENT_ORDER[model.mesh.cell_type])
    gain = 2.0 ** np.array([orders[k] for k in kinds])
    progress(f"discretisation control: the model's error at the start values by refining it in each of "
             f"{len(names)} direction(s) ({', '.join(names)}), target {target:g} noise levels RMS per quantity kind")
    ratios = []                          # measured / estimated peak of each build (fem/memory.py, Peak)
    if len(names) == 1:
        try:                             # uncalibrated (scale 1): a calibrated estimate is never smaller
            _least(model, names[0], max_memory, factorisation, ratios)
        except TooLarge as exc:          # nothing solved for the control: the fit condenses the model itself
            return Control(model_options, model, _skipped(target, str(exc), progress))
    with memory.Peak() as took:
        coarse = values(model, observations, mu, window, keep=True, factorisation=factorisation)
    _calibrate(ratios, took, memory.estimate(model, "model", max_memory, factorisation))
    try:
        differences, terms, sizes, steps = directional(model_options, model, observations, mu, coarse, window,
                                                       max_memory, factorisation, progress, ratios)
    except TooLarge as exc:
        return Control(model_options, model, _skipped(target, str(exc), progress))
    scale = _scale(ratios)
    if scale > 1.0:
        progress(f"discretisation control: the builds took up to {scale:.2f} times the memory law's estimate; the "
                 "refinements' estimates are scaled by it")
    chosen = _choose(model_options, model, terms, sizes, gain, observations.sigma, kinds, target, max_memory,
                     range(1, 2 ** budget + 1), scale, factorisation)
    factors, options, fitted, rms = chosen
    given = kind_rms(np.abs(combined(terms, [1] * len(terms), np.log2(gain), nested)) / observations.sigma, kinds)
    status = "not needed" if max(given.values()) <= target else \
        "reached" if max(rms.values()) <= target else "not reached"
    left = remaining(differences, factors, np.log2(gain), orders, nested)
    before = remaining(differences, [1] * len(names), np.log2(gain), orders, nested)
    slow = left.summary(observations.sigma, kinds)["slow"]
    progress(f"discretisation control: estimated error as given {_rms_text(given)}; fitting "
             f"{_factors_text(names, factors)} ({fitted.mesh.n_nodes:,} nodes), predicted {_rms_text(rms)} noise "
             f"levels RMS: target {target:g} {status}")
    check = None
    if any(k != 1 for k in factors):
        # kept: the fit condenses it once
        fine = values(fitted, observations, mu, window, keep=True, factorisation=factorisation)
        left, check = _checked(left, before, coarse - fine, observations.sigma, kinds)
        checked = max(check["remaining"]["nominal"].values())
        if status == "reached" and checked > target:
            status = "not reached"
        progress(_check_text(check) + ("" if not check["not_holding"] else f": target {target:g} {status}"))
    seconds = time.perf_counter() - start
    record = {"target": target, "status": status, "method": "splitting extrapolation", "orders": orders,
              "directions": steps, "error_as_given": given, "factors": dict(zip(names, factors)),
              "options": options.table(), "n_nodes": int(fitted.mesh.n_nodes), "predicted_error": rms,
              "predicted_error_slow": slow, "check": check, "memory_scale": round(scale, 3),
              "seconds": round(seconds, 1)}
    progress(f"discretisation control: took {seconds:.1f} s")
    log.info("discretisation control: %s", record)
    return Control(options, fitted, record, left, before, (terms, np.log2(gain), nested))


def directional(model_options: ModelSpec, model, observations, mu, coarse: np.ndarray, window=None,
                max_memory: float | None = None, factorisation: str = "auto", progress=None, ratios=None,
                memo=None) -> tuple[list, list, list, list]:
    """(differences, terms e_d, node counts, record steps) of the model refined by 2 in each :func:`directions`
    entry on its own, solved at ``mu`` against the model's values ``coarse`` (n_obs,); ``ratios`` gathers each
    build's measured / estimated peak (:func:`_calibrate`). ``memo`` (optional): ``memo.get(name)`` gives a
    direction's (difference, step) kept from an earlier call at the same ``mu`` (nothing solved), and
    ``memo.put(name, difference, step)`` keeps a new one as soon as it is made.

    Raises
    ------
    TooLarge
        When a directional model's condensation would exceed ``max_memory`` (its message says which).
    """
    progress, ratios = progress or (lambda text: None), [] if ratios is None else ratios
    names, kinds, nested = directions(model_options), observation_kinds(observations), within(model_options)
    orders = convergence_orders(ELEMENT_ORDER[model.mesh.cell_type])
    gain = 2.0 ** np.array([orders[k] for k in kinds])
    differences, terms, sizes, steps = [], [], [], []
    for d, name in enumerate(names):
        kept = None if memo is None else memo.get(name)
        if kept is None:
            if len(names) == 1:         # every size halved: the least growth is known before the mesh is built
                _least(model, name, max_memory, factorisation, ratios)
            difference, step = _direction(model_options, observations, mu, coarse, d, window, max_memory,
                                          factorisation, ratios, progress)
            if memo is not None:
                memo.put(name, difference, step)
        else:
            difference, step = kept
            progress(f"discretisation control: {name} x2 at these values read from the run's store")
        differences.append(difference)
        terms.append(difference * gain / (gain - 1.0))
        sizes.append(step["n_nodes"])
        steps.append({**step, "rms": kind_rms(np.abs(terms[-1]) / observations.sigma, kinds)})
        part = "" if nested[d] is None else f" (part of the {names[nested[d]]}')"
        progress(f"discretisation control: error from the {name}{part}: {_rms_text(steps[-1]['rms'])} noise levels "
                 f"RMS ({steps[-1]['seconds']:.1f} s)")
    return differences, terms, sizes, steps


def _least(model, name: str, max_memory, factorisation: str, ratios) -> None:
    """Raise :class:`TooLarge`, before its mesh is built, for a model with every element size halved whose
    condensation would exceed ``max_memory`` even at the least growth of a graded mesh, 2^(dim - 1) times the
    nodes (:func:`frictionid.fem.memory.check_growth`; on the 3-D M20 meshing the refinement took 150 s CPU)."""
    dim = 3 if model.kind == "3d" else 2
    cost = memory.estimate(model, f"discretisation control: {name} x2 (at least)", max_memory, factorisation,
                           n_nodes=model.mesh.n_nodes * 2 ** (dim - 1), scale=_scale(ratios))
    if not cost.fits:
        raise TooLarge(f"{cost.line()}: more than [solver] max_memory allows, not built")


def _direction(model_options, observations, mu, coarse, d, window, max_memory, factorisation, ratios, progress):
    """(difference coarse minus refined, step record) of the model refined by 2 in direction ``d`` only."""
    begun, names = time.perf_counter(), directions(model_options)
    options = refinement(model_options, tuple(2 if j == d else 1 for j in range(len(names))))
    fine_model = build_model(options, f"[model] ({names[d]} x2)")
    cost = memory.estimate(fine_model, f"discretisation control: {names[d]} x2", max_memory, factorisation,
                           scale=_scale(ratios))
    if not cost.fits:
        raise TooLarge(f"{cost.line()}: more than [solver] max_memory allows, not condensed")
    progress(cost.line() + "; condensing")
    with memory.Peak() as took:
        difference = coarse - values(fine_model, observations, mu, window, factorisation=factorisation)
    _calibrate(ratios, took, memory.estimate(fine_model, "", max_memory, factorisation))
    return difference, {"direction": names[d], "options": options.table(), "n_nodes": int(fine_model.mesh.n_nodes),
                        "memory_gb": round(cost.needed / memory.GB, 2),
                        "measured_gb": None if took.above is None else round((cost.held + took.above) / memory.GB,
                                                                              2),
                        "seconds": round(time.perf_counter() - begun, 1)}


def _checked(left: RemainingError, before: RemainingError, actual: np.ndarray, sigma, kinds):
    """(remaining error, record) of the chosen refinement checked against its actual values at the start values.

    ``actual`` is the model as given minus the chosen one, the change the prediction (``before`` minus ``left``)
    claims. In a quantity kind whose predicted change misses the actual one by more than :data:`CHECK_TOLERANCE`
    of it (and by more than :data:`CHECK_FLOOR` noise levels RMS) the splitting assumption does not hold there (on
    the 3-D block the strains next to the contact edges, whose error the edge and interface refinements do not
    reduce additively), and the remaining error of that kind is taken as the error as given minus the actual
    change (nominal and slow): the refined model's error is f_k - f = (f_1 - f) - (f_1 - f_k), which uses the
    extrapolation only for the model as given.
    """
    predicted = before.nominal - left.nominal
    check = {"actual_change": kind_rms(np.abs(actual) / sigma, kinds),
             "predicted_change": kind_rms(np.abs(predicted) / sigma, kinds),
             "missed": kind_rms(np.abs(predicted - actual) / sigma, kinds)}
    off = [kind for kind, miss in check["missed"].items()
           if miss > CHECK_FLOOR and miss > CHECK_TOLERANCE * check["predicted_change"][kind]]
    check["not_holding"] = off
    if off:
        mask = np.isin(kinds, off)
        left = RemainingError(np.where(mask, before.nominal - actual, left.nominal),
                              np.where(mask, before.slow - actual, left.slow), left.orders)
    check["remaining"] = left.summary(sigma, kinds)
    return left, check


def _check_text(check: dict) -> str:
    text = (f"discretisation control: the chosen model's values at the start values moved by "
            f"{_rms_text(check['actual_change'])} noise levels RMS, predicted {_rms_text(check['predicted_change'])}")
    if not check["not_holding"]:
        return text + ": the prediction holds"
    return (text + f": in {', '.join(check['not_holding'])} it does not, so the remaining error there is the error "
            f"as given less the actual change: {_rms_text(check['remaining']['nominal'])} noise levels RMS "
            f"({_rms_text(check['remaining']['slow'])} at half the orders)")


def _calibrate(ratios: list, took: memory.Peak, cost: memory.MemoryEstimate) -> None:
    """Add a build's measured peak over its estimate (nothing where the peak cannot be measured)."""
    if took.above is not None and cost.above > 0:
        ratios.append(took.above / cost.above)


def _scale(ratios: list) -> float:
    """The factor on the memory law for models not built yet: the largest measured ratio, never below 1."""
    return max([1.0, *ratios])


def _choose(model_options, model, terms, sizes, gain, sigma, kinds, target, max_memory, factors_tried,
            scale: float = 1.0, factorisation: str = "auto", floor=None):
    """(factors, options, model, predicted rms per kind) of the cheapest refinement within the target that fits
    in memory (its estimate times ``scale``), else of the smallest worst-kind error that does. ``floor``: only
    refinements at least this fine in every direction (a model fitted already); the floor itself comes back
    without options and model (None, None), as it is not built again."""
    base, nested = model.mesh.n_nodes, within(model_options)
    floor = tuple(floor or [1] * len(terms))
    rows = []
    for factors in itertools.product(factors_tried, repeat=len(terms)):
        # no refinement is left out for sliding: the small-sliding check's gap error is that of the solution, not
        # of the element length (fem/problem.py, check_small_sliding), and the fitted answer is checked
        if model_options.builder == "mesh" and any(k not in (1, 2, 4) for k in factors) \
                or any(k < f for k, f in zip(factors, floor)):
            continue
        error = combined(terms, factors, np.log2(gain), nested)
        rms = kind_rms(np.abs(error) / sigma, kinds)
        nodes = _nodes(model_options, factors, base, sizes)
        rows.append((max(rms.values()) > target, nodes if max(rms.values()) <= target else max(rms.values()),
                     factors, rms, nodes))
    for _, _, factors, rms, nodes in sorted(rows, key=lambda row: row[:2]):
        if all(k == 1 for k in factors):
            return factors, model_options, model, rms
        if factors == floor:
            return factors, None, None, rms
        if not memory.estimate(model, "discretisation control", max_memory, factorisation, n_nodes=int(nodes),
                               scale=scale).fits:
            continue                                   # refused on its predicted size, before meshing
        options = refinement(model_options, factors)
        candidate = build_model(options, "[model] (refined)")
        if memory.estimate(candidate, "discretisation control", max_memory, factorisation, scale=scale).fits:
            return factors, options, candidate, rms
    raise AssertionError("unreachable: the model as given (or the floor) is always a candidate")


def _nodes(model_options: ModelSpec, factors, base: int, sizes) -> float:
    """The node count of the refinement ``factors``: the 3-D block's exactly (its layout), others' from the
    directional models' sizes (``sizes``, refined by 2 each) as if each factor 2 multiplied it alike."""
    if model_options.builder == "block":
        return float(block_layout(**refinement(model_options, factors).table()).n_nodes(
            int(model_options.option("order", 1))))
    return base * np.prod([(n / base) ** np.log2(k) for n, k in zip(sizes, factors)])


def _rms_text(rms: dict) -> str:
    return ", ".join(f"{kind} {value:.2f}" for kind, value in rms.items())


def _factors_text(names, factors) -> str:
    if all(k == 1 for k in factors):
        return "the model as given"
    return "the model refined: " + ", ".join(f"{name} x{k}" for name, k in zip(names, factors) if k != 1)
