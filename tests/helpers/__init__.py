"""What several test modules share: a config writer (:func:`write_config`), central differences
(:func:`central_difference`, :func:`check_sensitivities`), the CalculiX marker (:func:`needs_ccx`), the block's
16 strain points (:data:`BLOCK_POINTS`) and the benchmarks' modules (:func:`benchmark`)."""

from .benchmarks import benchmark
from .ccx import needs_ccx
from .config import toml_value, write_config
from .differences import central_difference, check_sensitivities
from .points import BLOCK_POINTS

__all__ = ["BLOCK_POINTS", "benchmark", "central_difference", "check_sensitivities", "needs_ccx", "toml_value", "write_config"]
