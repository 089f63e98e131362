"""Are the include mode's intervals calibrated? Coverage over a population of plane-strain references whose model
errors differ (not noise replicates of one reference, where a systematic error is the same in every replicate).

    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/coverage_population.py [N] [--seed S] [--noise K]
        [--first I] [--as-drawn] [--out FILE.jsonl] [--summary FILE.jsonl]

Each reference i (seeded by ``--seed`` and i; tests/population_case.py) draws: 2 or 3 zones with truth coefficients
in [0.1, 0.5], the pull (0.05-0.2 mm) and the pressing force (100-300 N/mm), the block's height (4 or 6 mm), the
fitted mesh (``block2d``, linear triangles of 1, 1.5 or 2 mm, or quadratic ones of 1.5, 2 or 3 mm), the data's mesh
(the same order 6, 8 or 12 times finer, or the other order: quadratic 3 or 6 times finer for a linear fit, linear 12
or 16 times finer for a quadratic one: finer than any mesh the control may choose, whose factors go up to 4, and off
its grid), 16-60 points on the block's sides and the base top, the observed quantities (ux and uy; with the machine
force; with the strains exx, eyy, exy; with exy and the force), the stages (the pull, or both) and the displacement
noise (0.2, 0.5 or 1 um; strains 2e-5, force 0.5 N/mm). The data are the data mesh's solution at the truth
(``frictionid simulate``), the data mesh halved until converged to 0.25 noise levels RMS per quantity or the
reference redrawn (``population_case.reference``; ``--as-drawn``: the first draw, unchecked), plus ``--noise``
seeded noise replicates; each replicate, and the noise-free data, is fitted by ``frictionid.identify`` with the
discretisation control on (refine_target 0.5, the default), ``model_error = "include"`` and ``resolution = 0.05``,
from 0.1 in every zone.

Per fitted zone it records the error (value - truth), the standard error, its systematic part and the parts it is
the largest of (statistics.fit_statistics: the scaled estimate's coefficient shift, how far including the error
moved the fit, the control's remaining error propagated at the orders p and p / 2), the statistical part, the
control's predicted bias (order p, ``discretisation_bias``) against the actual bias (the noise-free fit's value
minus the truth), and whether the zone is claimed. The same fits are also summarised with the systematic part
chosen by other rules (``RULES``, fit_statistics re-evaluated at the fitted point with the rule swapped in, so
their claims are decided as identify would decide them).

Prints one short JSON line per fit (``--out`` keeps the whole record), then per rule: the number of claims (over
the noisy replicates), the coverage of the claimed 95 % intervals with its Clopper-Pearson 95 % range and a range
with the references resampled (a reference's replicates share its systematic error, so they are not independent
trials), the quantiles of |error| / stderr, the claims more than 3 standard errors off, the systematic part over
the statistical one and which measure was the largest; the same coverage for the statistical part alone; and over
the noise-free fits |actual bias| / systematic part, actual / predicted bias and how often it has the predicted
sign. ``--summary FILES`` prints the summary of earlier ``--out`` files without fitting.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from scipy import stats

import frictionid.inverse.statistics as statistics
import frictionid.result as result_module
from frictionid.data.table import Measurements
from frictionid.inverse.discretisation import SCALE_CEILING
from frictionid.inverse.remaining_error import bias

sys.path.insert(0, str(Path(__file__).parent))
import _tests  # noqa: E402,F401  (tests/ on the path)
from _measure import peak_memory_mb  # noqa: E402
from population_case import identify_case, noisy, reference  # noqa: E402

#: the keys of a fit's line printed (``--out`` keeps them all)
BRIEF = ("reference", "replicate", "truth", "value", "stderr", "claimed", "predicted_bias", "consistent", "control",
         "factors", "seconds")


#: the systematic part by rule: (include's two measures kept, the control's part from its biases b_p, b_p/2 at the
#: orders p and p / 2). "shipped": max(scaled shift, moved, |b_p|, |b_p/2|), what identify reports; "control only":
#: max(|b_p|, |b_p/2|); "order p": |b_p|; "p, spread": the order-p bias with the spread between the orders as its
#: uncertainty, hypot(b_p, b_p/2 - b_p); "shipped, p spread": max(scaled shift, moved, that); "include only":
#: max(scaled shift, moved)
RULES = {
    "shipped": (True, lambda b1, bh: np.fmax(np.abs(b1), np.abs(bh))),
    "control only": (False, lambda b1, bh: np.fmax(np.abs(b1), np.abs(bh))),
    "order p": (False, lambda b1, bh: np.abs(b1)),
    "p, spread": (False, lambda b1, bh: np.hypot(b1, bh - b1)),
    "shipped, p spread": (True, lambda b1, bh: np.hypot(b1, bh - b1)),
    "include only": (True, None),
}


@contextmanager
def _swapped(rule, seen: dict):
    """statistics.fit_statistics with the systematic part of ``rule``; records the parts in ``seen``."""
    keep, control = rule
    original_error, original_remaining = statistics.systematic_error, statistics.remaining_systematic

    def systematic_error(scaled_shift, before, after):
        seen["shift"] = np.nan_to_num(np.abs(np.asarray(scaled_shift, dtype=float)), nan=0.0)
        seen["moved"] = np.abs(np.asarray(after, dtype=float) - np.asarray(before, dtype=float))
        return original_error(scaled_shift, before, after) if keep else np.zeros_like(seen["moved"])

    def remaining_systematic(jac, weight, remaining, inner=None):
        b1, bh = bias(jac, weight, remaining.nominal, inner), bias(jac, weight, remaining.slow, inner)
        seen["b1"], seen["bh"] = b1, bh
        part = np.zeros_like(b1) if control is None else np.nan_to_num(control(b1, bh), nan=0.0)
        return b1, part

    statistics.systematic_error, statistics.remaining_systematic = systematic_error, remaining_systematic
    try:
        yield
    finally:
        statistics.systematic_error, statistics.remaining_systematic = original_error, original_remaining


class Recorder:
    """Wraps result.fit_statistics: the shipped statistics for result.json, every rule's on the side."""

    def __init__(self):
        self.original, self.rows = result_module.fit_statistics, {}

    def __call__(self, evaluator, problem, x, resolution, error=None, remaining=None):
        self.rows = {}
        for name, rule in RULES.items():
            seen = {}
            with _swapped(rule, seen):
                fitted = self.original(evaluator, problem, x, resolution, error, remaining)
            unc = fitted.uncertainty
            systematic = np.zeros(len(x)) if fitted.systematic is None else np.asarray(fitted.systematic)
            self.rows[name] = {"stderr": unc.stderr, "systematic": systematic, "ci95": unc.ci95,
                               "claimed": unc.identifiable, "at_bound": unc.at_bound, **seen}
        with _swapped(RULES["shipped"], {}):
            return self.original(evaluator, problem, x, resolution, error, remaining)


