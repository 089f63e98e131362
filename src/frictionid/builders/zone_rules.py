"""Friction zones by rules: the facets of a contact surface split by where their centroids lie (box, half-space,
ring, sector, axial section, all), so that one mesh can be partitioned coarser or finer without re-meshing.

A rule is a name and one or more shapes; a facet matches the rule when its centroid lies in every one of them
(boundaries included, within a round-off tolerance). The first matching rule, in order, takes a facet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .arguments import checked_table

#: relative tolerance on a shape's boundary: a centroid this far outside (times the surface's size) still matches
TOLERANCE = 1e-9


def _vector(value, dim: int, where: str, infinite: bool = False) -> np.ndarray:
    """(dim,) floats from a list of numbers; ``infinite`` lets +-inf through (a box's open side)."""
    if isinstance(value, (str, dict)) or not isinstance(value, (list, tuple)) or len(value) != dim \
            or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value) \
            or any(math.isnan(v) or (math.isinf(v) and not infinite) for v in value):
        kind = "numbers (inf allowed)" if infinite else "finite numbers"
        raise InputError(f"{where}: must be a list of {dim} {kind}, one per coordinate, got {value!r}")
    return np.array(value, dtype=float)


def _direction(value, dim: int, where: str) -> np.ndarray:
    """A unit vector from a non-zero list of dim numbers."""
    vector = _vector(value, dim, where)
    norm = float(np.linalg.norm(vector))
    if norm == 0.0:
        raise InputError(f"{where}: must not be the zero vector, got {value!r}")
    return vector / norm


def _number(value, where: str, infinite: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value) \
            or (math.isinf(value) and not infinite):
        raise InputError(f"{where}: must be a number, got {value!r}")
    return float(value)


def _axis_defaults(dim: int) -> dict:
    """``axis_point`` the origin and ``axis`` y: the axis of revolution of an axisymmetric model."""
    return {"axis_point": [0.0] * dim, "axis": [0.0, 1.0, 0.0][:dim]}


@dataclass(frozen=True)
class Box:
    """Centroids with lower <= x <= upper in every coordinate [mm]."""

    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def from_table(cls, table, dim: int, where: str) -> "Box":
        table = checked_table(table, {"min": ..., "max": ...}, where)
        lower = _vector(table["min"], dim, f"{where}.min", infinite=True)
        upper = _vector(table["max"], dim, f"{where}.max", infinite=True)
        if np.any(lower > upper):
            raise InputError(f"{where}: min must not exceed max in any coordinate, got min {lower.tolist()}, "
                             f"max {upper.tolist()}")
        return cls(lower, upper)

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        return np.all((x >= self.lower - tol) & (x <= self.upper + tol), axis=1)


@dataclass(frozen=True)
class HalfSpace:
    """Centroids on the side of a plane (a line in 2-D) that its unit normal points to, or on it."""

    point: np.ndarray
    normal: np.ndarray

    @classmethod
    def from_table(cls, table, dim: int, where: str) -> "HalfSpace":
        table = checked_table(table, {"point": ..., "normal": ...}, where)
        return cls(_vector(table["point"], dim, f"{where}.point"), _direction(table["normal"], dim, f"{where}.normal"))

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        return (x - self.point) @ self.normal >= -tol


@dataclass(frozen=True)
class Ring:
    """Centroids at a distance r_min <= r <= r_max [mm] from the axis through ``point`` along unit ``axis``
    (in 2-D a line of the plane: with the defaults, the axis y of an axisymmetric model, r = |x|)."""

    point: np.ndarray
    axis: np.ndarray
    r_min: float
    r_max: float

    @classmethod
    def from_table(cls, table, dim: int, where: str) -> "Ring":
        table = checked_table(table, {**_axis_defaults(dim), "r_min": 0.0, "r_max": math.inf}, where)
        r_min, r_max = _number(table["r_min"], f"{where}.r_min"), _number(table["r_max"], f"{where}.r_max")
        if not 0.0 <= r_min <= r_max:
            raise InputError(f"{where}: need 0 <= r_min <= r_max, got r_min {r_min:g}, r_max {r_max:g}")
        return cls(_vector(table["axis_point"], dim, f"{where}.axis_point"),
                   _direction(table["axis"], dim, f"{where}.axis"), r_min, r_max)

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        v = x - self.point
        r = np.linalg.norm(v - np.outer(v @ self.axis, self.axis), axis=1)
        return (r >= self.r_min - tol) & (r <= self.r_max + tol)


