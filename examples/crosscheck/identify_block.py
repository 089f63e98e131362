"""Identify the block's four zone coefficients with both backends and compare.

Strains at the 16 points of benchmarks/identify_block.py (block side faces near the contact), stage 2, goal
coefficients random in [0.1, 0.5] (fixed seed), trf from 0.1 everywhere:
(a) embedded data, embedded backend, analytic sensitivities;
(b) embedded data, calculix backend, forward differences with 2 workers (backend agreement: the aim is
    (a) and (b) within 0.01; the two backends discretise contact differently, node-to-node Lagrange vs
    surface-to-surface penalty, so (b) fits the data with a slightly different model);
(c) calculix data, calculix backend, forward differences (the twin: does the ccx pipeline recover its own
    coefficients through finite differences?).

Run: .venv/bin/python examples/crosscheck/identify_block.py [--model OPTIONS] [--stages S ...] [--workers N]
     [--iterations N] [--no-twin]
OPTIONS are block builder options as TOML, e.g. "mesh_size = 2.5" (default; a few minutes) or
"mesh_size = 2.5, order = 2, block_divisions = 6, grading = 3" (the graded quadratic mesh on which both backends'
rear-zone loads are near the converged ones; ccx needs about a minute and a half per solve there), or
"mesh_size = 1.6666666666666667, pull_levels = [0.04]" with --stages 2 3: strains also at a 0.04 mm pull, where
the lightly loaded rear zones A and B already slide under about 200 N and the backends' strains agree within
0.14 % RMS of range (the block twin of examples/block uses the same second pull level).
"""

import argparse
import os
import tomllib
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from frictionid.cli import main as cli  # noqa: E402
from frictionid.config import read_config  # noqa: E402
from frictionid.identification import identify_config  # noqa: E402

STRAINS = '["exx", "eyy", "ezz", "exy", "eyz", "exz"]'


def write_points(folder: Path, stages: tuple[int, ...]) -> None:
    rows, k = ["point,x,y,z,stage"], 0
    for z in (0.5, 1.5):
        for s in (-3.0, 3.0):
            for x, y in ((-5.0, s), (5.0, s), (s, -5.0), (s, 5.0)):
                k += 1
                rows += [f"P{k},{x},{y},{z},{stage}" for stage in stages]
    (folder / "points.csv").write_text("\n".join(rows) + "\n")


def model_lines(model: str) -> str:
    """Builder options given as the inside of a TOML inline table ("a = 1, b = [0.02, 0.04]"), one per line."""
    options = tomllib.loads(f"model = {{ {model} }}")["model"]
    return "\n".join(f"{key} = {value!r}" for key, value in options.items())


def config(model: str, stages: tuple[int, ...], data: str, zones: str, extra: str = "") -> str:
    lines = model_lines(model)
    return (f'[model]\nbuilder = "block"\n{lines}\n[friction]\nzones = {{ {zones} }}\n'
            f'[data]\nfile = "{data}"\nobservables = {STRAINS}\nstages = {list(stages)}\nnoise = {{ e = 1e-5 }}\n'
            f'regions = {{ "*" = "block" }}\n{extra}')


def run(folder: Path, name: str, data: str, start: str, model: str, stages: tuple[int, ...], solver: str,
        jacobian: str, workers: int, iterations: int) -> tuple[dict, float]:
    extra = (f'[solver]\nbackend = "{solver}"\n[identify]\njacobian = "{jacobian}"\nstep = 1e-2\n'
             f'max_iterations = {iterations}\n[run]\ndir = "runs/{name}"\nworkers = {workers}\n')
    (folder / f"{name}.toml").write_text(config(model, stages, data, start, extra))
    t0 = time.perf_counter()
    result = identify_config(read_config(folder / f"{name}.toml", need=("model", "friction", "data", "run")))
    return result, time.perf_counter() - t0


def main(model: str = "mesh_size = 2.5", stages: tuple[int, ...] = (2,), workers: int = 2, iterations: int = 15,
         twin: bool = True) -> None:
    mu_true = np.random.default_rng(2024).uniform(0.1, 0.5, 4)
    truth = ", ".join(f"{z} = {float(v)!r}" for z, v in zip("ABCD", mu_true))
    start = ", ".join(f"{z} = 0.1" for z in "ABCD")
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_points(folder, stages)
        for solver in ("embedded", "calculix")[:2 if twin else 1]:
            (folder / f"truth_{solver}.toml").write_text(
                config(model, stages, "points.csv", truth, f'[solver]\nbackend = "{solver}"\n'))
            assert cli(["simulate", str(folder / f"truth_{solver}.toml"), "--out",
                        str(folder / f"{solver}.csv")]) == 0
        cases = [("(a) embedded data, embedded", "embedded.csv", "embedded", "analytic"),
                 ("(b) embedded data, calculix", "embedded.csv", "calculix", "forward"),
                 ("(c) calculix data, calculix", "calculix.csv", "calculix", "forward")][:3 if twin else 2]
        for k, (name, data, solver, jacobian) in enumerate(cases):
            results[name] = run(folder, f"case{k}", data, start, model, stages, solver, jacobian, workers, iterations)
    print(f"3-D block ({model}), strains at 16 points (stages {list(stages)}), start 0.1, "
          f"max {iterations} iterations, {workers} workers")
    print("| case | jacobian | A | B | C | D | status | iterations | solves | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    print("| goal | | " + " | ".join(f"{v:.4f}" for v in mu_true) + " | | | | |")
    values = {}
    for name, (result, wall) in results.items():
        values[name] = np.array([result["parameters"][z]["value"] for z in "ABCD"])
        print(f"| {name} | {result['jacobian']} | " + " | ".join(f"{v:.4f}" for v in values[name])
              + f" | {result['status']} | {result['n_iterations']} | "
              f"{result['n_forward_solves'] + result['n_sensitivity_solves']} | {wall:.1f} |")
    a, b, *c = values.values()
    print(f"backend agreement max |(b) - (a)| = {np.abs(b - a).max():.4f} per zone "
          f"{np.round(np.abs(b - a), 4).tolist()} (aim: < 0.01)")
    if c:
        print(f"ccx twin max |(c) - goal| = {np.abs(c[0] - mu_true).max():.4f}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="mesh_size = 2.5",
                        help="block builder options, the inside of a TOML inline table")
    parser.add_argument("--stages", type=int, nargs="+", default=[2], help="stages fitted (default 2, the pull)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--iterations", type=int, default=15)
    parser.add_argument("--no-twin", dest="twin", action="store_false", help="skip case (c), the ccx twin")
    args = parser.parse_args()
    main(args.model, tuple(args.stages), args.workers, args.iterations, args.twin)
