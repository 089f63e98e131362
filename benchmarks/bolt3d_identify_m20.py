"""The seed's Fig. 9 study on the short 3-D M20 (window and jaws): twin data from a finer 3-D mesh, the resolution
of each thread zone from the ten points and from the window's full field before fitting, the identification
from the ten points with trf (analytic sensitivities) and with the seed's gradient descent (forward differences),
where the meshes' difference comes from, and the identification from the window's full field.

The layout is the short M20 of docs/bolt-study.md ("The 3-D model": engaged_length 5.0, thread_length 30.5,
n_axial 2, window and jaws, 10 kN in 2 increments); zones A-D (outer A, B and inner C, D of sections 1, 2 from the
bearing face) at frictionid.studies.bolt's TRUE_MU for those letters, head and nut bearing held at 0.15. Data: uy
at the ten points P1-P5 of flanks 1 and 2 (benchmarks/bolt3d.py ten_points) solved on the data mesh at the truth;
the fits use uy, noise-free, weighted by the seed's DIC noise 0.5 um (measured.csv, the copy with that noise, is
written and not fitted). The window's full field is ux, uy, uz at the vertex nodes of the fit mesh's "window_bolt"
and "window_nut" surfaces, each value with 0.5 um noise. Steps:
- data: the data mesh's condensation and solve;
- trf, gd: frictionid.studies.bolt3d, the runs of ``frictionid demo --model 3d``;
- window: the resolution from the window's faces before fitting (one condensation of the fit model with them);
- truth: the fit mesh's misfit at the true coefficients at the ten points;
- window_error: the ten and the window's points at the truth on the data mesh, on the fit mesh and on the fit
  mesh with the data mesh's bearing faces (contact size) only, and on the fit mesh at the start: which size
  carries the meshes' difference, and how much of it is each face's rigid motion (one condensation each);
- model_error: whether identify.model_error can run on the fit model within 9 GB (the product's check);
- window_fit: trf from the window's field (the window_error step's values, noise seeds --window-seeds) per
  WINDOW_FITS entry: the four zones; one coefficient per section ([friction] merge); either with each face's
  displacements relative to one of its points (``relative_to``, one view per face); the fitted mesh's own field,
  noise-free (*_self); the sections fitted on the fit layout with the data's bearing faces (*_bearing*).
Each model is built once and pickled (``--work``); each step runs in the process that asks for it, so ``--steps``
one at a time keeps the peaks apart.

Run (from benchmarks/, under /usr/bin/time -v for the peak):
../.venv/bin/python bolt3d_identify_m20.py --work DIR [--fit-flank 2.5] [--data-flank 1.875] [--gd-iterations 5]
[--trf-iterations 10] [--window-fits zones sections ...] [--window-seeds 1 2 3]
[--window-iterations 15] [--steps data trf gd window truth window_error model_error window_fit]
Each step writes DIR/<step>.json (a window fit DIR/window_fit_<fit>_<seed>.json); a step whose file exists is
read, not run again.
"""

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb
from frictionid.backends.embedded import use_cache
from frictionid.fem import memory
from frictionid.fem.problem import Problem
from frictionid.inverse.design import merged_stderr
from frictionid.inverse.resolution import resolution
from frictionid.studies.bolt import NOISE, START, TRUE_MU
from frictionid.backends import make_backend
from frictionid.builders.bolt import fixed_friction
from frictionid.config import config_from_dict
from frictionid.preparation import prepare
from frictionid.errors import InputError
from frictionid.identification import identify
from frictionid.inverse.parameters import Parameter, Parameters
from frictionid.model.merge import merge_zones
from frictionid.studies.bolt3d import (PLAN, ZONES, Settings3d, cached_model, fit, make_data, method_options,
                                       ten_points)

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


#: the meshes the window_error step solves: label -> (flank size, contact size) from the Settings3d (None: twice
#: the flank size); "bearing" is the fit model with the data model's bearing faces (contact size) only
MESHES = {"data": lambda s: (s.data_flank, None), "bearing": lambda s: (s.flank, 2.0 * s.data_flank),
          "fit": lambda s: (s.flank, None)}


