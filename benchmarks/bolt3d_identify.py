"""A twin identification on a small 3-D bolt from the seed's ten points: data from a finer 3-D mesh, fitted by
``frictionid.identify`` (trf, analytic sensitivities, factorisation "mumps") from the seed study's start values.

The bolt is the M6 with two engaged pitches of benchmarks/bolt3d_calculix.py (no window, no jaws, 1,500 N); its
zones A-D (thread, radial split at the pitch diameter, two axial sections) at the study's true values (A 0.14,
B 0.18, C 0.22, D 0.12; frictionid.studies.bolt), head and nut bearing held at 0.15. Data: uy at the ten points
P1-P5 of flanks 1 and 2 (benchmarks/bolt3d.py ten_points) solved on the finer mesh, noise-free, weighted by the
seed's DIC noise 0.5 um. Printed: the models' sizes, time, iterations, solves, coefficients with standard errors
and which zones the ten points resolve.

Run: .venv/bin/python benchmarks/bolt3d_identify.py [--data-flank 0.7] [--flank 1.0] [--work DIR]
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from bolt3d import ten_points
from frictionid import Parameter, Parameters, identify
from frictionid.builders.bolt import bolt_layout, bolt_model
from frictionid.fem.problem import Problem

TRUE = {"A": 0.14, "B": 0.18, "C": 0.22, "D": 0.12}
HELD = {"head_plate": 0.15, "nut_plate": 0.15}
START = 0.1
M6 = {"model": "3d", "size": "M6", "length": 24.0, "engaged_length": 2.0, "thread_length": 9.5, "n_axial": 2,
      "root_size": 0.25, "mesh_size": 3.0, "forces": [1500.0], "n_increments": 2, "cutout": False, "jaws": False}


def options(flank: float) -> dict:
    return {**M6, "flank_size": flank, "contact_size": 2.0 * flank}


def twin_data(flank: float, points: np.ndarray, path: Path) -> dict:
    """uy at ``points`` on the M6 meshed at ``flank``, at the true coefficients, written as a measurement file."""
    start = time.perf_counter()
    model = bolt_model(**options(flank))
    problem = Problem.build(model, points=points, quantities=("uy",), regions=["bolt"] * len(points),
                            factorisation="mumps")
    mu = np.array([{**TRUE, **HELD}[z] for z in model.zone_names])
    uy = problem.solve(mu).observations[-1]
    with open(path, "w") as out:
        out.write(f"# twin data: M6 3-D bolt, flank {flank} mm, {model.mesh.n_nodes} nodes, mu {json.dumps(TRUE)}\n"
                  "# units mm\npoint,x,y,z,stage,uy\n")
        for k, ((x, y, z), value) in enumerate(zip(points, uy)):
            out.write(f"P{k // 5 + 1}{k % 5 + 1},{x:.6f},{y:.6f},{z:.6f},1,{value:.9e}\n")
    return {"nodes": model.mesh.n_nodes, "seconds": time.perf_counter() - start, "uy_um": 1e3 * uy}


def main(data_flank: float, flank: float, work: Path) -> None:
    work.mkdir(parents=True, exist_ok=True)
    layout = bolt_layout("M6", M6["length"], M6["engaged_length"], None, 2, M6["n_axial"], None,
                         M6["thread_length"])
    points = ten_points(layout)
    data = twin_data(data_flank, points, work / "measured.csv")
    print(f"data: M6 at flank {data_flank} mm, {data['nodes']:,} nodes, {data['seconds']:.0f} s; uy at the ten "
          f"points {data['uy_um'].min():.3f} .. {data['uy_um'].max():.3f} um", flush=True)
    params = Parameters([Parameter(z, START) for z in TRUE] + [Parameter(z, v, vary=False) for z, v in HELD.items()])
    start, cpu = time.perf_counter(), time.process_time()
    result = identify({"builder": "bolt", **options(flank)}, work / "measured.csv", params, observables=["uy"],
                      stages=[1], noise={"u": 0.0005}, regions={"*": "bolt"}, run_dir=str(work / "run"),
                      method="trf", solver={"factorisation": "mumps"}, refine_target=0, suggestions=0,
                      progress=print)
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    r = result.to_dict()
    print(f"fit: M6 at flank {flank} mm, trf from {START}: {r['status']}, {r['n_iterations']} iterations, "
          f"{r['n_forward_solves']} forward and {r['n_sensitivity_solves']} sensitivity solves, {seconds:.0f} s "
          f"({cpu:.0f} s CPU)")
    for zone, truth in TRUE.items():
        p = r["parameters"][zone]
        stderr = "-" if p["stderr"] is None else f"{p['stderr']:.4f}"
        print(f"  {zone}: {p['value']:.4f} (true {truth}), standard error {stderr}, "
              f"{'resolved' if p['identifiable'] else 'not resolved'}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data-flank", type=float, default=0.7)
    parser.add_argument("--flank", type=float, default=1.0)
    parser.add_argument("--work", type=Path, default=Path("bolt3d_identify"))
    args = parser.parse_args()
    main(args.data_flank, args.flank, args.work)
