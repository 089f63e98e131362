"""The shipped M20 bolt-nut study (DESIGN.md reference test 2; the paper's sections 4.2-4.3), end to end.

Measured-like data are made by the tool itself on a finer mesh than the one identified with (no inverse crime),
with known coefficients; a noisy copy adds DIC-like Gaussian noise. The six thread zones are identified from
mu = 0.1 with the paper's algorithm (gradient descent, Armijo steps, forward differences) and with ours (bounded
trust-region Gauss-Newton with analytic sensitivities); the paper's Fig. 9 (|u_k - u| / |u_0 - u| per iteration)
compares them. Also written: the resolution of the ten DIC points before fitting, the mesh sequence of the
measured-point displacements, and the thread load shares against Sopwith's closed form.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..backends.embedded import EmbeddedBackend, cache_in
from ..builders.bolt import bolt_layout, fixed_friction, measurement_points
from ..builders.registry import build_model
from ..config import read_config
from ..data.measurements import Measurements, write_measurements
from ..errors import InputError
from ..options import DEFAULT_BOUNDS, ModelSpec
from ..identification import identify_config
from ..preparation import prepare
from ..report.html import NEAR_BOUND
from ..report.bolt import bolt_summary, nut_dilation, plot_load_shares, thread_loads
from ..report.outputs import write_outputs
from ..report.tables import prefit_summary, result_summary

#: the coefficients the data are made with (thread zones; outer A-C, inner D-F, section 1 at the bearing face)
TRUE_MU = {"A": 0.14, "B": 0.18, "C": 0.22, "D": 0.12, "E": 0.16, "F": 0.20}
#: DIC-like displacement noise [mm]: 0.5 um, about 0.02 px at 25 um per pixel (a 50 mm field on 2k pixels)
NOISE = 0.0005
FORCES = (10000.0, 30000.0)
START = 0.1
#: friction.bounds of the demo's configs (they set none: the config default)
BOUNDS = DEFAULT_BOUNDS
METHODS = (("trf", "analytic"), ("gradient-descent", "forward"))
#: per-method options: trf stops once an iteration lowers J by less than 0.1 % (J is a chi-square here: the
#: unresolved zones otherwise drift along their flat valley for dozens of iterations) or the coefficients change
#: by less than 1e-6 (relative); the paper's gradient descent starts every Armijo search from
#: t0 = 0.05 / max|grad J(x0)|, so that its first trial changes the steepest coefficient by 0.05
OPTIONS = {"trf": "ftol = 1e-3, xtol = 1e-6", "gradient-descent": "scaled_step = true, initial_step = 0.05"}


@dataclass(frozen=True)
class Settings:
    """Mesh sizes [mm] and iteration limits of a demo run; ``quick()`` is the coarse variant the tests run."""

    flank: float = 0.1
    data_flank: float = 0.05
    sequence: tuple[float, ...] = (0.2, 0.1, 0.05)
    gd_iterations: int = 20
    trf_iterations: int = 30
    seed: int = 7

    @classmethod
    def quick(cls) -> "Settings":
        return cls(flank=0.25, data_flank=0.15, sequence=(0.25, 0.15), gd_iterations=2, trf_iterations=8)


QUANTITIES = ("ux", "uy")


def points_measurements(points: np.ndarray, values: np.ndarray, sigma: float | None, comments) -> Measurements:
    """ux, uy [mm] at the points (n, 2) [mm] for every stage (values (n_stages, n_points * 2), point-major) as a
    measurement table with the study's machine forces; ``sigma`` [mm] per value, or None."""
    n_stages, n = values.shape[0], len(points)
    labels = tuple(f"P{k + 1}" for k in range(n)) * n_stages
    xyz = np.tile(np.column_stack([points, np.zeros(n)]), (n_stages, 1))
    columns = {q: values[:, k::len(QUANTITIES)].ravel() for k, q in enumerate(QUANTITIES)}
    extra = {} if sigma is None else {q: np.full(n * n_stages, sigma) for q in QUANTITIES}
    return Measurements(points=labels, coordinates=xyz, stage=np.repeat(np.arange(1, n_stages + 1), n),
                        force=np.repeat(FORCES[:n_stages], n), values=columns, sigma=extra, comments=tuple(comments))


