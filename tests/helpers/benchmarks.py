"""The benchmarks' modules for tests that check their measures (benchmarks/ is not a package; its scripts import
each other by name)."""

import importlib
import sys
from pathlib import Path

BENCHMARKS = Path(__file__).parents[2] / "benchmarks"


def benchmark(name: str):
    """The module benchmarks/<name>.py, benchmarks/ put on sys.path for its own imports."""
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    return importlib.import_module(name)
