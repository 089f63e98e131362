"""Command line: ``frictionid <command>``; user errors exit 2 without a traceback, run failures exit 1."""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np

from .errors import InputError, SolverError
from .progress import shown


def _add_demo(sub):
    parser = sub.add_parser("demo", help="the M20 bolt-nut study end to end (twin data, identification, report)")
    parser.add_argument("--out", default="frictionid-demo", help="folder for the results (default ./frictionid-demo)")
    parser.add_argument("--quick", action="store_true", help="coarse meshes and few iterations (a smoke test)")
    parser.add_argument("--resume", action="store_true",
                        help="continue (or replay) the identifications stored in the --out folder")
    parser.add_argument("--block", action="store_true",
                        help="instead: one forward solve with sensitivities of the block reference test")
    parser.add_argument("--mesh-size", type=float, default=1.0, help="with --block: block mesh size [mm] (default 1.0)")
    parser.add_argument("--model", choices=("axisymmetric", "3d"), default="axisymmetric",
                        help="the bolt study's model: axisymmetric (default) or 3d (the short M20 with the nut's "
                             "window and jaws; about 30 minutes and 7.5 GB here)")
    parser.set_defaults(run=_run_demo)


def _run_demo(args) -> int:
    if args.model == "3d" and (args.quick or args.block):
        raise InputError(f"frictionid demo --model 3d: {'--quick' if args.quick else '--block'} is not available "
                         "with the 3-D study (it has no coarse variant); run it without, or drop --model 3d")
    if args.block:
        return _run_block_demo(args)
    from .studies.bolt import Settings, run_demo
    from .studies.bolt3d import run_demo_3d

    try:
        if args.model == "3d":
            run_demo_3d(args.out, resume=args.resume, echo=lambda text: print(text, flush=True))
        else:
            run_demo(args.out, Settings.quick() if args.quick else Settings(), resume=args.resume,
                     echo=lambda text: print(text, flush=True))
    except KeyboardInterrupt:
        again = "frictionid demo --resume" + (" --model 3d" if args.model == "3d" else "") + f" --out {args.out}"
        print(f"frictionid: interrupted; every finished evaluation is stored in {args.out}/runs; continue with "
              f"{again}", file=sys.stderr)
        return 1
    return 0


def _run_block_demo(args) -> int:
    from .builders.block import block_model
    from .fem.problem import Problem
    from .report.tables import solution_summary

    start = time.perf_counter()
    model = block_model(mesh_size=args.mesh_size)
    built = time.perf_counter()
    problem = Problem.build(model)
    condensed = time.perf_counter()
    mu = {"A": 0.3, "B": 0.2, "C": 0.4, "D": 0.25}
    solution = problem.solve(mu, sensitivities=True)
    solved = time.perf_counter()
    print(f"Block on a plane (DESIGN.md reference test 1), 3-D, {model.mesh.n_nodes * 3} dofs, "
          f"{problem.pairs.n_pairs} contact pairs")
    print(f"mesh {built - start:.2f} s, condensation {condensed - built:.2f} s, "
          f"forward + sensitivities {solved - condensed:.3f} s ({int(solution.n_newton.sum())} Newton iterations)")
    print(solution_summary(solution))
    return 0


def _add_identify(sub):
    parser = sub.add_parser("identify", help="identify the zone coefficients a config describes")
    parser.add_argument("config", help="TOML config file")
    parser.add_argument("--resume", action="store_true", help="continue an interrupted run from its store")
    parser.set_defaults(run=_run_identify)


def _echo(text: str) -> None:
    print(text, flush=True)


def _run_identify(args) -> int:
    from .config import read_config
    from .identification import identify_config

    config = read_config(args.config, need=("model", "friction", "data", "run"))
    try:
        result = identify_config(config, resume=args.resume, echo=_echo)
    except KeyboardInterrupt:
        print(f"frictionid: interrupted; every finished evaluation is stored in "
              f"{config.resolve(config.run.dir)}; continue with --resume", file=sys.stderr)
        return 1
    print(result.fit_report())
    print(f"results in {result.run_dir}")
    return 0


