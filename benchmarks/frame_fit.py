"""Frames fitted to the model's surface (docs/data.md, "Fitted frames"): time, peak memory and accuracy of
``fit = "surface"`` on the 3-D block (mesh_size 2) for points on three block faces and the plate, in a frame turned
by (4, -3, 6) deg and shifted by up to 0.5 mm, fitted from no turn. Each size runs in its own process, so that its
peak memory is its own.

Run: .venv/bin/python benchmarks/frame_fit.py [n_points ...]      (default 100 10000 100000)
"""

import json
import subprocess
import sys

import numpy as np

from _measure import peak_memory_mb, timed


def face_points(n: int, seed: int = 3) -> np.ndarray:
    """About ``n`` points, a quarter on each of the block's faces x = -5, y = -5, z = 10 and on the plate's top."""
    rng = np.random.default_rng(seed)
    k = max(n // 4, 1)
    return np.concatenate([
        np.c_[np.full(k, -5.0), rng.uniform(-5, 5, k), rng.uniform(0.5, 9.5, k)],
        np.c_[rng.uniform(-5, 5, k), np.full(k, -5.0), rng.uniform(0.5, 9.5, k)],
        np.c_[rng.uniform(-5, 5, k), rng.uniform(-5, 5, k), np.full(k, 10.0)],
        np.c_[rng.uniform(-19, -6, k), rng.uniform(-19, 19, k), np.zeros(k)]])


def one(n: int) -> dict:
    from frictionid.builders.block import block_model
    from frictionid.data.frame_fit import fit_to_surface
    from frictionid.data.frames import Frame, frame_spec
    from frictionid.fem.surface import mesh_surface

    surface = mesh_surface(block_model(mesh_size=2.0).mesh)
    model_xyz = face_points(n)
    file_xyz = Frame.of([4.0, -3.0, 6.0], [0.5, -0.4, 0.3]).inverse().points(model_xyz)
    figures = {}
    with timed(figures, "fit_s"):
        fit = fit_to_surface(frame_spec({"fit": "surface"}, "transform"), [str(i) for i in range(len(file_xyz))],
                             file_xyz, surface, "benchmark")
    return {"n_points": len(model_xyz), "n_facets": len(surface.corners), **figures,
            "largest_error_mm": float(np.abs(fit.frame.points(file_xyz) - model_xyz).max()),
            "peak_mb": peak_memory_mb()}


def main(sizes) -> None:
    print(f"{'points':>8} {'facets':>7} {'fit [s]':>8} {'error [mm]':>11} {'peak [MB]':>10}")
    for n in sizes:
        out = subprocess.run([sys.executable, __file__, "--one", str(n)], capture_output=True, text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"{r['n_points']:>8,} {r['n_facets']:>7,} {r['fit_s']:>8.2f} {r['largest_error_mm']:>11.2g} "
              f"{r['peak_mb']:>10.0f}")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--one"]:
        print(json.dumps(one(int(sys.argv[2]))))
    else:
        main([int(a) for a in sys.argv[1:]] or [100, 10_000, 100_000])