def fit(case: dict, data: Measurements, recorder: Recorder) -> dict:
    """The fit's result.json and each rule's record; the shipped rule's claims and intervals are the result's,
    after the profile check of a zone claimed on a bound (made after the statistics the recorder sees)."""
    result = identify_case(case, data)
    names = [chr(ord("A") + k) for k in range(len(case["truth"]))]
    shipped = recorder.rows["shipped"]
    shipped["claimed"] = np.array([result["parameters"][n]["identifiable"] for n in names])
    shipped["ci95"] = np.array([result["parameters"][n]["ci95"] or [np.nan, np.nan] for n in names], dtype=float)
    return {"result": result, "rules": recorder.rows}


def _floats(values) -> list:
    return [None if v is None or not np.isfinite(v) else float(v) for v in np.asarray(values, dtype=float).ravel()]


def row(case: dict, replicate: int, fitted: dict, seconds: float) -> dict:
    result, truth = fitted["result"], np.array(case["truth"])
    names = [chr(ord("A") + k) for k in range(len(truth))]
    params = [result["parameters"][n] for n in names]
    record = result["model"].get("discretisation", {})
    rules = {name: {key: (_floats(v) if key != "ci95" else [_floats(c) for c in v])
                    for key, v in r.items()} for name, r in fitted["rules"].items()}
    return {"reference": case["index"], "attempt": case["attempt"], "data": case["data"],
            "data_check": case["data_check"], "replicate": replicate, "truth": case["truth"],
            "value": [p["value"] for p in params], "stderr": [p["stderr"] for p in params],
            "claimed": [p["identifiable"] for p in params], "predicted_bias": [p.get("discretisation_bias")
                                                                                for p in params],
            "status": result["status"], "consistent": result["fit"]["consistent"],
            "control": record.get("status"), "factors": record.get("factors"),
            "scales": (result["fit"].get("model_error") or {}).get("scales"),
            "rounds": [r.get("status") for r in record.get("at_fitted", [])], "rules": rules,
            "seconds": round(seconds, 1), "peak_mb": round(peak_memory_mb())}