def _add_simulate(sub):
    parser = sub.add_parser("simulate", help="one forward solve with the [friction] values")
    parser.add_argument("config", help="TOML config file")
    parser.add_argument("--out", required=True, help="measurement CSV to write")
    parser.set_defaults(run=_run_simulate)


def _run_simulate(args) -> int:
    from .config import read_config
    from .simulation import simulate

    config = read_config(args.config, need=("model", "friction", "data"))
    path = simulate(config, args.out, echo=_echo)
    print(f"wrote {path}")
    return 0


def _add_design(sub):
    parser = sub.add_parser("design", help="plan the measurement: predicted standard errors of the planned "
                                           "points, a chosen point set and the zone partition the data resolve")
    parser.add_argument("config", help="TOML config file ([friction] zones: the expected coefficients)")
    parser.add_argument("--points", type=int, help="number of points to choose (default design.points)")
    parser.add_argument("--out", help="folder for design.json, chosen_points.csv, sensitivity.png "
                                      "(default <run.dir>/design)")
    parser.set_defaults(run=_run_design)


def _run_design(args) -> int:
    from .config import read_config
    from .planning import design_config

    config = read_config(args.config, need=("model", "friction", "data", "run"))
    design_config(config, args.points, Path(args.out) if args.out else None, echo=_echo)
    return 0


def _add_check_data(sub):
    parser = sub.add_parser("check-data", help="validate a measurement file (or a config's [data]) and print a "
                                               "summary")
    parser.add_argument("file", help="measurement CSV or DIC export, or a config (.toml): its [data] files as "
                                     "identify reads them, frames and their residuals included")
    parser.add_argument("--format", help="force an export format (docs/data.md); default: recognised")
    parser.add_argument("--strain", help="strain measure where the export does not say it")
    parser.set_defaults(run=_run_check_data)


def _run_check_data(args) -> int:
    from .data.sources import check_config_data, check_data, fits_surface

    if not args.file.endswith(".toml"):
        print(check_data(args.file, args.format, args.strain))
        return 0
    from .builders.registry import build_model
    from .config import read_config

    config = read_config(args.file, need=("data",))
    model = build_model(config.model_spec) if fits_surface(config.data) else None
    print(check_config_data(config.data, config.resolve, config.where, model))
    return 0


def _add_crosscheck(sub):
    parser = sub.add_parser("crosscheck", help="solve a config's model with the embedded backend and CalculiX, "
                                               "and tabulate the differences")
    parser.add_argument("config", help="TOML config file ([model], [friction]; [data] and [solver] optional)")
    parser.add_argument("--out", help="also write the table (markdown) to this file")
    parser.set_defaults(run=_run_crosscheck)


def _run_crosscheck(args) -> int:
    from .config import read_config
    from .crosscheck import cross_check_config
    from .paths import check_file, input_files
    from .report.crosscheck import cross_check_table

    config = read_config(args.config, need=("model", "friction"))
    out = check_file(args.out, input_files(config), "--out") if args.out else None
    with config.naming_keys():
        table = cross_check_table(*cross_check_config(config))
    print(table, end="")
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(table)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``frictionid`` console script."""
    parser = argparse.ArgumentParser(prog="frictionid", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true", help="log solver progress")
    sub = parser.add_subparsers(dest="command", required=True)
    _add_identify(sub)
    _add_simulate(sub)
    _add_check_data(sub)
    _add_demo(sub)
    _add_crosscheck(sub)
    _add_design(sub)
    args = parser.parse_args(argv)
    # -v shows frictionid's own log; the libraries' (scikit-fem, matplotlib, ...) stay at warnings
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    logging.getLogger("frictionid").setLevel(logging.INFO if args.verbose else logging.WARNING)
    np.set_printoptions(precision=4, suppress=True)
    try:
        with shown():                     # progress bars of long loops on stderr
            return args.run(args)
    except InputError as exc:
        print(f"frictionid: error: {exc}", file=sys.stderr)
        return 2
    except SolverError as exc:
        print(f"frictionid: run failed: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
