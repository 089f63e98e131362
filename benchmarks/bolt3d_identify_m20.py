"""The seed's Fig. 9 study on the short 3-D M20 (window and jaws): twin data from a finer 3-D mesh, the resolution
of each thread zone from the ten points and from the window's full field before fitting, and the identification
from the ten points with trf (analytic sensitivities) and with the seed's gradient descent (forward differences).

The layout is the short M20 of docs/bolt-study.md ("The 3-D model": engaged_length 5.0, thread_length 30.5,
n_axial 2, window and jaws, 10 kN in 2 increments); zones A-D (outer A, B and inner C, D of sections 1, 2 from the
bearing face) at frictionid.studies.bolt's TRUE_MU for those letters, head and nut bearing held at 0.15. Data: ux,
uy, uz at the ten points P1-P5 of flanks 1 and 2 (benchmarks/bolt3d.py ten_points) solved on the data mesh at the
truth; the fits use uy, noise-free ("exact") or with Gaussian noise of the seed's DIC 0.5 um ("noisy"), weighted by
0.5 um. The window's full field is ux, uy, uz at the vertex nodes of the fit mesh's "window_bolt" and
"window_nut" surfaces, each value with 0.5 um noise. Each model is built once and pickled (``--work``).

Run (from benchmarks/, under /usr/bin/time -v for the peak):
../.venv/bin/python bolt3d_identify_m20.py --work DIR [--fit-flank 2.5] [--data-flank 1.875] [--gd-iterations 5]
[--steps data trf gd noisy window]
Each step writes DIR/<step>.json; a step whose file exists is read, not run again.
"""

import argparse
import json
import pickle
import time
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb
from bolt3d import ten_points
from frictionid import Parameter, Parameters, identify
from frictionid.backends.embedded import use_cache
from frictionid.builders.bolt import bolt_layout, bolt_model
from frictionid.fem import memory
from frictionid.fem.problem import Problem
from frictionid.inverse.resolution import resolution
from frictionid.studies.bolt import NOISE, OPTIONS, START, TRUE_MU

SHORT = {"model": "3d", "size": "M20", "engaged_length": 5.0, "thread_length": 30.5, "n_axial": 2,
         "root_size": 0.3, "forces": [10000.0], "n_increments": 2, "cutout": True, "jaws": True}
HELD = {"head_plate": 0.15, "nut_plate": 0.15}
ZONES = ("A", "B", "C", "D")
TRUE = {z: TRUE_MU[z] for z in ZONES}
#: identify.resolution: the largest standard error counted as resolved
TOLERANCE = 0.02
SEED = 7


def options(flank: float) -> dict:
    return {**SHORT, "flank_size": flank, "contact_size": 2.0 * flank}


def layout():
    return bolt_layout("M20", None, SHORT["engaged_length"], None, 2, SHORT["n_axial"], None, SHORT["thread_length"])


def cached_model(flank: float, work: Path):
    path = work / f"model_{flank:g}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes()), float("nan")
    cpu = time.process_time()
    model = bolt_model(**options(flank))
    path.write_bytes(pickle.dumps(model))
    return model, time.process_time() - cpu


def timed(step, *args):
    """step(*args) with its wall and CPU time [s] and the process's peak so far [MB] added to its dict."""
    wall, cpu = time.perf_counter(), time.process_time()
    out = step(*args)
    return {**out, "wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu,
            "peak_mb_so_far": peak_memory_mb()}


def data_step(flank: float, work: Path) -> dict:
    """ux, uy, uz at the ten points on the data mesh at the truth; writes measured_exact.csv and measured.csv
    (uy, noise-free and with 0.5 um noise)."""
    model, build_cpu = cached_model(flank, work)
    print(memory.check(model, "data model", 10.5, "mumps").line(), flush=True)
    points = ten_points(layout())
    start, cpu = time.perf_counter(), time.process_time()
    problem = Problem.build(model, points=points, quantities=("ux", "uy", "uz"), regions=["bolt"] * len(points),
                            factorisation="mumps")
    condense = (time.perf_counter() - start, time.process_time() - cpu)
    mu = np.array([{**TRUE, **HELD}[z] for z in model.zone_names])
    values = problem.solve(mu).observations[-1].reshape(-1, 3)
    uy = values[:, 1]
    noisy = uy + np.random.default_rng(SEED).normal(0.0, NOISE, uy.shape)
    for name, column in (("measured_exact.csv", uy), ("measured.csv", noisy)):
        with open(work / name, "w") as out:
            out.write(f"# twin data: short 3-D M20 (window, jaws), flank {flank:g} mm, {model.mesh.n_nodes} nodes, "
                      f"mu {json.dumps(TRUE)}, head/nut bearing 0.15, 10 kN\n"
                      + ("" if column is uy else f"# Gaussian noise sigma {NOISE} mm added (seed {SEED})\n")
                      + "# units mm\npoint,x,y,z,stage,uy\n")
            for k, ((x, y, z), value) in enumerate(zip(points, column)):
                out.write(f"P{k // 5 + 1}{k % 5 + 1},{x:.6f},{y:.6f},{z:.6f},1,{value:.9e}\n")
    return {"flank": flank, "nodes": model.mesh.n_nodes, "pairs": problem.pairs.n_pairs, "build_cpu_s": build_cpu,
            "condense_wall_s": condense[0], "condense_cpu_s": condense[1], "u_um": (1e3 * values).tolist()}


