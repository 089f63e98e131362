"""Running identifications: the run store that makes runs resumable, and executors."""

from .store import Evaluation, Iteration, RunStore

__all__ = ["Evaluation", "Iteration", "RunStore"]
