"""tests/ on the import path, so that the benchmarks import the tests' cases and fixture generators as the tests
do (``from fixtures.dense_block import generate``, ``from sliding_case import block_on_base``)."""

import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1] / "tests"
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))
