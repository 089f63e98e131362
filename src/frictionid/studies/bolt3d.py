"""The seed's Fig. 9 study on the 3-D M20 (``frictionid demo --model 3d``): twin data from a finer 3-D mesh, the
thread zones identified from the ten flank points with trf and with the seed's gradient descent.

The model is the short M20 layout of docs/bolt-study.md ("The 3-D model"): two engaged pitches, the nut's window
and its jaws, 10 kN in two increments, zones A-D (outer A, B and inner C, D of the two axial sections from the
bearing face) at :data:`frictionid.studies.bolt.TRUE_MU`'s values for those letters, head and nut bearing held at
0.15. The default 3-D M20 (eight turns) is beyond the dense contact solve on this machine. Data: uy at the ten
points P1-P5 of flanks 1 and 2 (0.1 mm inside the bolt tooth), solved on a mesh with finer flanks at the truth,
noise-free and with the seed's DIC noise (0.5 um); the fits weight them by 0.5 um. The axisymmetric study is
:mod:`frictionid.studies.bolt`.
"""

from __future__ import annotations

import json
import pickle
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..backends.embedded import cache_in
from ..builders.bolt import bolt_layout, bolt_model, fixed_friction
from ..builders.bolt3d import measurement_points_3d
from ..fem.problem import Problem
from ..identification import identify
from ..inverse.parameters import Parameter, Parameters
from .bolt import NOISE, OPTIONS, START, TRUE_MU, _cell, demo_folder

#: the short layout's options besides the mesh sizes (docs/bolt-study.md, "The 3-D model"): the nut meshed with the
#: bolt, the roots refined around the nut only
SHORT = {"model": "3d", "size": "M20", "engaged_length": 5.0, "thread_length": 30.5, "n_axial": 2,
         "root_size": 0.3, "root_refinement": "engaged", "nut_mesh": "conforming", "forces": [10000.0],
         "n_increments": 2, "cutout": True, "jaws": True}
ZONES = ("A", "B", "C", "D")
TRUE = {z: TRUE_MU[z] for z in ZONES}
#: the runs: name, data file, method, Jacobian (both fits weight the noise-free data by the DIC noise, so their
#: standard errors are those of the seed's measurement; measured.csv is the noisy copy, not fitted here)
PLAN = (("trf", "measured_exact.csv", "trf", "analytic"), ("gd", "measured_exact.csv", "gradient-descent", "forward"))


@dataclass(frozen=True)
class Settings3d:
    """Flank sizes [mm] of the fitted and the data mesh (contact size twice the flank size) and iteration caps
    (each iteration costs one to two solves with sensitivities (trf) or five to eight forward solves (gradient
    descent), 30-90 s each on this machine)."""

    flank: float = 2.5
    data_flank: float = 1.875
    gd_iterations: int = 5
    trf_iterations: int = 10
    seed: int = 7


def model_options(flank: float, contact: float | None = None) -> dict:
    """:func:`frictionid.builders.bolt.bolt_model` options of the short 3-D M20 at flank size ``flank`` [mm] and
    contact size ``contact`` [mm] (the bearing faces' mesh; twice the flank size when None)."""
    return {**SHORT, "flank_size": flank, "contact_size": 2.0 * flank if contact is None else contact}


def ten_points() -> np.ndarray:
    """(10, 3) [mm] P1-P5 of flanks 1 and 2 of the short layout, 0.1 mm inside the bolt tooth."""
    layout = bolt_layout("M20", None, SHORT["engaged_length"], None, 2, SHORT["n_axial"], None,
                         SHORT["thread_length"])
    return measurement_points_3d(layout, depth=0.1)


def cached_model(flank: float, folder: Path, contact: float | None = None):
    """The short model at ``flank`` (and ``contact``, :func:`model_options`), read from ``folder``/model_<flank>.pkl
    (model_<flank>_c<contact>.pkl when ``contact`` is given) or built (minutes) and stored there; and the build's
    CPU time [s] (nan when read)."""
    path = Path(folder) / (f"model_{flank:g}.pkl" if contact is None else f"model_{flank:g}_c{contact:g}.pkl")
    if path.exists():
        return pickle.loads(path.read_bytes()), float("nan")
    cpu = time.process_time()
    model = bolt_model(**model_options(flank, contact))
    path.write_bytes(pickle.dumps(model))
    return model, time.process_time() - cpu


