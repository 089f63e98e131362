"""Timing and memory helpers shared by the benchmark scripts."""

import json
import time
from contextlib import contextmanager


@contextmanager
def timed(figures: dict, name: str):
    """Store the wall time of the block in ``figures[name]`` [s]."""
    start = time.perf_counter()
    yield
    figures[name] = time.perf_counter() - start


def peak_memory_mb() -> float:
    """Peak resident memory of this process so far [MB] (frictionid's discretisation control resets the kernel's
    peak to measure its builds: fem/memory.py keeps the process's)."""
    from frictionid.fem.memory import process_peak
    return process_peak() / 2 ** 20


def best_of(repeat: int, function):
    """Smallest wall time of ``repeat`` calls [s] and the last result."""
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def emit(result: dict, out=None) -> None:
    """Print ``result`` as one JSON line and, when ``out`` (a path) is given, append the line to it."""
    line = json.dumps(result)
    print(line, flush=True)
    if out:
        with open(out, "a") as file:
            file.write(line + "\n")
