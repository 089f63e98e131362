"""Forward solver backends: each turns zone coefficients into observations (and, if it can, their derivatives).

``make_backend`` picks the one ``[solver] backend`` names: "embedded" (the condensed solver of
frictionid.fem, with analytic sensitivities) or "calculix" (ccx runs, finite differences only).
"""

from __future__ import annotations

import logging

from ..errors import InputError
from ..options import SolverOptions
from .base import Backend, BackendFactory, Prediction

log = logging.getLogger(__name__)
__all__ = ["Backend", "BackendFactory", "Prediction", "check_backend", "make_backend"]
BACKENDS = ("embedded", "calculix")
#: smallest finite-difference step that stays clear of ccx's 7 printed digits (see README, CalculiX backend)
CALCULIX_MIN_STEP = 1e-3


def make_backend(model, points, quantities, regions=None, solver: SolverOptions = SolverOptions(),
                 where: str = "[solver]", reactions: tuple[str, ...] = (), window: float | None = None) -> Backend:
    """The backend ``solver.backend`` names for a model and its observation points.

    Parameters
    ----------
    model : Model
    points : (n, dim) [mm]; quantities : observed quantities; regions : region of each point (or None)
    solver : the [solver] options (:class:`~frictionid.options.SolverOptions`; default: the embedded backend).
        "embedded" (the condensed solver of frictionid.fem, analytic sensitivities) reads ``factorisation``
        ("auto", "cholmod", "superlu", "mumps": how the condensation factorises the stiffness), ``increments`` ("fixed",
        "adaptive": :meth:`~frictionid.fem.problem.Problem.solve`) and ``sliding`` ("small", "finite": contact
        pairs fixed or re-coupled in the deformed configuration) and ``slip_tolerance`` (the small-sliding check's
        tolerance, or false); "calculix" (a ccx run per solve) the settings
        of :class:`~frictionid.backends.calculix.backend.CalculixSettings`.
    where : how messages name the options' origin
    reactions : labels of reaction sums ("boundary.axis") appended as rows after the point rows
    window : DIC strain window [mm] of the strains ([data] strain_window), embedded backend only

    Raises
    ------
    InputError
        For an unknown backend, or ccx not found.
    """
    if solver.backend == "embedded":
        from .embedded import EmbeddedBackend

        return EmbeddedBackend(model, points, quantities, regions, reactions=tuple(reactions), window=window,
                               factorisation=solver.factorisation, increments=solver.increments,
                               sliding=solver.sliding, slip_tolerance=solver.slip_tolerance)
    if solver.backend == "calculix":
        if window is not None:
            raise InputError("data.strain_window needs the embedded backend: the calculix backend reads strains "
                             "at the points only")
        from .calculix.backend import CalculixBackend, CalculixSettings

        return CalculixBackend(model, points, quantities, regions, CalculixSettings.from_solver(solver),
                               reactions=reactions)
    raise InputError(f"{where} backend = {solver.backend!r} is not one of {list(BACKENDS)}")


def check_backend(solver: SolverOptions, jacobian: str | None = None, where: str = "[solver]",
                  step: float | None = None) -> None:
    """Refuse, before anything is built, a backend that does not exist, cannot run, or cannot give ``jacobian``.

    A finite-difference ``step`` below :data:`CALCULIX_MIN_STEP` with ccx is allowed but logged: the printed
    displacements have 7 digits, so small steps leave mostly round-off in the differences.
    """
    if solver.backend not in BACKENDS:
        raise InputError(f"{where} backend = {solver.backend!r} is not one of {list(BACKENDS)}")
    if solver.backend == "calculix":
        from .calculix.runner import find_ccx

        if jacobian == "analytic":
            raise InputError(f"{where} backend = 'calculix' has no analytic sensitivities; set identify.jacobian "
                             "= 'forward' or 'central' (finite differences, parallel with run.workers)")
        find_ccx(solver.ccx)
        if step is not None and step < CALCULIX_MIN_STEP:
            log.warning("%s identify.step = %g is small for ccx results (7 printed digits); %g or more keeps "
                        "round-off out of the finite differences", where, step, CALCULIX_MIN_STEP)