def make_data(model, flank: float, folder: Path, seed: int) -> dict:
    """ux, uy, uz [um] at the ten points on ``model`` (flank size ``flank`` [mm]) at the truth; writes ``folder``/measured_exact.csv and
    measured.csv (uy, noise-free and with Gaussian noise NOISE, ``seed``). Returns sizes, times and values."""
    points = ten_points()
    start, cpu = time.perf_counter(), time.process_time()
    problem = Problem.build(model, points=points, quantities=("ux", "uy", "uz"), regions=["bolt"] * len(points),
                            factorisation="mumps")
    condense = (time.perf_counter() - start, time.process_time() - cpu)
    mu = np.array([{**TRUE, **fixed_friction()}[z] for z in model.zone_names])
    values = problem.solve(mu).observations[-1].reshape(-1, 3)
    uy = values[:, 1]
    noisy = uy + np.random.default_rng(seed).normal(0.0, NOISE, uy.shape)
    for name, column in (("measured_exact.csv", uy), ("measured.csv", noisy)):
        with open(Path(folder) / name, "w") as out:
            out.write(f"# twin data: short 3-D M20 (window, jaws), flank {flank:g} mm, {model.mesh.n_nodes} nodes, "
                      f"mu {json.dumps(TRUE)}, head/nut bearing 0.15, 10 kN\n"
                      + ("" if column is uy else f"# Gaussian noise sigma {NOISE} mm added (seed {seed})\n")
                      + "# units mm\npoint,x,y,z,stage,uy\n")
            for k, ((x, y, z), value) in enumerate(zip(points, column)):
                out.write(f"P{k // 5 + 1}{k % 5 + 1},{x:.6f},{y:.6f},{z:.6f},1,{value:.9e}\n")
    return {"flank": flank, "nodes": model.mesh.n_nodes, "pairs": problem.pairs.n_pairs,
            "condense_wall_s": condense[0], "condense_cpu_s": condense[1], "u_um": (1e3 * values).tolist()}


def method_options(method: str) -> dict:
    """The axisymmetric study's [identify] options of ``method`` (studies/bolt.py OPTIONS) as a dict."""
    return {key: json.loads(value) for key, value in (item.split(" = ") for item in OPTIONS[method].split(", "))}


def fit(model, folder: Path, name: str, data: str, method: str, jacobian: str, iterations: int, resume: bool,
        echo) -> dict:
    """One identification of zones A-D from ``data`` (a file in ``folder``) into ``folder``/runs/``name`` (no
    fields/: their solve factorises the model again, 9.3 GB at the peak on the default settings); its
    result.json dict with ``relative_error``: |u_k - u| / |u_0 - u| per iterate, sqrt(J_k / J_0), which is the
    seed's Fig. 9 quantity when the data are the noise-free u (one sigma for all values)."""
    params = Parameters([Parameter(z, START) for z in ZONES]
                        + [Parameter(z, v, vary=False) for z, v in fixed_friction().items()])
    result = identify(model, Path(folder) / data, params, observables=["uy"], stages=[1], noise={"u": NOISE},
                      regions={"*": "bolt"}, run_dir=str(Path(folder) / "runs" / name), resume=resume,
                      method=method, jacobian=jacobian, max_iterations=iterations, solver={"factorisation": "mumps"},
                      refine_target=0, suggestions=0, options=method_options(method), fields=False, progress=echo)
    r = result.to_dict()
    objective = np.array(r["history"]["objective"])
    return {**r, "relative_error": np.sqrt(objective / objective[0]).tolist()}


def run_demo_3d(out: Path, settings: Settings3d = Settings3d(), resume: bool = False, echo=print) -> dict:
    """Run the 3-D study into folder ``out`` (models pickled there, data, runs/, cache/, table.txt, fig9.txt,
    fig9.png, summary.json); returns the summary. ``resume``: continue (or replay) the runs stored in ``out``."""
    out = demo_folder(out, resume)
    with cache_in(out / "cache"):
        return _study(out, settings, resume, echo)


