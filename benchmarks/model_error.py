"""The discretisation-error estimate (frictionid.inverse.model_error) against the actual error, and its cost.

For a coarse model (mesh h) and an observation set, the estimate comes from the model refined once (h / 2); the
"actual" error is the difference to the finest mesh of the sequence h, h / 2, h / 4, ... (every element size
halved per level by ``builders.registry.refined``). Both are the largest magnitude over two coefficient sets
(a start and a final point, as an identification uses them). Per quantity kind the script prints

- RMS of estimate and actual error in units of the noise, and their ratio (estimate / actual);
- the fraction of observations whose estimate is within a factor 2 of the actual error, counting those whose
  actual error exceeds a tenth of the noise;

for the library's default orders (p = 1 for displacements and the force, capped by the contact edges'
singularity; 1.77 for strains, see frictionid.inverse.model_error) and for two alternatives: the a priori
orders of a smooth solution (k + 1 for u and force, k for strains), and per kind the order observed on the
meshes h, h / 2, h / 4 (RMS of the differences; with only three levels the reference is h / 4 itself).
Timings: the coarse model's build and condensation, a forward and a forward + sensitivity solve, and the
estimate's extra cost (refined build, condensation and two forward solves).

Cases: "block" (3-D block, twin points on the side faces and the plate top, ux uy uz and six strains and the
machine force at stage 2 (pull 0.2 mm); A 0.35 B 0.2 C 0.45 D 0.15, start 0.25), "bolt" (M20, the ten default
DIC points, ux uy and strains, both stages; the demo's coefficients, start 0.1) and "block2d" (plane-strain block,
order 2, pull 0.1 mm, points on the block faces and the base top, ux uy and strains and the machine force).

Run (times with both cores shared with other jobs):
     .venv/bin/python benchmarks/model_error.py block --size 2.5 --levels 3      (3 min, 2 GB)
     .venv/bin/python benchmarks/model_error.py block --size 1.0 --levels 2      (the estimate only: 7 min, 3 GB)
     .venv/bin/python benchmarks/model_error.py bolt --size 0.2 --levels 4       (13 min, 5.4 GB; --levels 3: 2 min)
     .venv/bin/python benchmarks/model_error.py block2d --size 4 --levels 6      (2-4 min, 2.6 GB)
``--identify`` also times an identification on the coarse model with ``identify.model_error = "estimate"`` (data:
the refined model's values at the true coefficients, start as above) and the estimate's share of it.
``--cache DIR`` keeps each level's predictions (.npy) so that a re-run only analyses.
"""

import argparse
import dataclasses
import hashlib
import time
from pathlib import Path

import numpy as np

from _measure import best_of, peak_memory_mb, timed
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.bolt import bolt_layout, fixed_friction, measurement_points
from frictionid.builders.registry import build_model, refined
from frictionid.data.measurements import Measurements
from frictionid.data.table import STRAINS
from frictionid.identification import identify
from frictionid.inverse.model_error import (ELEMENT_ORDER, convergence_orders, estimate_model_error,
                                            observation_kinds, richardson)
from frictionid.inverse.observations import FORCE, Observations
from frictionid.inverse.parameters import Parameters
from frictionid.studies import block as twin
from frictionid.studies.bolt import FORCES, TRUE_MU
from frictionid.options import ModelSpec

#: noise per kind: DIC 0.5 um, strain gauges 2e-5, load cell 1 N (plane strain: N/mm)
SIGMA = {"u": 0.0005, "e": 2e-5, "force": 1.0}
#: observations whose actual error is below this fraction of the noise do not count in the within-2 fraction
COUNT_ABOVE = 0.1


