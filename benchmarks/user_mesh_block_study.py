"""A user's gmsh mesh of reference test 1 against the block builder at a similar mesh size, on the block study's
observations: what the identification sees, so the figures say how much a user's meshing choices move the data
a fit compares with.

Observations (frictionid.studies.block, the set-up examples/block identifies all four zones with): stereo DIC on
the block's four side faces (ux, uy, uz; 1 mm pitch, 0.5 to 7 mm above the contact), 2-D DIC of the plate top
seen from above (ux, uy; 1 mm and more outside the block) and the machine force, at the pull levels 0.04 mm
(partial slip, stage 2) and 0.2 mm (gross slip, stage 3), at the study's goal coefficients (seed 2024).

Meshes, quadratic hexahedra (27 nodes) both:
- builder: ``block_model(order=2, grading=3, pull_levels=(0.04,), mesh_size=h, block_divisions=d)``; every
  coordinate mapped by one smooth function, smallest at the footprint's edges and quadrant borders and at the
  interface;
- user: gmsh's transfinite hexahedra graded with gmsh's own curve laws (tests/element_models.py
  ``write_hex_block``: "Bump" 0.4 along the footprint's half sides, "Progression" away from the interface and
  outside the footprint), read through ``builder = "mesh"`` with the stages press, pull 1, pull in 1, 2, 8
  increments (the builder's load path).

The measure is the acceptance measure of the user-mesh tests: per displacement component and stage the largest
difference over the points divided by the builder's range of that component over the points; the machine force
as a relative difference. The builder against its own finer mesh shows the discretisation error of each size.

Run: .venv/bin/python benchmarks/user_mesh_block_study.py [--cases=...]   (each case in its own process; about
15 min on an idle machine; results kept in /tmp/user_mesh_block_study.json, so a run can be resumed)

Measured (2026-11-24, other jobs on the 2 cores; seconds for build, 11 increments and sensitivities, peak
memory of the case's process):

    case                          nodes   user vs builder, % of range (max over points)   force
                                          stage 2: ux / uy / uz    stage 3: ux / uy / uz   st. 2 / st. 3
    h 2.5  (6 per side)  user    15,566    8.8 / 1.8 / 0.2          6.4 / 0.6 / 0.2        +0.14 / -0.05 %
    h 1.67 (8 per side)  user    33,332    1.6 / 0.5 / 0.1          1.2 / 0.1 / 0.2        +0.18 / -0.02 %
    builder 2.5 against builder 1.67       3.5 / 0.4 / 1.2          3.6 / 1.1 / 1.7        +1.68 / -0.03 %

    first-order bias of a fit to the builder's 1.67 mm data (goal A 0.3703, B 0.1857, C 0.2238, D 0.4198):
      on the builder's 2.5 mm mesh   A +0.0040  B -0.0058  C +0.0028  D +0.0042
      on the user's 2.5 mm mesh      A -0.0120  B -0.0170  C +0.0042  D +0.0043
      on the user's 1.67 mm mesh     A -0.0074  B -0.0081  C +0.0007  D +0.0006

    builder 2.5: 9,926 nodes, 45 s, 4.8 GB; user 2.5: 15,566 nodes, 63 s, 6.5 GB;
    builder 1.67: 23,420 nodes, 171 s, 11.2 GB; user 1.67: 33,332 nodes, 150 s, 11.1 GB

From 1.67 mm on, the user's mesh is within 2 % of range of the builder's at every observation, and a fit on it
to the builder's data lands within 0.008 of the goal in every zone (the lightly loaded trailing zones A and B
are the most sensitive, as in examples/block). At 2.5 mm neither mesh is converged to 2 %: the builder moves by
3.6 % of ux's range between 2.5 and 1.67 mm. The largest differences are ux on the plate top 1 mm from the
block's corners (ux's range is 5 um, uy's 180 um).
"""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import _tests  # noqa: F401  (tests/ importable)
from _measure import peak_memory_mb
from frictionid.options import ModelSpec

ROOT = Path(__file__).resolve().parents[1]
STORE = Path("/tmp/user_mesh_block_study.json")
QUANTITIES = ("ux", "uy", "uz")
#: case name -> (kind, keyword arguments): builder cases for block_model, user cases for write_hex_block
CASES = {
    "builder 2.5": ("builder", {"mesh_size": 2.5, "block_divisions": 6}),
    "user 2.5": ("user", {"quarter": 3, "outer": 10, "block_z": 4, "plate_z": 2, "z_ratio": 1.6}),
    "builder 1.67": ("builder", {"mesh_size": 1.67, "block_divisions": 8}),
    "user 1.67": ("user", {"quarter": 4, "outer": 12, "block_z": 6, "plate_z": 3, "z_ratio": 1.35}),
}
#: (case, against) pairs of the table
PAIRS = (("user 2.5", "builder 2.5"), ("user 1.67", "builder 1.67"), ("builder 2.5", "builder 1.67"))


def user_options(path: Path) -> dict:
    """[model] of the block study on a user's mesh file: the builder's stages, load path and materials."""
    return {"builder": "mesh", "file": str(path), "kind": "3d", "stages": ["press", "pull 1", "pull"],
            "increments": [1, 2, 8],
            "materials": {"plate": {"E": 3500, "nu": 0.35}, "block": {"E": 71000, "nu": 0.33}},
            "supports": [{"boundary": "plate_bottom", "components": ["x", "y", "z"]}],
            "loads": [{"type": "pressure", "boundary": "block_top", "values": [20.0, 20.0, 20.0]},
                      {"type": "displacement", "boundary": "block_top", "component": "x", "values": [0, 0, 0]},
                      {"type": "displacement", "boundary": "block_top", "component": "y",
                       "values": [0, 0.04, 0.2]}],
            "interfaces": [{"name": "block_plate", "zones": ["A", "B", "C", "D"], "target": "plate_top"}]}


