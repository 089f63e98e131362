"""IdentificationResult: an identification's outcome (result.json) as a read-only object with a report."""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType


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