def observations(points, regions, quantities, stages, reactions=()) -> Observations:
    """Observations of ``quantities`` at ``points`` and the ``reactions`` at 1-based ``stages`` (y = 0)."""
    n_q, rows, stage, labels = len(quantities), [], [], []
    for s in stages:
        rows += list(range(len(points) * n_q + len(reactions)))
        stage += [s - 1] * (len(points) * n_q + len(reactions))
        labels += [f"P{p}:{q}@{s}" for p in range(len(points)) for q in quantities] + [f"force@{s}" for _ in reactions]
    obs = Observations(points=np.asarray(points, float), point_regions=tuple(regions), quantities=tuple(quantities),
                       row=np.array(rows), stage=np.array(stage), y=np.zeros(len(rows)), sigma=np.ones(len(rows)),
                       labels=tuple(labels), noise_known=True, reactions=tuple(reactions))
    sigma = np.array([SIGMA[k] for k in observation_kinds(obs)])
    return dataclasses.replace(obs, sigma=sigma)


def block_case(size: float):
    xyz, labels = twin.points()
    regions = ["block" if label.startswith("F") else "plate" for label in labels]
    obs = observations(xyz, regions, ("ux", "uy", "uz", *STRAINS), (2,), ("block_top.y",))
    mus = [np.full(4, 0.25), np.array([0.35, 0.2, 0.45, 0.15])]
    return {"builder": "block", "mesh_size": size}, obs, mus


def bolt_case(size: float):
    points = measurement_points(bolt_layout("M20"))
    obs = observations(points, ["bolt"] * len(points), ("ux", "uy", "exx", "eyy", "ezz", "exy"), (1, 2))
    fixed = fixed_friction()
    zones = ("A", "B", "C", "D", "E", "F", *fixed)
    mus = [np.array([fixed.get(z, 0.1) for z in zones]), np.array([{**TRUE_MU, **fixed}[z] for z in zones])]
    return {"builder": "bolt", "forces": list(FORCES), "flank_size": size}, obs, mus


def block2d_case(size: float):
    face = [(side * 5.0, y) for side in (-1, 1) for y in (0.5, 1.0, 2.0, 3.0, 5.0, 7.0)]
    top = [(x, 0.0) for x in (-16.0, -12.0, -9.0, -7.0, -6.0, 6.0, 7.0, 9.0, 12.0, 16.0)]
    obs = observations(face + top, ["block"] * len(face) + ["base"] * len(top), ("ux", "uy", "exx", "eyy", "exy"),
                       (2,), ("block_top.x",))
    return {"builder": "block2d", "mesh_size": size, "order": 2, "pull": 0.1}, obs, [np.full(2, 0.2),
                                                                                       np.array([0.3, 0.15])]


CASES = {"block": block_case, "bolt": bolt_case, "block2d": block2d_case}


def predictions(options: dict, obs: Observations, mus, cache: Path | None, name: str) -> np.ndarray:
    """(n_mu, n_obs) values on the mesh ``options`` describe, from the cache if there."""
    key = hashlib.sha256(repr((sorted(options.items()), obs.labels, [m.tolist() for m in mus])).encode())
    path = None if cache is None else cache / f"{name}_{key.hexdigest()[:16]}.npy"
    if path is not None and path.exists():
        return np.load(path)
    start = time.perf_counter()
    model = build_model(ModelSpec.from_table(options))
    backend = EmbeddedBackend(model, obs.points, obs.quantities, obs.point_regions, obs.reactions, keep=False)
    values = np.array([obs.predicted(backend.predict(mu).values) for mu in mus])
    print(f"  {options}: {model.mesh.n_nodes} nodes, built, condensed and solved twice in "
          f"{time.perf_counter() - start:.1f} s, peak memory {peak_memory_mb():.0f} MB", flush=True)
    if path is not None:
        np.save(path, values)
    return values


def coarse_run(options: dict, obs: Observations, mus) -> tuple[dict, np.ndarray, object]:
    """Timings of the coarse model (build, condensation, forward, forward + sensitivities) and its values."""
    figures = {}
    with timed(figures, "build"):
        model = build_model(ModelSpec.from_table(options))
    with timed(figures, "condensation"):
        backend = EmbeddedBackend(model, obs.points, obs.quantities, obs.point_regions, obs.reactions)
    figures["forward"], _ = best_of(2, lambda: backend.predict(mus[-1]))
    figures["sensitivities"], _ = best_of(2, lambda: backend.predict(mus[-1], True))
    values = np.array([obs.predicted(backend.predict(mu).values) for mu in mus])
    return figures, values, model


