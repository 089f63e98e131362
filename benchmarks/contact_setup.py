"""What the contact set-up check at model build costs: the solver's set-up (Problem.build: space, pairs,
condensation) alone against the check (contact_setup: space, pairs, map) followed by the set-up, which then
reuses the check's space and pairs. 3-D block and axisymmetric bolt (builder defaults); each timing on a model
object of its own (made before the clock starts), best of --repeat.

Run: .venv/bin/python benchmarks/contact_setup.py [--repeat 3]
"""

import argparse
import dataclasses
import time

from frictionid.builders.registry import build_model
from frictionid.fem.interface import contact_setup
from frictionid.fem.problem import Problem
from frictionid.options import ModelSpec


def _timed(function) -> float:
    start = time.perf_counter()
    function()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    for builder in ("block", "bolt"):
        model = build_model(ModelSpec.from_table({"builder": builder}))
        copies = [dataclasses.replace(model) for _ in range(2 * args.repeat)]    # new objects: nothing cached
        alone, check, both = [], [], []
        for k in range(args.repeat):
            alone.append(_timed(lambda: Problem.build(copies[2 * k])))
            check.append(_timed(lambda: contact_setup(copies[2 * k + 1])))
            both.append(check[-1] + _timed(lambda: Problem.build(copies[2 * k + 1])))
        print(f"{builder}: {model.mesh.n_nodes:,} nodes; Problem.build alone {min(alone):.2f} s, contact_setup "
              f"{min(check):.2f} s + Problem.build {min(both) - min(check):.2f} s = {min(both):.2f} s "
              f"(ratio {min(both) / min(alone):.2f})")


if __name__ == "__main__":
    main()
