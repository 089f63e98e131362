"""Discretisation (model) error at the observations: a Richardson estimate from one refined condensation.

The model's value of an observation on a mesh of size h behaves as f_h = f + C h^p once h is small enough, so
the error of the coarse model is, from the same model refined by a factor r (h -> h / r),

    e_h = f_h - f = (f_h - f_{h/r}) r^p / (r^p - 1)

(Richardson extrapolation). For a smooth solution on elements of degree k the order of a pointwise value is
k + 1 for displacements and reaction forces and k for strains. The contact models here are not smooth: at the
edges of a contact (the block's footprint, the ends of a thread flank) the stress is singular, about r^(-1/2), and
under uniform refinement the error it pollutes the whole field with decays as h^(2 lambda) = h. So the orders of
displacements and forces are capped at :data:`SINGULAR_ORDER` = 1 (:func:`convergence_orders`), for linear and
quadratic elements alike: with r = 2 the factor r^p / (r^p - 1) is 2, and where the true order is 1 or more the
estimate lies between 1 and 2 times the error (the safe side for a weight). Face displacements of the 3-D
block converge more slowly than that on coarse meshes (observed order 0.3-0.8), so a higher order for them would
understate the error further.

Strains at points away from the contact edges converge faster than order 1 on the 3-D block and the bolt
(observed orders 2.6 and 2.3 over h, h / 2, h / 4), irregularly on coarse plane-strain meshes; by how much
depends on the element technology, the grading and the distance to the edge, none of which one refinement shows. For an order known only to lie in [1, inf) the factor lies in (1, 2]; the
estimate uses their geometric mean sqrt(2), which is within a factor sqrt(2) of the Richardson error for any such
order (:data:`STRAIN_ORDER` = log2(2 + sqrt(2)) = 1.77 is the order that gives it).

Measured with ``benchmarks/model_error.py`` (estimate from h / 2 against the difference to a mesh 4-32 times
finer, RMS ratio estimate / actual per kind, the runs its docstring lists):

============================================  ============  =====  =======  ===================
case (coarse mesh, finest)                     displacement  force  strains  strains with p = 1
============================================  ============  =====  =======  ===================
3-D block, builder default, 2.5 (0.625) mm     1.29          1.56   1.46     2.06
M20 bolt, flank 0.2 (0.05) mm                  1.29          --     1.23     1.7
plane-strain block, quadratic, 4 (0.125) mm    1.04          0.92   0.95     1.3
plane-strain block, quadratic, 2 (0.125) mm    1.07          0.99   3.47     4.9
============================================  ============  =====  =======  ===================

The a priori orders give 0.59-0.86 for displacements there. On the plane-strain block at 2 mm strains 1 mm from
a contact edge do not yet converge regularly (median ratio 1.04, but a few points far off): for strains the
estimate is an order of magnitude, not a bound. On the 3-D block with uniform linear hexahedra the face
displacements converge at an observed order of only 0.3 over 2.5, 1.25, 0.625 mm (pre-asymptotic), so there both
the estimate and the finest-mesh difference understate the error.

The estimate is made at several coefficient sets (an identification's start and end) and the largest
magnitude per observation is kept, so that it holds along the fit. In units of the noise it says whether the
discretisation error matters (in_noise >~ 1) and as extra variance, sigma_eff^2 = sigma^2 + e^2, it keeps the
stated uncertainty honest (:func:`inflated_sigma`).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from ..backends.embedded import EmbeddedBackend
from ..builders.registry import build_model, refined
from ..errors import InputError
from ..fem import memory
from ..fem.locate import PointsOutside
from ..model import Model
from ..options import ModelSpec
from .observations import FORCE, Observations

log = logging.getLogger(__name__)

#: polynomial degree of the displacement field of each cell type
ELEMENT_ORDER = {"triangle": 1, "quad": 1, "tetra": 1, "hexahedron": 1,
                 "triangle6": 2, "quad9": 2, "tetra10": 2, "hexahedron27": 2}
#: convergence order of a quantity kind minus the element order k for a smooth solution: u and force
#: O(h^(k+1)), strains O(h^k)
ORDER_OFFSET = {"u": 1, FORCE: 1, "e": 0}
#: order to which the contact edges' stress singularity (about r^(-1/2)) limits every quantity under uniform
#: refinement: its pollution error is O(h^(2 lambda)), lambda about 1/2 (measured: benchmarks/model_error.py)
SINGULAR_ORDER = 1
#: order used for strains under that cap: the one whose Richardson factor 2^p / (2^p - 1) = sqrt(2) is the
#: geometric mean of the factors of all orders in [1, inf) (module docstring)
STRAIN_ORDER = float(np.log2(2.0 + np.sqrt(2.0)))


def convergence_orders(element_order: int, singular: bool = True) -> dict[str, float]:
    """Convergence order p of each quantity kind ("u", "e", "force") on elements of ``element_order``.

    ``singular``: the model has contact edges (every frictional contact model here has), which cap p at
    :data:`SINGULAR_ORDER` for displacements and forces and make the strains' order unknown above it
    (:data:`STRAIN_ORDER`); False gives the a priori orders of a smooth solution.

    >>> convergence_orders(2), convergence_orders(2, singular=False)
    ({'u': 1, 'force': 1, 'e': 1.771553303163612}, {'u': 3, 'force': 3, 'e': 2})
    """
    if not singular:
        return {kind: element_order + offset for kind, offset in ORDER_OFFSET.items()}
    return {kind: STRAIN_ORDER if kind == "e" else SINGULAR_ORDER for kind in ORDER_OFFSET}


def richardson(coarse: np.ndarray, fine: np.ndarray, order, factor: int = 2) -> np.ndarray:
    """Error of ``coarse`` (values on mesh size h) from ``fine`` (h / factor): (coarse - fine) r^p / (r^p - 1).

    ``order``: p, a number or one per value. Signed, in the values' units.

    >>> richardson(np.array([1.04]), np.array([1.01]), 2).round(12)   # f = 1 + 0.04 h^2 at h = 1 and 1/2
    array([0.04])
    """
    gain = float(factor) ** np.asarray(order, dtype=float)
    return (np.asarray(coarse, dtype=float) - np.asarray(fine, dtype=float)) * gain / (gain - 1.0)


def observation_kinds(observations: Observations) -> np.ndarray:
    """(n_obs,) quantity kind of each observation: "u", "e" or "force" (the rows after the point rows)."""
    return np.where(observations.point < 0, FORCE, observations.kind).astype(str)


def _summary(values: np.ndarray) -> dict:
    return {"n": int(values.size), "rms": float(np.sqrt(np.mean(values ** 2))) if values.size else 0.0,
            "max": float(np.max(values)) if values.size else 0.0}


@dataclass(frozen=True)
class ModelError:
    """Estimated discretisation error of the model at each observation.

    Attributes
    ----------
    estimate : (n_obs,) magnitude of the error, in the observations' units ([mm], [-], [N])
    in_noise : (n_obs,) estimate / sigma
    kinds : (n_obs,) "u", "e" or "force"; stages : (n_obs,) 1-based stage of each observation
    orders : convergence order p used per quantity kind
    factor : refinement factor r; refined_options : the refined model's [model] table
    n_points : number of coefficient sets the estimate is the largest over
    seconds : wall time of the refined model's build, condensation and solves [s]
    scale : factor on ``estimate`` where it is used as extra variance (:func:`inflated_sigma`), a number or one
        per observation: the size of the error the data show relative to the estimate; 1 by default
    scales : {quantity: k_q} of mode "include" (``frictionid.inverse.discretisation.error_scales``): ``scale`` is
        each observation's quantity's; None otherwise
    signed : (n_obs,) the signed error (model minus converged value, observations' units) at the last
        coefficient set (an identification's fitted point): what the coarse model's values would be corrected
        by; it moves the fitted coefficients along the sensitivities, which the misfit alone cannot show
        (:func:`frictionid.inverse.adequacy.bias_shift`)
    before : (n_free,) the fitted free coefficients before the error was included in the weights (mode
        "include"; None otherwise): how far including it moves the fit is part of the coefficients' systematic
        error (:func:`frictionid.inverse.uncertainty.systematic_error`)
    """

    estimate: np.ndarray
    in_noise: np.ndarray
    kinds: np.ndarray
    stages: np.ndarray
    orders: dict
    factor: int
    refined_options: ModelSpec
    n_points: int
    seconds: float
    scale: float | np.ndarray = 1.0
    scales: dict | None = None
    signed: np.ndarray | None = None
    before: np.ndarray | None = None
    #: where the estimate comes from: the model refined by ``factor`` ("richardson") or the discretisation
    #: control's prediction for the fitted model ("discretisation control", :func:`from_control`)
    source: str = "richardson"
    summary: dict = field(init=False)

    def __post_init__(self):
        groups = {"all": np.ones(len(self.in_noise), bool)}
        groups |= {f"kind {k}": self.kinds == k for k in dict.fromkeys(self.kinds.tolist())}
        groups |= {f"stage {s}": self.stages == s for s in sorted(set(self.stages.tolist()))}
        object.__setattr__(self, "summary", {name: _summary(self.in_noise[mask]) for name, mask in groups.items()})

    def as_dict(self) -> dict:
        """JSON-ready: per-observation lists, the orders, the refined options and the summaries (in noise)."""
        return {"source": self.source, "estimate": self.estimate.tolist(), "in_noise": self.in_noise.tolist(),
                "orders": dict(self.orders), "factor": self.factor, "refined_options": self.refined_options.table(),
                "n_points": self.n_points,
                "seconds": self.seconds, "scale": float(np.max(self.scale, initial=0.0)),
                "scales": None if self.scales is None else dict(self.scales), "summary": self.summary,
                "signed": None if self.signed is None else self.signed.tolist(),
                "before_include": None if self.before is None else self.before.tolist()}


def from_control(remaining, observations: Observations, options: ModelSpec) -> ModelError:
    """The discretisation control's predicted error of the fitted model
    (:class:`~frictionid.inverse.remaining_error.RemainingError`) as a :class:`ModelError`: its magnitude at the
    control's orders as the estimate, signed as ``signed``; no extra condensation (``factor`` 1, the fitted
    ``options``). Made at the start values, like the control's decision."""
    kinds = observation_kinds(observations)
    estimate = np.abs(np.asarray(remaining.nominal, dtype=float))
    return ModelError(estimate=estimate, in_noise=estimate / observations.sigma, kinds=kinds,
                      stages=observations.stage + 1, orders=dict(remaining.orders), factor=1,
                      refined_options=options, n_points=1, seconds=0.0, signed=np.array(remaining.nominal),
                      source="discretisation control")


def inflated_sigma(observations: Observations, error: ModelError) -> np.ndarray:
    """(n_obs,) standard deviations with the model error as extra variance: sqrt(sigma^2 + (scale e)^2), scale
    a number or one per observation."""
    if error.estimate.shape != observations.sigma.shape:
        raise InputError(f"model error: {error.estimate.size} estimates for {observations.n_obs} observations")
    return np.hypot(observations.sigma, error.scale * error.estimate)


def _sizes(options: dict) -> str:
    """The size options of a [model] table, for progress lines."""
    keys = [k for k in options if "size" in k or "divisions" in k or k == "refine"]
    return ", ".join(f"{k} {options[k]:g}" if isinstance(options[k], (int, float)) else f"{k} {options[k]}"
                     for k in keys) or "the builder's defaults halved"


def _same_problem(coarse: Model, fine: Model, options: dict) -> None:
    """Refuse a refined model whose zones or stages differ from the coarse one's (they would not compare)."""
    stages = [(s.name, s.n_increments) for s in coarse.stages], [(s.name, s.n_increments) for s in fine.stages]
    if coarse.zone_names != fine.zone_names or stages[0] != stages[1]:
        raise InputError(f"[model] refined as {options}: zones {list(fine.zone_names)} and stages {stages[1]} differ "
                         f"from the model's {list(coarse.zone_names)} and {stages[0]}; it cannot estimate its error")


def _predictions(model: Model, observations: Observations, mu_points, keep: bool) -> list[np.ndarray]:
    """(n_obs,) model values at each coefficient set, from one condensation of ``model``."""
    obs = observations
    try:
        backend = EmbeddedBackend(model, obs.points, obs.quantities, obs.point_regions, obs.reactions, keep=keep)
    except PointsOutside as exc:
        raise exc.named(obs.point_labels, obs.source) from None
    return [obs.predicted(backend.predict(mu).values) for mu in mu_points]


def _checked_points(mu_points, n_zones: int) -> list[np.ndarray]:
    points = [np.asarray(mu, dtype=float) for mu in mu_points]
    if not points or any(mu.shape != (n_zones,) for mu in points):
        raise InputError(f"model error: `mu_points` must be a non-empty list of ({n_zones},) coefficient arrays "
                         f"(one value per zone), got shapes {[mu.shape for mu in points]}")
    return points


def _checked_values(values, n_points: int, n_obs: int) -> list[np.ndarray]:
    values = [np.asarray(v, dtype=float) for v in values]
    if len(values) != n_points or any(v.shape != (n_obs,) for v in values):
        raise InputError(f"model error: `coarse_values` must hold one ({n_obs},) array per coefficient set "
                         f"({n_points}), got shapes {[v.shape for v in values]}")
    return values


def _checked_orders(orders: dict, kinds: np.ndarray) -> dict:
    """The orders of the observed kinds; each must be a positive number."""
    used = {k: orders.get(k) for k in dict.fromkeys(kinds.tolist())}
    for kind, p in used.items():
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not p > 0:
            raise InputError(f"model error: `orders` {kind!r} must be a positive number, got {p!r}")
    return used


def estimate_model_error(model_options: ModelSpec, observations: Observations, mu_points, coarse_values=None,
                         factor: int = 2, model: Model | None = None, orders: dict | None = None,
                         max_memory: float | None = None, progress=None) -> ModelError:
    """Richardson estimate of the model's discretisation error at each observation (module docstring).

    Parameters
    ----------
    model_options : the [model] of the model the identification uses (see :func:`~frictionid.builders.
        registry.refined`)
    observations : Observations
    mu_points : list of (n_zones,) coefficient sets (all zones, model order), e.g. an identification's start and
        end; the largest error magnitude over them is kept per observation
    coarse_values : list of (n_obs,) model values at ``mu_points`` (e.g. ``Evaluator.model_values``), optional;
        computed with an :class:`EmbeddedBackend` (reused from the session's kept condensation if any) if absent
    factor : refinement factor r of the element sizes
    model : the model ``model_options`` build, if already built (to check zones and stages without rebuilding)
    orders : convergence order p per quantity kind ("u", "e", "force"); default :func:`convergence_orders` of
        the model's element order
    max_memory : [GB] what the refined model's condensation may take ([solver] max_memory; default a fraction of
        the machine's, :mod:`frictionid.fem.memory`): checked before its mesh is built (from the model's size)
        and before it is condensed (from its own)
    progress : called with one line of text per phase (refined model's size, memory estimate, time taken)

    Returns
    -------
    ModelError
        Costs one condensation of the refined model and a forward solve per coefficient set.

    Raises
    ------
    InputError
        When the model cannot be refined (builder without size options), refines into other zones or stages, or
        its condensation would take more memory than ``max_memory``.
    """
    fine_spec = refined(model_options, factor)
    fine_options = fine_spec.table()
    coarse_model = model if model is not None else build_model(model_options)
    mu_points = _checked_points(mu_points, coarse_model.n_zones)
    coarse = None if coarse_values is None else _checked_values(coarse_values, len(mu_points), observations.n_obs)
    kinds = observation_kinds(observations)
    orders = _checked_orders({**convergence_orders(ELEMENT_ORDER[coarse_model.mesh.cell_type]), **(orders or {})},
                             kinds)
    progress = progress or (lambda text: None)
    what = f"model error: the model refined by {factor} ({_sizes(fine_options)})"
    memory.check_growth(coarse_model, factor, what, max_memory)
    start = time.perf_counter()
    progress(f"{what}: building its mesh")
    fine_model = build_model(fine_spec, "[model] (refined)")
    _same_problem(coarse_model, fine_model, fine_options)
    progress(memory.check(fine_model, what, max_memory).line() + "; condensing")
    fine = _predictions(fine_model, observations, mu_points, keep=False)
    seconds = time.perf_counter() - start
    log.info("model error: refined model %s built, condensed and solved %d times in %.1f s", fine_options,
             len(mu_points), seconds)
    progress(f"{what}: built, condensed and solved {len(mu_points)} time(s) in {seconds:.1f} s")
    if coarse is None:
        coarse = _predictions(coarse_model, observations, mu_points, keep=True)
    p = np.array([orders[k] for k in kinds], dtype=float)
    errors = [richardson(c, f, p, factor) for c, f in zip(coarse, fine)]
    estimate = np.max(np.abs(errors), axis=0)
    return ModelError(estimate=estimate, in_noise=estimate / observations.sigma, kinds=kinds,
                      stages=observations.stage + 1, orders=orders, factor=factor, refined_options=fine_spec,
                      n_points=len(mu_points), seconds=seconds, signed=errors[-1])
