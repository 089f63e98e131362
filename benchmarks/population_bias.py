"""Where one reference of the include mode's population (tests/population_case.py) gets its bias: the fitted family's
actual model error at the truth and the coefficient offset it causes, per mesh size, and fits with a quantity left
out (docs/fit-quality.md, "The include mode over a population of references").

    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/population_bias.py SEED INDEX [--meshes 3,1.5,0.75]
        [--without force,exy] [--replicates 0,2]

Per mesh size h of the reference's fitted family (its [model] with ``mesh_size`` h): that model's values at the
truth minus the data's (both noise-free, ``frictionid simulate`` at the reference's points), RMS per quantity in
noise levels; the same after the part along the coefficients' sensitivities is taken out (what a fit would leave
as misfit); and the linearised offset of the fitted coefficients, -(J^T J)^-1 J^T delta, with their statistical
standard errors (J by forward differences of 1e-3, weights 1 / sigma). Then each replicate of ``--replicates``
(0: noise-free) is fitted as the population fits it (``identify_case``) with each quantity of ``--without`` left
out: values, standard errors, claims (and the whole fit's leave-group-out moves, ``fit.shifts``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import _tests  # noqa: E402,F401  (tests/ on the path)
from population_case import clean_data, draw, identify_case, noisy, sigma  # noqa: E402


def values(case: dict) -> tuple[np.ndarray, np.ndarray]:
    """(n_obs,) the case's data-mesh values at its truth in noise levels, and each one's quantity."""
    with tempfile.TemporaryDirectory(prefix="population-bias-") as folder:
        data = clean_data(case, Path(folder))
    columns, kinds = [], []
    for stage in case["stages"]:
        rows = data.stage == stage
        for q in (q for q in case["quantities"] if q != "force"):
            columns.append(data.values[q][rows] / sigma(q, case))
            kinds += [q] * int(rows.sum())
        if "force" in case["quantities"]:
            columns.append(data.force[rows][:1] / sigma("force", case))
            kinds.append("force")
    return np.concatenate(columns), np.array(kinds)


def rms(v: np.ndarray, kinds: np.ndarray) -> dict:
    return {q: round(float(np.sqrt(np.mean(v[kinds == q] ** 2))), 3) for q in dict.fromkeys(kinds.tolist())}


def mesh_bias(case: dict, h: float, y: np.ndarray, kinds: np.ndarray, step: float = 1e-3) -> dict:
    """The mesh h's error at the truth against the data y and the coefficient offset it causes."""
    model = dict(case, data={**case["model"], "mesh_size": h})
    f = values(model)[0]
    jac = np.column_stack([(values(dict(model, truth=[t + step * (i == k) for i, t in enumerate(case["truth"])]))[0]
                            - f) / step for k in range(len(case["truth"]))])
    delta = f - y
    shift = np.linalg.lstsq(jac, delta, rcond=None)[0]
    return {"mesh": h, "error rms": rms(delta, kinds), "left as misfit": rms(delta - jac @ shift, kinds),
            "offset": np.round(-shift, 4).tolist(),
            "statistical stderr": np.round(np.sqrt(np.diag(np.linalg.inv(jac.T @ jac))), 4).tolist()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("seed", type=int)
    parser.add_argument("index", type=int)
    parser.add_argument("--meshes", default="", help="mesh sizes of the fitted family, comma separated")
    parser.add_argument("--without", default="", help="quantities to leave out one at a time, comma separated")
    parser.add_argument("--replicates", default="0", help="replicates to fit without them (0: noise-free)")
    args = parser.parse_args(argv)
    case = draw(args.index, args.seed)
    print({k: case[k] for k in ("truth", "model", "data", "quantities", "stages", "u_noise")})
    y, kinds = values(case)
    for h in (float(v) for v in args.meshes.split(",") if v):
        print(mesh_bias(case, h, y, kinds))
    if not args.without:
        return 0
    with tempfile.TemporaryDirectory(prefix="population-bias-") as folder:
        clean = clean_data(case, Path(folder))
    for replicate in (int(v) for v in args.replicates.split(",")):
        for left in [None] + args.without.split(","):
            used = dict(case, quantities=[q for q in case["quantities"] if q != left])
            result = identify_case(used, noisy(clean, case, replicate, args.seed))
            zones = {z: (round(p["value"], 4), None if p["stderr"] is None else round(p["stderr"], 4),
                         p["identifiable"]) for z, p in result["parameters"].items()}
            print({"replicate": replicate, "without": left, "consistent": result["fit"]["consistent"], **zones})
            if left is None:            # the leave-group-out moves of the whole fit, in the check's deviations
                print({"shifts": {group: {z: None if v is None else round(v, 2) for z, v in moved.items()}
                                  for group, moved in result["fit"]["shifts"].items()}})
    return 0


if __name__ == "__main__":
    sys.exit(main())
