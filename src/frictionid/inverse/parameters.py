"""Parameters: one friction coefficient per zone, named as the zone, with start value, bounds and fixed flag."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..options import DEFAULT_BOUNDS


@dataclass(frozen=True)
class Parameter:
    """A zone's coefficient: ``value`` is the start (free, within [min, max]) or the held value (fixed).

    >>> Parameter("A", 0.1, max=0.6)
    Parameter(name='A', value=0.1, min=0.0, max=0.6, vary=True)
    """

    name: str
    value: float
    min: float = DEFAULT_BOUNDS[0]
    max: float = DEFAULT_BOUNDS[1]
    vary: bool = True

    def __post_init__(self):
        _check(self, f"parameter {self.name!r}:")


@dataclass(frozen=True)
class Parameters:
    """The coefficients of a model's zones, in the model's zone order; built in code from
    :class:`Parameter` items or with :meth:`from_dict`, from a config's [friction] table with :meth:`from_config`.

    >>> params = Parameters.from_dict({"A": 0.1, "B": 0.1}, bounds={"A": (0.0, 0.6)}, fixed={"nut": 0.15})
    >>> params.free_names, params.upper.tolist()
    (('A', 'B'), [0.6, 1.0])
    """

    items: tuple[Parameter, ...]

    def __post_init__(self):
        object.__setattr__(self, "items", tuple(self.items))
        names = [p.name for p in self.items]
        if not all(isinstance(p, Parameter) for p in self.items):
            raise InputError("Parameters takes Parameter items")
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise InputError(f"parameters: zone(s) {twice} given more than once")
        if not any(p.vary for p in self.items):
            raise InputError("parameters: every zone is fixed; nothing to identify")

    @classmethod
    def from_dict(cls, zones: dict, bounds=DEFAULT_BOUNDS, fixed: dict | None = None,
                  where: str = "parameters") -> "Parameters":
        """Free zones with their start values, ``fixed`` zones with their held values.

        ``bounds`` is one pair [lower, upper] for every free zone or a table zone -> pair, where the key "*"
        gives the pair of the zones not named (default :data:`DEFAULT_BOUNDS`).
        """
        if not isinstance(zones, dict) or fixed is not None and not isinstance(fixed, dict):
            raise InputError(f"{where}: zones and fixed must be tables of zone = value")
        fixed = dict(fixed or {})
        both = sorted(set(zones) & set(fixed))
        if both:
            raise InputError(f"{where}: zone(s) {both} are both in 'zones' and in 'fixed'")
        pairs = _zone_bounds(bounds, zones, where)
        items = []
        for name, start in zones.items():
            lower, upper = pairs[name]
            value = _number(start, f"{where} zones.{name}")
            if not lower <= value <= upper:
                raise InputError(f"{where} zones.{name} = {value} lies outside bounds [{lower}, {upper}]")
            items.append(Parameter(name, value, lower, upper))
        for name, held in fixed.items():
            value = _number(held, f"{where} fixed.{name}")
            if value < 0:
                raise InputError(f"{where} fixed.{name} = {value}: a friction coefficient cannot be negative")
            items.append(Parameter(name, value, min(value, DEFAULT_BOUNDS[0]), max(value, DEFAULT_BOUNDS[1]),
                                   vary=False))
        if not any(p.vary for p in items):
            raise InputError(f"{where}: every zone is fixed; nothing to identify")
        return cls(tuple(items))

    @classmethod
    def from_config(cls, zone_names, zones: dict, bounds=DEFAULT_BOUNDS, fixed: dict | None = None,
                    where: str = "[friction]") -> "Parameters":
        """Validate the [friction] table against the model's zones.

        >>> Parameters.from_config(("A", "B"), {"A": 0.1}, fixed={"B": 0.15}).free_names
        ('A',)
        """
        return cls.from_dict(zones, bounds, fixed, where).ordered_as(zone_names, where)

    def ordered_as(self, zone_names, where: str = "parameters") -> "Parameters":
        """The same parameters in the order of a model's zones; every zone must have one, and no other."""
        by_name = {p.name: p for p in self.items}
        for key, vary in (("zones", True), ("fixed", False)):
            unknown = [p.name for p in self.items if p.vary is vary and p.name not in zone_names]
            if unknown:
                raise InputError(f"{where} {key}: unknown zone(s) {unknown}; the model's zones are {list(zone_names)}")
        missing = [z for z in zone_names if z not in by_name]
        if missing:
            raise InputError(f"{where} zones: no start value for zone(s) {missing}; give one in 'zones' "
                             "or hold them in 'fixed'")
        return Parameters(tuple(by_name[z] for z in zone_names))

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


def _check(p: Parameter, where: str) -> None:
    for key in ("value", "min", "max"):
        _number(getattr(p, key), f"{where} {key}")
    if p.min < 0:
        raise InputError(f"{where} lower bound {p.min} is negative; friction coefficients are >= 0")
    if p.vary and not p.min < p.max:
        raise InputError(f"{where} bounds [{p.min}, {p.max}]: the lower bound must be below the upper")
    if p.vary and not p.min <= p.value <= p.max:
        raise InputError(f"{where} start value {p.value} lies outside bounds [{p.min}, {p.max}]")
    if not p.vary and p.value < 0:
        raise InputError(f"{where} held value {p.value}: a friction coefficient cannot be negative")


def _number(value, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
            or not np.isfinite(value):
        raise InputError(f"{key} must be a finite number, got {value!r}")
    return float(value)


def _zone_bounds(bounds, zones: dict, where: str) -> dict[str, tuple[float, float]]:
    """Bounds per free zone from one pair or a table zone -> pair (key "*": the others)."""
    if not isinstance(bounds, dict):
        pair = _bounds(bounds, f"{where} bounds")
        return {name: pair for name in zones}
    unknown = [k for k in bounds if k != "*" and k not in zones]
    if unknown:
        raise InputError(f"{where} bounds: zone(s) {unknown} are not free zones; the free zones are {list(zones)}")
    default = _bounds(bounds.get("*", DEFAULT_BOUNDS), f"{where} bounds.*")
    return {name: _bounds(bounds[name], f"{where} bounds.{name}") if name in bounds else default for name in zones}


def _bounds(bounds, key: str) -> tuple[float, float]:
    if not isinstance(bounds, (list, tuple)) or len(bounds) != 2:
        raise InputError(f"{key} must be a pair [lower, upper], got {bounds!r}")
    lower, upper = (_number(b, key) for b in bounds)
    if lower < 0:
        raise InputError(f"{key}: lower bound {lower} is negative; friction coefficients are >= 0")
    if not lower < upper:
        raise InputError(f"{key} [{lower}, {upper}]: the lower bound must be below the upper")
    return lower, upper
