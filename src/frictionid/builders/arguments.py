"""Checks of the builders' keyword arguments: each error names the argument and what it must be."""

from __future__ import annotations

import difflib
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


def checked_table(table, allowed: dict, where: str) -> dict:
    """``table`` with the defaults of ``allowed`` (key -> default, ``...`` for a required key) filled in, else an
    InputError naming ``where``: not a table, an unknown key (with a "did you mean"), a missing required key.

    >>> checked_table({"E": 1.0}, {"E": ..., "nu": 0.3}, "[model.materials] steel")
    {'E': 1.0, 'nu': 0.3}
    """
    if not isinstance(table, dict):
        raise InputError(f"{where}: must be a table, got {table!r}")
    for key in table:
        if key not in allowed:
            close = difflib.get_close_matches(key, list(allowed), n=1) or \
                [k for k in allowed if k.lower() == str(key).lower()]
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise InputError(f"{where}: unknown key {key!r}{hint}; keys are {list(allowed)}")
    missing = [k for k, v in allowed.items() if v is ... and k not in table]
    if missing:
        raise InputError(f"{where}: missing key {missing[0]!r}")
    return {**allowed, **table}
