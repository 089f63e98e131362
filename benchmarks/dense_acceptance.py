"""Noise replicates of the dense CalculiX reference (tests/fixtures/dense_block) fitted with frictionid's defaults
(the discretisation control on) in several modes; prints, per mode and zone, the values, how many replicates
claim the zone, the largest error of a claim in standard errors and the coverage of the claimed 95 % intervals.

    PYTHONPATH=src .venv/bin/python benchmarks/dense_acceptance.py N [--modes default,include,u,u-include]
        [--max-memory GB] [--out DIR] [--first K] [--reference CSV] [--twin] [--exclude-plate-within MM] [--where]
        [--model-lines OPTIONS] [--at-truth NAME OPTIONS]

Modes: "default" all observations of the fixture's identify.toml (displacements, the 2 mm VSG strains, the
machine force, both stages) with the defaults (identify.model_error "auto": the control's error included where it
ran); "off" and "include" the same with identify.model_error = "off" / "include"; "u" displacements and the
force only, with the defaults; "u-off" and "u-include" that with "off" / "include"; "include-no-force" and
"u-include-no-force" those without the machine force (the control's estimate at the start values has no force
error: there the force is mu times the normal force on any mesh). Truth A 0.35, B 0.20, C 0.45, D 0.15.

The control's choice and its predicted remaining error depend on the model, the points, the stated noise and the
start values, never on the measured values (``discretisation_control.control`` does not read them;
tests/test_remaining_error.py checks it). So it runs once per set of observables, at the start values 0.1 of the
config, and every fit of that set (all replicates, the "include" mode) gets that same decision: the model it
chose and the remaining error the result's systematic errors come from. The control again at the fitted values
(``discretisation_refit``, ``model.discretisation.at_fitted``) reads the fit, so it runs in every fit; each fit's
line says what it found (``at fitted``: per round the estimated error of the model fitted, its status and, with a
refit, the refit's coefficients), and the process's peak. It is kept in ``--out`` (control_<set>.npz
and .json) for later invocations, and the condensations in ``--out``/cache (embedded.use_cache). The first
replicate of a mode starts at 0.1; later ones start at the first's fitted values (the same minimum, fewer
iterations). Replicate k is generate.py's ``replicate(values, force, k)`` of the noise-free ``--reference``
(default the fixture's measured.csv; replicate 0 of it is measured_noisy.csv).

``--exclude-plate-within MM`` leaves out the plate points nearer than MM to the footprint (the noise drawn on all
points first, so the points kept carry the same noise as in the full replicate); use its own ``--out`` (the kept
control decisions are per point set). ``--where`` prints after each fit its chi-square per quantity kind by region
of the points (dense_convergence.regions: each block face in height bands above the contact edge, the plate by
distance from the footprint): the mean squared weighted residual (the weights with the model error in the
"include" modes) and the region's share of the kind's chi-square.

``--twin``: the reference is frictionid's own default block model at the truth (``frictionid simulate`` of the
fits' config: the fixture's points, the cells it gives, the same 2 mm window), fitted with the control off
(``refine_target = 0``) so that the fitted model is the one that made the data: no model error, the noise alone.
How often the claimed intervals hold there is the intervals' own coverage, free of any reference's error.

``--at-truth NAME OPTIONS`` (no fits: the replicates are not read): frictionid's block model with the ``[model]`` lines
OPTIONS (e.g. ``'edge_splits = 4\ninterface_splits = 4'``) at the truth, displacements and the force only, on the
fixture's points, written to ``--out``/NAME/measured.csv for ``dense_convergence.py fixture=tests/fixtures/dense_block
NAME=DIR``; prints the nodes, the seconds and the process's peak. The solver's small-sliding check is off there
(``[solver] slip_tolerance = false``): the reference is ccx's small-sliding limit, the same problem.

``--fresh``: before each replicate the session's kept condensations are dropped (``embedded._RECENT``; they are
read back from ``--out``/cache) and freed memory is returned to the system, so that each fit holds what a fit of its
own process holds: without it a later replicate of "default" at ``--max-memory 5`` held enough more that the
control's estimate at the fitted values (the footprint divisions' model, estimated at 5.0 GB) was skipped.

``--model-lines OPTIONS``: the fits' ``[model]`` gets these lines (as ``--at-truth``), with the control and the
small-sliding check off (``slip_tolerance = false``): a fixed refinement of the model fitted as it is.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np

import _tests  # noqa: F401  (tests/ importable)
import dense_convergence
from fixtures.dense_block import generate
from frictionid import identification
from frictionid.backends import embedded
from frictionid.backends.embedded import use_cache
from frictionid.builders.registry import build_model
from frictionid.config import read_config
from frictionid.fem import memory
from frictionid.identification import identify_config
from frictionid.options import ModelSpec
from frictionid.simulation import simulate
from frictionid.inverse.discretisation_control import Control
from frictionid.inverse.observations import label_parts
from frictionid.inverse.remaining_error import RemainingError

ROOT = Path(__file__).resolve().parents[1]
FIXTURE = ROOT / "tests" / "fixtures" / "dense_block"
TRUTH = {"A": 0.35, "B": 0.20, "C": 0.45, "D": 0.15}
MODES = {"default": ("all", None), "off": ("all", "off"), "include": ("all", "include"), "u": ("u", None),
         "u-off": ("u", "off"), "u-include": ("u", "include"),
         "include-no-force": ("no-force", "include"), "u-include-no-force": ("u-no-force", "include")}
OBSERVABLES = {"all": '["ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz", "force"]',
               "u": '["ux", "uy", "uz", "force"]',
               "no-force": '["ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz"]', "u-no-force": '["ux", "uy", "uz"]'}



def read_values(path: Path):
    """labels, xyz (n, 3), values (2, n, 9) with NaN for empty cells, force (2,) of a fixture CSV."""
    rows = [line.split(",") for line in path.read_text().splitlines() if line and not line.startswith("#")][1:]
    n = len(rows) // 2
    labels = [r[0] for r in rows[:n]]
    xyz = np.array([[float(v) for v in r[1:4]] for r in rows[:n]])
    values = np.array([[[float(v) if v else np.nan for v in r[6:15]] for r in rows[s * n:(s + 1) * n]]
                       for s in (0, 1)])
    force = np.array([float(rows[0][5]), float(rows[n][5])])
    return labels, xyz, values, force


def write_replicate(k: int, out: Path, reference: Path, exclude: float | None = None) -> Path:
    """Replicate k of the reference as a CSV in out; with ``exclude`` without the plate points nearer than that to
    the footprint (the noise drawn on all points first)."""
    labels, xyz, values, force = read_values(reference)
    noisy, noisy_force = generate.replicate(values, force, k)
    note = ""
    if exclude:
        keep = ~(np.array([label.startswith("plate:") for label in labels])
                 & (dense_convergence.footprint_distance(xyz) < exclude))
        labels, xyz, noisy = [l for l, kept in zip(labels, keep) if kept], xyz[keep], noisy[:, keep]
        note = f", the plate points within {exclude:g} mm of the footprint left out ({int((~keep).sum())})"
    path = out / f"replicate_{k}.csv"
    generate.write_csv(path, [f"dense_block noise replicate {k} (benchmarks/dense_acceptance.py){note}"], labels,
                       xyz, noisy, noisy_force)
    return path


def misfit_where(result: dict, data: Path) -> list[dict]:
    """Per region of the points (dense_convergence.regions, by face) and quantity kind: observations n, mean squared
    weighted residual and share of the kind's chi-square, of a fit's result and its data file; the per-stage
    force as a region of its own."""
    labels, xyz, _, _ = read_values(data)
    region_of = {}
    for name, mask in dense_convergence.regions(labels, xyz, by_face=True):
        region_of.update({label: name for label, inside in zip(labels, mask) if inside})
    sums: dict = {}
    for o in result["fit"]["observations"]:
        point, quantity, _ = label_parts(o["label"])
        key = (region_of.get(point, "other") if point else "machine", quantity)
        n, chi2 = sums.get(key, (0, 0.0))
        sums[key] = (n + 1, chi2 + ((o["model"] - o["measured"]) / o["sigma"]) ** 2)
    total = {q: sum(c for (_, kind), (_, c) in sums.items() if kind == q) for _, q in sums}
    return [{"region": region, "quantity": q, "n": n, "mean_r2": round(c / n, 3), "share": round(c / total[q], 3)}
            for (region, q), (n, c) in sums.items()]


def where_table(rows: list[dict]) -> str:
    """misfit_where's rows as a table: a line per region, per kind its mean squared residual (share of the kind)."""
    kinds = list(dict.fromkeys(r["quantity"] for r in rows))
    lines = ["| region | " + " | ".join(kinds) + " |", "|---" * (len(kinds) + 1) + "|"]
    for region in dict.fromkeys(r["region"] for r in rows):
        cell = {r["quantity"]: f"{r['mean_r2']:.2f} ({r['share']:.0%}, {r['n']})" for r in rows if r["region"] == region}
        lines.append(f"| {region} | " + " | ".join(cell.get(k, "") for k in kinds) + " |")
    return "\n".join(lines)