def write_config(out: Path, name: str, data: str, method: str, jacobian: str, iterations: int, flank: float,
            noise: float, observables=QUANTITIES) -> Path:
    """``out``/``name``.toml: an identification of the thread zones from ``START`` on the data file ``data``
    (relative to ``out``) with ``method`` and ``jacobian``, the flank mesh size ``flank`` [mm] and the
    displacement noise ``noise`` [mm]; returns its path."""
    zones = ", ".join(f"{z} = {START}" for z in TRUE_MU)
    fixed = ", ".join(f"{z} = {v}" for z, v in fixed_friction().items())
    path = out / f"{name}.toml"
    path.write_text(f'# frictionid demo: {name}\n[model]\nbuilder = "bolt"\nsize = "M20"\nforces = {list(FORCES)}\n'
                    f"flank_size = {flank}\n[friction]\nzones = {{ {zones} }}\nfixed = {{ {fixed} }}\n"
                    f'[data]\nfile = "{data}"\nobservables = {json.dumps(list(observables))}\nstages = [1, 2]\n'
                    f'noise = {{ u = {noise!r} }}\nregions = {{ "*" = "bolt" }}\n'
                    f'[identify]\nmethod = "{method}"\njacobian = "{jacobian}"\nmax_iterations = {iterations}\n'
                    # the study compares algorithms on the paper's mesh, and the noise-free twin's stated noise is
                    # that mesh's own discretisation error: the control would refine towards an unreachable target
                    "refine_target = 0\n"
                    + (f"options = {{ {OPTIONS[method]} }}\n" if method in OPTIONS else "")
                    + f'[run]\ndir = "runs/{name}"\n')
    return path


def _relative_errors(result: dict, backend, obs_of, y_true: np.ndarray) -> np.ndarray:
    """|u_k - u| / |u_0 - u| over the history (the paper's Fig. 9), one solve per iterate."""
    u = np.array([obs_of(backend.predict(np.array(mu)).values) for mu in result["history"]["coefficients"]])
    return np.linalg.norm(u - y_true, axis=1) / np.linalg.norm(u[0] - y_true)


@dataclass(frozen=True)
class MeshRow:
    """One mesh of the sequence: flank size [mm], counts, ux/uy at the points (n_stages, 2 n_points) at the
    true and at the start coefficients, and the time to build and solve it [s]."""

    size: float
    n_nodes: int
    n_pairs: int
    at_true: np.ndarray
    at_start: np.ndarray
    seconds: float


def _mesh_sequence(settings: Settings, points: np.ndarray, true: dict, initial: dict, echo):
    """The mesh sequence at coefficients ``true`` and ``initial`` (zone -> mu); returns its rows, the
    identification mesh's backend and ``true`` as a vector in its zone order."""
    rows, kept = [], None
    for size in sorted(set(settings.sequence) | {settings.data_flank, settings.flank}, reverse=True):
        start = time.perf_counter()
        model = build_model(ModelSpec("bolt", {"size": "M20", "forces": list(FORCES), "flank_size": size}))
        mu, mu0 = (np.array([c[z] for z in model.zone_names]) for c in (true, initial))
        backend = EmbeddedBackend(model, points, QUANTITIES, ["bolt"] * len(points))
        rows.append(MeshRow(size, model.mesh.n_nodes, backend.problem.pairs.n_pairs, backend.predict(mu).values,
                            backend.predict(mu0).values, time.perf_counter() - start))
        kept = (backend, mu) if size == settings.flank else kept
        echo(f"  flank size {size:g} mm: {model.mesh.n_nodes} nodes, {rows[-1].n_pairs} contact pairs, "
             f"built and solved twice in {rows[-1].seconds:.1f} s")
    return rows, *kept


def _sequence_table(rows, reference: float, points: np.ndarray) -> list[str]:
    ref = next(r for r in rows if r.size == reference).at_true[-1]
    lines = [f"ux, uy at the 10 DIC points, stage 2 (F = {FORCES[-1]:g} N), true coefficients: difference to the "
             f"{reference:g} mm mesh [um]",
             f"{'flank size':>10} {'nodes':>7} {'pairs':>6} {'max |diff|':>11} {'RMS diff':>9} {'rel. to range':>14}"]
    for row in rows:
        diff = (row.at_true[-1] - ref) * 1000
        rms = np.sqrt(np.mean(diff ** 2))
        lines.append(f"{row.size:>10g} {row.n_nodes:>7d} {row.n_pairs:>6d} {np.abs(diff).max():>11.4f} "
                     f"{rms:>9.4f} {rms / (np.ptp(ref) * 1000):>14.3%}")
    lines.append("\nuy [um] at stage 2 per point (r, y) [mm] and flank size [mm]")
    lines.append(f"{'point':>20}" + "".join(f"{r.size:>10g}" for r in rows))
    for k, p in enumerate(points):
        lines.append(f"{f'({p[0]:.3f}, {p[1]:.3f})':>20}" + "".join(f"{r.at_true[-1, 2 * k + 1] * 1000:>10.3f}"
                                                                  for r in rows))
    return lines


