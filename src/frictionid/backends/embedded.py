"""The embedded backend: the condensed frictional-contact solver of frictionid.fem."""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import pickle
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..fem.problem import SLIP_TOLERANCE, Problem, sensitivity_zones
from ..model import Model
from .base import Prediction


log = logging.getLogger(__name__)
_RECENT: dict = {}
#: condensations kept for reuse: an identification's and its pre-fit candidates' (see :func:`_built`)
N_KEPT = 2
_CACHE: list[Path] = []


@contextlib.contextmanager
def cache_in(folder: str | Path):
    """:func:`use_cache` for the duration of a ``with`` block; the previous setting afterwards."""
    previous = list(_CACHE)
    use_cache(folder)
    try:
        yield
    finally:
        _CACHE[:] = previous


def use_cache(folder: str | Path | None) -> None:
    """Store condensations and the solves made with them in ``folder`` (None: nowhere) and reuse them from there
    in later sessions.

    A condensation is filed under a hash of the model's content (:meth:`Model.fingerprint`), the observation
    points, quantities and regions, and the solver's source code, so any change to one of them builds anew. Files are
    a few MB (plane strain) to tens of MB (3-D); the folder is the caller's to remove.
    """
    _CACHE[:] = [] if folder is None else [Path(folder)]


def _code_version() -> str:
    """Hash of the source of the packages a condensation depends on: a changed solver never reads old files."""
    root = Path(__file__).parents[1]
    digest = hashlib.sha256()
    for path in sorted([*(root / "fem").glob("*.py"), *(root / "model").glob("*.py")]):
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _cached(key, kind: str = "condensed", *extra) -> Path | None:
    """The cache file of a condensation (or of one of its solves: ``kind`` "predicted" and the solve's
    arguments in ``extra``), None without a cache folder."""
    if not _CACHE:
        return None
    digest = hashlib.sha256(repr((key, _code_version(), *extra)).encode()).hexdigest()[:32]
    return _CACHE[0] / f"{kind}-{digest}.{'pkl' if kind == 'condensed' else 'npz'}"


def _key(model: Model, points, quantities: tuple[str, ...], regions, window=None, factorisation="auto",
         sliding="small") -> tuple:
    return ((model.fingerprint(), None if points is None else np.asarray(points, dtype=float).tobytes(),
             quantities, None if regions is None else tuple(regions)) + (() if window is None else (window,))
            + (() if factorisation == "auto" else (factorisation,)) + (() if sliding == "small" else (sliding,)))


def _load_or_build(key, model: Model, points, quantities, regions, window=None, factorisation="auto",
                   sliding="small") -> Problem:
    path = _cached(key)
    if path is not None and path.exists():
        try:
            with path.open("rb") as handle:
                problem = pickle.load(handle)
            if problem.model.fingerprint() == key[0]:
                log.info("condensation read from %s", path)
                return problem
        except Exception as exc:                              # a truncated or stale file: build anew
            log.warning("condensation cache %s unreadable (%s); building it again", path, exc)
    for kept in _RECENT.values():       # their factors (kept for the displacement field) not beside a new one
        kept.condensed.inverse.release()
    problem = Problem.build(model, points=points, quantities=quantities, regions=regions, window=window,
                            factorisation=factorisation, sliding=sliding)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(f".{os.getpid()}.part")
        with partial.open("wb") as handle:
            pickle.dump(problem, handle, protocol=pickle.HIGHEST_PROTOCOL)
        partial.replace(path)                                  # whole files only, also when interrupted
    return problem


def holds(model: Model, points, quantities, regions, window: float | None = None, factorisation: str = "auto",
          sliding: str = "small") -> bool:
    """Whether this session keeps the condensation a backend of these arguments would use (making one then
    condenses nothing: a study's later runs on the same model and points)."""
    points = None if points is None or len(points) == 0 or not quantities else points
    return _key(model, points, tuple(quantities), regions, window, factorisation, sliding) in _RECENT


