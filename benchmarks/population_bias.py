"""Where one reference of the include mode's population (tests/population_case.py) gets its bias: the fitted family's
actual model error at the truth and the coefficient offset it causes, per mesh size, and fits with a quantity left
out (docs/fit-quality.md, "The include mode over a population of references").

    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/population_bias.py SEED INDEX [--meshes 3,1.5,0.75]
        [--without force,exy] [--replicates 0,2] [--data-factors 1,2,4]

The reference is the population's (``population_case.reference``: its data mesh converged to REFERENCE_ERROR, or
redrawn); with ``--data-factors`` it is the drawn one with its data mesh divided by each factor instead, each set of
data's difference to the finest's printed (RMS and largest per quantity, in noise levels), and each is analysed as
follows. Per mesh size h of the reference's fitted family (its [model] with ``mesh_size`` h): that model's values at
the truth minus the data's (both noise-free, ``frictionid simulate`` at the reference's points), RMS per quantity in
noise levels; the same after the part along the coefficients' sensitivities is taken out (what a fit would leave as
misfit); and the linearised offset of the fitted coefficients, -(J^T J)^-1 J^T delta, with their statistical
standard errors (J by forward differences of 1e-3, weights 1 / sigma). Then each replicate of ``--replicates`` (0:
noise-free) is fitted as the population fits it (``identify_case``), as it is and with each quantity of
``--without`` left out (fits made with ``--without`` or ``--data-factors``): values, standard errors, claims (and
the whole fit's leave-group-out moves, ``fit.shifts``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import _tests  # noqa: E402,F401  (tests/ on the path)
from population_case import clean_data, draw, identify_case, noisy, reference, sigma  # noqa: E402


def values(case: dict) -> tuple[np.ndarray, np.ndarray]:
    """(n_obs,) the case's data-mesh values at its truth in noise levels, and each one's quantity."""
    with tempfile.TemporaryDirectory(prefix="population-bias-") as folder:
        return scaled(clean_data(case, Path(folder)), case)


def scaled(data, case: dict) -> tuple[np.ndarray, np.ndarray]:
    """(n_obs,) ``data``'s values of the case's quantities and stages in noise levels, and each one's quantity."""
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
    parser.add_argument("--data-factors", default="", help="the drawn data mesh divided by these, comma separated")
    args = parser.parse_args(argv)
    for case, clean in references(args.seed, args.index, [int(v) for v in args.data_factors.split(",") if v]):
        print({k: case.get(k) for k in ("attempt", "truth", "model", "data", "data_check", "quantities", "stages",
                                        "u_noise")})
        y, kinds = scaled(clean, case)
        for h in (float(v) for v in args.meshes.split(",") if v):
            print(mesh_bias(case, h, y, kinds))
        if args.without or args.data_factors:
            fits(case, clean, args.seed, [int(v) for v in args.replicates.split(",")], args.without)
    return 0


def references(seed: int, index: int, factors: list[int]) -> list:
    """[(case, noise-free data)]: the population's reference (``reference``), or with ``factors`` the drawn one with
    its data mesh divided by each factor, and each one's difference to the finest (RMS and largest, noise levels)."""
    with tempfile.TemporaryDirectory(prefix="population-bias-") as folder:
        if not factors:
            return [reference(index, seed, Path(folder))]
        drawn = draw(index, seed)
        cases = [dict(drawn, data={**drawn["data"], "mesh_size": drawn["data"]["mesh_size"] / k}) for k in factors]
        out = [(case, clean_data(case, Path(folder))) for case in cases]
    finest = scaled(out[-1][1], cases[-1])[0]
    for case, clean in out:
        v, kinds = scaled(clean, case)
        largest = {q: round(float(np.max(np.abs((v - finest)[kinds == q]))), 3) for q in dict.fromkeys(kinds.tolist())}
        print({"data mesh": case["data"]["mesh_size"], "against": cases[-1]["data"]["mesh_size"],
               "rms": rms(v - finest, kinds), "largest": largest})
    return out


def fits(case: dict, clean, seed: int, replicates: list[int], without: str) -> None:
    """Each replicate fitted as the population fits it, with all quantities and each of ``without`` left out."""
    for replicate in replicates:
        for left in [None] + [q for q in without.split(",") if q]:
            used = dict(case, quantities=[q for q in case["quantities"] if q != left])
            result = identify_case(used, noisy(clean, case, replicate, seed))
            zones = {z: (round(p["value"], 4), None if p["stderr"] is None else round(p["stderr"], 4),
                         p["identifiable"]) for z, p in result["parameters"].items()}
            print({"replicate": replicate, "without": left, "consistent": result["fit"]["consistent"], **zones})
            if left is None:            # the leave-group-out moves of the whole fit, in the check's deviations
                print({"shifts": {group: {z: None if v is None else round(v, 2) for z, v in moved.items()}
                                  for group, moved in result["fit"]["shifts"].items()}})


if __name__ == "__main__":
    sys.exit(main())