def _model_error(rows, settings: Settings) -> float:
    """RMS difference [mm] of the observed values between the identification mesh and the finest mesh, at the
    start coefficients (a mesh study an engineer can make without knowing the answer)."""
    coarse = next(r for r in rows if r.size == settings.flank).at_start
    fine = min(rows, key=lambda r: r.size).at_start
    return float(np.sqrt(np.mean((coarse - fine) ** 2)))


def _bolt_results(out: Path, backend, mu: np.ndarray, echo) -> str:
    """Load shares (with the Sopwith plot), zone states and nut dilation at the true coefficients."""
    problem = backend.problem
    solution = problem.solve(mu)
    text = bolt_summary(problem.model, solution)
    plot_load_shares(thread_loads(problem.model, solution), out / "load_shares.png",
                     f"M20, F = {FORCES[-1] / 1000:g} kN, true coefficients")
    y, u_r = nut_dilation(problem.model, problem.displacement(solution))
    text += f"\nnut dilation u_r on its outer surface: {u_r.min() * 1000:.3f} ... {u_r.max() * 1000:.3f} um"
    (out / "bolt.txt").write_text(text + "\n")
    echo(text)
    return text


def _cell(p: dict) -> str:
    """'0.1376 [0.1350, 0.1402]': value and 95 % interval (within the bounds), with '?' when the data do not
    resolve the zone and 'b' when it ends on a bound or within NEAR_BOUND of one (it then prints as the bound)."""
    interval = " [not seen]" if p.get("ci95") is None else f" [{p['ci95'][0]:.4f}, {p['ci95'][1]:.4f}]"
    near = min(p["value"] - BOUNDS[0], BOUNDS[1] - p["value"]) <= NEAR_BOUND * (BOUNDS[1] - BOUNDS[0])
    flags = ("b" if p.get("at_bound") or near else "") + ("" if p.get("identifiable") else "?")
    return f"{p['value']:.4f}{interval}{' ' + flags if flags else ''}"


def run_demo(out: Path, settings: Settings = Settings(), resume: bool = False, echo=print) -> dict:
    """Run the study into folder ``out``; returns a summary dict (also written as summary.json).

    ``resume``: continue the identifications stored in ``out`` (finished ones are replayed, not recomputed).
    """
    out = demo_folder(out, resume)
    with cache_in(out / "cache"):            # a replay (--resume) reads the condensations and solves stored there
        return _run(out, settings, resume, echo)