def config_text(data: Path, observables: str, model_error: str | None, run: Path, max_memory: float | None,
                start: dict, control: bool = True, model_lines: str = "") -> str:
    zones = ", ".join(f"{z} = {v:.6g}" for z, v in start.items())
    lines = model_lines.replace("\\n", "\n")                 # "\n" typed in a shell's quotes: a new line
    return ('[model]\nbuilder = "block"\n' + (lines + "\n" if lines else "") + '[friction]\nzones = { ' + zones + ' }\n'
            f'[data]\nfile = "{data}"\nobservables = {observables}\nstages = [1, 2]\n'
            f'noise = {{ {_noise(observables)} }}\n' 'regions = { "plate:*" = "plate", "*" = "block" }\n'
            'strain_window = 2.0\nstrain_window_shape = "circle"\n'
            "[identify]\n" + (f'model_error = "{model_error}"\n' if model_error else "")
            + ("" if control else "refine_target = 0\n")
            + "[solver]\n" + (f"max_memory = {max_memory}\n" if max_memory else "")
            + ("slip_tolerance = false\n" if model_lines else "") + f'[run]\ndir = "{run}"\nfields = false\n')


def _noise(observables: str) -> str:
    """The stated noise of the observed kinds (a kind stated but not observed is refused with a note)."""
    noise = {"u": "u = 0.0005", "e": "e = 2e-5", "force": "force = 1.0"}
    return ", ".join(text for kind, text in noise.items() if f'"{kind}' in observables)


