"""The 3-D M20 bolt-nut model: build, condensation, forward solve and forward + sensitivities, with the sizes that
set the dense condensation's cost (contact pairs n_c, contact dofs n_w = 3 n_c, the dofs the contact and
observation rows touch, which the Schur complement is taken onto).

Run: .venv/bin/python benchmarks/bolt3d.py '<bolt_model options as JSON>' [model.pkl]
e.g. '{"model": "3d", "engaged_length": 5.0, "thread_length": 30.5, "n_axial": 2, "flank_size": 1.25,
"contact_size": 2.5, "forces": [10000.0], "n_increments": 2}'. With a second argument the built model is pickled
there, or read from there when it exists (the build takes minutes). Run it under /usr/bin/time -v for the peak.
"""

import json
import pickle
import sys
import time
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb, timed
from frictionid.builders.bolt import bolt_layout, bolt_model
from frictionid.builders.bolt3d import measurement_points_3d
from frictionid.fem.problem import Problem


def ten_points(layout) -> np.ndarray:
    """(10, 3) [mm] the seed's P1-P5 on flanks 1 and 2, moved 0.1 mm radially into the bolt tooth: the tets are
    straight-sided, the points on the exact helicoid lie up to a few um outside the mesh's chords."""
    points = measurement_points_3d(layout)
    radius = np.hypot(points[:, 0], points[:, 2])
    points[:, [0, 2]] *= ((radius - 0.1) / radius)[:, None]
    return points


def main(options: dict, cache: str | None = None):
    figures = {}
    options = {"model": "3d", **options}
    if cache and Path(cache).exists():
        model = pickle.loads(Path(cache).read_bytes())
        figures["build"] = float("nan")
    else:
        with timed(figures, "build"):
            model = bolt_model(**options)
        if cache:
            Path(cache).write_bytes(pickle.dumps(model))
    layout = bolt_layout(options.get("size", "M20"), options.get("length"), options.get("engaged_length"),
                         options.get("clearance"), options.get("n_radial", 2), options.get("n_axial", 3),
                         options.get("bearing_diameter"), options.get("thread_length"))
    points = ten_points(layout)
    print(f"3-D M20 bolt-nut {json.dumps(options)}: {model.mesh.n_nodes:,} nodes, {3 * model.mesh.n_nodes:,} dofs;"
          f" build {figures['build']:.1f} s, peak so far {peak_memory_mb():.0f} MB", flush=True)
    with timed(figures, "condense"):
        problem = Problem.build(model, points=points, quantities=("ux", "uy", "uz"),
                                regions=["bolt"] * len(points))
    n_pairs = problem.pairs.n_pairs
    print(f"  contact pairs n_c = {n_pairs:,}, contact dofs n_w = {3 * n_pairs:,}: dense W {72 * n_pairs ** 2 / 1e9:.2f}"
          f" GB; condensation {figures['condense']:.1f} s, peak so far {peak_memory_mb():.0f} MB", flush=True)
    mu = np.full(len(model.zone_names), 0.15)
    start = time.perf_counter()
    forward = problem.solve(mu)
    figures["forward"] = time.perf_counter() - start
    start = time.perf_counter()
    problem.solve(mu, sensitivities=True)
    figures["sensitivities"] = time.perf_counter() - start
    print(f"  forward {figures['forward']:.1f} s ({forward.n_newton.sum()} Newton iterations), forward + "
          f"sensitivities {figures['sensitivities']:.1f} s, peak {peak_memory_mb():.0f} MB")


if __name__ == "__main__":
    main(json.loads(sys.argv[1]), sys.argv[2] if len(sys.argv) > 2 else None)
