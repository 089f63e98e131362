"""Checks of the builders' keyword arguments: each error names the argument and what it must be."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError


def positive(name: str, value, low: float = 0.0) -> float:
    """``value`` as a float when it is a finite number (not a bool) above ``low``, else an InputError naming
    ``name``.

    >>> positive("mesh_size", 2)
    2.0
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or not value > low:
        raise InputError(f"`{name}` must be a finite number > {low:g}, got {value!r}")
    return float(value)


def count(name: str, value, low: int = 1, high: int | None = None) -> int:
    """``value`` as an int when it is an integer (not a bool) in [``low``, ``high``] (no upper limit: ``high``
    None), else an InputError naming ``name``.

    >>> count("n_pull", 10)
    10
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low \
            or (high is not None and value > high):
        span = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise InputError(f"`{name}` must be an integer {span}, got {value!r}")
    return int(value)