def _built(model: Model, points, quantities: tuple[str, ...], regions, keep: bool = True,
           window: float | None = None, factorisation: str = "auto", sliding: str = "small") -> Problem:
    """Problem.build, reusing a recent build when model and observation points are the same in content.

    Runs of one session (a study's several identifications, an example's methods) share the condensation;
    at most :data:`N_KEPT` builds are kept, and a new condensation frees their factors (kept for the displacement
    field, made again where it is asked for), so memory holds no factorisation besides the one being made.
    ``keep=False``: a one-off build (e.g. a refined mesh for an error estimate) that uses a kept build if there
    is one but neither stores itself nor pushes a kept build out. With :func:`use_cache` the builds are also
    stored on disk and read back in later sessions. ``factorisation``: how the condensation factorises the
    stiffness (:meth:`Problem.build`); builds with another factorisation are not reused; nor with another
    ``sliding`` ("small" or "finite", :meth:`Problem.build`).
    """
    key = _key(model, points, quantities, regions, window, factorisation, sliding)
    if key in _RECENT:
        _RECENT[key] = _RECENT.pop(key)                        # most recently used last
        return _RECENT[key]
    if not keep:
        return _load_or_build(key, model, points, quantities, regions, window, factorisation, sliding)
    while len(_RECENT) >= N_KEPT:
        _RECENT.pop(next(iter(_RECENT)))
    _RECENT[key] = _load_or_build(key, model, points, quantities, regions, window, factorisation, sliding)
    return _RECENT[key]


