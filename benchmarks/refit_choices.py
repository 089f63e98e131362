"""What the discretisation control at the fitted values could choose: a finished run's round of ``model.discretisation.at_fitted``, its directional differences read
from the run's store (nothing solved), and every refinement with factors 1-4 per direction predicted from them. Prints
the cheapest refinement predicted within the target, the one with the smallest worst-kind error, and the best one
whose memory-law estimate (without the run's held memory and measured scale) is within each of 4, 6 and 8 GB.

    PYTHONPATH=src .venv/bin/python benchmarks/refit_choices.py CONFIG RUN_DIR [ROUND]
"""

import itertools
import json
import sys
from pathlib import Path

import numpy as np

from frictionid.builders.block import block_layout
from frictionid.config import read_config
from frictionid.fem import memory
from frictionid.inverse.discretisation_control import directions, kind_rms, refinement, within
from frictionid.inverse.discretisation_refit import ESTIMATE
from frictionid.inverse.model_error import ELEMENT_ORDER, convergence_orders, observation_kinds
from frictionid.inverse.remaining_error import combined
from frictionid.preparation import prepare
from frictionid.run.store import RunStore


def candidates(config: str, run_dir: Path, index: int) -> tuple[float, list]:
    """(target, rows (factors, predicted rms per kind, nodes, law GB)) of round ``index``."""
    setup = prepare(read_config(config), echo=lambda text: None)
    obs, spec = setup.observations, setup.model_options
    result = json.loads((run_dir / "result.json").read_text())
    record = result["model"]["discretisation"]
    row = record["at_fitted"][index - 1]
    mu = np.array([row["at"][zone] for zone in setup.parameters.names])
    kinds, names, nested = observation_kinds(obs), directions(spec), within(spec)
    orders = convergence_orders(ELEMENT_ORDER[setup.model.mesh.cell_type])
    p = np.array([orders[k] for k in kinds])
    gain = 2.0 ** p
    with _store(run_dir) as store:
        terms = [store.lookup(mu, f"{ESTIMATE}: {name}")["difference"] * gain / (gain - 1.0) for name in names]
    rows = []
    for factors in itertools.product([1, 2, 3, 4], repeat=len(names)):
        rms = kind_rms(np.abs(combined(terms, factors, p, nested)) / obs.sigma, kinds)
        nodes = block_layout(**refinement(spec, factors).table()).n_nodes(int(spec.option("order", 1)))
        law = memory.estimate(setup.model, "", None, "auto", n_nodes=int(nodes)).needed / memory.GB
        rows.append((factors, {k: round(v, 3) for k, v in rms.items()}, nodes, round(law, 2)))
    return record["target"], rows


def _store(run_dir: Path):
    """The run's store read as it is (its fingerprint is not checked: nothing is written)."""
    import sqlite3
    from contextlib import closing
    return closing(RunStore(sqlite3.connect(run_dir / "store.sqlite"), run_dir / "store.sqlite", resumed=True))


def main(argv: list[str]) -> None:
    config, run_dir, index = argv[0], Path(argv[1]), int(argv[2]) if len(argv) > 2 else 1
    target, rows = candidates(config, run_dir, index)
    inside = sorted((r for r in rows if max(r[1].values()) <= target), key=lambda r: r[2])
    print(f"cheapest within the target {target:g}: {inside[0] if inside else 'none'}")
    print(f"smallest worst-kind error: {min(rows, key=lambda r: max(r[1].values()))}")
    for limit in (4.0, 6.0, 8.0):
        fits = [r for r in rows if r[3] <= limit]
        best = min(fits, key=lambda r: (max(r[1].values()) > target,
                                        r[2] if max(r[1].values()) <= target else max(r[1].values())))
        print(f"memory law within {limit:g} GB: {best}")


if __name__ == "__main__":
    main(sys.argv[1:])