def window_error_step(fit_model, work: Path, settings: Settings3d) -> dict:
    """ux, uy, uz [um] at the ten points and the window's points (the fit mesh's, :func:`window_points`; the ten
    points' rows first) on each of MESHES at the truth, and on the fit mesh at the start: the meshes' differences
    against the signal of the coefficients, and which size (flank or bearing faces) carries the difference. One
    condensation of each model, one after the other."""
    field, regions = window_points(fit_model)
    points = np.vstack([ten_points(), field])
    regions = ["bolt"] * 10 + regions
    names = list(fit_model.zone_names)
    truth = np.array([{**TRUE_MU, **fixed_friction()}[z] for z in names])
    start = np.array([{**{z: START for z in ZONES}, **fixed_friction()}[z] for z in names])
    values, sizes = {}, {}
    for label, size in MESHES.items():
        flank, contact = size(settings)
        model = fit_model if label == "fit" else cached_model(flank, work, contact)[0]
        wall, cpu = time.perf_counter(), time.process_time()
        problem = Problem.build(model, points=points, quantities=("ux", "uy", "uz"), regions=regions,
                                factorisation="mumps")
        values[f"{label}_truth"] = 1e3 * problem.solve(truth).observations[-1]
        if label == "fit":
            values["fit_start"] = 1e3 * problem.solve(start).observations[-1]
        sizes[label] = {"flank": flank, "contact": 2.0 * flank if contact is None else contact,
                        "nodes": model.mesh.n_nodes, "pairs": problem.pairs.n_pairs,
                        "wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu}
        del problem, model
    return {"n_points": len(field), "n_bolt": regions.count("bolt") - 10, "meshes": sizes,
            "points_mm": points.tolist(), "values_um": {key: value.tolist() for key, value in values.items()}}


#: one coefficient per axial section: A + C (section 1, next to the bearing face), B + D (section 2)
SECTIONS = {"AC": ("A", "C"), "BD": ("B", "D")}


def section_stderr(singular_values, directions) -> dict:
    """Predicted standard errors of one coefficient per axial section (SECTIONS), from the information matrix
    F = V S^2 V^T of the four zones (V: directions, rows in ZONES' order)."""
    v = np.asarray(directions, dtype=float)
    information = v @ np.diag(np.asarray(singular_values, dtype=float) ** 2) @ v.T
    groups = [[ZONES.index(z) for z in zones] for zones in SECTIONS.values()]
    return dict(zip(SECTIONS, merged_stderr(information, groups).tolist()))


def without_rigid(values: np.ndarray, points: np.ndarray, n_bolt: int, rotation: bool) -> np.ndarray:
    """(n, 3) values less, on each face (bolt rows first, then the nut's), their least-squares rigid translation,
    and with ``rotation`` also a small rotation (t + w x p): what is left after a DIC's rigid-body correction of
    each face."""
    out = np.array(values, dtype=float)
    for rows in (slice(0, n_bolt), slice(n_bolt, None)):
        p = points[rows] - points[rows].mean(axis=0)
        basis = [np.tile(np.eye(3), (len(p), 1))]
        if rotation:            # w x p = -[p]x w: columns of the cross-product matrix per point
            cross = np.zeros((len(p), 3, 3))
            cross[:, 0, 1], cross[:, 0, 2], cross[:, 1, 2] = p[:, 2], -p[:, 1], p[:, 0]
            cross[:, 1, 0], cross[:, 2, 0], cross[:, 2, 1] = -p[:, 2], p[:, 1], -p[:, 0]
            basis.append(cross.reshape(-1, 3))
        a = np.hstack(basis)
        y = out[rows].reshape(-1)
        out[rows] = (y - a @ np.linalg.lstsq(a, y, rcond=None)[0]).reshape(-1, 3)
    return out


#: the pairs of meshes the window_error step compares: what each difference changes
PAIRS = (("fit", "data", "flank and bearing faces"), ("bearing", "data", "flank only"),
         ("fit", "bearing", "bearing faces only"))


def window_error_lines(step: dict) -> list[str]:
    """The meshes' differences (PAIRS) and the coefficients' signal (0.1 to the truth, fit mesh): uy at the ten
    points [um]; ux, uy, uz at the window's points, RMS [um] and norm in noise levels, as they are, with each
    face's translation and with its rigid motion taken out; each face's mean translation."""
    v = {key: np.array(value).reshape(-1, 3) for key, value in step["values_um"].items()}
    points, n_bolt = np.array(step["points_mm"])[10:], step["n_bolt"]
    lines = ["meshes: " + "; ".join(f"{k} flank {m['flank']:g} / contact {m['contact']:g} mm, {m['nodes']:,} nodes, "
                                    f"{m['pairs']:,} pairs, {m['wall_s']:.0f} s wall ({m['cpu_s']:.0f} s CPU)"
                                    for k, m in step["meshes"].items())]
    changes = {"field": lambda a: a, "translation out": lambda a: without_rigid(a, points, n_bolt, False),
               "rigid motion out": lambda a: without_rigid(a, points, n_bolt, True)}
    for label, diff in [*((f"{a} - {b} ({what})", v[f"{a}_truth"] - v[f"{b}_truth"]) for a, b, what in PAIRS),
                        ("signal (fit mesh, truth - start)", v["fit_truth"] - v["fit_start"])]:
        ten, window = diff[:10, 1], diff[10:]
        parts = []
        for name, change in changes.items():
            e = change(window)
            parts.append(f"{name} {np.sqrt(np.mean(e ** 2)):.3f} RMS ({np.linalg.norm(e) / (1e3 * NOISE):.2f})")
        shifts = ", ".join(f"{face} [{', '.join(f'{t:+.3f}' for t in rows.mean(axis=0))}]"
                           for face, rows in (("bolt", window[:n_bolt]), ("nut", window[n_bolt:])))
        lines.append(f"{label}: ten points uy {ten.min():+.4f} .. {ten.max():+.4f} um; window's points "
                     f"{'; '.join(parts)} um (noise levels in norm); mean per face {shifts} um")
    return lines


#: the window fits: name -> merged zones ([friction] merge), whether each face is fitted relative to one of its
#: points (``relative_to``), the MESHES entry the data come from and the one fitted (data from the fitted mesh
#: itself are noise-free: there the sections' fit finds the merged coefficients' values free of discretisation
#: error)
WINDOW_FITS = {"zones": ({}, False, "data", "fit"), "sections": (SECTIONS, False, "data", "fit"),
               "zones_relative": ({}, True, "data", "fit"), "sections_relative": (SECTIONS, True, "data", "fit"),
               "zones_self": ({}, False, "fit", "fit"), "sections_self": (SECTIONS, False, "fit", "fit"),
               "sections_bearing": (SECTIONS, False, "data", "bearing"),
               "sections_bearing_self": (SECTIONS, False, "bearing", "bearing")}
#: the bolt's and the nut's window points are labelled B<k> and N<k>
WINDOW_REGIONS = {"B*": "bolt", "N*": "nut"}


def window_data(work: Path, step: dict, seed: int, source: str = "data") -> dict:
    """ux, uy, uz [mm] at the window's points on the ``source`` mesh at the truth (the window_error step's), with
    Gaussian noise NOISE (``seed``; 0: none) on every value, written to ``work``/window_<seed>.csv (points B<k>
    on the bolt, N<k> on the nut; window_<source>_<seed>.csv for another source than "data") and, each face alone,
    to window_<seed>_bolt.csv and window_<seed>_nut.csv; the paths by face ("all", "bolt", "nut")."""
    points, n_bolt = np.array(step["points_mm"])[10:], step["n_bolt"]
    exact = 1e-3 * np.array(step["values_um"][f"{source}_truth"]).reshape(-1, 3)[10:]
    noisy = exact + (np.random.default_rng(seed).normal(0.0, NOISE, exact.shape) if seed else 0.0)
    stem = "window" if source == "data" else f"window_{source}"
    labels = [f"B{k + 1}" if k < n_bolt else f"N{k + 1 - n_bolt}" for k in range(len(points))]
    paths = {}
    for face, rows in (("all", slice(None)), ("bolt", slice(0, n_bolt)), ("nut", slice(n_bolt, None))):
        paths[face] = work / (f"{stem}_{seed}.csv" if face == "all" else f"{stem}_{seed}_{face}.csv")
        with open(paths[face], "w") as out:
            noise = f"Gaussian noise {NOISE} mm (seed {seed})" if seed else "no noise"
            out.write(f"# twin data: the window's points (fit mesh's vertices) on the {source} mesh at mu "
                      f"{json.dumps({z: TRUE_MU[z] for z in ZONES})}, {noise}\n# units mm\n"
                      "point,x,y,z,stage,ux,uy,uz\n")
            for label, (x, y, z), u in zip(labels[rows], points[rows], noisy[rows]):
                out.write(f"{label},{x:.6f},{y:.6f},{z:.6f},1,{u[0]:.9e},{u[1]:.9e},{u[2]:.9e}\n")
    return paths


def window_fit_step(model, work: Path, name: str, seed: int, step: dict, iterations: int) -> dict:
    """trf (analytic sensitivities, the study's options) of the zones (or, by WINDOW_FITS[name], the sections'
    merged coefficients; with each face's displacements relative to its first point) from the window's ux, uy, uz
    with noise ``seed``, weighted by NOISE; per zone the value, standard error, whether it is claimed and whether
    the truth lies within 3 standard errors."""
    groups, relative, source, _ = WINDOW_FITS[name]
    fitted = merge_zones(model, groups) if groups else model
    names = [z for z in fitted.zone_names if z not in fixed_friction()]
    truth = {z: float(np.mean([TRUE_MU[m] for m in groups.get(z, (z,))])) for z in names}
    params = Parameters([Parameter(z, START) for z in names]
                        + [Parameter(z, v, vary=False) for z, v in fixed_friction().items()])
    paths = window_data(work, step, seed, source)
    data, regions = paths["all"], WINDOW_REGIONS
    if relative:        # one table per face (a DIC view each), displacements relative to the face's first point
        data = [{"path": str(paths[face]), "stage": 1, "view": face, "relative_to": f"{face[0].upper()}1"}
                for face in ("bolt", "nut")]
        regions = {"bolt/*": "bolt", "nut/*": "nut"}
    lines = []
    r = identify(fitted, data, params, observables=["ux", "uy", "uz"], stages=[1], noise={"u": NOISE},
                 regions=regions, run_dir=str(work / "runs" / f"window_{name}_{seed}"),
                 resume=True, method="trf", jacobian="analytic", max_iterations=iterations,
                 solver={"factorisation": "mumps", "max_memory": 10.5}, refine_target=0, suggestions=0,
                 options=method_options("trf"),
                 fields=False, progress=lambda text: (lines.append(text), print(text, flush=True))).to_dict()
    zones = {}
    for z in names:
        p = r["parameters"][z]
        holds = None if p["stderr"] is None else abs(p["value"] - truth[z]) <= 3.0 * p["stderr"]
        zones[z] = {"value": p["value"], "true": truth[z], "stderr": p["stderr"], "claimed": p["identifiable"],
                    "within_3_stderr": holds}
    return {"fit": name, "seed": seed, "status": r["status"], "n_iterations": r["n_iterations"],
            "n_forward_solves": r["n_forward_solves"], "n_sensitivity_solves": r["n_sensitivity_solves"],
            "fit_quality": {k: r["fit"].get(k) for k in ("chi2", "dof", "consistent", "error_scale", "rms_residual")},
            "zones": zones, "log": lines}


def model_error_step(model) -> dict:
    """Whether identify.model_error (the model refined by 2, one more condensation) can run on ``model`` within
    the 9 GB this study allows a process: the product's own check before the refined mesh is built."""
    try:
        memory.check_growth(model, 2, "model error: the fit model refined by 2", 9.0)
    except InputError as refused:
        return {"runs": False, "message": str(refused)}
    return {"runs": True, "message": ""}


def window_fit_lines(fits: dict) -> list[str]:
    """Per window fit and zone: value, standard error, claimed or not, and the truth within 3 standard errors or
    not. A merged coefficient's truth is the value of the same merged fit of the fitted mesh's own noise-free field
    (sections_self, sections_bearing_self) when that fit was run, else its zones' mean."""
    reference = {WINDOW_FITS[name][3]: {z: p["value"] for z, p in r["zones"].items()} for (name, _), r in fits.items()
                 if WINDOW_FITS[name][0] and WINDOW_FITS[name][2] == WINDOW_FITS[name][3]}
    lines = []
    for (name, seed), r in sorted(fits.items()):
        cells = []
        groups, _, source, mesh = WINDOW_FITS[name]
        for z, p in r["zones"].items():
            true = p["true"] if source == mesh else reference.get(mesh, {}).get(z, p["true"])
            holds = "" if p["stderr"] is None else ", holds" if abs(p["value"] - true) <= 3 * p["stderr"] else ", OFF"
            stderr = "-" if p["stderr"] is None else format(p["stderr"], ".3g")
            cells.append(f"{z} {p['value']:.4f} (true {true:.4f}) +/- {stderr} "
                         f"{'claimed' if p['claimed'] else 'not claimed'}{holds}")
        q = r["fit_quality"]
        lines.append(f"window fit {name}, seed {seed}: {r['status']}, {r['n_iterations']} iterations, "
                     f"{r['n_sensitivity_solves']} solves with sensitivities, chi2/dof {q['chi2'] / q['dof']:.2f}"
                     f", consistent {q.get('consistent')}; {r['wall_s']:.0f} s wall ({r['cpu_s']:.0f} s CPU): "
                     + "; ".join(cells))
    return lines


def report(results: dict) -> None:
    """Print the fits zone by zone, the resolution before fitting of both observation sets, the meshes'
    differences at the ten and the window's points and the window fits."""
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
    sets = [("ten points, uy", (results.get("trf") or {}).get("prefit")), ("window, ux uy uz", results.get("window"))]
    for label, prefit in sets:
        if prefit is None:
            continue
        names = list(prefit["stderr"])
        directions = prefit["directions"]
        v = [directions[z] for z in names] if isinstance(directions, dict) else directions
        stderr = ", ".join(f"{z} {prefit['stderr'][z]:.3g}" for z in names)
        merged = ", ".join(f"{k} {e:.3g}" for k, e in section_stderr(prefit["singular_values"], v).items())
        sizes = f" ({prefit['n_points']} points, {prefit['n_values']} values)" if "n_points" in prefit else ""
        print(f"resolution before fitting, {label}{sizes}, 0.5 um: singular values "
              f"{', '.join(f'{s:.3g}' for s in prefit['singular_values'])}; standard errors {stderr}; one "
              f"coefficient per section: {merged}")
    if results.get("window_error") is not None:
        print("\n".join(window_error_lines(results["window_error"])))
    if results.get("model_error") is not None:
        print(f"model_error on the fit model: {'runs' if results['model_error']['runs'] else 'refused'} "
              f"{results['model_error']['message']}")
    print("\n".join(window_fit_lines(results.get("window_fits", {}))))


@dataclass(frozen=True)
class WindowFits:
    """The window fits the window_fit step runs: WINDOW_FITS names, noise seeds (the fit mesh's own field is
    fitted noise-free, seed 0), trf's iteration cap."""

    fits: tuple = tuple(WINDOW_FITS)
    seeds: tuple = (1, 2, 3)
    iterations: int = 15


def main(work: Path, settings: Settings3d, steps: list[str], settings_window: WindowFits = WindowFits()) -> None:
    work.mkdir(parents=True, exist_ok=True)
    use_cache(work / "cache")

    def once(step: str, make, kind: str | None = None):
        path = work / f"{step}.json"
        if path.exists():
            return json.loads(path.read_text())
        if (kind or step) not in steps:
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
    results["model_error"] = once("model_error", lambda: model_error_step(model))
    results["window_fits"] = {}
    if results["window_error"] is not None:
        for name in settings_window.fits:
            _, _, source, mesh = WINDOW_FITS[name]
            flank, contact = MESHES[mesh](settings)
            for seed in (0,) if source == mesh else settings_window.seeds:   # a mesh's own field: noise-free
                out = once(f"window_fit_{name}_{seed}", lambda: window_fit_step(
                    model if mesh == "fit" else cached_model(flank, work, contact)[0], work, name, seed,
                    results["window_error"], settings_window.iterations), "window_fit")
                if out is not None:
                    results["window_fits"][name, seed] = out
    report(results)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, default=Path("bolt3d_identify_m20"))
    parser.add_argument("--fit-flank", type=float, default=Settings3d.flank)
    parser.add_argument("--data-flank", type=float, default=Settings3d.data_flank)
    parser.add_argument("--gd-iterations", type=int, default=Settings3d.gd_iterations)
    parser.add_argument("--trf-iterations", type=int, default=Settings3d.trf_iterations)
    parser.add_argument("--window-fits", nargs="+", default=list(WindowFits.fits), choices=list(WINDOW_FITS))
    parser.add_argument("--window-seeds", nargs="+", type=int, default=list(WindowFits.seeds))
    parser.add_argument("--window-iterations", type=int, default=WindowFits.iterations)
    parser.add_argument("--steps", nargs="+", default=["data", *(name for name, *_ in PLAN), "window", "truth",
                                                            "window_error", "model_error", "window_fit"])
    args = parser.parse_args()
    main(args.work, Settings3d(args.fit_flank, args.data_flank, args.gd_iterations, args.trf_iterations), args.steps,
         WindowFits(tuple(args.window_fits), tuple(args.window_seeds), args.window_iterations))
