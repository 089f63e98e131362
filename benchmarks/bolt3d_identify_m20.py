"""The seed's Fig. 9 study on the short 3-D M20 (window and jaws): twin data from a finer 3-D mesh, the resolution
of each thread zone from the ten points and from the window's full field before fitting, and the identification
from the ten points with trf (analytic sensitivities) and with the seed's gradient descent (forward differences).

The layout is the short M20 of docs/bolt-study.md ("The 3-D model": engaged_length 5.0, thread_length 30.5,
n_axial 2, window and jaws, 10 kN in 2 increments); zones A-D (outer A, B and inner C, D of sections 1, 2 from the
bearing face) at frictionid.studies.bolt's TRUE_MU for those letters, head and nut bearing held at 0.15. Data: ux,
uy, uz at the ten points P1-P5 of flanks 1 and 2 (benchmarks/bolt3d.py ten_points) solved on the data mesh at the
truth; the fits use uy, noise-free, weighted by the seed's DIC noise 0.5 um (measured.csv, the copy with that
noise, is written and not fitted). The window's full field is ux, uy, uz at the vertex nodes of the fit mesh's "window_bolt" and
"window_nut" surfaces, each value with 0.5 um noise. Steps: data (the data mesh's condensation and solve), trf and
gd (frictionid.studies.bolt3d, the runs of ``frictionid demo --model 3d``), window (the resolution from the
window's faces before fitting: one condensation of the fit model with those points), truth (the fit mesh's misfit
at the true coefficients at the ten points), window_error (the two meshes' difference at the window's points
against the coefficients' signal: one condensation of each model). Each model is built once and pickled
(``--work``); each step runs in the process that asks for it, so ``--steps`` one at a time keeps the peaks apart.

Run (from benchmarks/, under /usr/bin/time -v for the peak):
../.venv/bin/python bolt3d_identify_m20.py --work DIR [--fit-flank 2.5] [--data-flank 1.875] [--gd-iterations 5]
[--trf-iterations 10] [--steps data trf gd window truth window_error]
Each step writes DIR/<step>.json; a step whose file exists is read, not run again.
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb
from frictionid.backends.embedded import use_cache
from frictionid.fem import memory
from frictionid.fem.problem import Problem
from frictionid.inverse.resolution import resolution
from frictionid.studies.bolt import NOISE, START, TRUE_MU
from frictionid.backends import make_backend
from frictionid.builders.bolt import fixed_friction
from frictionid.config import config_from_dict
from frictionid.preparation import prepare
from frictionid.studies.bolt3d import PLAN, ZONES, Settings3d, cached_model, fit, make_data

#: identify.resolution: the largest standard error counted as resolved
TOLERANCE = 0.02


def timed(step, *args):
    """step(*args) with its wall and CPU time [s] and the process's peak so far [MB] added to its dict."""
    wall, cpu = time.perf_counter(), time.process_time()
    out = step(*args)
    return {**out, "wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu,
            "peak_mb_so_far": peak_memory_mb()}


def data_step(flank: float, work: Path, seed: int) -> dict:
    model, build_cpu = cached_model(flank, work)
    print(memory.check(model, "data model", 10.5, "mumps").line(), flush=True)
    return {**make_data(model, flank, work, seed), "build_cpu_s": build_cpu}


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
    mu = np.array([{**{z: START for z in ZONES}, **fixed_friction()}[z] for z in model.zone_names])
    solution = problem.solve(mu, sensitivities=True)
    free = [list(model.zone_names).index(z) for z in ZONES]
    jacobian = solution.d_observations[-1][:, free] / NOISE
    report = resolution(jacobian, ZONES, TOLERANCE)
    return {"n_points": len(points), "n_values": jacobian.shape[0], "pairs": problem.pairs.n_pairs,
            "condense_wall_s": condense[0], "condense_cpu_s": condense[1],
            "singular_values": report.singular_values.tolist(), "stderr": dict(zip(ZONES, report.stderr.tolist())),
            "directions": report.directions.tolist(), "resolved": dict(zip(ZONES, map(bool, report.resolved)))}


def fit_step(model, work: Path, name: str, data: str, method: str, jacobian: str, iterations: int) -> dict:
    """frictionid.studies.bolt3d.fit (resumed from its store when one exists), the fields kept here."""
    lines = []
    r = fit(model, work, name, data, method, jacobian, iterations, True,
            lambda text: (lines.append(text), print(text, flush=True)))
    return {**{key: r[key] for key in ("status", "n_iterations", "n_forward_solves", "n_sensitivity_solves",
                                       "history", "relative_error", "wall_time_s")},
            "parameters": {z: r["parameters"][z] for z in ZONES}, "prefit": r["identifiability"]["prefit"],
            "log": lines}