def measurements_of(obs: Observations, values: np.ndarray, forces) -> Measurements:
    """The observations' ``values`` (n_obs,) as a measurement table: one row per point and stage, the reaction
    (if observed) in the force column, else the stage's machine force from ``forces``."""
    n_q, n_p, stages = len(obs.quantities), len(obs.points), sorted(set(obs.stage.tolist()))
    per_stage = n_p * n_q + len(obs.reactions)
    rows = [values[k * per_stage:(k + 1) * per_stage] for k in range(len(stages))]
    labels = [f"P{p}" for p in range(n_p)] * len(stages)
    xyz = np.column_stack([obs.points, np.zeros((n_p, 3 - obs.points.shape[1]))])
    force = [r[n_p * n_q] if obs.reactions else forces[s] for r, s in zip(rows, stages)]
    return Measurements(points=tuple(labels), coordinates=np.tile(xyz, (len(stages), 1)),
                        stage=np.repeat(np.array(stages) + 1, n_p), force=np.repeat(force, n_p),
                        values={q: np.concatenate([r[k:n_p * n_q:n_q] for r in rows])
                                for k, q in enumerate(obs.quantities)},
                        sigma={}, comments=("benchmarks/model_error.py: the refined model's values",))


def identification_cost(options: dict, obs: Observations, mus, fine_values: np.ndarray, forces) -> None:
    """Wall time of an identification on the coarse model with identify.model_error = "estimate" (data: the
    refined model's values at the true coefficients), and the share of it the estimate took."""
    zones = build_model(ModelSpec.from_table(options)).zone_names
    params = Parameters.from_dict({z: float(mus[0][k]) for k, z in enumerate(zones)})
    if "bolt" in options["builder"]:                                   # the head and nut-plate zones are held
        fixed = fixed_friction()
        params = Parameters.from_dict({z: float(mus[0][k]) for k, z in enumerate(zones) if z not in fixed},
                                      fixed=fixed)
    kinds = dict.fromkeys(observation_kinds(obs).tolist())
    noise = {"u": SIGMA["u"], "e": SIGMA["e"], **({"force": SIGMA["force"]} if FORCE in kinds else {})}
    observables = list(obs.quantities) + (["force"] if obs.reactions else [])
    start = time.perf_counter()
    result = identify(options, measurements_of(obs, fine_values, forces), params, observables=observables,
                      stages=sorted({int(s) + 1 for s in obs.stage}), noise=noise,
                      regions={f"P{p}": r for p, r in enumerate(obs.point_regions)}, model_error="estimate")
    seconds = time.perf_counter() - start
    error = result["fit"]["model_error"]
    print(f"  identification (model_error = \"estimate\", {result['n_iterations']} iterations, {result['status']}): "
          f"{seconds:.1f} s, of which the estimate {error['seconds']:.1f} s ({100 * error['seconds'] / seconds:.0f} %)",
          flush=True)


def observed_orders(levels: list[np.ndarray], kinds: np.ndarray) -> dict:
    """Per kind: log2 of the RMS difference ratio of the first three levels (max over mu of |difference|)."""
    d1 = np.abs(levels[0] - levels[1]).max(axis=0)
    d2 = np.abs(levels[1] - levels[2]).max(axis=0)
    return {k: float(np.log2(np.sqrt(np.mean(d1[kinds == k] ** 2)) / np.sqrt(np.mean(d2[kinds == k] ** 2))))
            for k in dict.fromkeys(kinds.tolist())}