def _study(out: Path, settings: Settings3d, resume: bool, echo) -> dict:
    start = time.perf_counter()
    echo(f"Short 3-D M20 (window, jaws, 10 kN), zones {', '.join(f'{z}={v}' for z, v in TRUE.items())}; head and "
         f"nut bearing 0.15; fit mesh flank {settings.flank:g} mm, data mesh flank {settings.data_flank:g} mm")
    if not all((out / name).exists() for name in ("measured_exact.csv", "measured.csv")):
        model, cpu = cached_model(settings.data_flank, out)
        echo(f"1. twin data: {model.mesh.n_nodes:,} nodes (build {cpu:.0f} s CPU); condensing and solving")
        data = make_data(model, settings.data_flank, out, settings.seed)
        (out / "data.json").write_text(json.dumps(data, indent=1) + "\n")
        del model
    model, cpu = cached_model(settings.flank, out)
    echo(f"2. fit model: {model.mesh.n_nodes:,} nodes (build {cpu:.0f} s CPU)")
    runs = {}
    for name, data, method, jacobian in PLAN:
        iterations = settings.gd_iterations if method == "gradient-descent" else settings.trf_iterations
        echo(f"3. identify {name}: {method} with {jacobian} Jacobian, uy from {data}, at most {iterations} "
             "iterations")
        runs[name] = fit(model, out, name, data, method, jacobian, iterations, resume, echo)
    return _write_summary(out, settings, runs, time.perf_counter() - start, echo)


def fig9_lines(runs: dict) -> list[str]:
    """The seed's Fig. 9 as a table: |u_k - u| / |u_0 - u| per iteration k of the noise-free runs."""
    names = [name for name, data, _, _ in PLAN if data == "measured_exact.csv"]
    curves = [runs[name]["relative_error"] for name in names]
    lines = ["|u_k - u| / |u_0 - u| per iteration k (noise-free data; the seed's Fig. 9)",
             f"{'k':>4}" + "".join(f"{runs[n]['method'] + ' (' + runs[n]['jacobian'] + ')':>32}" for n in names)]
    for k in range(max(map(len, curves))):
        lines.append(f"{k:>4}" + "".join(f"{c[k]:>32.4g}" if k < len(c) else f"{'':>32}" for c in curves))
    return lines


def _write_summary(out: Path, settings: Settings3d, runs: dict, seconds: float, echo) -> dict:
    width = 28
    table = [f"{'run':<11}{'status':<16}{'iter':>5}{'solves':>8}{'time [s]':>9}  "
             + "".join(f"{z:>{width}}" for z in ZONES)]
    table.append(f"{'true':<11}{'':<16}{'':>5}{'':>8}{'':>9}  " + "".join(f"{v:>{width}.4f}" for v in TRUE.values()))
    for name, r in runs.items():
        table.append(f"{name:<11}{r['status']:<16}{r['n_iterations']:>5}"
                     f"{r['n_forward_solves'] + r['n_sensitivity_solves']:>8}{r['wall_time_s']:>9.1f}  "
                     + "".join(_cell(r["parameters"][z]).rjust(width) for z in ZONES))
    table.append("value [95 % interval, within the bounds]; '?' not resolved by the data, 'b' on a bound")
    fig9 = fig9_lines(runs)
    (out / "table.txt").write_text("\n".join(table) + "\n")
    (out / "fig9.txt").write_text("\n".join(fig9) + "\n")
    fig = Figure(figsize=(6, 4))
    ax = fig.subplots()
    for name, _, _, _ in PLAN[:2]:
        ax.semilogy(runs[name]["relative_error"], "o-", ms=3, label=f"{runs[name]['method']} "
                    f"({runs[name]['jacobian']})")
    ax.set(xlabel="iteration k", ylabel="|u_k - u| / |u_0 - u|", title="short 3-D M20, 10 DIC points (Fig. 9)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "fig9.png", dpi=110)
    summary = {"true": TRUE, "noise_mm": NOISE, "settings": settings.__dict__, "runs": runs, "wall_time_s": seconds}
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=list) + "\n")
    echo("\n" + "\n".join(table) + "\n\n" + "\n".join(fig9))
    echo(f"\nresults in {out.resolve()}: table.txt, fig9.txt, fig9.png, measured*.csv, runs/*/ (result.json, "
         f"history.csv, report.html); {seconds:.0f} s in all")
    return summary