def truth_step(model, work: Path, trf: dict) -> dict:
    """The fit model's uy at the ten points against the data [um], at the start, at the truth and at trf's last
    iterate, through the backend the fits used (its condensation and the solves with sensitivities read from the
    cache): the fit mesh's own misfit at the truth, and |u_k - u| / |u_0 - u| against trf's sqrt(J_k / J_0)."""
    config = config_from_dict({"friction": {"zones": {z: START for z in ZONES}, "fixed": fixed_friction()},
                               "data": {"file": str(work / "measured_exact.csv"), "observables": ["uy"],
                                        "stages": [1], "noise": {"u": NOISE}, "regions": {"*": "bolt"}},
                               "solver": {"factorisation": "mumps"}, "run": {"dir": str(work / "runs" / "trf")}},
                              need=("friction", "data", "run"), name="truth")
    obs = prepare(config, model).observations
    backend = make_backend(model, obs.points, obs.quantities, obs.point_regions, config.solver, "truth")
    names = list(model.zone_names)
    at = {"start": (np.array(trf["history"]["coefficients"][0]), True),
          "truth": (np.array([{**TRUE_MU, **fixed_friction()}[z] for z in names]), False),
          "trf_last": (np.array(trf["history"]["coefficients"][-1]), True)}
    misfit = {key: 1e3 * (obs.predicted(backend.predict(mu, sensitivities).values) - obs.y) for key, (mu, sensitivities)
              in at.items()}
    norm = {key: float(np.linalg.norm(value)) for key, value in misfit.items()}
    return {"misfit_um": {key: value.tolist() for key, value in misfit.items()}, "norm_um": norm,
            "noise_levels": {key: value / (1e3 * NOISE) for key, value in norm.items()},
            "relative_error_trf_last": norm["trf_last"] / norm["start"]}


def window_error_step(fit_model, work: Path, settings: Settings3d) -> dict:
    """ux, uy, uz [um] at the window's points (the fit mesh's, :func:`window_points`) on the data mesh and on the
    fit mesh at the truth, and on the fit mesh at the start: the two meshes' difference against the signal of
    the coefficients, in noise levels (0.5 um). One condensation of each model, one after the other."""
    field, regions = window_points(fit_model)
    names = list(fit_model.zone_names)
    truth = np.array([{**TRUE_MU, **fixed_friction()}[z] for z in names])
    start = np.array([{**{z: START for z in ZONES}, **fixed_friction()}[z] for z in names])
    values = {}
    for label, flank in (("data", settings.data_flank), ("fit", settings.flank)):
        model = fit_model if label == "fit" else cached_model(flank, work)[0]
        problem = Problem.build(model, points=field, quantities=("ux", "uy", "uz"), regions=regions,
                                factorisation="mumps")
        values[f"{label}_truth"] = 1e3 * problem.solve(truth).observations[-1]
        if label == "fit":
            values["fit_start"] = 1e3 * problem.solve(start).observations[-1]
        del problem, model
    error = values["fit_truth"] - values["data_truth"]
    signal = values["fit_truth"] - values["fit_start"]
    noise = 1e3 * NOISE
    return {"n_points": len(field), "error_rms_um": float(np.sqrt(np.mean(error ** 2))),
            "error_max_um": float(np.abs(error).max()), "signal_rms_um": float(np.sqrt(np.mean(signal ** 2))),
            "signal_max_um": float(np.abs(signal).max()), "error_norm_noise": float(np.linalg.norm(error) / noise),
            "signal_norm_noise": float(np.linalg.norm(signal) / noise),
            "values_um": {key: value.tolist() for key, value in values.items()}}


#: one coefficient per axial section: A + C (section 1, next to the bearing face), B + D (section 2)
SECTIONS = {"AC": ("A", "C"), "BD": ("B", "D")}


def merged_stderr(singular_values, directions) -> dict:
    """Predicted standard errors of one coefficient per axial section (SECTIONS), from the information matrix
    F = V S^2 V^T of the four zones (V: directions, rows in ZONES' order)."""
    v = np.asarray(directions, dtype=float)
    information = v @ np.diag(np.asarray(singular_values, dtype=float) ** 2) @ v.T
    merge = np.array([[z in zones for zones in SECTIONS.values()] for z in ZONES], dtype=float)
    covariance = np.linalg.inv(merge.T @ information @ merge)
    return dict(zip(SECTIONS, np.sqrt(np.diag(covariance)).tolist()))


def without_translations(values: np.ndarray, n_bolt: int) -> np.ndarray:
    """(n, 3) values less their mean per component on each face (bolt rows first, then the nut's): what is left
    after a DIC's rigid translation of each face is taken out."""
    out = np.array(values, dtype=float)
    for rows in (slice(0, n_bolt), slice(n_bolt, None)):
        out[rows] -= out[rows].mean(axis=0)
    return out