def window_points(model) -> tuple[np.ndarray, list[str]]:
    """(n, 3) [mm] the vertex nodes of the window's bolt and nut surfaces and each one's region."""
    points, regions = [], []
    for surface, region in (("window_bolt", "bolt"), ("window_nut", "nut")):
        nodes = np.unique(model.mesh.boundaries[surface][:, :3])        # a 6-node facet's corners come first
        points.append(model.mesh.points[nodes])
        regions += [region] * len(nodes)
    return np.vstack(points), regions


def prefit_step(model, points, quantities, regions) -> dict:
    """One condensation of the fit model with these observations and one solve with sensitivities at the start:
    the singular values and predicted standard errors of the free zones at 0.5 um per value."""
    start, cpu = time.perf_counter(), time.process_time()
    problem = Problem.build(model, points=points, quantities=quantities, regions=regions, factorisation="mumps")
    condense = (time.perf_counter() - start, time.process_time() - cpu)
    mu = np.array([{**{z: START for z in ZONES}, **HELD}[z] for z in model.zone_names])
    solution = problem.solve(mu, sensitivities=True)
    free = [list(model.zone_names).index(z) for z in ZONES]
    jacobian = solution.d_observations[-1][:, free] / NOISE
    report = resolution(jacobian, ZONES, TOLERANCE)
    return {"n_points": len(points), "n_values": jacobian.shape[0], "pairs": problem.pairs.n_pairs,
            "condense_wall_s": condense[0], "condense_cpu_s": condense[1],
            "singular_values": report.singular_values.tolist(), "stderr": dict(zip(ZONES, report.stderr.tolist())),
            "directions": report.directions.tolist(), "resolved": dict(zip(ZONES, map(bool, report.resolved)))}


def method_options(method: str) -> dict:
    """The axisymmetric demo's [identify] options of ``method`` (studies/bolt.py OPTIONS) as a dict."""
    return {key: json.loads(value) for key, value in (item.split(" = ") for item in OPTIONS[method].split(", "))}


def fit_step(model, work: Path, name: str, data: str, method: str, jacobian: str, iterations: int) -> dict:
    params = Parameters([Parameter(z, START) for z in ZONES] + [Parameter(z, v, vary=False) for z, v in HELD.items()])
    lines = []
    result = identify(model, work / data, params, observables=["uy"], stages=[1], noise={"u": NOISE},
                      regions={"*": "bolt"}, run_dir=str(work / "runs" / name), resume=True, method=method,
                      jacobian=jacobian, max_iterations=iterations, solver={"factorisation": "mumps"},
                      refine_target=0, suggestions=0,
                      options=method_options(method),
                      progress=lambda text: (lines.append(text), print(text, flush=True)))
    r = result.to_dict()
    objective = np.array(r["history"]["objective"])
    return {"status": r["status"], "n_iterations": r["n_iterations"], "n_forward_solves": r["n_forward_solves"],
            "n_sensitivity_solves": r["n_sensitivity_solves"], "parameters": {z: r["parameters"][z] for z in ZONES},
            "history": r["history"], "prefit": r["identifiability"]["prefit"],
            # noise-free data from the same points and one sigma: |u_k - u| / |u_0 - u| = sqrt(J_k / J_0)
            "relative_error": np.sqrt(objective / objective[0]).tolist(), "log": lines}


def main(work: Path, fit_flank: float, data_flank: float, gd_iterations: int, steps: list[str]) -> None:
    work.mkdir(parents=True, exist_ok=True)
    use_cache(work / "cache")

    def once(step: str, make):
        path = work / f"{step}.json"
        if path.exists():
            return json.loads(path.read_text())
        if step not in steps:
            return None
        out = timed(make)
        path.write_text(json.dumps(out, indent=1, default=float))
        print(f"{step}: {json.dumps({k: v for k, v in out.items() if k not in ('history', 'log', 'prefit')}, default=float)}",
              flush=True)
        return out

    once("data", lambda: data_step(data_flank, work))
    model, build_cpu = cached_model(fit_flank, work)
    print(f"fit model: flank {fit_flank:g} mm, {model.mesh.n_nodes:,} nodes, build {build_cpu:.0f} s CPU", flush=True)
    once("trf", lambda: fit_step(model, work, "trf", "measured_exact.csv", "trf", "analytic", 30))
    once("gd", lambda: fit_step(model, work, "gd", "measured_exact.csv", "gradient-descent", "forward",
                                gd_iterations))
    once("noisy", lambda: fit_step(model, work, "trf-noisy", "measured.csv", "trf", "analytic", 30))
    field, regions = window_points(model)
    once("window", lambda: prefit_step(model, field, ("ux", "uy", "uz"), regions))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, default=Path("bolt3d_identify_m20"))
    parser.add_argument("--fit-flank", type=float, default=2.5)
    parser.add_argument("--data-flank", type=float, default=1.875)
    parser.add_argument("--gd-iterations", type=int, default=5)
    parser.add_argument("--steps", nargs="+", default=["data", "trf", "gd", "noisy", "window"])
    args = parser.parse_args()
    main(args.work, args.fit_flank, args.data_flank, args.gd_iterations, args.steps)
