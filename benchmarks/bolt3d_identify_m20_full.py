"""The 8-turn 3-D M20 (the whole nut, window and jaws, nut meshed on its own): the ten points' discretisation error
against another mesh, and a whole identification of zones A-F from them, run the way a user runs it.

Layout: the default 3-D M20's (docs/models.md: eight turns, window and jaws, 10 and 30 kN in 3 increments each),
zones A-F at frictionid.studies.bolt's TRUE_MU, head and nut bearing held at 0.15. The fitted model has the
builder options ``--fit`` (JSON, bolt_model options; default none: the builder's 3-D defaults), the data model
those of ``--data`` (default: the defaults with flanks 2.5 and bearings 5.0 mm, a coarser mesh; a finer one does
not fit this machine's memory beside the fit). Data: uy at the ten points P1-P5 of flanks 1 and 2
(frictionid.builders.bolt3d.measurement_points_3d, depth 0.1 mm) at both stages, solved on the data mesh at the
truth, noise-free (measured_exact.csv) and with 0.5 um Gaussian noise (measured.csv); the fits weight them by
0.5 um. Steps:
- data: the data model's condensation and solve at the truth;
- mesh_error: the fit model at the truth with sensitivities: the ten points' difference from the data (um, % of
  each stage's range, noise levels), the zones' predicted standard errors at 0.5 um and the linearised shift of
  the fitted coefficients that the difference alone causes (J^+ applied to it);
- identify: ``frictionid identify config.toml`` in a subprocess (the model built, condensed and fitted from
  scratch, trf, analytic sensitivities; ``--settings`` the config's other tables, default none: the defaults):
  wall, CPU (the child's rusage), peak (its largest resident set), iterations, coefficients, and the wall and CPU
  time at each line the run prints (the child's /proc stat when the line arrives), from which the phases: build
  (to "model:"), control and condensation (to "... backend ready"), resolution and suggestions (to its table),
  fit (to the last iteration line), fields (to "fields:").
Each step writes DIR/<step>.json and is read back when present; models are pickled in DIR.

Run (from benchmarks/): ../.venv/bin/python bolt3d_identify_m20_full.py --work DIR [--fit JSON] [--data JSON]
[--steps data mesh_error identify] [--file measured_exact.csv] [--settings '{"solver": {"factorisation": "mumps"}}']
"""

import argparse
import json
import os
import pickle
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb
from frictionid.builders.bolt import bolt_layout, bolt_model, fixed_friction
from frictionid.builders.bolt3d import measurement_points_3d
from frictionid.data.measurements import Measurements, write_measurements
from frictionid.fem.problem import Problem
from frictionid.inverse.resolution import resolution
from frictionid.studies.bolt import FORCES, NOISE, START, TRUE_MU

FIT: dict = {}
DATA = {"flank_size": 2.5, "contact_size": 5.0}
ZONES = tuple(TRUE_MU)
#: the console script `frictionid` of this checkout (PYTHONPATH), as a user runs it
CLI = "import sys; from frictionid.cli import main; sys.exit(main(sys.argv[1:]))"


def ten_points() -> np.ndarray:
    """(10, 3) [mm] P1-P5 of flanks 1 and 2 of the default M20, 0.1 mm inside the bolt tooth."""
    return measurement_points_3d(bolt_layout("M20", None, None, None, 2, 3, None, None), depth=0.1)


def cached(options: dict, work: Path):
    """The 3-D M20 with ``options``, read from ``work`` or built and pickled there; and its build CPU [s]."""
    path = work / ("model_" + "_".join(f"{k}{v}" for k, v in sorted(options.items())) + ".pkl")
    if path.exists():
        return pickle.loads(path.read_bytes()), float("nan")
    cpu = time.process_time()
    model = bolt_model(model="3d", **options)
    path.write_bytes(pickle.dumps(model))
    return model, time.process_time() - cpu


def truth(model) -> np.ndarray:
    return np.array([{**TRUE_MU, **fixed_friction()}[z] for z in model.zone_names])


def solved(options: dict, work: Path, sensitivities: bool) -> tuple[dict, object, object]:
    """The model's condensation with the ten points (uy) and its solve at the truth; figures, model, solution."""
    model, build = cached(options, work)
    points = ten_points()
    wall, cpu = time.perf_counter(), time.process_time()
    problem = Problem.build(model, points=points, quantities=("uy",), regions=["bolt"] * len(points),
                            factorisation="mumps")
    condense = (time.perf_counter() - wall, time.process_time() - cpu)
    wall, cpu = time.perf_counter(), time.process_time()
    solution = problem.solve(truth(model), sensitivities=sensitivities)
    solve = (time.perf_counter() - wall, time.process_time() - cpu)
    ends = [solution.stage_end(s) for s in range(model.n_stages)]
    figures = {"options": options, "nodes": model.mesh.n_nodes, "pairs": problem.pairs.n_pairs,
               "build_cpu_s": build, "condense_wall_s": condense[0], "condense_cpu_s": condense[1],
               "solve_wall_s": solve[0], "solve_cpu_s": solve[1], "uy_um": (1e3 * solution.observations[ends]).tolist(),
               "peak_mb_so_far": peak_memory_mb()}
    return figures, model, solution


