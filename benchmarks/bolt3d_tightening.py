"""The 3-D bolt's tightening test against VDI 2230: the nut's flats turned against the held head, uniform mu on
thread, head and nut bearing; prints the wrench torque, the clamp force, where the torque goes (thread: from the
normal forces, i.e. the lead, and from friction; nut bearing), the effective radii and VDI 2230's torque at
them (:func:`frictionid.report.bolt.vdi_torque`), per mu.

Run: .venv/bin/python benchmarks/bolt3d_tightening.py '<bolt_model options as JSON>' [model.pkl] [--mu 0.1 0.2]
e.g. '{"size": "M8", "model": "3d", "load": "tightening", "engaged_length": 2.5, "thread_length": 13.05,
"n_axial": 2, "flank_size": 1.25, "contact_size": 2.5, "mesh_size": 4.0, "root_size": 0.25, "cutout": false,
"angles": [0.05, 0.1], "n_increments": 1}' (the model of tests/test_bolt3d_tightening.py). With a second argument
the built model is pickled there, or read from there when it exists. Condensed with factorisation "mumps". Run
it under /usr/bin/time -v for the peak.
"""

import argparse
import json
import time

import numpy as np

from bolt3d import built
from frictionid.builders.bolt import bolt_layout
from frictionid.fem.problem import Problem
from frictionid.report.bolt import torque_split, vdi_torque


def main(options: dict, cache: str | None, mus: list[float]):
    start = time.process_time()
    model = built(options, cache, {})
    made = time.process_time()
    problem = Problem.build(model, factorisation="mumps")
    condensed = time.process_time()
    pitch = bolt_layout(options.get("size", "M20")).size.P
    print(f"{json.dumps(options)}: {model.mesh.n_nodes:,} nodes, {problem.pairs.n_pairs:,} pairs; model "
          f"{made - start:.1f} s CPU, assembly + condensation {condensed - made:.1f} s CPU")
    for mu in mus:
        solution = problem.solve(np.full(model.n_zones, mu))
        reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
        torque, force = reactions["nut_outer.torque"], reactions["plate1_rim.y"]
        split = torque_split(solution)
        vdi = vdi_torque(force, pitch, split.r_thread, split.r_bearing, mu, mu)
        print(f"  mu {mu}: T {torque:.3f} N mm, F {force:.3f} N, T/F {torque / force:.5f} mm; thread "
              f"{split.thread:.3f} (normal forces {split.thread_normal:.3f} = F x {split.thread_normal / force:.5f}"
              f" mm, P/2pi {pitch / (2 * np.pi):.5f}), bearing {-split.bearing:.3f}; r_G {split.r_thread:.4f}, r_K "
              f"{split.r_bearing:.4f} mm; VDI 2230 {vdi:.3f} N mm, T / VDI - 1 = {100 * (torque / vdi - 1):+.2f} %")


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("options")
    parser.add_argument("cache", nargs="?")
    parser.add_argument("--mu", type=float, nargs="+", default=[0.1, 0.2])
    arguments = parser.parse_args()
    main(json.loads(arguments.options), arguments.cache, arguments.mu)