@dataclass(frozen=True)
class Axial:
    """Centroids whose coordinate along the unit ``axis`` from ``point`` lies in [lower, upper] [mm]."""

    point: np.ndarray
    axis: np.ndarray
    lower: float
    upper: float

    @classmethod
    def from_table(cls, table, dim: int, where: str) -> "Axial":
        table = checked_table(table, {**_axis_defaults(dim), "min": -math.inf, "max": math.inf}, where)
        lower, upper = _number(table["min"], f"{where}.min"), _number(table["max"], f"{where}.max")
        if lower > upper:
            raise InputError(f"{where}: min must not exceed max, got min {lower:g}, max {upper:g}")
        return cls(_vector(table["axis_point"], dim, f"{where}.axis_point"),
                   _direction(table["axis"], dim, f"{where}.axis"), lower, upper)

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        s = (x - self.point) @ self.axis
        return (s >= self.lower - tol) & (s <= self.upper + tol)


@dataclass(frozen=True)
class Sector:
    """Centroids at an angle in [from_deg, to_deg] about the axis, counted from the unit ``reference`` (normal to
    the axis) in the right-hand sense about the axis (in 2-D: about ``point``, counter-clockwise). Centroids on the
    axis lie in every sector."""

    point: np.ndarray
    axis: np.ndarray | None
    reference: np.ndarray
    start: float
    span: float

    @classmethod
    def from_table(cls, table, dim: int, where: str) -> "Sector":
        allowed = {"axis_point": [0.0] * dim, "from_deg": ..., "to_deg": ..., "reference": None}
        table = checked_table(table, {**allowed, "axis": [0.0, 1.0, 0.0]} if dim == 3 else allowed, where)
        start, end = _number(table["from_deg"], f"{where}.from_deg", False), \
            _number(table["to_deg"], f"{where}.to_deg", False)
        if not start < end <= start + 360.0:
            raise InputError(f"{where}: need from_deg < to_deg <= from_deg + 360, got from_deg {start:g}, "
                             f"to_deg {end:g}")
        axis = _direction(table["axis"], 3, f"{where}.axis") if dim == 3 else None
        if table["reference"] is None:
            reference = np.eye(dim)[int(np.argmin(np.abs(axis)))] if dim == 3 else np.array([1.0, 0.0])
        else:
            reference = _direction(table["reference"], dim, f"{where}.reference")
        if dim == 3:
            reference = reference - (reference @ axis) * axis
            if np.linalg.norm(reference) < 1e-9:
                raise InputError(f"{where}.reference: must not be parallel to the axis, got {table['reference']!r}")
            reference = reference / np.linalg.norm(reference)
        return cls(_vector(table["axis_point"], dim, f"{where}.axis_point"), axis, reference, start, end - start)

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        v = x - self.point
        if self.axis is None:
            second = np.array([-self.reference[1], self.reference[0]])
        else:
            v = v - np.outer(v @ self.axis, self.axis)
            second = np.cross(self.axis, self.reference)
        r = np.linalg.norm(v, axis=1)
        angle = np.degrees(np.arctan2(v @ second, v @ self.reference))
        past = np.mod(angle - self.start, 360.0)
        slack = np.degrees(tol / np.maximum(r, tol))                   # the tolerance as an arc at radius r
        return (r <= tol) | (past <= self.span + slack) | (past >= 360.0 - slack)


@dataclass(frozen=True)
class Everything:
    """Every centroid (``all = true``: the facets no rule before took)."""

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        return np.ones(len(x), dtype=bool)


#: rule kinds by their key in a zone rule's table
KINDS = {"box": Box, "plane": HalfSpace, "ring": Ring, "sector": Sector, "axial": Axial, "all": Everything}


@dataclass(frozen=True)
class ZoneRule:
    """A friction zone by rule: the facets whose centroid lies in every one of ``shapes``."""

    name: str
    shapes: tuple

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        """(n,) True for the centroids ``x`` (n, dim) [mm] inside every shape (within ``tol`` [mm])."""
        inside = np.ones(len(x), dtype=bool)
        for shape in self.shapes:
            inside &= shape.contains(x, tol)
        return inside


