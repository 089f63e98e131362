"""Forward solver backends: each turns zone coefficients into observations (and, if it can, their derivatives).

``make_backend`` picks one by name ([solver] backend of a config): "embedded" (the condensed solver of
frictionid.fem, with analytic sensitivities) or "calculix" (ccx runs, finite differences only).
"""

from __future__ import annotations

import logging

from ..errors import InputError
from .base import Backend, BackendFactory, Prediction

log = logging.getLogger(__name__)
__all__ = ["Backend", "BackendFactory", "Prediction", "check_backend", "make_backend", "solver_options"]
BACKENDS = ("embedded", "calculix")
#: smallest finite-difference step that stays clear of ccx's 7 printed digits (see README, CalculiX backend)
CALCULIX_MIN_STEP = 1e-3


def make_backend(name: str, model, points, quantities, regions=None, options: dict | None = None,
                 where: str = "[solver]", reactions: tuple[str, ...] = (), window: float | None = None) -> Backend:
    """The backend called ``name`` for a model and its observation points.

    Parameters
    ----------
    name : "embedded" | "calculix"
    model : Model
    points : (n, dim) [mm]; quantities : observed quantities; regions : region of each point (or None)
    options : the [solver] keys (``ccx``, ``timeout``, ``keep_work``, ``work_dir``, ``threads``, ``contact``,
        ``normal_stiffness``, ``stick_slope``, ``load_scale``: see
        :class:`~frictionid.backends.calculix.backend.CalculixSettings`); the embedded backend reads
        ``factorisation`` ("auto", "cholmod", "superlu": how the condensation factorises the stiffness) and
        ``increments`` ("fixed", "adaptive": :meth:`~frictionid.fem.problem.Problem.solve`) and ``sliding``
        ("small", "finite": contact pairs fixed or re-coupled in the deformed configuration) and ignores the others.
    where : how messages name the options' origin
    reactions : labels of reaction sums ("boundary.axis") appended as rows after the point rows
    window : DIC strain window [mm] of the strains ([data] strain_window), embedded backend only

    Raises
    ------
    InputError
        For an unknown backend, a bad option, or ccx not found.
    """
    if name == "embedded":
        from .embedded import EmbeddedBackend

        return EmbeddedBackend(model, points, quantities, regions, reactions=tuple(reactions), window=window,
                               factorisation=(options or {}).get("factorisation", "auto"),
                               increments=(options or {}).get("increments", "fixed"),
                               sliding=(options or {}).get("sliding", "small"))
    if name == "calculix":
        if window is not None:
            raise InputError("data.strain_window needs the embedded backend: the calculix backend reads strains "
                             "at the points only")
        from .calculix.backend import CalculixBackend, CalculixSettings

        return CalculixBackend(model, points, quantities, regions, CalculixSettings.from_options(options or {}, where),
                               reactions=reactions)
    raise InputError(f"{where} backend = {name!r} is not one of {list(BACKENDS)}")


def check_backend(name: str, jacobian: str | None = None, options: dict | None = None,
                  where: str = "[solver]", step: float | None = None) -> None:
    """Refuse, before anything is built, a backend that does not exist, cannot run, or cannot give ``jacobian``.

    A finite-difference ``step`` below :data:`CALCULIX_MIN_STEP` with ccx is allowed but logged: the printed
    displacements have 7 digits, so small steps leave mostly round-off in the differences.
    """
    if name not in BACKENDS:
        raise InputError(f"{where} backend = {name!r} is not one of {list(BACKENDS)}")
    if name == "calculix":
        from .calculix.backend import CalculixSettings
        from .calculix.runner import find_ccx

        if jacobian == "analytic":
            raise InputError(f"{where} backend = 'calculix' has no analytic sensitivities; set identify.jacobian "
                             "= 'forward' or 'central' (finite differences, parallel with run.workers)")
        find_ccx(CalculixSettings.from_options(options or {}, where).ccx)
        if step is not None and step < CALCULIX_MIN_STEP:
            log.warning("%s identify.step = %g is small for ccx results (7 printed digits); %g or more keeps "
                        "round-off out of the finite differences", where, step, CALCULIX_MIN_STEP)


def solver_options(config) -> dict:
    """The [solver] table of a config with ``work_dir`` resolved against the config's folder."""
    options = dict(config.solver)
    if options.get("work_dir"):
        options["work_dir"] = str(config.resolve(options["work_dir"]))
    return options