def clopper_pearson(k: int, n: int) -> tuple[float, float]:
    if n == 0:
        return float("nan"), float("nan")
    low = stats.beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
    high = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return float(low), float(high)


#: the measures the shipped systematic part is the largest of, and their keys in a rule's record
PARTS = {"scaled shift": "shift", "moved": "moved", "control at p": "b1", "control at p/2": "bh"}


def clustered(held: list[tuple[int, bool]], n_draws: int = 2000) -> tuple[float, float]:
    """95 % range of the coverage with the references resampled (bootstrap): the replicates of one reference share
    its systematic error, so they are not independent trials (Clopper-Pearson's range treats them as such)."""
    if not held:
        return float("nan"), float("nan")
    by_reference = {}
    for reference, inside in held:
        by_reference.setdefault(reference, []).append(inside)
    counts = np.array([(sum(v), len(v)) for v in by_reference.values()], dtype=float)
    rng = np.random.default_rng(0)
    draws = counts[rng.integers(len(counts), size=(n_draws, len(counts)))].sum(axis=1)
    coverage = draws[:, 0] / draws[:, 1]
    return float(np.quantile(coverage, 0.025)), float(np.quantile(coverage, 0.975))


def summary(rows: list[dict]) -> list[dict]:
    """Per rule: claims, coverage with its range, |error| / stderr, and the statistical part alone."""
    noisy_rows = [r for r in rows if r["replicate"] > 0]
    clean = {r["reference"]: r for r in rows if r["replicate"] == 0}
    out = []
    for name in [name for name in RULES if all(name in r["rules"] for r in rows)]:    # older lines: fewer rules
        z, zs, inside, inside_stat, zones, references, held = [], [], 0, 0, set(), set(), []
        split, largest, ceiling = [], dict.fromkeys(PARTS, 0), []
        for r in noisy_rows:
            rule = r["rules"][name]
            for k, truth in enumerate(r["truth"]):
                if not rule["claimed"][k]:
                    continue
                error, se, sys_ = r["value"][k] - truth, rule["stderr"][k], rule["systematic"][k]
                stat = float(np.sqrt(max(se ** 2 - sys_ ** 2, 0.0)))
                low, high = rule["ci95"][k]
                inside += low <= truth <= high
                held.append((r["reference"], low <= truth <= high))
                if r.get("scales") and max(r["scales"].values()) >= SCALE_CEILING:
                    ceiling.append(low <= truth <= high)
                inside_stat += abs(error) <= 1.959964 * stat
                z.append(abs(error) / se)
                zs.append(abs(error) / stat if stat > 0 else np.inf)
                split.append(sys_ / stat if stat > 0 else np.inf)
                parts = [abs(rule[key][k] or 0.0) for key in PARTS.values()]
                largest[list(PARTS)[int(np.argmax(parts))]] += 1
                zones.add((r["reference"], k))
                references.add(r["reference"])
        n = len(z)
        ratio, actual_over_predicted = [], []
        for ref, r in clean.items():
            rule = r["rules"][name]
            for k, truth in enumerate(r["truth"]):
                actual = r["value"][k] - truth
                if rule["systematic"][k] and not rule["at_bound"][k]:
                    ratio.append(abs(actual) / rule["systematic"][k])
                if r["predicted_bias"][k] and not rule["at_bound"][k]:
                    actual_over_predicted.append(actual / r["predicted_bias"][k])
        quantiles = (lambda a: [round(float(q), 3) for q in np.quantile(a, [0.5, 0.9, 1.0])] if len(a) else [])
        out.append({"rule": name, "claims": n, "zones claimed": len(zones), "references claiming": len(references),
                    "coverage": round(inside / n, 4) if n else None, "coverage 95% range": clopper_pearson(inside, n),
                    "coverage 95% range, references resampled": clustered(held),
                    "|error|/stderr median, 90%, max": quantiles(z), "beyond 3 stderr": int(np.sum(np.array(z) > 3)),
                    "systematic/statistical median, 10%, 90%": ([round(float(q), 3) for q in
                                                                  np.quantile(split, [0.5, 0.1, 0.9])] if n else []),
                    "largest part": largest,
                    "claims with a scale k_q at its ceiling, held": (len(ceiling), int(np.sum(ceiling))),
                    "statistical coverage": round(inside_stat / n, 4) if n else None,
                    "|error|/statistical median, 90%, max": quantiles(zs),
                    "noise-free |bias|/systematic median, 90%, max": quantiles(ratio),
                    "noise-free bias/predicted median, 10%, 90%": ([round(float(q), 3) for q in
                                                                    np.quantile(actual_over_predicted, [0.5, 0.1, 0.9])]
                                                                   if actual_over_predicted else []),
                    "noise-free bias of the predicted sign": (round(float(np.mean(np.array(actual_over_predicted) > 0)),
                                                                    3) if actual_over_predicted else None)})
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("n", type=int, nargs="?", default=30, help="references in the population")
    parser.add_argument("--seed", type=int, default=1, help="the population's seed")
    parser.add_argument("--noise", type=int, default=2, help="noise replicates per reference")
    parser.add_argument("--first", type=int, default=0, help="first reference index")
    parser.add_argument("--out", help="append each fit's JSON line to this file")
    parser.add_argument("--summary", nargs="+", help="no fits: summarise these files' lines")
    parser.add_argument("--as-drawn", action="store_true", help="the references' data meshes as drawn, unchecked")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    if args.summary:
        rows = [json.loads(line) for path in args.summary for line in Path(path).read_text().splitlines() if line]
        for line in summary(rows):
            print(json.dumps(line))
        return 0
    recorder = Recorder()
    result_module.fit_statistics = recorder
    rows = []
    begun = time.perf_counter()
    for index in range(args.first, args.first + args.n):
        with tempfile.TemporaryDirectory(prefix="population-") as folder:
            case, clean = reference(index, args.seed, Path(folder), check=not args.as_drawn)
        for replicate in range(args.noise + 1):
            start = time.perf_counter()
            fitted = fit(case, noisy(clean, case, replicate, args.seed), recorder)
            rows.append(row(case, replicate, fitted, time.perf_counter() - start))
            line = json.dumps(rows[-1])
            print(json.dumps({key: rows[-1][key] for key in BRIEF}), flush=True)
            if args.out:
                with open(args.out, "a") as file:
                    file.write(line + "\n")
    print(json.dumps({"references": args.n, "fits": len(rows), "wall_s": round(time.perf_counter() - begun, 1),
                      "peak_mb": round(peak_memory_mb())}))
    for line in summary(rows):
        print(json.dumps(line))
    return 0


if __name__ == "__main__":
    sys.exit(main())
