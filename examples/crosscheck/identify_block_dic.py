"""Identify the block's four zones with both backends from the block twin's observation set.

The observation set of examples/block: DIC displacements on the block's side faces and the plate top,
the machine force, at the pull levels 0.04 and 0.2 mm, noise 0.5 um / 1 N. The data are made by the embedded
backend on the identification mesh itself, with the paper's random goal coefficients and no noise added, so the
embedded fit recovers the goal and the calculix fit (forward differences, 2 workers) shows how far the backends'
models differ in coefficient terms.

Other pull levels and stages test other observation sets, e.g. `--pull-levels 0.02 0.04 0.08 --stages 2 3 4`:
three levels of partial slip and none of gross slip, where `frictionid crosscheck` predicts the smallest
coefficient shifts between the backends (README, CalculiX backend).

`--predict` runs `frictionid crosscheck` on the same observation set at the goal coefficients instead: one ccx run
(about 25 s) that predicts, to first order, where the calculix identification will end up relative to the
embedded one.

`--load-scale 0.01` runs ccx at 1 % of the loads, results scaled back ([solver] load_scale): its small-sliding
limit, the embedded solver's problem. With a mesh graded towards the footprint's edges (`--mesh-size 2.5
--block-divisions 8 --grading 4`) the two backends then identify the same coefficients on the gross-slip set
within 0.0013 (README, CalculiX backend).

Run: .venv/bin/python examples/crosscheck/identify_block_dic.py [--mesh-size H] [--block-divisions N]
     [--grading G] [--iterations N] [--pull-levels L ...] [--stages S ...] [--load-scale F] [--predict]
(hex8, mesh_size 1.6666666666666667 by default: about 1 minute per ccx iteration on 2 cores)
"""

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from frictionid.cli import main as cli  # noqa: E402
from frictionid.config import read_config  # noqa: E402
from frictionid.identification import identify_config  # noqa: E402
from frictionid.studies import block as twin  # noqa: E402


def measured(folder: Path, mesh: dict, goal: dict, levels: dict) -> None:
    """folder/measured.csv: the twin's observation set simulated by the embedded backend at the goal, as the
    cameras give it (no noise)."""
    twin.write_points(folder / "points.csv")
    truth = twin.config(folder, "truth", mesh, goal, "points.csv", **levels)
    assert cli(["simulate", str(truth), "--out", str(folder / "simulated.csv")]) == 0
    twin.as_measured(folder / "simulated.csv", folder / "measured.csv")


def predict(mesh: dict, pull_levels=twin.PULL_LEVELS, stages=twin.STAGES, load_scale: float = 1.0) -> None:
    """The cross-check table of this observation set at the goal, with the coefficient shift of exactly the rows
    the identifications fit (the measured file's layout: no uz on the plate top)."""
    goal = twin.goal_coefficients()
    levels = {"pull_levels": tuple(pull_levels), "stages": tuple(stages)}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        measured(folder, mesh, goal, levels)
        path = twin.config(folder, "crosscheck", mesh, goal, "measured.csv",
                           f'[solver]\nbackend = "calculix"\nload_scale = {load_scale!r}\n', **levels)
        assert cli(["crosscheck", str(path)]) == 0


def main(mesh: dict, iterations: int = 12, pull_levels=twin.PULL_LEVELS, stages=twin.STAGES,
         load_scale: float = 1.0) -> None:
    goal = twin.goal_coefficients()
    levels = {"pull_levels": tuple(pull_levels), "stages": tuple(stages)}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        measured(folder, mesh, goal, levels)
        for solver, jacobian in (("embedded", "analytic"), ("calculix", "forward")):
            scale = f"load_scale = {load_scale!r}\n" if solver == "calculix" else ""
            table = (f'[solver]\nbackend = "{solver}"\n{scale}[identify]\njacobian = "{jacobian}"\nstep = 1e-2\n'
                     f"max_iterations = {iterations}\n")
            path = twin.config(folder, solver, mesh, dict.fromkeys("ABCD", 0.1), "measured.csv", table, **levels)
            path.write_text(path.read_text() + "workers = 2\n")
            start = time.perf_counter()
            result = identify_config(read_config(path, need=("model", "friction", "data", "run")),
                              on_iteration=lambda k, mu, j, ev: print(f"  {solver} iteration {k}: J = {j:.4g}, mu = "
                                                                  f"{np.round(mu, 4).tolist()}", flush=True))
            values = "  ".join(f"{z} {p['value']:.4f} +- {p['stderr']:.4f}" if p.get("stderr") is not None
                               else f"{z} {p['value']:.4f}" for z, p in result["parameters"].items())
            print(f"{solver}: {values}  ({result['status']}, {result['n_iterations']} iterations, "
                  f"{time.perf_counter() - start:.0f} s)", flush=True)
    print("goal: " + "  ".join(f"{z} {v:.4f}" for z, v in goal.items()))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh-size", type=float, default=5 / 3)
    parser.add_argument("--block-divisions", type=int, help="block builder option (default: the builder's)")
    parser.add_argument("--grading", type=float, default=1.0,
                        help="block builder option (default 1: uniform, as docs/calculix.md's figures were measured)")
    parser.add_argument("--element", default="standard",
                        help="block builder option (default 'standard': C3D8 in ccx, as docs/calculix.md's figures)")
    parser.add_argument("--iterations", type=int, default=12)
    parser.add_argument("--pull-levels", type=float, nargs="+", default=list(twin.PULL_LEVELS))
    parser.add_argument("--stages", type=int, nargs="+", default=list(twin.STAGES))
    parser.add_argument("--predict", action="store_true", help="only the cross-check's prediction (one ccx run)")
    parser.add_argument("--load-scale", type=float, default=1.0,
                        help="[solver] load_scale of the ccx runs (0.01: ccx's small-sliding limit)")
    args = parser.parse_args()
    mesh = {"mesh_size": args.mesh_size} | {key: getattr(args, key) for key in ("block_divisions", "grading", "element")
                                             if getattr(args, key) is not None}
    if args.predict:
        predict(mesh, args.pull_levels, args.stages, args.load_scale)
    else:
        main(mesh, args.iterations, args.pull_levels, args.stages, args.load_scale)