def compare(name: str, estimate: np.ndarray, actual: np.ndarray, obs: Observations, kinds: np.ndarray) -> None:
    """Print estimate vs actual per kind: RMS in noise, RMS ratio, fraction within a factor 2."""
    print(f"  {name}")
    for kind in dict.fromkeys(kinds.tolist()):
        m = kinds == kind
        est, act, sig = estimate[m], actual[m], obs.sigma[m]
        counted = act > COUNT_ABOVE * sig
        ratio = est[counted] / act[counted]
        within = np.mean((ratio >= 0.5) & (ratio <= 2.0)) if counted.any() else float("nan")
        every = np.mean((est >= 0.5 * act) & (est <= 2.0 * act))
        rms_e, rms_a = np.sqrt(np.mean((est / sig) ** 2)), np.sqrt(np.mean((act / sig) ** 2))
        print(f"    {kind:5s} n={m.sum():5d}  RMS in noise: estimate {rms_e:9.3f} actual {rms_a:9.3f}  "
              f"ratio {rms_e / rms_a:6.2f}  max in noise {np.max(est / sig):9.2f} / {np.max(act / sig):9.2f}  "
              f"within 2: {within:5.2f} of {counted.sum()} "
              f"(ratio median {np.median(ratio) if counted.any() else float('nan'):.2f}; all {m.sum()}: {every:.2f})")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=sorted(CASES))
    parser.add_argument("--size", type=float, help="coarse element size (block, block2d: mesh_size; bolt: flank_size)")
    parser.add_argument("--levels", type=int, default=3, help="meshes h, h/2, ...; 2: the estimate only")
    parser.add_argument("--cache", type=Path, help="folder for each level's predictions")
    parser.add_argument("--identify", action="store_true",
                        help="also time an identification with the estimate (data: the refined model's values)")
    args = parser.parse_args(argv)
    default = {"block": 2.5, "bolt": 0.2, "block2d": 4.0}[args.case]
    options, obs, mus = CASES[args.case](args.size or default)
    if args.cache:
        args.cache.mkdir(parents=True, exist_ok=True)
    print(f"{args.case}: {obs.n_obs} observations, coarse {options}", flush=True)
    figures, coarse, model = coarse_run(options, obs, mus)
    start = time.perf_counter()
    error = estimate_model_error(ModelSpec.from_table(options), obs, mus, coarse_values=list(coarse), model=model)
    figures["estimate"] = time.perf_counter() - start
    print(f"  coarse: {model.mesh.n_nodes} nodes; build {figures['build']:.2f} s, condensation "
          f"{figures['condensation']:.2f} s, forward {figures['forward']:.3f} s, forward + sensitivities "
          f"{figures['sensitivities']:.3f} s")
    print(f"  estimate (refined {error.refined_options}): build + condensation + 2 forward solves "
          f"{error.seconds:.2f} s (whole call {figures['estimate']:.2f} s) = "
          f"{error.seconds / figures['condensation']:.1f} x the coarse condensation, "
          f"{error.seconds / figures['sensitivities']:.0f} x a forward + sensitivity solve", flush=True)
    print("  estimate in noise: " + ", ".join(f"{name} RMS {v['rms']:.3g} max {v['max']:.3g}"
                                           for name, v in error.summary.items()), flush=True)
    sequence = [options]
    for _ in range(max(args.levels, 2) - 1):
        sequence.append(refined(ModelSpec.from_table(sequence[-1])))
    if args.identify:
        fine = predictions(sequence[1], obs, mus, args.cache, args.case)
        identification_cost(options, obs, mus, fine[-1], {0: FORCES[0], 1: FORCES[1]})
    if args.levels < 3:
        return
    levels = [coarse] + [predictions(o, obs, mus, args.cache, args.case) for o in sequence[1:]]
    kinds = observation_kinds(obs)
    actual = np.abs(levels[0] - levels[-1]).max(axis=0)
    print(f"  actual error: difference to {sequence[-1]}; orders used by default {error.orders}")
    compare("library default", error.estimate, actual, obs, kinds)
    smooth = convergence_orders(ELEMENT_ORDER[model.mesh.cell_type], singular=False)
    for label, orders in (("a priori orders of a smooth solution", smooth),
                          ("observed order per kind (h, h/2, h/4)", observed_orders(levels, kinds))):
        p = np.array([max(orders[k], 0.3) for k in kinds])
        estimate = np.abs(richardson(levels[0], levels[1], p)).max(axis=0)
        compare(f"{label}: " + ", ".join(f"{k} {v:.2f}" for k, v in orders.items()), estimate, actual, obs, kinds)


if __name__ == "__main__":
    main()
