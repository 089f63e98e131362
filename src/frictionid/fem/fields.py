"""Fields of a forward solve at each stage end: nodal displacement, cell strains and the contact interface."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import Model
from .pairs import ContactPairs
from .points import QUANTITIES, cell_centre_operator
from .problem import Problem
from .solution import Solution


@dataclass(frozen=True)
class StageFields:
    """One stage end of a solution, on the model's mesh and on its contact pairs.

    Attributes
    ----------
    stage : 0-based stage index; name : the stage's name; increment : index of its last increment
    displacement : (n_nodes, dim) [mm] at every mesh node (axisymmetric: u_r, u_y)
    strain : quantity -> (n_cells,) small-strain tensor component at each cell's centre (tensor shear;
        plane strain ezz = 0; axisymmetric: exx = e_rr, ezz = hoop strain u_r / r, exy = e_ry)
    pressure : (n_pairs,) [MPa]; traction : (n_pairs, dim) [MPa] tangential traction in the global frame
    slip : (n_pairs, dim) [mm] accumulated tangential relative displacement in the global frame
    gap : (n_pairs,) [mm] current normal gap; state : (n_pairs,) 0 open, 1 stick, 2 slip
    """

    stage: int
    name: str
    increment: int
    displacement: np.ndarray
    strain: dict
    pressure: np.ndarray
    traction: np.ndarray
    slip: np.ndarray
    gap: np.ndarray
    state: np.ndarray


@dataclass(frozen=True)
class Fields:
    """The fields of one forward solve: the model, its zone coefficients (n_zones,), its contact pairs (positions,
    tributary areas [mm^2], zone shares) and one :class:`StageFields` per stage."""

    model: Model
    mu: np.ndarray
    pairs: ContactPairs
    stages: tuple[StageFields, ...]


def strain_names(kind: str) -> tuple[str, ...]:
    """The strain components a model kind has, in frictionid's quantity names (fem.points.QUANTITIES)."""
    return tuple(q for q in QUANTITIES[kind] if q.startswith("e"))


def _global(frames: np.ndarray, local: np.ndarray) -> np.ndarray:
    """(n_pairs, dim) vector from its tangential components (n_pairs, dim - 1) in the pair frames."""
    return np.einsum("pk,pkd->pd", local, frames[:, 1:, :])


def solution_fields(problem: Problem, solution: Solution) -> Fields:
    """The fields of ``solution`` (a solve of ``problem``) at the end of every stage.

    Displacements come from :meth:`Problem.displacement` (one solve with the stored factor per stage end),
    strains from :func:`~frictionid.fem.points.cell_centre_operator`, the contact data from the solution.

    Examples
    --------
    >>> problem = Problem.build(block_model_2d(mesh_size=2.0))                  # doctest: +SKIP
    >>> last = solution_fields(problem, problem.solve({"A": 0.3, "B": 0.2})).stages[-1]   # doctest: +SKIP
    """
    model, frames = problem.model, solution.pairs.frames
    names = strain_names(model.kind)
    operator, _ = cell_centre_operator(problem.space, names, model.materials)
    out = []
    for stage, spec in enumerate(model.stages):
        end = solution.stage_end(stage)
        u = problem.displacement(solution, end)
        strain = (operator @ u.ravel()).reshape(-1, len(names))
        out.append(StageFields(
            stage=stage, name=spec.name, increment=end, displacement=u,
            strain={name: strain[:, k] for k, name in enumerate(names)},
            pressure=solution.pressure[end], traction=_global(frames, solution.traction[end]),
            slip=_global(frames, solution.slip[end]), gap=solution.gap[end], state=solution.state[end]))
    return Fields(model, np.asarray(solution.mu, dtype=float), solution.pairs, tuple(out))