def demo_folder(out, resume: bool) -> Path:
    """The folder ``out`` of a demo's results, with its runs/ made; refused (InputError) when it is a file, or
    when it holds runs already and ``resume`` is off."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: is a file; expected a folder for the demo's results")
    stored = sorted(p.parent.name for p in (out / "runs").glob("*/store.sqlite"))
    if stored and not resume:
        raise InputError(f"{out}: already holds the demo's runs {stored}; continue or replay them with --resume, "
                         "or choose another --out")
    (out / "runs").mkdir(parents=True, exist_ok=True)
    return out


def _run(out: Path, settings: Settings, resume: bool, echo) -> dict:
    start = time.perf_counter()
    points = measurement_points(bolt_layout("M20"))
    true = {**TRUE_MU, **fixed_friction()}
    initial = {**{z: START for z in TRUE_MU}, **fixed_friction()}
    echo(f"1. Mesh sequence ({', '.join(f'{z}={v}' for z, v in TRUE_MU.items())}; head and nut plate 0.15)")
    rows, backend, mu = _mesh_sequence(settings, points, true, initial, echo)
    (out / "mesh_sequence.txt").write_text("\n".join(_sequence_table(rows, min(settings.sequence), points)) + "\n")
    echo("\n2. Bolt results at the true coefficients (identification mesh)")
    _bolt_results(out, backend, mu, echo)
    exact = next(r for r in rows if r.size == settings.data_flank).at_true
    noisy = exact + np.random.default_rng(settings.seed).normal(0.0, NOISE, exact.shape)
    provenance = [f"frictionid demo: M20 bolt-nut, made on a {settings.data_flank:g} mm flank mesh with "
                  + ", ".join(f"{z}={v}" for z, v in TRUE_MU.items()) + ", head/nut-plate 0.15",
                  "units: mm, N; ux, uy of the bolt load flanks 1 and 2 (from the nut bearing face), 1/6 ... 5/6"]
    write_measurements(out / "measured_exact.csv", points_measurements(points, exact, None, provenance))
    write_measurements(out / "measured.csv", points_measurements(
        points, noisy, NOISE, provenance + [f"Gaussian noise sigma = {NOISE} mm added (seed {settings.seed})"]))
    model_error = _model_error(rows, settings)
    echo(f"\nmodel (discretisation) error of the identification mesh at the start values: {model_error * 1000:.4f} um "
         "RMS; the noise-free twin states it as its noise level")
    plan = (("trf", "measured_exact.csv", *METHODS[0], model_error, QUANTITIES),
            ("paper", "measured_exact.csv", *METHODS[1], model_error, QUANTITIES),
            ("trf-noisy", "measured.csv", *METHODS[0], NOISE, QUANTITIES),
            ("trf-noisy-uy", "measured.csv", *METHODS[0], NOISE, ("uy",)))
    runs = {}
    for name, data, method, jacobian, noise, observables in plan:
        iterations = settings.gd_iterations if method == "gradient-descent" else settings.trf_iterations
        path = write_config(out, name, data, method, jacobian, iterations, settings.flank, noise, observables)
        echo(f"\n3. identify {name}: {method} with {jacobian} Jacobian, {'+'.join(observables)} from {data}, "
             f"noise {noise * 1000:.4f} um")
        config = read_config(path, need=("model", "friction", "data", "run"))
        result = identify_config(config, resume=resume,
                          on_iteration=lambda k, m, j, ev: echo(f"   iter {k:3d}  J={j:.4e}  "
                                                            + " ".join(f"{v:.4f}" for v in m[:6])),
                          on_prefit=lambda report: echo(prefit_summary(report.as_dict())))
        result = {**result.to_dict(), "truth": dict(TRUE_MU)}      # the plots and report.html then show the true values
        write_outputs(config.resolve(config.run.dir), result, None, config.text,
                      config.resolve(config.data.file))
        runs[name] = (path, result)
    echo("\n" + result_summary(runs["trf"][1]))
    obs_of = prepare(read_config(runs["trf"][0], need=("model", "friction", "data", "run"))).observations.predicted
    curves = {name: _relative_errors(runs[name][1], backend, obs_of, obs_of(exact)) for name in ("trf", "paper")}
    return _write_summary(out, settings, runs, curves, model_error, start, echo)


def _write_summary(out: Path, settings: Settings, runs: dict, curves: dict, model_error: float, start: float,
                   echo) -> dict:
    fig = Figure(figsize=(6, 4))
    ax = fig.subplots()
    for name, curve in curves.items():
        ax.semilogy(curve, "o-", ms=3, label=f"{runs[name][1]['method']} ({runs[name][1]['jacobian']})")
    ax.set(xlabel="iteration k", ylabel="|u_k - u| / |u_0 - u|", title="M20 bolt-nut, 10 DIC points (Fig. 9)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "fig9.png", dpi=110)
    width = 28
    table = [f"{'run':<13}{'status':<16}{'iter':>5}{'solves':>8}{'time [s]':>9}  "
             + "".join(f"{z:>{width}}" for z in TRUE_MU)]
    table.append(f"{'true':<13}{'':<16}{'':>5}{'':>8}{'':>9}  " + "".join(f"{v:>{width}.4f}" for v in TRUE_MU.values()))
    for name, (_, r) in runs.items():
        cells = "".join(_cell(r["parameters"][z]).rjust(width) for z in TRUE_MU)
        table.append(f"{name:<13}{r['status']:<16}{r['n_iterations']:>5}"
                     f"{r['n_forward_solves'] + r['n_sensitivity_solves']:>8}{r['wall_time_s']:>9.1f}  " + cells)
    table.append("value [95 % interval, within the bounds]; '?' not resolved by the data (standard error above "
                 "identify.resolution = 0.02 or the data contradict each other), "
                 f"'b' on a bound (within {NEAR_BOUND:g})")
    (out / "table.txt").write_text("\n".join(table) + "\n")
    summary = {"true": TRUE_MU, "noise_mm": NOISE, "model_error_mm": model_error, "settings": settings.__dict__,
               "runs": {name: r for name, (_, r) in runs.items()}, "wall_time_s": time.perf_counter() - start}
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=list) + "\n")
    echo("\n" + "\n".join(table))
    echo(f"\nresults in {out.resolve()}: table.txt, fig9.png, load_shares.png, bolt.txt, mesh_sequence.txt, "
         "measured*.csv, runs/*/ "
         f"(result.json, history.csv, convergence.png, report.html); {summary['wall_time_s']:.0f} s in all")
    return summary
