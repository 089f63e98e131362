"""Iterates: memoised evaluations and the record of accepted iterations of one optimiser run."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np

from ..errors import InputError, SolverError
from .least_squares import LeastSquares, OptimiseResult

log = logging.getLogger(__name__)

# Optimisers ask for the same x more than once (scipy evaluates r at an iterate, then the Jacobian there);
# a few entries cover that without holding on to many large Jacobians.
_MEMO_SIZE = 8


class Iterates:
    """Evaluations of a :class:`LeastSquares` problem and the accepted iterates of one optimiser run.

    Every residual and Jacobian evaluation goes through here, memoised by the exact bytes of x, so that
    recording an iterate scipy has just evaluated costs no extra forward solve. The problem's callables
    always receive a copy of x and callers receive copies of what is stored, so nothing a method does can
    change the caller's arrays or the record.

    Parameters
    ----------
    problem : LeastSquares
        The problem; its ``x0`` is read, never written.
    """

    def __init__(self, problem: LeastSquares):
        self.problem = problem
        self.n_residuals = 0
        self.n_jacobians = 0
        self._residuals: dict[bytes, np.ndarray] = {}
        self._jacobians: dict[bytes, np.ndarray] = {}
        self._x: list[np.ndarray] = []
        self._objective: list[float] = []

    @property
    def n_iterations(self) -> int:
        """Accepted iterations so far (the start is iteration 0)."""
        return len(self._x) - 1

    @property
    def x(self) -> np.ndarray:
        """The last accepted iterate (a copy)."""
        return self._x[-1].copy()

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """r(x) (n_res,), evaluated once per distinct x among the last few."""
        r, evaluated = _memoised(self._residuals, x, self.problem.residuals)
        self.n_residuals += evaluated
        return r.copy()

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """dr/dx (n_res, n_free), evaluated once per distinct x among the last few."""
        jac, evaluated = _memoised(self._jacobians, x, self.problem.jacobian)
        self.n_jacobians += evaluated
        return jac.copy()

    def objective(self, x: np.ndarray) -> float:
        """J(x) = ||r(x)||^power."""
        return self.problem.objective(self.residuals(x))

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """dJ/dx (n_free,) from r(x) and the problem's Jacobian."""
        return self.problem.gradient(self.residuals(x), self.jacobian(x))

    def accept(self, x: np.ndarray) -> int:
        """Record x as the next accepted iterate, report it to ``problem.progress`` and return its number.

        Raises
        ------
        SolverError
            If the objective at the start (iteration 0) is not finite.
        """
        x = np.array(x, dtype=float)  # scipy updates its iterate in place
        objective = self.objective(x)
        if not self._x and not np.isfinite(objective):
            raise SolverError(f"the objective at the start x0 = {x.tolist()} is {objective}; "
                              "the residuals must be finite there")
        self._x.append(x)
        self._objective.append(objective)
        iteration = self.n_iterations
        log.debug("iteration %d: J = %.6e at x = %s", iteration, objective, x.tolist())
        self.problem.progress(iteration, x.copy(), objective)
        return iteration

    def result(self, status: str, message: str, options: dict) -> OptimiseResult:
        """The run as an :class:`OptimiseResult`: the last accepted iterate and the whole history (read-only)."""
        history_x = _read_only(np.array(self._x, dtype=float).reshape(len(self._x), -1))
        history_objective = _read_only(np.array(self._objective, dtype=float))
        log.info("%s after %d iterations (%d residual, %d Jacobian evaluations): J = %.6e; %s", status,
                 self.n_iterations, self.n_residuals, self.n_jacobians, history_objective[-1], message)
        return OptimiseResult(x=_read_only(history_x[-1].copy()), objective=float(history_objective[-1]),
                              status=status, message=message, n_iterations=self.n_iterations,
                              history_x=history_x, history_objective=history_objective, options=dict(options))


def _memoised(memo: dict, x: np.ndarray, evaluate: Callable) -> tuple[np.ndarray, bool]:
    """The stored value for x, or evaluate(copy of x) stored; and whether it was evaluated now."""
    key = np.asarray(x, dtype=float).tobytes()
    if key in memo:
        return memo[key], False
    value = np.array(evaluate(np.array(x, dtype=float)), dtype=float)
    if len(memo) >= _MEMO_SIZE:
        memo.pop(next(iter(memo)))
    memo[key] = value
    return value, True


def _read_only(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Option:
    """One option of a method: its kind ("float", "int", "bool", "scale" or "str"), a check and a default.

    ``default(max_iterations, tol, n_free)`` gives the value when the caller does not set one;
    ``valid(value)`` is True for acceptable values, described by ``expected`` in error messages.
    """

    kind: str
    default: Callable[[int, float, int], object]
    valid: Callable[[object], bool] = lambda value: True
    expected: str = ""


_KINDS = {
    "float": lambda v: isinstance(v, Real) and not isinstance(v, bool),
    "int": lambda v: isinstance(v, Integral) and not isinstance(v, bool),
    "bool": lambda v: isinstance(v, (bool, np.bool_)),
    "scale": lambda v: v in ("jac", "se") if isinstance(v, str) else isinstance(v, Real) and not isinstance(v, bool),
    "str": lambda v: isinstance(v, str),
}
_KIND_NAMES = {"float": "a number", "int": "an integer", "bool": "true or false", "scale": '"jac", "se" or a number',
               "str": "a string"}


def resolve_options(method: str, spec: dict[str, Option], given: dict | None, max_iterations: int,
                    tol: float, n_free: int) -> dict:
    """The method's options with defaults filled in; InputError naming the key for an unknown or bad one."""
    given = {} if given is None else given
    if not isinstance(given, dict):
        raise InputError(f"options for method {method!r} must be a table (dict), not {type(given).__name__}")
    unknown = sorted(set(given) - set(spec))
    if unknown:
        raise InputError(f"option {unknown[0]!r} is not an option of method {method!r}; "
                         f"its options are {sorted(spec)}")
    resolved = {}
    for key, option in spec.items():
        value = given[key] if key in given else option.default(max_iterations, tol, n_free)
        if not _KINDS[option.kind](value) or not option.valid(value):
            expected = " ".join(filter(None, [_KIND_NAMES[option.kind], option.expected]))
            raise InputError(f"option {key!r} of method {method!r} must be {expected}, not {value!r}")
        resolved[key] = float(value) if option.kind == "float" else value
    return resolved