class KeptControl:
    """identification.control replaced by one decision per set of observables (module docstring), kept on disk."""

    def __init__(self, out: Path, original):
        self.out, self.original, self.group, self.made = out, original, None, {}

    def __call__(self, model_options, model, observations, mu, target, budget=2, max_memory=None, progress=None,
                 window=None, backend="embedded", factorisation="auto"):
        progress = progress or (lambda text: None)
        if self.group in self.made:
            progress("discretisation control: the decision of this set of observables reused (it does not read "
                     "the measured values)")
            return self.made[self.group]
        stem = self.out / f"control_{self.group}"
        if stem.with_suffix(".json").exists():
            kept = json.loads(stem.with_suffix(".json").read_text())
            arrays = np.load(stem.with_suffix(".npz"))
            if arrays["nominal"].shape != (observations.n_obs,):
                sys.exit(f"{stem}: kept for {arrays['nominal'].shape} observations, these are {observations.n_obs}")
            spec = ModelSpec.from_table(kept["options"])
            chosen = Control(spec, build_model(spec), kept["record"],
                             RemainingError(arrays["nominal"], arrays["slow"], kept["orders"]))
            progress(f"discretisation control: kept decision read from {stem}.json")
        else:
            chosen = self.original(model_options, model, observations, mu, target, budget, max_memory, progress,
                                   window, backend, factorisation)
            if chosen.remaining is not None:
                np.savez(stem.with_suffix(".npz"), nominal=chosen.remaining.nominal, slow=chosen.remaining.slow)
                stem.with_suffix(".json").write_text(json.dumps({"options": chosen.options.table(), "record": chosen.record,
                                                                 "orders": chosen.remaining.orders}, default=float))
        self.made[self.group] = chosen
        return chosen


def twin_reference(out: Path) -> Path:
    """frictionid's default block model at the truth, simulated at the fixture's points and cells (--twin)."""
    path = out / "twin.toml"
    path.write_text(config_text(FIXTURE / "measured.csv", OBSERVABLES["all"], "off", out / "twin_run", None, TRUTH))
    written = simulate(read_config(path), out / "twin.csv")
    if not np.array_equal(np.isnan(read_values(written)[2]), np.isnan(read_values(FIXTURE / "measured.csv")[2])):
        sys.exit(f"{written}: the twin's cells are not the fixture's")
    return written


