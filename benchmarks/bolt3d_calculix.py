"""The 3-D bolt-nut tensile test solved by the embedded backend and by CalculiX (the product's own deck writer and
runner) on the same mesh: the seed's ten points (P1-P5 of flanks 1 and 2, 0.1 mm inside the bolt tooth, as
benchmarks/bolt3d.py places them), the machine's side (plate 1's axial displacement at four rim points, the held
plate's reaction) and the contact force per zone, at one mu everywhere and the model's forces.

Run: .venv/bin/python benchmarks/bolt3d_calculix.py '<bolt_model options as JSON>' [model.pkl]
[--factorisation NAME] [--mu 0.15] [--threads 1] [--work DIR] [--stiffness S [S ...]] [--order N [N ...]]
[--flank F]
e.g. '{"size": "M6", "length": 24.0, "engaged_length": 2.0, "thread_length": 9.5, "n_axial": 2,
"flank_size": 1.0, "contact_size": 2.0, "root_size": 0.25, "mesh_size": 3.0, "forces": [1000.0],
"n_increments": 2, "cutout": false, "jaws": false}'. With a second
argument the built model is pickled there, or read from there when it exists. Run it under /usr/bin/time -v for
this process's peak; ccx runs as a child process whose peak it does not count.
"""

import argparse
import copy
import json
import pickle
import time
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb
from bolt3d import layout_of, ten_points
from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
from frictionid.builders.bolt import bolt_model
from frictionid.fem import space
from frictionid.fem.problem import Problem

QUANTITIES = ("ux", "uy", "uz")


def rim_points(layout) -> np.ndarray:
    """(4, 3) [mm] points of plate 1 (the pulled one) at 97 % of its outer radius, mid-thickness, every 90 deg."""
    r, y = 0.97 * layout.r_outer, 0.5 * sum(layout.plate1)
    return np.array([[r * np.cos(t), y, r * np.sin(t)] for t in np.radians([0.0, 90.0, 180.0, 270.0])])


def observed(options: dict) -> tuple[np.ndarray, list[str]]:
    layout = layout_of(options)
    return np.vstack([ten_points(layout), rim_points(layout)]), ["bolt"] * 10 + ["plate1"] * 4


def axial_zone_force(solution, increment: int) -> np.ndarray:
    """(n_zones,) [N] size of the axial (y) component of the contact force on each zone, normal and tangential
    parts summed as vectors (what ccx's *CONTACT PRINT total surface force gives; its "normal force" is the total
    projected on the surface's mean normal, which on a helicoid is not the sum of the normal forces)."""
    lam, frames = solution.lam[increment], solution.pairs.frames
    per_pair = np.einsum("pk,pk->p", lam, frames[:, :, 1])
    return np.abs(per_pair @ solution.pairs.zone_share)


def embedded_result(model, points, regions, mu: float, factorisation: str, order: int | None = None) -> dict:
    """The embedded backend's results at the last stage end: 'embedded' (n_points, 3) [mm] displacements,
    reactions [N], zone normal and axial forces [N], plus timings. ``order``: the tetra10 stiffness's quadrature
    order instead of the product's (2 is the 4-point rule of ccx's C3D10; both are exact on straight-sided cells,
    not on curved ones)."""
    out = {"order": order or space.INTORDER["tetra10"]}
    product = space.INTORDER["tetra10"]
    if out["order"] != product:
        model = copy.deepcopy(model)  # contact_setup keeps the last model's Space (its quadrature) by identity
    space.INTORDER["tetra10"] = out["order"]
    start, cpu = time.perf_counter(), time.process_time()
    try:
        problem = Problem.build(model, points=points, quantities=QUANTITIES, regions=regions,
                                factorisation=factorisation)
        solution = problem.solve(np.full(len(model.zone_names), mu))
    finally:
        space.INTORDER["tetra10"] = product
    out["embedded_seconds"], out["embedded_cpu"] = time.perf_counter() - start, time.process_time() - cpu
    end = solution.stage_end(model.n_stages - 1)
    out["embedded"] = solution.observations[end].reshape(len(points), 3)
    out["embedded_reactions"] = solution.reactions[end]
    out["embedded_zones"] = solution.zone_normal_force[end]
    out["embedded_axial"] = axial_zone_force(solution, end)
    out["n_pairs"] = problem.pairs.n_pairs
    out["labels"] = solution.reaction_labels
    return out


class _EditedBackend(CalculixBackend):
    """The backend with its deck passed through ``edit`` (str -> str) before ccx runs it."""

    def __init__(self, *args, edit, **kwargs):
        super().__init__(*args, **kwargs)
        self._edit = edit

    def deck(self, mu) -> str:
        return self._edit(super().deck(mu))


def ccx_result(model, points, regions, mu: float, settings: CalculixSettings, edit=None) -> dict:
    """ccx's results at the last stage end: 'ccx' (n_points, 3) [mm] displacements, reactions [N], zone normal
    and axial forces [N], its penalty slopes and wall time. ``edit`` (str -> str), if given, changes the deck
    (e.g. its increment control) before ccx runs it."""
    backend = CalculixBackend(model, points, QUANTITIES, regions, settings) if edit is None else \
        _EditedBackend(model, points, QUANTITIES, regions, settings, edit=edit)
    ccx = backend.solve(np.full(len(model.zone_names), mu), full_field=False)
    return {"stiffness": (backend.contact.normal_stiffness, backend.contact.stick_slope, backend.contact.pair_type),
            "ccx_seconds": ccx.wall_time, "ccx": ccx.observations[-1].reshape(len(points), 3),
            "ccx_reactions": ccx.reactions[-1], "ccx_labels": ccx.reaction_labels,
            "ccx_zones": ccx.zone_normal_force[-1],
            "ccx_axial": np.abs(ccx.zone_force[-1, :, 1])}


