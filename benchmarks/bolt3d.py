"""The 3-D M20 bolt-nut model: build, condensation, forward solve and forward + sensitivities (to every zone, and
to the thread's zones alone, what a fit holding the bearings asks), with the sizes that
set the dense condensation's cost (contact pairs n_c, contact dofs n_w = 3 n_c, the dofs the contact and
observation rows touch, which the Schur complement is taken onto); with ``--factorisation mumps`` each body's
MUMPS factorisation (ordering, factor entries, MUMPS's memory, Schur complement size, time).

Run: .venv/bin/python benchmarks/bolt3d.py '<bolt_model options as JSON>' [model.pkl] [--factorisation NAME]
e.g. '{"model": "3d", "engaged_length": 5.0, "thread_length": 30.5, "n_axial": 2, "flank_size": 1.25,
"contact_size": 2.5, "forces": [10000.0], "n_increments": 2}'. With a second argument the built model is pickled
there, or read from there when it exists (the build takes minutes). Run it under /usr/bin/time -v for the peak.

``--central A D`` then checks the sensitivities of the observations and reactions to those zones against central
differences (step 1e-4) at the end of the load path.

``--phases`` profiles the build, Problem.build, the forward solve and forward + sensitivities (cProfile with the
process's CPU time as its clock, benchmarks/_phases.py) and prints the CPU time of each phase and its share.

``--orderings scotch pord metis amd`` instead condenses the model once per MUMPS ordering, each in a process of its
own (its peak is its own; the inputs of the condensation are assembled once and handed over in a file), and prints
the condensation's wall and CPU time and peak per ordering; no load path.

"""

import argparse
import contextlib
import json
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb, timed
from _phases import Phases
from frictionid.builders.bolt import bolt_layout, bolt_model
from frictionid.builders.bolt3d import measurement_points_3d
from frictionid.fem.problem import Problem


def ten_points(layout) -> np.ndarray:
    """(10, 3) [mm] the seed's P1-P5 on flanks 1 and 2, moved 0.1 mm radially into the bolt tooth: the tets are
    straight-sided, the points on the exact helicoid lie up to a few um outside the mesh's chords."""
    return measurement_points_3d(layout, depth=0.1)


def built(options: dict, cache: str | None, figures: dict):
    if cache and Path(cache).exists():
        figures["build"] = float("nan")
        return pickle.loads(Path(cache).read_bytes())
    with timed(figures, "build"):
        model = bolt_model(**options)
    if cache:
        Path(cache).write_bytes(pickle.dumps(model))
    return model


def layout_of(options: dict):
    """The layout of :func:`frictionid.builders.bolt.bolt_model` with these options."""
    return bolt_layout(options.get("size", "M20"), options.get("length"), options.get("engaged_length"),
                       options.get("clearance"), options.get("n_radial", 2), options.get("n_axial", 3),
                       options.get("bearing_diameter"), options.get("thread_length"))


def observed(options: dict) -> dict:
    points = ten_points(layout_of(options))
    return {"points": points, "quantities": ("ux", "uy", "uz"), "regions": ["bolt"] * len(points)}


def body_lines(condensed) -> list[str]:
    """One line per body of a MUMPS condensation (fem/mumps_schur.py's Statistics)."""
    bodies = getattr(condensed.inverse, "bodies", None)
    if bodies is None:
        return []
    return [f"    body of {len(dofs):,} dofs: Schur complement onto {s.schur_size:,}, {s.ordering} ordering, "
            f"{s.factor_entries / 1e6:.1f} M factor entries, MUMPS {s.used_mb:,} MB (estimated {s.estimated_mb:,}),"
            f" {s.flops / 1e9:.0f} GFlop, {s.seconds:.1f} s ({s.cpu_seconds:.1f} s CPU)"
            for dofs, s in zip(bodies.dofs, bodies.stats)]


def central_differences(problem, mu: np.ndarray, solution, zones: list[str], names, step: float = 1e-4):
    """Print the largest difference between the analytic sensitivities at the last increment and central
    differences, per zone, for the observations [mm] and the reactions [N]."""
    for zone in zones:
        z = list(names).index(zone)
        e = np.zeros_like(mu)
        e[z] = step
        up, down = problem.solve(mu + e), problem.solve(mu - e)
        for what, unit in (("observations", "mm"), ("reactions", "N")):
            analytic = getattr(solution, f"d_{what}")[-1][:, z]
            central = (getattr(up, what)[-1] - getattr(down, what)[-1]) / (2 * step)
            print(f"  zone {zone}: d {what} / d mu: largest |analytic| {np.abs(analytic).max():.3e} {unit}, largest "
                  f"|analytic - central| {np.abs(analytic - central).max():.3e} {unit}", flush=True)