def at_truth(name: str, options: str, out: Path, max_memory: float | None) -> dict:
    """--at-truth: the block with the ``[model]`` lines ``options`` simulated at the truth (module docstring)."""
    folder = out / name
    folder.mkdir(parents=True, exist_ok=True)
    text = config_text(FIXTURE / "measured.csv", OBSERVABLES["u"], "off", folder / "run", max_memory, TRUTH,
                       control=False, model_lines=options)
    (folder / "sim.toml").write_text(text)
    lines = []
    begun = time.perf_counter()
    simulate(read_config(folder / "sim.toml"), folder / "measured.csv", echo=lines.append)
    nodes = next(int(m.group(1).replace(",", "")) for m in map(re.compile(r"([\d,]+) nodes").search, lines) if m)
    return {"at_truth": name, "options": options.replace("\\n", "\n"), "nodes": nodes, "seconds": round(time.perf_counter() - begun, 1),
            "process_peak_gb": round(memory.process_peak() / memory.GB, 2), "export": str(folder)}


def fit(mode: str, k: int, out: Path, reference: Path, max_memory: float | None, start: dict,
        control: bool = True, exclude: float | None = None, where: bool = False, model_lines: str = "") -> dict:
    observables, model_error = MODES[mode]
    data = write_replicate(k, out, reference, exclude)
    path = out / f"{mode}_{k}.toml"
    path.write_text(config_text(data, OBSERVABLES[observables], model_error, out / f"run_{mode}_{k}", max_memory,
                                start, control, model_lines))
    identification.control.group = observables
    start = time.perf_counter()
    result = identify_config(read_config(path), echo=lambda text: print(f"  [{mode} {k}] {text}", flush=True))
    row = {"mode": mode, "replicate": k, "seconds": round(time.perf_counter() - start, 1),
           "reduced_chi2": result["fit"]["reduced_chi2"], "model": result["model"], "zones": {},
           "kinds": {q: round(g["rms"] ** 2, 3) for q, g in result["fit"]["misfit"]["by_quantity"].items()},
           "beyond": result["fit"]["kinds_beyond_noise"], "model_error": result["fit"]["model_error"]["mode"]}
    if where:
        row["where"] = misfit_where(result, data)
        print(f"{mode} {k}: mean squared weighted residual by region and kind (share of the kind's chi-square, "
              f"observations)\n{where_table(row['where'])}", flush=True)
    for zone, p in result["parameters"].items():
        off = None if not p["stderr"] else (p["value"] - TRUTH[zone]) / p["stderr"]
        low, high = p["ci95"] if p.get("ci95") else (math.nan, math.nan)
        row["zones"][zone] = {"value": p["value"], "stderr": p["stderr"], "claimed": bool(p["identifiable"]),
                              "off_se": off, "covered": bool(low <= TRUTH[zone] <= high), "why": p.get("why"),
                              "systematic": p.get("stderr_systematic"), "bias": p.get("discretisation_bias")}
    return row


def at_fitted_text(record: dict) -> str:
    """The control's rounds at the fitted values (model.discretisation.at_fitted), one clause each."""
    def clause(r):
        text = (f"round {r['round']}: error of the model fitted " + ", ".join(f"{q} {v:.2f}" for q, v in
                r.get("error_fitted", {}).items()) + f" -> {r['status']} ({r['seconds']:.0f} s)")
        if "refit" in r:
            text += (f"; refit on {r['n_nodes']:,} nodes ({r['factors']}): " + ", ".join(
                f"{z} {v:.4f}" for z, v in r["refit"]["value"].items()) + f" ({r['refit']['seconds']:.0f} s)")
        return text
    return "; ".join(map(clause, record.get("at_fitted", []))) or "not run"


def table(rows: list[dict]) -> str:
    lines = ["| mode | zone | replicates | values (min / median / max) | standard error (systematic part) | claimed | "
             "largest claimed error [se] | claimed 95 % covering | claimed within 0.02 |",
             "|---|---|---|---|---|---|---|---|---|"]
    for mode in dict.fromkeys(r["mode"] for r in rows):
        mine = [r for r in rows if r["mode"] == mode]
        for zone in TRUTH:
            z = [r["zones"][zone] for r in mine]
            v = np.array([e["value"] for e in z])
            claimed = [e for e in z if e["claimed"]]
            worst = max((abs(e["off_se"]) for e in claimed if e["off_se"] is not None), default=float("nan"))
            covered = sum(e["covered"] for e in claimed)
            near = sum(abs(e["value"] - TRUTH[zone]) <= 0.02 for e in claimed)
            se = np.array([e["stderr"] or np.nan for e in z])
            sys_ = np.array([e.get("systematic") or 0.0 for e in z])
            lines.append(f"| {mode} | {zone} ({TRUTH[zone]}) | {len(z)} | {v.min():.4f} / {np.median(v):.4f} / "
                         f"{v.max():.4f} | {np.nanmedian(se):.4f} ({np.median(sys_):.4f}) | {len(claimed)} | "
                         f"{worst:.2f} | {covered} / {len(claimed)} | {near} / {len(claimed)} |")
    return "\n".join(lines)


