"""A population of plane-strain references whose model errors differ, for the include mode's calibration
(tests/test_coverage_population.py, benchmarks/coverage_population.py): per reference the truth, the loads, the
fitted mesh, the data's mesh, the points, the quantities, the stages and the noise are drawn from a seed; the data
are the data mesh's solution at the truth (``frictionid simulate``) plus seeded noise, fitted by
``frictionid.identify`` with the discretisation control on and ``model_error = "include"``. A reference's data mesh
is halved until it differs from its own halving by at most :data:`REFERENCE_ERROR` noise levels RMS per quantity
(:func:`reference`): data whose own discretisation error is a sizeable fraction of the noise are not a reference."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from frictionid import identify
from frictionid.config import config_from_dict
from frictionid.data.measurements import read_measurements
from frictionid.data.table import Measurements
from frictionid.simulation import simulate

QUANTITY_SETS = (("ux", "uy"), ("ux", "uy", "force"), ("ux", "uy", "exx", "eyy", "exy"), ("ux", "uy", "exy", "force"))
NOISE = {"e": 2e-5, "force": 0.5}              # [-], [N/mm]; displacements drawn per reference
START = 0.1
#: identify.resolution: the largest standard error of a claimed zone (tests/test_coverage.py's)
RESOLUTION = 0.05
#: the most a reference's data may differ from its data mesh halved [noise levels RMS per quantity]: half the
#: control's default target (0.5), the finer of the two meshes kept
REFERENCE_ERROR = 0.25
#: the finest data mesh's node spacing (mesh_size / order) [mm]: quadratic 0.094 mm (128k nodes) peaked at 1.4 GB
FINEST_SPACING = 0.045
#: redraws of a reference whose data mesh does not converge above FINEST_SPACING
REDRAWS = 30
#: noise-free data of tests/test_coverage_population.py's references as :func:`clean_data` wrote them (README there)
STORED = Path(__file__).parent / "fixtures" / "population"


def draw(index: int, seed: int, attempt: int = 0) -> dict:
    """Reference ``index`` of the population ``seed`` (its ``attempt``-th redraw): truth, loads, meshes, points,
    quantities, stages, noise."""
    rng = np.random.default_rng([seed, index] if attempt == 0 else [seed, index, 10 ** 6 + attempt])
    n_zones = int(rng.choice([2, 3], p=[0.6, 0.4]))
    order = int(rng.choice([1, 2]))
    mesh = float(rng.choice([1.0, 1.5, 2.0] if order == 1 else [1.5, 2.0, 3.0]))
    # finer than any mesh the control may fit (its factors go up to 4), off its grid
    if rng.random() < 0.7:
        data = {"order": order, "mesh_size": mesh / float(rng.choice([6, 8, 12]))}
    else:
        data = ({"order": 2, "mesh_size": mesh / float(rng.choice([3, 6]))} if order == 1 else
                {"order": 1, "mesh_size": mesh / float(rng.choice([12, 16]))})
    height = float(rng.choice([4.0, 6.0]))
    common = {"builder": "block2d", "n_zones": n_zones, "height": height,
              "pull": round(float(rng.uniform(0.05, 0.2)), 4), "force": round(float(rng.uniform(100.0, 300.0)), 1)}
    side = np.round(rng.uniform(0.25, height - 0.25, int(rng.integers(4, 16)) * 2), 3)
    base = np.round(rng.uniform(5.5, 19.0, int(rng.integers(4, 16)) * 2), 3)
    points = ([(-5.0 if k % 2 else 5.0, y, "block") for k, y in enumerate(side)]
              + [(-x if k % 2 else x, 0.0, "base") for k, x in enumerate(base)])
    return {"index": index, "attempt": attempt, "truth": np.round(rng.uniform(0.1, 0.5, n_zones), 4).tolist(),
            "model": {**common, "order": order, "mesh_size": mesh}, "data": {**common, **data},
            "points": points, "quantities": list(QUANTITY_SETS[int(rng.integers(len(QUANTITY_SETS)))]),
            "stages": [2] if rng.random() < 0.7 else [1, 2], "u_noise": float(rng.choice([2e-4, 5e-4, 1e-3]))}


def stored_data(seed: int, index: int) -> Path:
    """The file of reference ``index`` of the population ``seed`` in :data:`STORED`: what :func:`clean_data` wrote
    for the draw and data mesh tests/test_coverage_population.py's CHOSEN gives it."""
    return STORED / f"seed{seed}_reference{index:02d}.csv"


def clean_data(case: dict, folder: Path) -> Measurements:
    """The data mesh's solution at the truth at the case's points (``frictionid simulate``)."""
    points = folder / "points.csv"
    points.write_text("point,x,y,z,stage\n" + "".join(f"{'P' if r == 'block' else 'Q'}{i + 1},{x},{y},0.0,2\n"
                                                      for i, (x, y, r) in enumerate(case["points"])))
    zones = {chr(ord("A") + k): v for k, v in enumerate(case["truth"])}
    observables = [q for q in case["quantities"] if q != "force"]
    config = config_from_dict({"model": case["data"], "friction": {"zones": zones},
                               "data": {"file": str(points), "observables": observables, "stages": [1, 2],
                                        "regions": regions(case)},
                               "run": {"fields": False}}, need=("model", "friction", "data"), base=folder)
    return read_measurements(simulate(config, folder / "clean.csv"))