def main(options: dict, cache: str | None = None, factorisation: str = "auto", central: list[str] = (),
         phases: Phases | None = None):
    figures = {}
    options = {"model": "3d", **options}
    part = phases.part if phases is not None else lambda name: contextlib.nullcontext()
    with part("build"):
        model = built(options, cache, figures)
    print(f"3-D M20 bolt-nut {json.dumps(options)}: {model.mesh.n_nodes:,} nodes, {3 * model.mesh.n_nodes:,} dofs;"
          f" build {figures['build']:.1f} s, peak so far {peak_memory_mb():.0f} MB", flush=True)
    start_cpu = time.process_time()
    with timed(figures, "condense"), part("Problem.build"):
        problem = Problem.build(model, factorisation=factorisation, **observed(options))
    cpu = time.process_time() - start_cpu
    n_pairs = problem.pairs.n_pairs
    print(f"  contact pairs n_c = {n_pairs:,}, contact dofs n_w = {3 * n_pairs:,}: dense W {72 * n_pairs ** 2 / 1e9:.2f}"
          f" GB; assembly + condensation ({factorisation}) {figures['condense']:.1f} s ({cpu:.1f} s CPU), peak so far "
          f"{peak_memory_mb():.0f} MB", flush=True)
    print("\n".join(body_lines(problem.condensed)), flush=True)
    mu = np.full(len(model.zone_names), 0.15)
    start, cpu = time.perf_counter(), time.process_time()
    with part("forward"):
        forward = problem.solve(mu)
    figures["forward"], forward_cpu = time.perf_counter() - start, time.process_time() - cpu
    start, cpu = time.perf_counter(), time.process_time()
    with part("forward + sensitivities"):
        solution = problem.solve(mu, sensitivities=True)
    figures["sensitivities"], sensitivities_cpu = time.perf_counter() - start, time.process_time() - cpu
    print(f"  forward {figures['forward']:.1f} s ({forward_cpu:.1f} s CPU, {forward.n_newton.sum()} Newton "
          f"iterations), forward + sensitivities {figures['sensitivities']:.1f} s ({sensitivities_cpu:.1f} s CPU), "
          f"peak {peak_memory_mb():.0f} MB", flush=True)
    # what a fit of the thread's zones asks (the seed's study holds the head and nut bearings)
    thread = [k for k, z in enumerate(model.zone_names) if z not in ("head_plate", "nut_plate")]
    start, cpu = time.perf_counter(), time.process_time()
    with part("forward + thread zones' sensitivities"):
        problem.solve(mu, sensitivities=thread)
    print(f"  forward + sensitivities to the {len(thread)} thread zones of {len(mu)}: "
          f"{time.perf_counter() - start:.1f} s ({time.process_time() - cpu:.1f} s CPU)", flush=True)
    if phases is not None:
        print(phases.table(kinds={"forward": "solve", "forward + sensitivities": "solve",
                                  "forward + thread zones' sensitivities": "solve"}), flush=True)
    central_differences(problem, mu, solution, central, model.zone_names)


def condense_once(inputs: str, ordering: str) -> dict:
    """Condense the pickled inputs with MUMPS in ``ordering`` (this process); its figures."""
    from frictionid.fem import mumps_schur
    from frictionid.fem.condense import condense
    mumps_schur.ORDERING = ordering
    args = pickle.loads(Path(inputs).read_bytes())
    start, cpu = time.perf_counter(), time.process_time()
    condensed = condense(*args, factorisation="mumps")
    return {"seconds": time.perf_counter() - start, "cpu": time.process_time() - cpu, "peak_mb": peak_memory_mb(),
            "bodies": body_lines(condensed)}


def orderings(options: dict, cache: str | None, names: list[str]):
    from frictionid.fem import problem as problem_module

    class Captured(Exception):
        pass

    def capture(*args, **kwargs):
        raise Captured(args)

    options = {"model": "3d", **options}
    model = built(options, cache, {})
    original, problem_module.condense = problem_module.condense, capture
    try:
        Problem.build(model, **observed(options))
    except Captured as captured:
        args = captured.args[0]
    finally:
        problem_module.condense = original
    print(f"3-D M20 bolt-nut {json.dumps(options)}: {model.mesh.n_nodes:,} nodes, {args[0].shape[0]:,} dofs, "
          f"n_w = {args[1].shape[0]:,}; MUMPS condensation per ordering, one process each", flush=True)
    del model
    with tempfile.TemporaryDirectory() as folder:
        inputs = f"{folder}/inputs.pkl"
        Path(inputs).write_bytes(pickle.dumps(args, protocol=5))
        del args
        for name in names:
            out = subprocess.run([sys.executable, __file__, "--condense-once", inputs, name], capture_output=True,
                                 text=True, check=True, timeout=7200)
            result = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"  {name}: condensation {result['seconds']:.1f} s ({result['cpu']:.1f} s CPU), process peak "
                  f"{result['peak_mb']:.0f} MB (with the inputs)\n" + "\n".join(result["bodies"]), flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("options", nargs="?")
    parser.add_argument("cache", nargs="?")
    parser.add_argument("--factorisation", default="auto")
    parser.add_argument("--orderings", nargs="+")
    parser.add_argument("--central", nargs="+", default=[])
    parser.add_argument("--phases", action="store_true")
    parser.add_argument("--condense-once", nargs=2, help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    if arguments.condense_once:
        print(json.dumps(condense_once(*arguments.condense_once)))
    elif arguments.orderings:
        orderings(json.loads(arguments.options), arguments.cache, arguments.orderings)
    else:
        main(json.loads(arguments.options), arguments.cache, arguments.factorisation, arguments.central,
             Phases() if arguments.phases else None)