def window_error_lines(step: dict, n_bolt: int) -> list[str]:
    """The two meshes' difference and the coefficients' signal at the window's points, RMS [um] and norm in
    noise levels, as they are and with each face's translation taken out."""
    v = {key: np.array(value).reshape(-1, 3) for key, value in step["values_um"].items()}
    error, signal = v["fit_truth"] - v["data_truth"], v["fit_truth"] - v["fit_start"]
    lines = []
    for label, change in (("as solved", lambda a: a), ("each face's translation taken out",
                                                        lambda a: without_translations(a, n_bolt))):
        e, s = change(error), change(signal)
        lines.append(f"window's points, {label}: meshes' difference {np.sqrt(np.mean(e ** 2)):.3f} um RMS "
                     f"({np.linalg.norm(e) / (1e3 * NOISE):.2f} noise levels in norm), coefficients' signal (0.1 to "
                     f"the truth) {np.sqrt(np.mean(s ** 2)):.3f} um RMS ({np.linalg.norm(s) / (1e3 * NOISE):.2f})")
    return lines


def report(results: dict, n_bolt: int) -> None:
    """Print the fits zone by zone, the resolution before fitting of both observation sets and the meshes'
    difference at the window's points (``n_bolt`` of them on the bolt, listed first)."""
    for name, r in ((n, results.get(n)) for n, *_ in PLAN):
        if r is None:
            continue
        print(f"{name}: {r['status']}, {r['n_iterations']} iterations, {r['n_forward_solves']} forward and "
              f"{r['n_sensitivity_solves']} sensitivity solves, {r['wall_s']:.0f} s wall ({r['cpu_s']:.0f} s CPU, "
              f"the first run's includes the fit model's condensation), |u_k - u| / |u_0 - u| at the end "
              f"{r['relative_error'][-1]:.3f}")
        for z in ZONES:
            p = r["parameters"][z]
            stderr = "-" if p["stderr"] is None else f"{p['stderr']:.3g}"
            print(f"  {z}: {p['value']:.4f} (true {TRUE_MU[z]}), standard error {stderr}, "
                  f"{'resolved' if p['identifiable'] else 'not resolved'}")
    sets = [("ten points, uy", results.get("trf", {}).get("prefit")), ("window, ux uy uz", results.get("window"))]
    for label, prefit in sets:
        if prefit is None:
            continue
        names = list(prefit["stderr"])
        directions = prefit["directions"]
        v = [directions[z] for z in names] if isinstance(directions, dict) else directions
        stderr = ", ".join(f"{z} {prefit['stderr'][z]:.3g}" for z in names)
        merged = ", ".join(f"{k} {e:.3g}" for k, e in merged_stderr(prefit["singular_values"], v).items())
        sizes = f" ({prefit['n_points']} points, {prefit['n_values']} values)" if "n_points" in prefit else ""
        print(f"resolution before fitting, {label}{sizes}, 0.5 um: singular values "
              f"{', '.join(f'{s:.3g}' for s in prefit['singular_values'])}; standard errors {stderr}; one "
              f"coefficient per section: {merged}")
    if results.get("window_error") is not None:
        print("\n".join(window_error_lines(results["window_error"], n_bolt)))


def main(work: Path, settings: Settings3d, steps: list[str]) -> None:
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

    once("data", lambda: data_step(settings.data_flank, work, settings.seed))
    model, build_cpu = cached_model(settings.flank, work)
    print(f"fit model: flank {settings.flank:g} mm, {model.mesh.n_nodes:,} nodes, build {build_cpu:.0f} s CPU",
          flush=True)
    results = {}
    for name, data, method, jacobian in PLAN:
        iterations = settings.gd_iterations if method == "gradient-descent" else settings.trf_iterations
        results[name] = once(name, lambda: fit_step(model, work, name, data, method, jacobian, iterations))
    field, regions = window_points(model)
    results["window"] = once("window", lambda: prefit_step(model, field, ("ux", "uy", "uz"), regions))
    results["window_error"] = once("window_error", lambda: window_error_step(model, work, settings))
    if results.get("trf") is not None:
        results["truth"] = once("truth", lambda: truth_step(model, work, results["trf"]))
    report(results, int(np.sum(np.array(regions) == "bolt")))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, default=Path("bolt3d_identify_m20"))
    parser.add_argument("--fit-flank", type=float, default=Settings3d.flank)
    parser.add_argument("--data-flank", type=float, default=Settings3d.data_flank)
    parser.add_argument("--gd-iterations", type=int, default=Settings3d.gd_iterations)
    parser.add_argument("--trf-iterations", type=int, default=Settings3d.trf_iterations)
    parser.add_argument("--steps", nargs="+", default=["data", *(name for name, *_ in PLAN), "window", "truth",
                                                            "window_error"])
    args = parser.parse_args()
    main(args.work, Settings3d(args.fit_flank, args.data_flank, args.gd_iterations, args.trf_iterations), args.steps)
