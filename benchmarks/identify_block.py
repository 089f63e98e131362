"""Solves and wall time to reach |mu - mu_true| < 0.01 on the 3-D block: trf + analytic Jacobian versus the
paper's gradient descent + forward differences, measured in one run (issue 3 target: 20x fewer, 20x faster).

Data are made by the same mesh with the paper's goal coefficients (random in [0.1, 0.5], fixed seed), observed
strains on the block's side faces near the contact; both methods start from 0.1. Same-mesh data let both methods
reach the target: this measures the cost of converging, not the model error.
Run: .venv/bin/python benchmarks/identify_block.py [max_gd_iterations]
"""

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from frictionid.cli import main as cli  # noqa: E402
from frictionid.config import read_config  # noqa: E402
from frictionid.identify import identify  # noqa: E402

STRAINS = '["exx", "eyy", "ezz", "exy", "eyz", "exz"]'


def write_case(folder: Path, mu_true) -> None:
    rows = ["point,x,y,z,stage,exx"]
    k = 0
    for z in (0.5, 1.5):
        for s in (-3.0, 3.0):
            for x, y in ((-5.0, s), (5.0, s), (s, -5.0), (s, 5.0)):
                k += 1
                rows.append(f"P{k},{x},{y},{z},2,0.0")
    (folder / "points.csv").write_text("\n".join(rows) + "\n")
    zones = ", ".join(f"{z} = {float(v)!r}" for z, v in zip("ABCD", mu_true))
    common = ('[model]\nbuilder = "block"\nmesh_size = 2.5\n[data]\nobservables = ' + STRAINS
              + '\nstages = [2]\nnoise = { e = 1e-5 }\nregions = { "*" = "block" }\n')
    (folder / "truth.toml").write_text(common + f'file = "points.csv"\n[friction]\nzones = {{ {zones} }}\n')
    assert cli(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0


def run(folder: Path, name: str, method: str, jacobian: str, iterations: int, mu_true) -> dict:
    path = folder / f"{name}.toml"
    path.write_text('[model]\nbuilder = "block"\nmesh_size = 2.5\n[friction]\nzones = { A = 0.1, B = 0.1, C = 0.1, D = 0.1 }\n'
                    f'[data]\nfile = "measured.csv"\nobservables = {STRAINS}\nstages = [2]\nnoise = {{ e = 1e-5 }}\n'
                    'regions = { "*" = "block" }\n'
                    f'[identify]\nmethod = "{method}"\njacobian = "{jacobian}"\nmax_iterations = {iterations}\n'
                    f'[run]\ndir = "runs/{name}"\n')
    trace = []
    start = time.perf_counter()

    def progress(iteration, mu, objective, evaluator):
        trace.append((np.abs(mu - mu_true).max(), evaluator.n_forward + evaluator.n_sensitivity,
                      time.perf_counter() - start))

    result = identify(read_config(path, need=("model", "friction", "data", "run")), progress=progress)
    reached = next(((solves, t) for error, solves, t in trace if error < 0.01), None)
    return {"result": result, "reached": reached, "final_error": trace[-1][0], "solves": trace[-1][1],
            "time": trace[-1][2]}


def main(gd_iterations: int = 300):
    mu_true = np.random.default_rng(2024).uniform(0.1, 0.5, 4)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_case(folder, mu_true)
        trf = run(folder, "trf", "trf", "analytic", 50, mu_true)
        gd = run(folder, "gd", "gradient-descent", "forward", gd_iterations, mu_true)
    print(f"3-D block, goal coefficients {np.round(mu_true, 4).tolist()}, start 0.1, target |mu - mu_true| < 0.01")
    for name, r in (("trf + analytic", trf), ("gradient descent + forward differences", gd)):
        res = r["result"]
        reached = (f"reached after {r['reached'][0]} solves, {r['reached'][1]:.2f} s" if r["reached"]
                   else f"NOT reached ({r['solves']} solves, {r['time']:.1f} s, final error {r['final_error']:.3g})")
        print(f"  {name:<40} {reached}; {res['n_iterations']} iterations, status {res['status']}")
    if trf["reached"] and gd["reached"]:
        print(f"  ratio: {gd['reached'][0] / trf['reached'][0]:.1f}x fewer solves, "
              f"{gd['reached'][1] / trf['reached'][1]:.1f}x less time")
    elif trf["reached"]:
        print(f"  ratio: more than {gd['solves'] / trf['reached'][0]:.0f}x fewer solves and "
              f"{gd['time'] / trf['reached'][1]:.0f}x less time (gradient descent never got there)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 300)