def zone_rule(table, dim: int, where: str) -> ZoneRule:
    """One rule from its table: ``name`` and one or more kinds of :data:`KINDS` (``all = true`` alone).

    >>> zone_rule({"name": "A", "box": {"min": [-5, -5], "max": [0, 0]}}, 2, "rule").contains(
    ...     np.array([[-1.0, -1.0], [1.0, -1.0]]), 1e-9).tolist()
    [True, False]
    """
    table = checked_table(table, {"name": ..., **{kind: None for kind in KINDS}}, where)
    name = table["name"]
    if not isinstance(name, str) or not name:
        raise InputError(f"{where} name: must be a non-empty string (the zone's name), got {name!r}")
    kinds = [kind for kind in KINDS if table[kind] is not None]
    if not kinds:
        raise InputError(f"{where} ({name!r}): needs a rule kind, one or more of {list(KINDS)}")
    if "all" in kinds:
        if table["all"] is not True:
            raise InputError(f"{where} ({name!r}) all: must be true (the facets no rule before took), "
                             f"got {table['all']!r}")
        if len(kinds) > 1:
            raise InputError(f"{where} ({name!r}): all = true takes every facet left; it cannot be combined with "
                             f"{[k for k in kinds if k != 'all']}")
        return ZoneRule(name, (Everything(),))
    return ZoneRule(name, tuple(KINDS[kind].from_table(table[kind], dim, f"{where} {kind}") for kind in kinds))


def zone_rules(tables, dim: int, where: str) -> tuple[ZoneRule, ...]:
    """The rules of a ``zone_rules`` list, each name once."""
    if isinstance(tables, dict) or not isinstance(tables, (list, tuple)) or not tables:
        raise InputError(f"{where}: must be a list of tables ([[...zone_rules]]), each a zone's name and rule, "
                         f"got {tables!r}")
    rules = []
    for index, table in enumerate(tables, 1):
        rule = zone_rule(table, dim, f"{where} {index}")
        if rule.name in [r.name for r in rules]:
            raise InputError(f"{where} {index} name: zone {rule.name!r} is named by an earlier rule too")
        rules.append(rule)
    return tuple(rules)


def classify(centroids: np.ndarray, rules, tol: float) -> np.ndarray:
    """(n,) index of the first rule each centroid (n, dim) [mm] matches, -1 where none does.

    >>> rules = [ZoneRule("left", (HalfSpace(np.zeros(2), np.array([-1.0, 0.0])),)), ZoneRule("rest", (Everything(),))]
    >>> classify(np.array([[-1.0, 0.0], [2.0, 0.0]]), rules, 1e-9).tolist()
    [0, 1]
    """
    index = np.full(len(centroids), -1, dtype=np.int64)
    for k, rule in enumerate(rules):
        free = index < 0
        index[free & rule.contains(centroids, tol)] = k
    return index


def _extent(x: np.ndarray) -> str:
    """The bounding box of points (n, dim) [mm] as text: "x [a, b], y [c, d]"."""
    return ", ".join(f"{'xyz'[k]} [{low:.6g}, {high:.6g}]" for k, (low, high) in
                     enumerate(zip(x.min(axis=0), x.max(axis=0))))


def split_facets(points: np.ndarray, facets: np.ndarray, rules, where: str) -> dict[str, np.ndarray]:
    """The facets (n, n_facet_nodes) split by rules into zone name -> facets (each in the given order), by their
    centroids (mean of their nodes' ``points`` [mm]); an InputError naming ``where`` when a rule takes no facet or
    a facet matches no rule."""
    centroids = points[facets].mean(axis=1)
    tol = TOLERANCE * max(float(np.ptp(centroids, axis=0).max()), 1.0)
    index = classify(centroids, rules, tol)
    left = index < 0
    if left.any():
        raise InputError(f"{where}: {int(left.sum())} of {len(facets)} facet(s) match no rule (their centroids lie "
                         f"in {_extent(centroids[left])}); every facet needs a zone: widen a rule or end with "
                         "{ name = \"...\", all = true }")
    for k, rule in enumerate(rules):
        if not np.any(index == k):
            taken = int(rule.contains(centroids, tol).sum())
            why = f"the {taken} facet(s) it matches are taken by the rules before it" if taken else \
                "it matches no facet of the contact surface"
            raise InputError(f"{where} {k + 1} ({rule.name!r}): the zone would be empty: {why} (the surface's "
                             f"centroids lie in {_extent(centroids)})")
    return {rule.name: facets[index == k] for k, rule in enumerate(rules)}