def data_step(options: dict, work: Path, seed: int = 7) -> dict:
    figures, model, _ = solved(options, work, False)
    uy = np.array(figures["uy_um"]) / 1e3                                   # (n_stages, 10) [mm]
    points, n_stages = ten_points(), uy.shape[0]
    labels = tuple(f"P{k // 5 + 1}{k % 5 + 1}" for k in range(len(points))) * n_stages
    note = (f"twin data: 8-turn 3-D M20 (window, jaws) {json.dumps(options)}, {model.mesh.n_nodes} nodes, "
            f"mu {json.dumps(TRUE_MU)}, head/nut bearing 0.15; units mm, N")
    for name, values in (("measured_exact.csv", uy), ("measured.csv",
                                                     uy + np.random.default_rng(seed).normal(0.0, NOISE, uy.shape))):
        table = Measurements(points=labels, coordinates=np.tile(points, (n_stages, 1)),
                             stage=np.repeat(np.arange(1, n_stages + 1), len(points)),
                             force=np.repeat(FORCES[:n_stages], len(points)), values={"uy": values.ravel()},
                             sigma={}, comments=(note,) if values is uy else (note, f"noise {NOISE} mm, seed {seed}"))
        write_measurements(work / name, table)
    return figures


def mesh_error_step(options: dict, work: Path) -> dict:
    data = json.loads((work / "data.json").read_text())
    figures, model, solution = solved(options, work, True)
    fit_uy, data_uy = np.array(figures["uy_um"]), np.array(data["uy_um"])
    error = fit_uy - data_uy                                               # (n_stages, 10) [um]
    span = data_uy.max(axis=1) - data_uy.min(axis=1)
    ends = [solution.stage_end(s) for s in range(model.n_stages)]
    free = [list(model.zone_names).index(z) for z in ZONES]
    jacobian = np.vstack([solution.d_observations[e][:, free] for e in ends]) / NOISE
    report = resolution(jacobian, ZONES, 0.02)
    shift = np.linalg.lstsq(jacobian, -error.ravel() / (1e3 * NOISE), rcond=None)[0]
    return {**figures, "error_um": error.tolist(), "range_um": span.tolist(),
            "error_pct_of_range": (100 * np.abs(error).max(axis=1) / span).tolist(),
            "error_rms_noise_levels": float(np.sqrt(np.mean(error ** 2)) / (1e3 * NOISE)),
            "singular_values": report.singular_values.tolist(), "stderr": dict(zip(ZONES, report.stderr.tolist())),
            "shift_from_mesh_error": dict(zip(ZONES, shift.tolist()))}


def config_text(options: dict, data_file: str, run_dir: str, settings: dict) -> str:
    """The identification's config: [model] the builder's 3-D bolt with ``options``, the data, trf with the
    analytic Jacobian; ``settings`` ({table: {key: value}}) adds keys to [solver], [identify] or [run]."""
    def keys(table: dict) -> str:
        return "".join(f"{k} = {json.dumps(v)}\n" for k, v in table.items())
    zones = ", ".join(f"{z} = {START}" for z in ZONES)
    fixed = ", ".join(f"{z} = {v}" for z, v in fixed_friction().items())
    return (f'[model]\nbuilder = "bolt"\nmodel = "3d"\n{keys(options)}'
            f"[friction]\nzones = {{ {zones} }}\nfixed = {{ {fixed} }}\n"
            f'[data]\nfile = "{data_file}"\nobservables = ["uy"]\nstages = [1, 2]\nnoise = {{ u = {NOISE} }}\n'
            f'regions = {{ "*" = "bolt" }}\n'
            f'[solver]\n{keys(settings.get("solver", {}))}'
            f'[identify]\nmethod = "trf"\njacobian = "analytic"\n{keys(settings.get("identify", {}))}'
            f'[run]\ndir = "{run_dir}"\n{keys(settings.get("run", {}))}')


