"""The discretisation control alone on a config's data (target 0.5, budget 2) at a `max_memory` [GB]: its phases,
what it chooses, the memory it estimated and measured per directional model, and the scale it put on the law.

Run (from the config's folder): PYTHONPATH=<repo>/src <repo>/.venv/bin/python <repo>/benchmarks/control_memory.py
     CONFIG MAX_MEMORY
e.g. in tests/fixtures/dense_block: identify.toml 6 (four directional models and the check of the chosen one;
3-4 min on a shared 2-core machine, 3.5 GB peak)

The condensation alone (``Problem.build``) of the block with the options OPTIONS (``block_model``'s keywords,
``k=v,k=v``) at N of tests/fixtures/dense_block's points (ux, uy, uz; N spread over the list, all if N >= 1,752):
its seconds, its peak above what the process held (:class:`frictionid.fem.memory.Peak`) and
:func:`frictionid.fem.memory.estimate`'s parts (the law of the sparse factor, the dense contact blocks): where a
condensation's memory goes, with the dense observation points against a few (fit-quality.md)::

     PYTHONPATH=src .venv/bin/python benchmarks/control_memory.py --condense edge_splits=4,interface_splits=4 1752
"""

import json
import sys
from pathlib import Path

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


def condense(options: str, n_points: int) -> None:
    """--condense (module docstring)."""
    import time

    import numpy as np

    from frictionid.builders.block import block_model
    from frictionid.fem.problem import Problem
    import dense_convergence

    number = lambda text: int(text) if text.lstrip("-").isdigit() else float(text)
    kw = {key: number(value) for key, value in (part.split("=") for part in options.split(",") if part)}
    fixture = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "dense_block"
    labels, xyz = dense_convergence.read(fixture)[0], dense_convergence.coordinates(fixture)
    pick = np.arange(len(labels)) if n_points >= len(labels) else \
        np.linspace(0, len(labels) - 1, n_points).round().astype(int)
    model = block_model(**kw)
    cost, pairs = memory.estimate(model, "condensation"), memory.contact_pairs(model)
    with memory.Peak() as took:
        begun = time.perf_counter()
        Problem.build(model, points=xyz[pick], quantities=("ux", "uy", "uz"),
                      regions=["plate" if labels[i].startswith("plate:") else "block" for i in pick])
        seconds = time.perf_counter() - begun
    print(json.dumps({"options": kw, "nodes": model.mesh.n_nodes, "dofs": cost.n_dofs, "points": len(pick),
                      "seconds": round(seconds, 1), "measured_gb": round(took.above / memory.GB, 2),
                      "estimated_gb": round(cost.above / memory.GB, 2),
                      "law_factor_gb": round(memory.condensation_bytes(cost.n_dofs, 3) / memory.GB, 2),
                      "contact_blocks_gb": round(memory.contact_bytes(pairs, 3) / memory.GB, 3),
                      "process_peak_gb": round(memory.process_peak() / memory.GB, 2)}))


if __name__ == "__main__":
    if sys.argv[1] == "--condense":
        condense(sys.argv[2], int(sys.argv[3]))
    else:
        main(sys.argv[1], float(sys.argv[2]))
