"""Progress bars of long loops (condensation blocks, finite-difference columns): shown on stderr inside
:func:`shown` (the command line), silent elsewhere (the Python interface is quiet by default)."""

from __future__ import annotations

import contextvars
import sys
from contextlib import contextmanager

from tqdm import tqdm

_SHOWN = contextvars.ContextVar("frictionid_progress_shown", default=False)


@contextmanager
def shown(enabled: bool = True):
    """Within this block, :func:`bar` draws (when ``enabled``); the command line runs its commands inside it."""
    token = _SHOWN.set(enabled)
    try:
        yield
    finally:
        _SHOWN.reset(token)


def bar(iterable, total: int, description: str, minimum: int = 2):
    """``iterable`` wrapped in a bar on stderr, drawn once the loop has run 2 s and erased when done; a plain
    iterable outside :func:`shown`, for fewer than ``minimum`` items, or when stderr is not a terminal (a log
    file gets no bar lines).

    >>> list(bar(range(3), 3, "columns"))
    [0, 1, 2]
    """
    if not _SHOWN.get() or total < minimum or not sys.stderr.isatty():
        return iterable
    return tqdm(iterable, total=total, desc=description, leave=False, file=sys.stderr, dynamic_ncols=True,
                mininterval=0.5, delay=2.0)
