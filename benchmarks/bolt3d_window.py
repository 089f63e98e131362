"""The nut window's effect on the seed's ten points: uy at P1-P5 of flanks 1 and 2 (in the window's centre section,
0.1 mm inside the bolt tooth) of the 3-D model with and without the window, same layout, sizes, force and mu.

Run: .venv/bin/python benchmarks/bolt3d_window.py '<bolt_model options as JSON>' with.pkl [without.pkl]
(the 3-D options; "cutout" true for the first model, false for the second, jaws as given; each model pickled to
its file, or read from it when it exists, as in benchmarks/bolt3d.py; without the second file only the model with
the window is solved, e.g. at another flank size). Both are condensed with
``factorisation = "mumps"`` (docs/bolt-study.md: CHOLMOD's factor with the contact dofs last passes 10 GB on the
3-D bolt), one model after the other. Run it under /usr/bin/time -v for the peak.
"""

import json
import pickle
import sys
import time
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb
from bolt3d import ten_points
from frictionid.builders.bolt import bolt_layout, bolt_model
from frictionid.fem.problem import Problem

MU = 0.15


def ten_point_uy(model, points: np.ndarray) -> np.ndarray:
    """(10,) [mm] uy at the points at the last increment, mu = MU everywhere."""
    start, cpu = time.perf_counter(), time.process_time()
    problem = Problem.build(model, points=points, quantities=("uy",), regions=["bolt"] * len(points),
                            factorisation="mumps")
    built, built_cpu = time.perf_counter() - start, time.process_time() - cpu
    solution = problem.solve(np.full(len(model.zone_names), MU))
    print(f"  {model.mesh.n_nodes:,} nodes, {problem.pairs.n_pairs:,} contact pairs; assembly + condensation "
          f"{built:.1f} s ({built_cpu:.1f} s CPU), forward solve {time.perf_counter() - start - built:.1f} s "
          f"({time.process_time() - cpu - built_cpu:.1f} s CPU), peak so far {peak_memory_mb():.0f} MB", flush=True)
    return solution.observations[-1]


def cached(options: dict, path: str):
    if Path(path).exists():
        return pickle.loads(Path(path).read_bytes())
    model = bolt_model(**options)
    Path(path).write_bytes(pickle.dumps(model))
    return model


def main(options: dict, with_window: str, without_window: str | None = None):
    options = {**options, "model": "3d"}
    layout = bolt_layout(options.get("size", "M20"), options.get("length"), options.get("engaged_length"),
                         options.get("clearance"), options.get("n_radial", 2), options.get("n_axial", 3),
                         options.get("bearing_diameter"), options.get("thread_length"))
    points = ten_points(layout)
    print(f"3-D {json.dumps(options)}, mu = {MU} everywhere; uy at the ten points with / without the window")
    uy = []
    for cutout, path in ((True, with_window), (False, without_window))[:2 if without_window else 1]:
        start = time.process_time()
        model = cached({**options, "cutout": cutout}, path)
        print(f"{'with' if cutout else 'without'} the window: model {time.process_time() - start:.1f} s CPU "
              f"(built, or read from {path})", flush=True)
        uy.append(ten_point_uy(model, points))
        del model
    if not without_window:
        for i, a in enumerate(uy[0]):
            print(f"  flank {i // 5 + 1} P{i % 5 + 1}: {1000 * a:.3f} um")
        return
    span = np.ptp(uy[1])
    print(f"  range of uy over the ten points without the window: {1000 * span:.3f} um")
    for i, (a, b) in enumerate(zip(*uy)):
        print(f"  flank {i // 5 + 1} P{i % 5 + 1}: {1000 * a:.3f} / {1000 * b:.3f} um, difference "
              f"{1000 * (a - b):+.3f} um ({100 * (a - b) / span:+.1f} % of the range without the window)")


if __name__ == "__main__":
    main(json.loads(sys.argv[1]), *sys.argv[2:4])
