"""The 3-D bolt-nut model without window and jaws against the axisymmetric model of the same layout: load share per
engaged thread (3-D: per turn, a turn from the seam opposite theta = 0 round to it), load share per pitch of axial
position, cut midway between the axisymmetric model's flanks (the same cut for both models:
frictionid.report.bolt.pitch_loads; the 3-D helix's pairs below and above the engaged flanks' pitches count to
the first and last) and bolt
elongation (uy of the bolt end's centre minus that of the head's centre), at the same machine force and
coefficients.

Run: .venv/bin/python benchmarks/bolt3d_vs_axisymmetric.py '<bolt_model options as JSON>' [model.pkl [factorisation]]
(options for both models; the 3-D one gets model = "3d", cutout = false, jaws = false; a second argument as in
benchmarks/bolt3d.py; the third the 3-D model's factorisation, e.g. "cholmod_solves"). Run it under
/usr/bin/time -v for the peak.
"""

import json
import sys
import time

import numpy as np

from _measure import peak_memory_mb
from bolt3d import built
from frictionid.builders.bolt import bolt_layout, bolt_model
from frictionid.fem.problem import Problem
from frictionid.report.bolt import pitch_loads, ring_gap, thread_loads

MU = 0.15
AXISYMMETRIC_ONLY = ("flank_size", "contact_size", "mesh_size", "root_size")


def elongation_points(layout, dim: int) -> np.ndarray:
    """Head centre 0.5 mm below its top face and bolt end centre 0.5 mm inside it, on the axis."""
    s = layout.size
    ends = [-s.head_k + 0.5, layout.length - 0.5]
    return np.array([[0.0, y, 0.0][:dim] for y in ends])


def solved(model, layout, dim: int, factorisation: str = "auto", y_start: float | None = None):
    """(per-turn loads, per-pitch shares, elongation [mm], y_start) at mu = MU; the pitches cut from y_start, by
    default between the model's first two flanks (an axisymmetric model's)."""
    start = time.perf_counter()
    problem = Problem.build(model, points=elongation_points(layout, dim), quantities=("uy",),
                            regions=["bolt", "bolt"], factorisation=factorisation)
    built = time.perf_counter() - start
    solution = problem.solve(np.full(len(model.zone_names), MU))
    loads = thread_loads(model, solution)
    if y_start is None:
        y_start = ring_gap(model, solution, layout.size.P)
    shares = pitch_loads(model, solution, y_start, layout.size.P, len(layout.flanks))
    uy = solution.observations[-1]
    print(f"  {model.kind}: {model.mesh.n_nodes:,} nodes, {problem.pairs.n_pairs:,} contact pairs; condensation "
          f"{built:.1f} s, solve {time.perf_counter() - start - built:.1f} s, peak {peak_memory_mb():.0f} MB",
          flush=True)
    return loads, shares, float(uy[1] - uy[0]), y_start


def main(options: dict, cache: str | None = None, factorisation: str = "auto"):
    layout = bolt_layout(options.get("size", "M20"), options.get("length"), options.get("engaged_length"),
                         options.get("clearance"), options.get("n_radial", 2), options.get("n_axial", 3),
                         options.get("bearing_diameter"), options.get("thread_length"))
    three = {**options, "model": "3d", "cutout": False, "jaws": False}
    model3 = built(three, cache, {})
    axi = {k: v for k, v in options.items() if k not in AXISYMMETRIC_ONLY}
    print(f"3-D {json.dumps(three)} against the axisymmetric model {json.dumps(axi)}, mu = {MU} everywhere")
    loads2, pitch2, elongation2, y_start = solved(bolt_model(**axi), layout, 2)
    loads3, pitch3, elongation3, _ = solved(model3, layout, 3, factorisation, y_start)
    print(f"  machine force {loads2.applied:.0f} / {loads3.applied:.0f} N; thread forces sum to "
          f"{loads2.force.sum():.0f} / {loads3.force.sum():.0f} N (axisymmetric / 3-D)")
    for i in range(max(loads2.n_threads, loads3.n_threads)):
        a = loads2.share[i] if i < loads2.n_threads else float("nan")
        b = loads3.share[i] if i < loads3.n_threads else float("nan")
        print(f"  thread {i + 1}: share {100 * a:.2f} % / {100 * b:.2f} %, difference "
              f"{100 * (b - a) / loads2.share[0]:+.2f} % of the first thread's share")
    for k, (a, b) in enumerate(zip(pitch2, pitch3)):
        print(f"  pitch {k + 1} from y = {y_start + k * layout.size.P:.3f} mm: share {100 * a:.2f} % / {100 * b:.2f} %, difference "
              f"{100 * (b - a) / pitch2[0]:+.2f} % of the first pitch's share")
    print(f"  bolt elongation {1000 * elongation2:.3f} / {1000 * elongation3:.3f} um: "
          f"{100 * (elongation3 / elongation2 - 1):+.2f} %")


def axis(options: dict, heights: list[float], cache: str | None = None, factorisation: str = "auto"):
    """uy's change between consecutive ``heights`` on the axis, both models, at mu = MU."""
    three = {**options, "model": "3d", "cutout": False, "jaws": False}
    axi = {k: v for k, v in options.items() if k not in AXISYMMETRIC_ONLY}
    ys = np.asarray(heights, float)
    changes = []
    for model, dim, how in ((bolt_model(**axi), 2, "auto"), (built(three, cache, {}), 3, factorisation)):
        points = np.array([[0.0, y, 0.0][:dim] for y in ys])
        problem = Problem.build(model, points=points, quantities=("uy",), regions=["bolt"] * len(ys),
                                factorisation=how)
        uy = np.asarray(problem.solve(np.full(len(model.zone_names), MU)).observations[-1]).ravel()
        changes.append(1000 * np.diff(uy))
    for k, (a, b) in enumerate(zip(*changes)):
        print(f"  y {ys[k]:7.2f} -> {ys[k + 1]:7.2f} mm: axisymmetric {a:8.4f} um, 3-D {b:8.4f} um, "
              f"{100 * (b / a - 1):+.2f} %")
    print(f"  total: axisymmetric {changes[0].sum():.4f} um, 3-D {changes[1].sum():.4f} um, "
          f"{100 * (changes[1].sum() / changes[0].sum() - 1):+.2f} %")


if __name__ == "__main__":
    if "--axis" in sys.argv:
        at = sys.argv.index("--axis")
        heights = [float(v) for v in sys.argv[at + 1].split(",")]
        rest = sys.argv[1:at] + sys.argv[at + 2:]
        axis(json.loads(rest[0]), heights, *rest[1:3])
    else:
        main(json.loads(sys.argv[1]), *sys.argv[2:4])
