"""The discretisation control alone on a config's data (target 0.5, budget 2) at a `max_memory` [GB]: its phases,
what it chooses, the memory it estimated and measured per directional model, and the scale it put on the law.

Run (from the config's folder): PYTHONPATH=<repo>/src <repo>/.venv/bin/python <repo>/benchmarks/control_memory.py
     CONFIG MAX_MEMORY
e.g. in tests/fixtures/dense_block: identify.toml 6 (four directional models and the check of the chosen one;
3-4 min on a shared 2-core machine, 3.5 GB peak)
"""

import json
import sys

from frictionid.config import read_config
from frictionid.fem import memory
from frictionid.inverse.discretisation_control import control
from frictionid.preparation import prepare, strain_window


def main(path: str, max_memory: float) -> None:
    config = read_config(path)
    setup = prepare(config, echo=lambda text: None)
    obs = setup.observations
    chosen = control(setup.model_options, setup.model, obs, setup.parameters.full(setup.parameters.x0), 0.5, 2,
                     max_memory, print, strain_window(setup.window, obs), "embedded")
    record = chosen.record
    print(json.dumps({key: record.get(key) for key in ("status", "factors", "n_nodes", "memory_scale")}))
    for step in record["directions"]:
        print(f"{step['direction']}: {step['n_nodes']:,} nodes, estimated {step['memory_gb']} GB, measured "
              f"{step['measured_gb']} GB, {step['seconds']} s")
    print(f"process peak {memory.process_peak() / memory.GB:.2f} GB")


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]))