def cpu_seconds(pid: int) -> float:
    """User + system CPU time [s] of a running process (all its threads), from /proc/<pid>/stat."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


#: the phases of a run: (name, the start of the line that ends it; the last such line for the fit); the
#: discretisation control, when on, runs between the build and "backend ready" (and condenses the model for it)
PHASES = (("build", "model:"), ("control and condensation", "embedded backend ready"),
          ("resolution and suggestions", "[[Resolution before fitting]]"), ("fit", "iter "), ("fields", "fields:"))


def phases(lines: list) -> dict:
    """Wall and CPU time [s] of each of :data:`PHASES` from the stamped lines (wall, CPU, text) of a run."""
    out, previous = {}, (0.0, 0.0)
    for name, marker in PHASES:
        ends = [(w, c) for w, c, text in lines if text.startswith(marker)]
        if not ends:
            continue
        end = ends[-1] if name == "fit" else ends[0]
        out[name] = {"wall_s": end[0] - previous[0], "cpu_s": end[1] - previous[1]}
        previous = end
    return out


def identify_step(options: dict, work: Path, data_file: str, settings: dict) -> dict:
    name = Path(data_file).stem
    config = work / f"identify_{name}.toml"
    config.write_text(config_text(options, data_file, f"runs/{name}", settings))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-u", "-c", CLI, "identify", config.name], cwd=work, text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    lines = []
    with open(work / f"identify_{name}.log", "w") as log:      # as the lines come: an interrupted run keeps them
        for text in child.stdout:
            lines.append((time.perf_counter() - start, cpu_seconds(child.pid), text.rstrip("\n")))
            log.write("[{:7.1f} s wall {:7.1f} s CPU] {}\n".format(*lines[-1]))
            log.flush()
    child.wait(timeout=7200)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = {"exit": child.returncode, "wall_s": wall, "user_s": after.ru_utime - before.ru_utime,
           "system_s": after.ru_stime - before.ru_stime, "peak_gb": after.ru_maxrss * 1024 / 1e9,
           "settings": settings, "phases": phases(lines)}
    result = work / "runs" / name / "result.json"
    if result.exists():
        r = json.loads(result.read_text())
        out.update({key: r.get(key) for key in ("status", "n_iterations", "n_forward_solves",
                                                "n_sensitivity_solves", "wall_time_s", "objective", "fit")},
                   parameters={z: {k: r["parameters"][z].get(k) for k in ("value", "stderr", "identifiable",
                                                                            "at_bound", "why")} for z in ZONES})
    return out


def show(step: str, out: dict) -> None:
    print(f"== {step}")
    if step == "identify":
        print(f"  exit {out['exit']}, {out.get('status')}: {out.get('n_iterations')} iterations, "
              f"{out.get('n_forward_solves')} forward + {out.get('n_sensitivity_solves')} sensitivity solves; "
              f"wall {out['wall_s']:.0f} s, CPU {out['user_s'] + out['system_s']:.0f} s (user {out['user_s']:.0f})"
              f", peak {out['peak_gb']:.2f} GB")
        for phase, t in out.get("phases", {}).items():
            print(f"  {phase}: {t['wall_s']:.0f} s wall, {t['cpu_s']:.0f} s CPU")
        for z, p in (out.get("parameters") or {}).items():
            print(f"  {z}: true {TRUE_MU[z]:.3f}, fitted {p['value']:.4f} +/- {p['stderr']}, "
                  f"identifiable {p['identifiable']}{'' if not p.get('why') else ' (' + p['why'] + ')'}")
        return
    print(f"  {out['nodes']:,} nodes, {out['pairs']:,} pairs; build {out['build_cpu_s']:.0f} s CPU, condensation "
          f"{out['condense_cpu_s']:.0f} s CPU ({out['condense_wall_s']:.0f} s wall), solve {out['solve_cpu_s']:.0f} s"
          f" CPU; peak so far {out['peak_mb_so_far'] / 1024:.2f} GiB")
    for s, uy in enumerate(out["uy_um"]):
        print(f"  stage {s + 1} uy [um]: {np.array2string(np.array(uy), precision=4)}")
    if step == "mesh_error":
        for s, e in enumerate(out["error_um"]):
            print(f"  stage {s + 1} fit - data [um]: {np.array2string(np.array(e), precision=4)}; largest "
                  f"{out['error_pct_of_range'][s]:.1f} % of the range {out['range_um'][s]:.3f} um")
        print(f"  RMS {out['error_rms_noise_levels']:.3f} noise levels; singular values "
              f"{np.array2string(np.array(out['singular_values']), precision=4)}")
        print("  predicted stderr at 0.5 um: " + ", ".join(f"{z} {v:.3g}" for z, v in out["stderr"].items()))
        print("  coefficient shift from the mesh error alone: "
              + ", ".join(f"{z} {v:+.3g}" for z, v in out["shift_from_mesh_error"].items()))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", required=True)
    parser.add_argument("--fit", default=json.dumps(FIT))
    parser.add_argument("--data", default=json.dumps(DATA))
    parser.add_argument("--steps", nargs="+", default=["data", "mesh_error", "identify"])
    parser.add_argument("--file", default="measured_exact.csv")
    parser.add_argument("--settings", default="{}", help="the config's other keys, {table: {key: value}}")
    args = parser.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    fit, data = json.loads(args.fit), json.loads(args.data)
    steps = {"data": lambda: data_step(data, work), "mesh_error": lambda: mesh_error_step(fit, work),
             "identify": lambda: identify_step(fit, work, args.file, json.loads(args.settings))}
    for step in ("data", "mesh_error", "identify"):
        path = work / (f"{step}.json" if step != "identify" else f"identify_{Path(args.file).stem}.json")
        if not path.exists() and step in args.steps:
            path.write_text(json.dumps(steps[step](), indent=1) + "\n")
        if path.exists():
            show(step, json.loads(path.read_text()))


if __name__ == "__main__":
    main()
