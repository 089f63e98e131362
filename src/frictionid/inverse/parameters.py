"""Parameters: one friction coefficient per zone, named as the zone, with start value, bounds and fixed flag."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class Parameter:
    """A zone's coefficient: ``value`` is the start (free) or the held value (fixed)."""

    name: str
    value: float
    min: float = 0.0
    max: float = 1.0
    vary: bool = True


@dataclass(frozen=True)
class Parameters:
    """The coefficients of all zones of a model, in the model's zone order."""

    items: tuple[Parameter, ...]

    @classmethod
    def from_config(cls, zone_names, zones: dict, bounds=(0.0, 1.0), fixed: dict | None = None,
                    where: str = "[friction]") -> "Parameters":
        """Validate the [friction] table against the model's zones.

        >>> Parameters.from_config(("A", "B"), {"A": 0.1}, fixed={"B": 0.15}).free_names
        ('A',)
        """
        fixed = dict(fixed or {})
        lower, upper = _bounds(bounds, where)
        for table, key in ((zones, "zones"), (fixed, "fixed")):
            unknown = [z for z in table if z not in zone_names]
            if unknown:
                raise InputError(f"{where} {key}: unknown zone(s) {unknown}; the model's zones are {list(zone_names)}")
        both = sorted(set(zones) & set(fixed))
        if both:
            raise InputError(f"{where}: zone(s) {both} are both in 'zones' and in 'fixed'")
        missing = [z for z in zone_names if z not in zones and z not in fixed]
        if missing:
            raise InputError(f"{where} zones: no start value for zone(s) {missing}; give one in 'zones' "
                             "or hold them in 'fixed'")
        items = []
        for name in zone_names:
            value = _number(zones.get(name, fixed.get(name)), f"{where} {'fixed' if name in fixed else 'zones'}.{name}")
            if name in zones and not lower <= value <= upper:
                raise InputError(f"{where} zones.{name} = {value} lies outside bounds [{lower}, {upper}]")
            if name in fixed and value < 0:
                raise InputError(f"{where} fixed.{name} = {value}: a friction coefficient cannot be negative")
            items.append(Parameter(name, value, lower, upper, vary=name in zones))
        if not any(p.vary for p in items):
            raise InputError(f"{where}: every zone is fixed; nothing to identify")
        return cls(tuple(items))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.items)

    @property
    def free_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.items if p.vary)

    @property
    def free(self) -> np.ndarray:
        """(n_zones,) bool mask of the free zones."""
        return np.array([p.vary for p in self.items])

    @property
    def x0(self) -> np.ndarray:
        return np.array([p.value for p in self.items if p.vary])

    @property
    def lower(self) -> np.ndarray:
        return np.array([p.min for p in self.items if p.vary])

    @property
    def upper(self) -> np.ndarray:
        return np.array([p.max for p in self.items if p.vary])

    def full(self, x: np.ndarray) -> np.ndarray:
        """(n_zones,) coefficients of all zones from the free ones ``x``."""
        out = np.array([p.value for p in self.items], dtype=float)
        out[self.free] = x
        return out


def _number(value, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise InputError(f"{key} must be a finite number, got {value!r}")
    return float(value)


def _bounds(bounds, where: str) -> tuple[float, float]:
    if not isinstance(bounds, (list, tuple)) or len(bounds) != 2:
        raise InputError(f"{where} bounds must be a pair [lower, upper], got {bounds!r}")
    lower, upper = (_number(b, f"{where} bounds") for b in bounds)
    if lower < 0:
        raise InputError(f"{where} bounds: lower bound {lower} is negative; friction coefficients are >= 0")
    if not lower < upper:
        raise InputError(f"{where} bounds [{lower}, {upper}]: the lower bound must be below the upper")
    return lower, upper