def release() -> None:
    """Drop the session's kept condensations (the disk cache keeps them) and return freed memory to the system;
    prints what the process holds then."""
    embedded._RECENT.clear()
    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except OSError:                                     # not glibc: the freed memory stays with the process
        pass
    print(f"holding {memory.resident() / memory.GB:.2f} GB before the fit", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("replicates", type=int)
    parser.add_argument("--modes", default="default,include,u,u-include")
    parser.add_argument("--max-memory", type=float, default=None, help="[solver] max_memory [GB]")
    parser.add_argument("--out", type=Path, default=Path("/tmp/dense_acceptance"))
    parser.add_argument("--first", type=int, default=0, help="first replicate")
    parser.add_argument("--reference", type=Path, default=FIXTURE / "measured.csv",
                        help="the noise-free reference the replicates are drawn around")
    parser.add_argument("--merge", type=Path, nargs="*", default=[],
                        help="rows.json files of earlier runs: their rows join the printed table (0 replicates: "
                             "only print it)")
    parser.add_argument("--exclude-plate-within", type=float, default=None, metavar="MM",
                        help="leave out the plate points nearer than MM to the footprint")
    parser.add_argument("--where", action="store_true", help="each fit's chi-square per kind by region")
    parser.add_argument("--twin", action="store_true", help="replicates of frictionid's own model at the truth, "
                        "fitted with the control off (module docstring)")
    parser.add_argument("--at-truth", nargs=2, metavar=("NAME", "OPTIONS"), help="simulate the block with these "
                        "[model] lines at the truth, displacements only, into --out/NAME (module docstring)")
    parser.add_argument("--fresh", action="store_true", help="each replicate starts holding what a process of its "
                        "own holds (module docstring)")
    parser.add_argument("--model-lines", default="", metavar="OPTIONS", help="these [model] lines in the fits, the "
                        "control and the small-sliding check off (module docstring)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.at_truth:
        print(json.dumps(at_truth(*args.at_truth, args.out, args.max_memory)))
        return 0
    if args.twin:
        args.reference = twin_reference(args.out)
    use_cache(args.out / "cache")
    identification.control = KeptControl(args.out, identification.control)
    rows = []
    for mode in args.modes.split(","):
        start = dict.fromkeys(TRUTH, 0.1)
        for k in range(args.first, args.first + args.replicates):
            if args.fresh:
                release()
            row = fit(mode, k, args.out, args.reference, args.max_memory, start,
                      control=not (args.twin or args.model_lines), exclude=args.exclude_plate_within,
                      where=args.where, model_lines=args.model_lines)
            if k == args.first:
                print(f"{mode}: the control: {json.dumps(row['model']['discretisation'], default=dict)}", flush=True)
                start = {z: min(max(e["value"], 0.01), 0.99) for z, e in row["zones"].items()}
            rows.append(row)
            print(f"{mode} {k}: at fitted: {at_fitted_text(row['model']['discretisation'])}", flush=True)
            print(f"{mode} {k}: chi2/dof {row['reduced_chi2']:.3g}, " + ", ".join(
                f"{z} {e['value']:.4f} +- {e['stderr'] or float('nan'):.4f}{' claimed' if e['claimed'] else ''}"
                for z, e in row["zones"].items()) + f" ({row['seconds']:.0f} s); per kind " + ", ".join(
                f"{q} {v:.2f}" for q, v in row["kinds"].items()) + f"; beyond the noise: {row['beyond']}; model error "
                f"{row['model_error']}; process "
                f"peak {memory.process_peak() / memory.GB:.2f} GB",
                flush=True)
            (args.out / "rows.json").write_text(json.dumps(rows, indent=1, default=dict))
    earlier = [row for path in args.merge for row in json.loads(path.read_text())]
    print(table(earlier + rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