def run(name: str, folder: Path) -> dict:
    """One case: (n_stages, n_points * 3 + 1) displacements at the study's points and the machine force."""
    from frictionid.backends.embedded import EmbeddedBackend
    from frictionid.builders.block import block_model
    from frictionid.builders.registry import build_model
    from frictionid.studies import block as study
    start = time.perf_counter()
    kind, arguments = CASES[name]
    if kind == "builder":
        model = block_model(order=2, grading=3, pull_levels=study.PULL_LEVELS, **arguments)
    else:
        from element_models import write_hex_block
        model = build_model(ModelSpec.from_table(user_options(write_hex_block(folder / "user.msh", **arguments))))
    points, _ = study.points()
    mu = study.goal_coefficients()
    backend = EmbeddedBackend(model, points, QUANTITIES, None, ("block_top.y",))
    prediction = backend.predict(np.array([mu[z] for z in model.zone_names]), sensitivities=True)
    return {"values": prediction.values.tolist(), "derivatives": prediction.derivatives.tolist(),
            "zones": list(model.zone_names), "n_nodes": int(model.mesh.n_nodes),
            "seconds": time.perf_counter() - start, "peak_mb": peak_memory_mb()}


def differences(ours: np.ndarray, theirs: np.ndarray) -> list[tuple[float, ...]]:
    """Per stage after the press: (ux, uy, uz, force) differences, displacements as the largest difference over
    the observed points divided by ``theirs``' range there (uz on the side faces only), force relative."""
    from frictionid.studies import block as study
    _, labels = study.points()
    faces = np.array([label.startswith("F") for label in labels])
    out = []
    for stage in range(1, len(theirs)):
        a = np.asarray(ours[stage][:-1]).reshape(len(labels), len(QUANTITIES))
        b = np.asarray(theirs[stage][:-1]).reshape(len(labels), len(QUANTITIES))
        row = []
        for k, quantity in enumerate(QUANTITIES):
            seen = faces if quantity == "uz" else slice(None)
            row.append(float(np.abs(a[seen, k] - b[seen, k]).max() / np.ptp(b[seen, k])))
        out.append((*row, float(ours[stage][-1] / theirs[stage][-1] - 1)))
    return out


def bias(case: dict, data: dict) -> np.ndarray:
    """First-order bias -pinv(J) e of a least-squares fit on ``case``'s mesh to noise-free data from ``data``'s mesh
    at the goal (examples/block/screen.py): e = W (f_case - f_data), J = W df_case/dmu over the study's
    observations (stages 2 and 3; uz on the side faces only; the force), W = 1 / (0.5 um, 1 N)."""
    from frictionid.studies import block as study
    _, labels = study.points()
    seen = np.array([[True, True, label.startswith("F")] for label in labels]).ravel()
    rows = np.concatenate([np.flatnonzero(seen), [len(seen)]])
    weights = np.where(rows < len(seen), 1 / study.SIGMA_U, 1 / study.SIGMA_FORCE)
    f, g = np.asarray(case["values"]), np.asarray(data["values"])
    J = np.asarray(case["derivatives"])
    e = np.concatenate([weights * (f[s, rows] - g[s, rows]) for s in (1, 2)])
    jacobian = np.concatenate([weights[:, None] * J[s][rows] for s in (1, 2)])
    return -np.linalg.pinv(jacobian) @ e


def report(store: dict) -> None:
    print(f"{'case':<13} {'against':<13} {'stage 2: ux / uy / uz  force':>30} {'stage 3: ux / uy / uz  force':>30}")
    for name, against in PAIRS:
        if name in store and against in store:
            rows = differences(np.asarray(store[name]["values"]), np.asarray(store[against]["values"]))
            print(f"{name:<13} {against:<13} " + " ".join(
                f"{100 * ux:6.1f} /{100 * uy:5.1f} /{100 * uz:5.1f} % {100 * force:+6.2f} %"
                for ux, uy, uz, force in rows))
    from frictionid.studies import block as study
    reference = "builder 1.67"
    if reference in store:
        goal = ", ".join(f"{zone} {value:.4f}" for zone, value in study.goal_coefficients().items())
        print(f"first-order bias of a fit to {reference}'s data (goal {goal}):")
        for name, case in store.items():
            if name != reference:
                print(f"  on {name:<13} " + " ".join(f"{z} {b:+.4f}" for z, b in
                                                     zip(case["zones"], bias(case, store[reference]))))
    for name, case in store.items():
        print(f"{name:<13} {case['n_nodes']:7,d} nodes {case['seconds']:6.0f} s {case['peak_mb']:6.0f} MB")


def main(names) -> None:
    """Each case in a fresh process (its own peak memory), kept in :data:`STORE`; then the table."""
    store = json.loads(STORE.read_text()) if STORE.exists() else {}
    with tempfile.TemporaryDirectory() as folder:
        for name in names:
            if name in store:
                continue
            done = subprocess.run([sys.executable, __file__, "--case", name, folder], capture_output=True,
                                  text=True, check=True, timeout=3600)
            store[name] = json.loads(done.stdout.splitlines()[-1])
            STORE.write_text(json.dumps(store))
            print(f"{name}: {store[name]['n_nodes']} nodes, {store[name]['seconds']:.0f} s", flush=True)
    report(store)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--case"]:
        print(json.dumps(run(sys.argv[2], Path(sys.argv[3]))))
    else:
        chosen = next((a.split("=", 1)[1].split(",") for a in sys.argv[1:] if a.startswith("--cases=")), list(CASES))
        main(chosen)
