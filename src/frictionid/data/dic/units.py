"""Units and strain measures of DIC exports, converted to frictionid's mm and small-strain tensor (docs/data.md)."""

from __future__ import annotations

import numpy as np

from ...errors import InputError

#: length units -> factor to mm; 'µ' comes as the micro sign (U+00B5, Latin-1) or the Greek mu (U+03BC)
LENGTH = {"mm": 1.0, "m": 1e3, "cm": 10.0, "µm": 1e-3, "μm": 1e-3, "um": 1e-3}
#: strain units -> factor to a pure number ("S": DaVis's name for a pure strain)
STRAIN = {"-": 1.0, "1": 1.0, "": 1.0, "S": 1.0, "mm/mm": 1.0, "m/m": 1.0, "%": 1e-2, "µm/m": 1e-6, "μm/m": 1e-6,
          "µε": 1e-6, "μɛ": 1e-6, "microstrain": 1e-6}
#: force units -> factor to N (a load cell's channel in an export)
FORCE = {"N": 1.0, "kN": 1e3, "mN": 1e-3, "MN": 1e6, "lbf": 4.4482216152605}
#: strain measures a file may state, and how they are called in messages
MEASURES = {"engineering": "engineering (technical) strain", "green-lagrange": "Green-Lagrange strain",
            "log": "logarithmic (true, Hencky) strain"}


def _factor(table: dict, unit: str | None, cannot: str) -> float:
    """``table``'s factor of ``unit`` (None: no unit stated, factor 1); else InputError with ``cannot`` + the
    known units."""
    if unit is None:
        return 1.0
    try:
        return table[unit.strip()]
    except KeyError:
        raise InputError(cannot) from None


def length_factor(unit: str | None, column: str, source: str) -> float:
    """Factor from the column's unit to mm (None: no unit stated, taken as mm)."""
    return _factor(LENGTH, unit, f"{source}: column {column!r}: unit {unit!r} cannot be converted to mm (known: "
                   f"{', '.join(LENGTH)}); pixels need the DIC software's calibration, export in mm")


def force_factor(unit: str | None, column: str, source: str) -> float:
    """Factor from the column's unit to N (None: no unit stated, taken as N)."""
    return _factor(FORCE, unit, f"{source}: column {column!r}: force unit {unit!r} cannot be converted to N (known: "
                   f"{', '.join(FORCE)})")


def strain_factor(unit: str | None, column: str, source: str) -> float:
    """Factor from the column's unit to a pure number (``%`` -> 0.01); None: no unit stated, a pure number."""
    return _factor(STRAIN, unit, f"{source}: column {column!r}: strain unit {unit!r} cannot be converted (known: "
                   f"{', '.join(repr(u) for u in STRAIN)})")


def small_strain(values: np.ndarray, measure: str, normal: bool) -> np.ndarray:
    """A measured strain component as the small-strain tensor component the model computes.

    Normal components through the one-dimensional relation of the measure to the engineering strain e
    (exact for a stretch along the axis): Green-Lagrange E = e + e^2 / 2, so e = sqrt(1 + 2 E) - 1; log
    l = ln(1 + e), so e = exp(l) - 1. Shear components are equal in all three measures to first order and
    are taken as they are. expm1 / log1p keep full relative precision at strains of 1e-6.

    >>> round(float(small_strain(np.array([0.01 + 0.01**2 / 2]), "green-lagrange", normal=True)[0]), 15)
    0.01
    """
    if measure == "engineering" or not normal:
        return values
    if measure == "green-lagrange":
        return np.expm1(0.5 * np.log1p(2.0 * values))
    if measure == "log":
        return np.expm1(values)
    raise InputError(f"strain measure {measure!r} is not one of {', '.join(MEASURES)}")


def small_strain_slope(values: np.ndarray, measure: str, normal: bool) -> np.ndarray:
    """d(small strain) / d(measured strain) of :func:`small_strain` at the measured values: what a standard
    deviation of the measured strain is multiplied by (independent small errors). Green-Lagrange: 1 / (1 + e) =
    1 / sqrt(1 + 2 E); log: 1 + e = exp(l); engineering and shear components: 1.

    >>> float(small_strain_slope(np.array([np.log(1.02)]), "log", normal=True)[0])
    1.02
    """
    if measure == "engineering" or not normal:
        return np.ones_like(values)
    if measure == "green-lagrange":
        return 1.0 / np.sqrt(1.0 + 2.0 * values)
    if measure == "log":
        return np.exp(values)
    raise InputError(f"strain measure {measure!r} is not one of {', '.join(MEASURES)}")