class EmbeddedBackend:
    """Condenses the model once; each :meth:`predict` is one load path with optional sensitivities.

    ``reactions``: labels of reaction sums ("boundary.axis", e.g. "block_top.y", the machine force of the
    block test) appended as rows after the point rows; none by default. ``keep``: whether the condensation is
    kept for reuse by later backends of the same session (see :func:`_built`). ``window`` [mm]: the DIC strain
    window the model's strains are filtered with ([data] strain_window; :func:`frictionid.fem.points.point_operator`).
    ``factorisation``: "auto", "cholmod", "superlu" or "mumps", the condensation's factorisation ([solver] factorisation).
    ``increments``: "fixed" or "adaptive", how each solve steps through the stages ([solver] increments).
    ``sliding``: "small" or "finite" ([solver] sliding, :meth:`Problem.build`).
    ``slip_tolerance``: the small-sliding check's tolerance, or False: no check ([solver] slip_tolerance,
    :meth:`Problem.check_small_sliding`).
    """

    name = "embedded"
    has_sensitivities = True

    def __init__(self, model: Model, points: np.ndarray, quantities: tuple[str, ...], regions=None,
                 reactions: tuple[str, ...] = (), keep: bool = True, window: float | None = None,
                 factorisation: str = "auto", increments: str = "fixed", sliding: str = "small",
                 slip_tolerance: float | bool = SLIP_TOLERANCE):
        self.model = model
        self.increments = increments
        self.max_slip = None if slip_tolerance is False else float(slip_tolerance)
        self._last = None                       # (mu, solution) of the last predict
        points = None if points is None or len(points) == 0 or not quantities else points
        self.problem = _built(model, points, tuple(quantities), regions, keep, window, factorisation, sliding)
        unknown = [r for r in reactions if r not in self.problem.reaction_labels]
        if unknown:
            raise InputError(f"model: no reaction {unknown}; the model's reactions are "
                             f"{list(self.problem.reaction_labels)}")
        self.reactions = tuple(reactions)
        self._reaction_rows = [self.problem.reaction_labels.index(r) for r in self.reactions]
        self._key = _key(model, points, tuple(quantities), regions, window, factorisation, sliding) \
            + ((increments,) if increments != "fixed" else ()) if _CACHE else None

    def predict(self, mu: np.ndarray, sensitivities: bool | Sequence[int] = False) -> Prediction:
        """The observation rows at ``mu``; ``sensitivities`` as :meth:`Problem.solve`'s (True, False or the zones'
        indices: a fit's free zones, the others' derivatives NaN); with :func:`use_cache` read from (or written
        to) the cache folder."""
        mu = np.asarray(mu, dtype=float)
        zones = sensitivity_zones(sensitivities, self.model.n_zones)
        taken = None if zones is None else tuple(zones.tolist())
        path = None if self._key is None else _cached(self._key, "predicted", mu.tobytes(), taken, self.reactions)
        if path is not None and path.exists():
            with np.load(path) as stored:
                return Prediction(stored["values"], stored["derivatives"] if zones is not None else None)
        solution = self.problem.solve(mu, sensitivities=zones if zones is not None else False,
                                      increments=self.increments, max_slip=None)
        # kept for check_sliding and fields at the same mu (simulate's one solve; a fit's last solve, often at its
        # answer): the contact unknowns and the observation rows per increment, without the displacement field
        self._last = (mu.copy(), solution)
        ends = [solution.stage_end(s) for s in range(self.model.n_stages)]
        values = np.hstack([solution.observations[ends], solution.reactions[ends][:, self._reaction_rows]])
        derivatives = None
        if solution.d_observations is not None:
            derivatives = np.concatenate([solution.d_observations[ends],
                                          solution.d_reactions[ends][:, self._reaction_rows]], axis=1)
        if path is not None:
            partial = path.with_suffix(f".{os.getpid()}.part.npz")
            np.savez(partial, values=values, derivatives=derivatives if derivatives is not None else np.zeros(0))
            partial.replace(path)
        return Prediction(values, derivatives)

    def point_sensitivities(self, mu: np.ndarray, points, quantities: tuple[str, ...], regions=None):
        """(n_stages, n_points * n_quantities, n_zones) derivatives of ``quantities`` at other points than the
        observed ones at ``mu`` (point-major; strains pointwise: scattered points make no DIC window), from this
        backend's condensation: no second condensation, the solve of the last :meth:`predict` where it was at
        ``mu`` with sensitivities, else one solve with sensitivities (:meth:`Problem.point_sensitivities`). None
        where the condensation cannot give them (finite sliding): make a backend for the points instead."""
        mu = np.asarray(mu, dtype=float)
        d_x = None if self._last is None or not np.array_equal(self._last[0], mu) else self._last[1].d_x
        if d_x is not None and np.isfinite(d_x).all():
            solution = self._last[1]
        else:
            solution = self.problem.solve(mu, sensitivities=True, increments=self.increments, max_slip=None)
        return self.problem.point_sensitivities(solution, points, quantities, regions)

    def contact_states(self, mu: np.ndarray) -> list[dict[str, dict[str, float]]]:
        """Per stage end: each zone's area fractions open / stick / slip and its normal force [N] at ``mu``."""
        solution = self.problem.solve(mu, increments=self.increments, max_slip=None)
        out = []
        for stage in range(self.model.n_stages):
            end = solution.stage_end(stage)
            states = solution.zone_state(end)
            normal = solution.zone_normal_force[end]
            out.append({zone: {**states[zone], "normal_force": float(normal[z])}
                        for z, zone in enumerate(solution.zone_names)})
        return out

    def stick_thresholds(self, mu: np.ndarray, movable=None) -> np.ndarray:
        """(n_zones,) each zone's stick threshold at ``mu`` (:meth:`Solution.stick_thresholds`): one forward
        solve."""
        return self.problem.solve(mu, increments=self.increments, max_slip=None).stick_thresholds(movable)

    def fields(self, mu):
        """Displacement, strain and contact fields at every stage end at ``mu``: one forward solve, or none where
        :meth:`predict` solved at ``mu`` last (see :func:`frictionid.fem.fields.solution_fields`)."""
        from ..fem.fields import solution_fields

        if self._last is not None and np.array_equal(self._last[0], self.model.coefficients(mu)):
            solution = self._last[1]
        else:
            solution = self.problem.solve(mu, increments=self.increments, max_slip=None)
        return solution_fields(self.problem, solution)

    def check_sliding(self, mu: np.ndarray) -> None:
        """Raise :class:`~frictionid.errors.SolverError` when the solution at ``mu`` lies beyond small sliding
        (:meth:`Problem.check_small_sliding` at ``slip_tolerance``; nothing with False or finite sliding): one
        forward solve and the check. The other methods solve without it: the check costs several solves' time
        (the deformed coupling's search), and it is the answer that must lie within small sliding, not each trial
        point of a fit (:func:`frictionid.identification.identify_config` checks the fitted point, ``simulate``
        its one solve, whose solution :meth:`predict` keeps for this)."""
        if self.max_slip is None:
            return
        mu = np.asarray(mu, dtype=float)
        if self._last is not None and np.array_equal(self._last[0], mu):
            self.problem.check_small_sliding(self._last[1], self.max_slip)
        else:
            self.problem.solve(mu, increments=self.increments, max_slip=self.max_slip)

    def __getstate__(self):
        return {**self.__dict__, "_last": None}    # a solution of this process, not shipped to workers
