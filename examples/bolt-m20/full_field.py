"""Full-field DIC on the M20 bolt's cut-out plane: which thread zones are resolved against the
number of measured points, at 0.5 um DIC noise.

The ten default flank points of the study (README.md beside this file) resolve none of the six thread zones at
this noise. A DIC system looking at the cut-out plane (the (r, y) section of bolt and nut, as in the paper's
sectioned specimen) gives thousands of points. Here the tool makes such data itself, on a finer mesh than the one
it identifies with (no inverse crime):

1. Points: a square grid over the engaged threads in the section, r in [7.5, 11.5] mm (bolt core to nut wall
   beyond the thread), y from the nut bearing face (94.5) to its top (112.5): a camera zoomed on the threads;
   spacing chosen for about 100 ... 100000 points (0.02 mm spacing at 1e5: a 2k camera on this 4 x 18 mm field
   at a 2-3 pixel step). A grid point is kept where it lies inside the same region (bolt or nut) of both meshes,
   at least 0.01 mm from any region boundary (:func:`frictionid.fem.locate.region_at`). Plus the study's ten
   default flank points.
2. Data: ux, uy at both stages (10 and 30 kN) from the 0.05 mm flank mesh at the study's goal coefficients
   (A-F = 0.14, 0.18, 0.22, 0.12, 0.16, 0.20; head and nut on the plates 0.15, fixed), plus Gaussian noise of
   0.5 um on every value (seed 7), written as generic CSV files with sigma columns (points B..., N...).
3. For each set, on the 0.1 mm mesh from mu = 0.1: the resolution before fitting (predicted standard errors at
   the start values for the stated noise, :mod:`frictionid.inverse.resolution`), and the identification
   (``frictionid identify``'s path: trf, analytic Jacobian; standard errors and identifiability from
   :mod:`frictionid.inverse.uncertainty`).

Writes <out>/table.md (the table in README.md), <out>/summary.json, the data files, configs and runs.
Run: .venv/bin/python examples/bolt-m20/full_field.py [--quick] [--out DIR]   (default out: out/full_field)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from frictionid.backends.embedded import EmbeddedBackend, cache_in
from frictionid.builders.bolt import bolt_layout, fixed_friction, measurement_points
from frictionid.builders.registry import build_model
from frictionid.config import read_config
from frictionid.data.measurements import Measurements, write_measurements
from frictionid.fem.locate import region_at
from frictionid.fem.space import Space
from frictionid.identification import identify_config
from frictionid.studies.bolt import FORCES, NOISE, OPTIONS, START, TRUE_MU
from frictionid.options import ModelSpec

QUANTITIES = ("ux", "uy")
#: the grids' target numbers of points (the study's ten default flank points come first)
SIZES = (100, 1000, 5000, 20000, 100000)
#: the field of view in the section: radii [mm] (bolt core to nut wall); axially the nut, bearing face to top
R_RANGE = (7.5, 11.5)
#: a grid point is kept only this far [mm] inside its region on both meshes
DEPTH = 0.01
#: identify.resolution: the largest standard error counted as resolved
TOLERANCE = 0.02
SEED = 7


def section_grid(spaces, n_target: int, layout) -> tuple[np.ndarray, list[str]]:
    """About ``n_target`` grid points (r, y) [mm] over the threads in the bolt-nut section, inside the same region
    (bolt or nut) of every space by DEPTH; returns the points and their region names."""
    r_range, y_range = R_RANGE, (layout.y_bearing, layout.y_top)
    area = (r_range[1] - r_range[0]) * (y_range[1] - y_range[0])
    spacing, points, names = np.sqrt(area / n_target), None, None
    for _ in range(4):                                # a few rescalings: the section is not all bolt or nut
        r = np.arange(r_range[0] + spacing / 2, r_range[1], spacing)
        y = np.arange(y_range[0] + spacing / 2, y_range[1], spacing)
        grid = np.column_stack([a.ravel() for a in np.meshgrid(r, y)])
        kept, region = np.ones(len(grid), dtype=bool), None
        for space in spaces:
            here = region_at(space, grid, DEPTH)
            region = here if region is None else region
            kept &= (here == region) & (here >= 0)
        wanted = [space.mesh.region_names.index(n) for n in ("bolt", "nut")]
        kept &= np.isin(region, wanted)
        points, names = grid[kept], [spaces[0].mesh.region_names[k] for k in region[kept]]
        if abs(len(points) - n_target) <= 0.03 * n_target:
            break
        spacing *= np.sqrt(len(points) / n_target)
    return points, names


def labels_of(names: list[str]) -> list[str]:
    counts = {"bolt": 0, "nut": 0}
    out = []
    for name in names:
        counts[name] += 1
        out.append(f"{name[0].upper()}{counts[name]}")
    return out


def write_data(path: Path, points: np.ndarray, labels: list[str], values: np.ndarray, note: str) -> None:
    """ux, uy (values (n_stages, 2 n), point-major) with sigma = NOISE as a generic CSV."""
    n_stages, n = values.shape[0], len(points)
    write_measurements(path, Measurements(
        points=tuple(labels) * n_stages, coordinates=np.tile(np.column_stack([points, np.zeros(n)]), (n_stages, 1)),
        stage=np.repeat(np.arange(1, n_stages + 1), n), force=np.repeat(FORCES[:n_stages], n),
        values={q: values[:, k::2].ravel() for k, q in enumerate(QUANTITIES)},
        sigma={q: np.full(n * n_stages, NOISE) for q in QUANTITIES}, comments=(note,)))


#: --merge: the outer and inner part of each axial section share one coefficient ([friction] merge)
MERGE = {"AD": ("A", "D"), "BE": ("B", "E"), "CF": ("C", "F")}


def write_config(out: Path, name: str, flank: float, regions: str, merge: bool = False) -> Path:
    zones = ", ".join(f"{z} = {START}" for z in (MERGE if merge else TRUE_MU))
    merged = ", ".join(f'{m} = {list(parts)!r}'.replace("'", '"') for m, parts in MERGE.items())
    fixed = ", ".join(f"{z} = {v}" for z, v in fixed_friction().items())
    path = out / f"{name}.toml"
    path.write_text(f'# bolt-m20 full field: {name}\n[model]\nbuilder = "bolt"\nsize = "M20"\n'
                    f"forces = {list(FORCES)}\nflank_size = {flank}\n[friction]\nzones = {{ {zones} }}\n"
                    + (f"merge = {{ {merged} }}\n" if merge else "")
                    + f'fixed = {{ {fixed} }}\n[data]\nfile = "{name.removesuffix("_merged")}.csv"\n'
                    f'observables = ["ux", "uy"]\n'
                    f'stages = [1, 2]\nregions = {{ {regions} }}\n'
                    f'[identify]\nmethod = "trf"\njacobian = "analytic"\nmax_iterations = 30\n'
                    f'resolution = {TOLERANCE}\nsuggestions = 0\noptions = {{ {OPTIONS["trf"]} }}\n'
                    f'[run]\ndir = "runs/{name}"\nfields = false\n')
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="coarse meshes (0.25 / 0.15 mm), 100 and 1000 points")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "out" / "full_field")
    parser.add_argument("--merge", action="store_true", help="one coefficient per axial section (A+D, B+E, C+F)")
    parser.add_argument("--sets", type=int, nargs="+", help="identify only these sets (their target sizes, 10 for "
                        "the default points); the data files of a previous run in --out are read, not made again")
    args = parser.parse_args(argv)
    flank, data_flank, sizes = (0.25, 0.15, SIZES[:2]) if args.quick else (0.1, 0.05, SIZES)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    with cache_in(out / "cache"):             # a second run reads the condensations and solves stored there
        return _run(out, flank, data_flank, sizes, args.merge, args.sets)


def _run(out: Path, flank: float, data_flank: float, sizes, merge: bool = False, only=None) -> int:
    start = time.perf_counter()
    layout = bolt_layout("M20")
    options = {"builder": "bolt", "size": "M20", "forces": list(FORCES)}
    model = build_model(ModelSpec.from_table({**options, "flank_size": flank}))
    data_model = build_model(ModelSpec.from_table({**options, "flank_size": data_flank}))
    spaces = [Space.build(m.mesh, m.kind, m.element) for m in (model, data_model)]
    sets = {"10 default": (measurement_points(layout), ["bolt"] * 10)}
    targets = {"10 default": 10}
    for n in sizes:
        points, names = section_grid(spaces, n, layout)
        sets[f"{len(points)}"] = (points, names)
        targets[f"{len(points)}"] = n
        print(f"grid for about {n} points: {len(points)} ({names.count('bolt')} bolt, {names.count('nut')} nut)")
    tags = {name: "points_10" if name.startswith("10 ") else f"points_{len(p)}" for name, (p, _) in sets.items()}
    if only is None or not all((out / f"{tag}.csv").exists() for tag in tags.values()):
        _make_data(out, sets, tags, data_model, data_flank)
    rows = []
    for name, (points, names) in sets.items():
        n, tag = len(points), tags[name]
        if only is not None and targets[name] not in only:
            continue
        regions = '"B*" = "bolt"' + (', "N*" = "nut"' if "nut" in names else "")
        config = read_config(write_config(out, tag + ("_merged" if merge else ""), flank, regions, merge),
                             need=("model", "friction", "data", "run"))
        t = time.perf_counter()
        prefit = {}                                   # the resolution before fitting, at the start values
        result = identify_config(config, on_prefit=lambda report: prefit.update(report.as_dict())).to_dict()
        seconds = time.perf_counter() - t
        before = prefit["stderr"]
        rows.append({"set": name, "n_points": n, "n_bolt": names.count("bolt"), "n_nut": names.count("nut"),
                     "n_obs": result["fit"]["n_obs"], "predicted_stderr": before,
                     "parameters": {z: result["parameters"][z] for z in (MERGE if merge else TRUE_MU)},
                     "reduced_chi2": result["fit"].get("reduced_chi2"), "seconds": seconds})
        print(_line(rows[-1]))
    table = _table(rows, flank, data_flank, merge)
    partial = only is not None and set(targets.values()) - set(only)
    suffix = ("_merged" if merge else "") + ("_" + "-".join(map(str, only)) if partial else "")
    (out / f"table{suffix}.md").write_text(table + "\n")
    (out / f"summary{suffix}.json").write_text(json.dumps({"true": TRUE_MU, "noise_mm": NOISE, "flank": flank,
                                                  "data_flank": data_flank, "rows": rows,
                                                  "wall_time_s": time.perf_counter() - start},
                                                 indent=2, default=float) + "\n")
    print("\n" + table + f"\n\n{time.perf_counter() - start:.0f} s in all; results in {out}")
    return 0


def _resolved(row) -> list[str]:
    return [z for z, p in row["parameters"].items() if p.get("identifiable")]


def _line(row) -> str:
    return (f"{row['set']:>12}: resolved {', '.join(_resolved(row)) or 'none'}; "
            + " ".join(f"{z}={p['value']:.3f}" for z, p in row["parameters"].items()) + f" ({row['seconds']:.0f} s)")


def _make_data(out: Path, sets: dict, tags: dict, data_model, data_flank: float) -> None:
    """ux, uy of every set at both stages from the finer mesh (one condensation for all points), noise added,
    written as <out>/<tag>.csv."""
    every = np.vstack([p for p, _ in sets.values()])
    every_regions = [r for _, names in sets.values() for r in names]
    truth = {**TRUE_MU, **fixed_friction()}
    mu_true = np.array([truth[z] for z in data_model.zone_names])
    t = time.perf_counter()
    exact = EmbeddedBackend(data_model, every, QUANTITIES, every_regions, keep=False).predict(mu_true).values
    print(f"data on the {data_flank:g} mm mesh ({data_model.mesh.n_nodes} nodes) at {len(every)} points: "
          f"{time.perf_counter() - t:.1f} s")
    noisy = exact + np.random.default_rng(SEED).normal(0.0, NOISE, exact.shape)
    offset = 0
    for name, (points, names) in sets.items():
        n = len(points)
        values = noisy[:, 2 * offset:2 * (offset + n)]
        offset += n
        labels = [f"B{k + 1}" for k in range(n)] if tags[name] == "points_10" else labels_of(names)
        write_data(out / f"{tags[name]}.csv", points, labels, values,
                   f"bolt-m20 full field: {n} points, ux, uy from the {data_flank:g} mm mesh at "
                   + ", ".join(f"{z}={v}" for z, v in TRUE_MU.items()) + f", noise {NOISE} mm (seed {SEED})")


def _cell(p: dict) -> str:
    se = p.get("stderr")
    value = f"{p['value']:.3f}" + (f" +- {se:.3f}" if se is not None and np.isfinite(se) else "")
    return value + ("" if p.get("identifiable") else " ?")


def _table(rows, flank: float, data_flank: float, merge: bool = False) -> str:
    zones = list(MERGE if merge else TRUE_MU)
    goal = {m: "/".join(f"{TRUE_MU[z]:.2f}" for z in parts) for m, parts in MERGE.items()} if merge else \
        {z: f"{TRUE_MU[z]:.3f}" for z in zones}
    lines = [f"M20 bolt-nut, ux and uy at 10 and 30 kN with {NOISE * 1000:g} um noise, data from the {data_flank:g} mm "
             f"mesh, identified on the {flank:g} mm mesh from mu = {START}; resolved: standard error <= {TOLERANCE}",
             "",
             "| points (bolt + nut) | observations | resolved | predicted standard error before fitting, "
             + " / ".join(zones) + " | " + " | ".join(zones) + " | time |",
             "|---|---|---|---|" + "---|" * len(zones) + "---|",
             "| goal | | | | " + " | ".join(goal[z] for z in zones) + " | |"]
    for row in rows:
        before = " / ".join("inf" if row["predicted_stderr"].get(z) is None else f"{row['predicted_stderr'][z]:.3g}"
                            for z in zones)
        lines.append(f"| {row['set']} ({row['n_bolt']} + {row['n_nut']}) | {row['n_obs']} | "
                     f"{', '.join(_resolved(row)) or 'none'} | {before} | "
                     + " | ".join(_cell(row["parameters"][z]) for z in zones) + f" | {row['seconds']:.0f} s |")
    lines.append("")
    lines.append("value +- standard error; '?': not identifiable (standard error above the tolerance, or the data "
                 "contradict each other about it); times: one identification (condensation, resolution, fit) on a "
                 "shared machine")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