def penalty_limit(runs: list[dict], key: str) -> np.ndarray:
    """ccx's ``key`` extrapolated to an infinite penalty from the two stiffest runs, by d(k) = d0 + c / k
    (the penalty's compliance adds a penetration proportional to 1 / k)."""
    (k1, a), (k2, b) = sorted((r["stiffness"][0], r[key]) for r in runs)[-2:]
    return (k2 * b - k1 * a) / (k2 - k1)


def report(model, result: dict, ccx: dict, heading: str | None = None) -> None:
    bolt, plate = slice(0, 10), slice(10, 14)
    e, c = result["embedded"], ccx["ccx"]
    if heading is None:
        print(f"  {model.mesh.n_nodes:,} nodes, {result['n_pairs']:,} contact pairs; embedded "
              f"{result['embedded_seconds']:.1f} s ({result['embedded_cpu']:.1f} s CPU), ccx {ccx['ccx_seconds']:.1f}"
              f" s; ccx contact {ccx['stiffness'][2]}, normal / stick slope {ccx['stiffness'][0]:.3g} / "
              f"{ccx['stiffness'][1]:.3g} N/mm^3")
    else:
        print(f"  {heading}")
    print(f"  embedded tetra10 stiffness quadrature order {result['order']}")
    for k, q in enumerate(QUANTITIES):
        span = np.ptp(e[bolt, k])
        worst = np.abs(c[bolt, k] - e[bolt, k]).max()
        print(f"  ten points {q}: embedded {1000 * e[bolt, k].min():.4f} .. {1000 * e[bolt, k].max():.4f} um, range "
              f"{1000 * span:.4f} um; largest |ccx - embedded| {1000 * worst:.4f} um = {100 * worst / span:.2f} % of "
              f"the range ({100 * worst / np.ptp(e[bolt, 1]):.2f} % of uy's)")
    for i in range(10):
        print(f"    flank {i // 5 + 1} P{i % 5 + 1}: uy {1000 * e[i, 1]:.4f} / {1000 * c[i, 1]:.4f} um")
    machine = e[plate, 1].mean(), c[plate, 1].mean()
    print(f"  plate 1 at the rim, mean uy (the machine's displacement): embedded {1000 * machine[0]:.4f} um, ccx "
          f"{1000 * machine[1]:.4f} um ({100 * (machine[1] / machine[0] - 1):+.3f} %)")
    for label, a, b in zip(result["labels"], result["embedded_reactions"], ccx["ccx_reactions"]):
        print(f"  reaction {label}: embedded {a:.3f} N, ccx {b:.3f} N")
    for name, a, b, c, d in zip(model.zone_names, result["embedded_zones"], ccx["ccx_zones"],
                                result["embedded_axial"], ccx["ccx_axial"]):
        print(f"  zone {name}: axial force embedded {c:.2f} N, ccx {d:.2f} N ({100 * (d / c - 1):+.2f} %); normal "
              f"force embedded {a:.2f} N, ccx (on the mean normal) {b:.2f} N")


def main(options: dict, cache: str | None, factorisation: str, mu: float, settings: list[CalculixSettings],
         orders: list[int | None]):
    options = {"model": "3d", **options}
    if cache and Path(cache).exists():
        model = pickle.loads(Path(cache).read_bytes())
    else:
        start = time.process_time()
        model = bolt_model(**options)
        print(f"  build {time.process_time() - start:.1f} s CPU", flush=True)
        if cache:
            Path(cache).write_bytes(pickle.dumps(model))
    print(f"3-D bolt-nut {json.dumps(options)}, mu = {mu} everywhere, embedded ({factorisation}) against ccx",
          flush=True)
    points, regions = observed(options)
    results = [embedded_result(model, points, regions, mu, factorisation, order) for order in orders]
    runs = []
    for each in settings:
        runs.append(ccx_result(model, points, regions, mu, each))
        for result in results:
            report(model, result, runs[-1])
            print(flush=True)
    if len({r["stiffness"][0] for r in runs}) > 1:
        limit = {key: penalty_limit(runs, key) for key in ("ccx", "ccx_reactions", "ccx_zones", "ccx_axial")}
        for result in results:
            report(model, result, {**runs[-1], **limit}, "ccx extrapolated to an infinite penalty from the two "
                   "stiffest runs (d = d0 + c / k):")
    print(f"  peak of this process {peak_memory_mb():.0f} MB (ccx's own is not counted: watch it with ps)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("options")
    parser.add_argument("cache", nargs="?")
    parser.add_argument("--factorisation", default="auto")
    parser.add_argument("--mu", type=float, default=0.15)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--work", default=None, help="keep ccx's work directories in this folder")
    parser.add_argument("--stiffness", type=float, nargs="+", default=[None],
                        help="ccx's normal and stick penalty slopes [N/mm^3], one ccx run each (default: the "
                             "backend's); with two or more, also ccx extrapolated to an infinite penalty")
    parser.add_argument("--order", type=int, nargs="+", default=[None],
                        help="the embedded tetra10 stiffness's quadrature orders, one embedded solve each (default: "
                             "the product's; 2 is ccx's C3D10 rule)")
    parser.add_argument("--flank", type=float, default=None, help="the model's flank_size [mm] (overrides the JSON)")
    arguments = parser.parse_args()
    penalties = [CalculixSettings(threads=arguments.threads, work_dir=arguments.work,
                                  keep_work=arguments.work is not None, timeout=7200, normal_stiffness=k,
                                  stick_slope=k) for k in arguments.stiffness]
    main({**json.loads(arguments.options), **({} if arguments.flank is None else {"flank_size": arguments.flank})},
         arguments.cache, arguments.factorisation, arguments.mu, penalties, arguments.order)