def reference(index: int, seed: int, folder: Path | None, check: bool = True,
              chosen: tuple[int, float] | None = None, stored: bool = False) -> tuple[dict, Measurements]:
    """Reference ``index`` of the population ``seed`` and its noise-free data, converged to :data:`REFERENCE_ERROR`
    (:func:`converged`): the first of its draws (attempt 0, then redraws) whose data mesh converges.
    ``case["data_check"]`` records each pair of data meshes compared, and their differences. ``check`` False: the
    first draw with its drawn data mesh, unchecked. ``chosen`` (attempt, data mesh size): the draw and data mesh
    the check chose before (:func:`choices`), not checked again (``data_check`` "stored"); with ``stored`` also its
    data as ``frictionid simulate`` wrote them before (:func:`stored_data`), not solved again."""
    if chosen is not None:
        attempt, size = chosen
        drawn = draw(index, seed, attempt)
        case = dict(drawn, data={**drawn["data"], "mesh_size": size}, data_check="stored")
        return case, read_measurements(stored_data(seed, index)) if stored else clean_data(case, folder)
    if not check:
        drawn = draw(index, seed)
        return dict(drawn, data_check=[]), clean_data(drawn, folder)
    for attempt in range(REDRAWS + 1):
        found = converged(draw(index, seed, attempt), folder)
        if found is not None:
            return found
    raise RuntimeError(f"reference {index} of seed {seed}: no draw of {REDRAWS + 1} converges to {REFERENCE_ERROR}")


def converged(case: dict, folder: Path) -> tuple[dict, Measurements] | None:
    """The case with its data mesh halved until the data of h and h / 2 differ by at most :data:`REFERENCE_ERROR`
    per quantity (RMS over the case's values, in noise levels), the data of h / 2 kept (from 2 h where the drawn h
    halved would be finer than :data:`FINEST_SPACING`, so that the drawn mesh itself may pass); None where h / 2 would
    be finer than that, or where the difference could not reach the tolerance in the halvings left even if it fell
    by 4 in each."""
    order, size = case["data"]["order"], case["data"]["mesh_size"]
    allowed = (lambda h: h / order >= FINEST_SPACING)
    coarse_size = size if allowed(size / 2) else 2 * size
    coarse, checks = clean_data(dict(case, data={**case["data"], "mesh_size": coarse_size}), folder), []
    while allowed(coarse_size / 2):
        finer = dict(case, data={**case["data"], "mesh_size": coarse_size / 2})
        fine = clean_data(finer, folder)
        differences = difference(coarse, fine, case)
        checks.append({"mesh_size": [coarse_size, coarse_size / 2], "rms": differences})
        if max(differences.values()) <= REFERENCE_ERROR:
            return dict(finer, data_check=checks), fine
        left = int(np.floor(np.log2(coarse_size / 2 / order / FINEST_SPACING)))   # further halvings allowed
        if max(differences.values()) / 4.0 ** left > REFERENCE_ERROR:
            return None
        coarse_size, coarse = coarse_size / 2, fine
    return None


def difference(first: Measurements, second: Measurements, case: dict) -> dict:
    """RMS of ``first - second`` per quantity of the case (its stages) [noise levels]."""
    rows = np.isin(first.stage, case["stages"])
    out = {q: float(np.sqrt(np.mean(((first.values[q] - second.values[q])[rows] / sigma(q, case)) ** 2)))
           for q in case["quantities"] if q != "force"}
    if "force" in case["quantities"]:
        stages = [np.flatnonzero(first.stage == stage)[0] for stage in case["stages"]]
        out["force"] = float(np.sqrt(np.mean(((first.force - second.force)[stages] / sigma("force", case)) ** 2)))
    return out


def regions(case: dict) -> dict:
    return {f"{'P' if r == 'block' else 'Q'}{i + 1}": r for i, (x, y, r) in enumerate(case["points"])}


def noisy(clean: Measurements, case: dict, replicate: int, seed: int) -> Measurements:
    """Replicate ``replicate`` (>= 1; 0 is the noise-free data) of the case's data."""
    if replicate == 0:
        return clean
    rng = np.random.default_rng([seed, case["index"], replicate])
    values = {q: v + rng.normal(0.0, sigma(q, case), v.shape) for q, v in clean.values.items()}
    force = clean.force.copy()
    for stage in np.unique(clean.stage):                 # one machine force per stage
        force[clean.stage == stage] += rng.normal(0.0, NOISE["force"])
    return Measurements(clean.points, clean.coordinates, clean.stage, force, values, source="population")


def sigma(quantity: str, case: dict) -> float:
    return case["u_noise"] if quantity.startswith("u") else NOISE["force"] if quantity == "force" else NOISE["e"]


def identify_case(case: dict, data: Measurements) -> dict:
    """result.json of ``data`` fitted as the population fits (from 0.1 in every zone, the control on with its
    default target 0.5, ``model_error = "include"``, resolution :data:`RESOLUTION`)."""
    zones = {chr(ord("A") + k): START for k in range(len(case["truth"]))}
    noise = {"u": case["u_noise"], "e": NOISE["e"], "force": NOISE["force"]}
    used = {k: v for k, v in noise.items() if any(q == k or q.startswith(k) for q in case["quantities"])}
    return identify(case["model"], data, zones, observables=case["quantities"], stages=case["stages"], noise=used,
                    regions=regions(case), fields=False, model_error="include", refine_target=0.5,
                    resolution=RESOLUTION).to_dict()


def choices(seed: int, n: int, folder: Path) -> dict[int, tuple[int, float]]:
    """{index: (attempt, data mesh size)} the check (:func:`reference`) chooses for references 0 to n - 1 of the
    population ``seed``: what ``reference(..., chosen=...)`` takes without checking again."""
    out = {}
    for index in range(n):
        case, _ = reference(index, seed, folder)
        out[index] = (case["attempt"], case["data"]["mesh_size"])
    return out


if __name__ == "__main__":      # python tests/population_case.py SEED N: the choices, as a Python literal
    import sys
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        print(choices(int(sys.argv[1]), int(sys.argv[2]), Path(scratch)))
