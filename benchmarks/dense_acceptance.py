"""Noise replicates of the dense CalculiX reference (tests/fixtures/dense_block) fitted with frictionid's defaults
(the discretisation control on) in several modes; prints, per mode and zone, the values, how many replicates
claim the zone, the largest error of a claim in standard errors and the coverage of the claimed 95 % intervals.

    PYTHONPATH=src .venv/bin/python benchmarks/dense_acceptance.py N [--modes default,include,u,u-include]
        [--max-memory GB] [--out DIR] [--first K] [--chosen JSON]

Modes: "default" all observations of the fixture's identify.toml (displacements, the 2 mm VSG strains, the
machine force, both stages); "include" the same with identify.model_error = "include"; "u" displacements and the
force only; "u-include" that with "include". Truth A 0.35, B 0.20, C 0.45, D 0.15.

The control's choice depends on the points, the stated noise and the start values, not on a replicate's values:
it runs in the first replicate of the first mode of each set of observables, and every other fit of that set
(later replicates, the "include" mode) is on the [model] table it chose with refine_target = 0 (their record
says "off"; the first's says what the control did). Their condensation is the first's, kept in the process. Replicate k is generate.py's ``replicate(values,
force, k)`` of the noise-free measured.csv (replicate 0 is measured_noisy.csv).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import _tests  # noqa: F401  (tests/ importable)
from fixtures.dense_block import generate
from frictionid.config import read_config
from frictionid.identification import identify_config

ROOT = Path(__file__).resolve().parents[1]
FIXTURE = ROOT / "tests" / "fixtures" / "dense_block"
TRUTH = {"A": 0.35, "B": 0.20, "C": 0.45, "D": 0.15}
MODES = {"default": ("all", "off"), "include": ("all", "include"), "u": ("u", "off"), "u-include": ("u", "include")}
OBSERVABLES = {"all": '["ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz", "force"]',
               "u": '["ux", "uy", "uz", "force"]'}



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


def write_replicate(k: int, out: Path) -> Path:
    labels, xyz, values, force = read_values(FIXTURE / "measured.csv")
    noisy, noisy_force = generate.replicate(values, force, k)
    path = out / f"replicate_{k}.csv"
    generate.write_csv(path, [f"dense_block noise replicate {k} (benchmarks/dense_acceptance.py)"], labels, xyz,
                       noisy, noisy_force)
    return path


def config_text(data: Path, observables: str, model_error: str, model: dict | None, run: Path,
                max_memory: float | None) -> str:
    table = model or {"builder": "block"}
    model_lines = "".join(f"{k} = {json.dumps(v)}\n" for k, v in table.items())
    return ("[model]\n" + model_lines + "[friction]\nzones = { A = 0.1, B = 0.1, C = 0.1, D = 0.1 }\n"
            f'[data]\nfile = "{data}"\nobservables = {observables}\nstages = [1, 2]\n'
            'noise = { u = 0.0005, e = 2e-5, force = 1.0 }\nregions = { "plate:*" = "plate", "*" = "block" }\n'
            'strain_window = 2.0\nstrain_window_shape = "circle"\n'
            f'[identify]\nmodel_error = "{model_error}"\n' + ("refine_target = 0\n" if model else "")
            + (f"[solver]\nmax_memory = {max_memory}\n" if max_memory else "") + f'[run]\ndir = "{run}"\n')


def fit(mode: str, k: int, out: Path, model: dict | None, max_memory: float | None) -> dict:
    observables, model_error = MODES[mode]
    data = write_replicate(k, out)
    path = out / f"{mode}_{k}.toml"
    path.write_text(config_text(data, OBSERVABLES[observables], model_error, model, out / f"run_{mode}_{k}",
                                max_memory))
    start = time.perf_counter()
    result = identify_config(read_config(path), echo=lambda text: print(f"  [{mode} {k}] {text}", flush=True))
    row = {"mode": mode, "replicate": k, "seconds": round(time.perf_counter() - start, 1),
           "reduced_chi2": result["fit"]["reduced_chi2"], "model": result["model"], "zones": {}}
    for zone, p in result["parameters"].items():
        off = None if not p["stderr"] else (p["value"] - TRUTH[zone]) / p["stderr"]
        low, high = p["ci95"] if p.get("ci95") else (math.nan, math.nan)
        row["zones"][zone] = {"value": p["value"], "stderr": p["stderr"], "claimed": bool(p["identifiable"]),
                              "off_se": off, "covered": bool(low <= TRUTH[zone] <= high), "why": p.get("why")}
    return row


def table(rows: list[dict]) -> str:
    lines = ["| mode | zone | replicates | values (min / median / max) | claimed | largest claimed error [se] | "
             "claimed 95 % covering | claimed within 0.02 |", "|---|---|---|---|---|---|---|---|"]
    for mode in dict.fromkeys(r["mode"] for r in rows):
        mine = [r for r in rows if r["mode"] == mode]
        for zone in TRUTH:
            z = [r["zones"][zone] for r in mine]
            v = np.array([e["value"] for e in z])
            claimed = [e for e in z if e["claimed"]]
            worst = max((abs(e["off_se"]) for e in claimed if e["off_se"] is not None), default=float("nan"))
            covered = sum(e["covered"] for e in claimed)
            near = sum(abs(e["value"] - TRUTH[zone]) <= 0.02 for e in claimed)
            lines.append(f"| {mode} | {zone} ({TRUTH[zone]}) | {len(z)} | {v.min():.4f} / {np.median(v):.4f} / "
                         f"{v.max():.4f} | {len(claimed)} | {worst:.2f} | {covered} / {len(claimed)} | "
                         f"{near} / {len(claimed)} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("replicates", type=int)
    parser.add_argument("--modes", default="default,include,u,u-include")
    parser.add_argument("--max-memory", type=float, default=None, help="[solver] max_memory [GB]")
    parser.add_argument("--out", type=Path, default=Path("/tmp/dense_acceptance"))
    parser.add_argument("--first", type=int, default=0, help="first replicate")
    parser.add_argument("--chosen", default=None,
                        help='the [model] table a run of the control chose for these observables, as JSON (e.g. '
                             '\'{"builder": "block", "mesh_size": 0.5, "block_divisions": 10}\'): no control run')
    parser.add_argument("--merge", type=Path, nargs="*", default=[],
                        help="rows.json files of earlier runs: their rows join the printed table (0 replicates: "
                             "only print it)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    given = json.loads(args.chosen) if args.chosen else None
    rows, chosen = [], {}
    for mode in args.modes.split(","):
        group = MODES[mode][0]
        if given is not None:
            chosen.setdefault(group, given)
        for k in range(args.first, args.first + args.replicates):
            row = fit(mode, k, args.out, chosen.get(group), args.max_memory)
            if group not in chosen:
                chosen[group] = {key: v for key, v in row["model"].items() if key not in ("contact", "discretisation")}
                print(f"{mode}: the control: {json.dumps(row['model']['discretisation'], default=dict)}", flush=True)
            rows.append(row)
            print(f"{mode} {k}: chi2/dof {row['reduced_chi2']:.3g}, " + ", ".join(
                f"{z} {e['value']:.4f} +- {e['stderr'] or float('nan'):.4f}{' claimed' if e['claimed'] else ''}"
                for z, e in row["zones"].items()) + f" ({row['seconds']:.0f} s)", flush=True)
            (args.out / "rows.json").write_text(json.dumps(rows, indent=1, default=dict))
    earlier = [row for path in args.merge for row in json.loads(path.read_text())]
    print(table(earlier + rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
