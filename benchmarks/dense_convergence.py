"""How converged the dense block reference is: level-to-level differences of its exports in noise levels.

Reads the noise-free exports (``measured.csv``) of tests/fixtures/dense_block/generate.py at several mesh levels of
benchmarks/tilt_ccx.py (same points, same deck, ccx's small-sliding limit) and prints, per stage and per kind
(displacements, strains, machine force), the RMS and the largest difference between consecutive levels in
noise levels (0.5 um, 2e-5, 1 N: generate.py's NOISE_*). Strains are compared where the file has them.

With three levels or more it also estimates the finest level's own error by Richardson extrapolation over the
three finest: the element size is taken as h ~ 1 / n (n the divisions per half side of the footprint, LEVELS;
levels of tilt_ccx.py's graded family are named ``g<k>`` with tilt_ccx.GRADED's flags (a label only here), h ~ 1 / k;
those of its edge-refined family ``e<m>`` (tilt_ccx.EDGE), h the edges' element size 8^-m),
the observed order p per stage and kind from the ratio of the two differences' RMS,

    rms(f_a - f_b) / rms(f_b - f_c) = (h_a^p - h_b^p) / (h_b^p - h_c^p),

and the finest level's error as (f_c - f_b) h_c^p / (h_b^p - h_c^p) per value (its RMS and largest value printed).
The order is searched in [0.25, 4]; an order at a limit is printed as such (the estimate is then only a scale).

    PYTHONPATH=src .venv/bin/python benchmarks/dense_convergence.py g2Qrpc=/tmp/g2Qrpc g3Qrpc=/tmp/g3Qrpc \\
        g4Qrpc=/tmp/g4Qrpc

Each row also gives the changes of the block's rigid motion at the end of the pull, in noise levels: ``slide``
the block faces' mean uy, ``tilt`` the mean uz of the face y = -5 minus that of y = +5 (about x), ``roll`` that of
x = -5 minus x = +5 (about y). With names that are not level numbers (``base=DIR penalty_x10=DIR ...``) every export
after the first is compared with the first (``sink_press`` / ``sink_pull``: the change of the block faces' mean uz at the end of the press /
the pull): variants of the deck on one mesh (contact parameters, increments,
convergence criteria), or levels of different families under names that are no level's (``ring=DIR``), the same
numbers per variant (with ``--where``, by region too). A column that one export lacks (``frictionid simulate``
with displacements only, say) is left out of every comparison. ``--where`` adds, per pair of levels, the end of the pull's
differences by region (block faces by height above the contact edge, plate by distance from the footprint): RMS
in noise levels and share of the kind's sum of squares (also the block faces and the plate pooled).

``--splitting P ref=DIR model=DIR d1=DIR ...``: the discretisation control's splitting estimate of a frictionid
model's error (each directional refinement by 2 exported by ``dense_acceptance.py --at-truth``) against its actual
error, the reference being the first export.

Levels of several graded families (``g2Qrp g3Qrp g4Qrp g2Qrpc g3Qrpc g4Qrpc``: the same k, other flags) are
compared within their family; with two or more families of three levels each, their Richardson limits (per
value, at each family's own order per stage and kind) are compared with each other, and every level with each
family's limit: RMS and largest difference in noise levels. Two families refined differently give two
independent estimates of the limit; their gap is a check of both. ``--order P`` adds each family's limit from
its two finest levels at order P (named ``<family>@<P>``): where a family's three levels give no usable order,
its two finest at another family's order.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

import numpy as np

from _measure import emit

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("dense_generate", ROOT / "tests" / "fixtures" / "dense_block" / "generate.py")
dense = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(dense)
LEVELS = dense.tilt.LEVELS
KINDS = {"u": (slice(0, 3), dense.NOISE_U), "e": (slice(3, 9), dense.NOISE_E)}


def read(folder: Path, name: str = "measured.csv") -> tuple[list[str], np.ndarray, np.ndarray]:
    """(labels, values (2, n, 9) with NaN for empty cells, force (2,)) of an export."""
    lines = [line for line in (folder / name).read_text().splitlines() if not line.startswith("#")]
    rows = [line.split(",") for line in lines[1:]]
    cell = lambda v: float(v) if v else np.nan
    stage = np.array([int(r[4]) for r in rows])
    labels = [r[0] for r in rows if r[4] == "1"]
    values = np.array([[cell(v) for v in (r[6:15] + [""] * 9)[:9]] for r in rows])   # missing columns empty
    force = np.array([float(next(r[5] for r in rows if int(r[4]) == s)) for s in (1, 2)])
    return labels, np.stack([values[stage == 1], values[stage == 2]]), force


def coordinates(folder: Path, name: str = "measured.csv") -> np.ndarray:
    """(n, 3) undeformed point coordinates of an export (stage 1's rows)."""
    lines = [line for line in (folder / name).read_text().splitlines() if not line.startswith("#")]
    return np.array([[float(v) for v in line.split(",")[1:4]] for line in lines[1:] if line.split(",")[4] == "1"])


#: where the differences sit (``--where``): block faces by height above the contact edge, plate by distance from
#: the footprint [mm]
BLOCK_BANDS, PLATE_BANDS = ((0, 1), (1, 2), (2, 4), (4, 10)), ((1, 1.6), (1.6, 2.5), (2.5, 4), (4, 6.6))


def footprint_distance(xyz: np.ndarray) -> np.ndarray:
    """(n,) distance [mm] of points (n, 3) from the 10 x 10 mm footprint in the x-y plane (0 inside it)."""
    return np.hypot(np.maximum(np.abs(xyz[:, 0]) - 5, 0), np.maximum(np.abs(xyz[:, 1]) - 5, 0))


def regions(labels: list[str], xyz: np.ndarray, by_face: bool = False) -> list[tuple[str, np.ndarray]]:
    """(name, mask) per region of the points: the block faces by height above the contact edge (BLOCK_BANDS; each
    face on its own with ``by_face``), the plate by distance from the footprint (PLATE_BANDS)."""
    face = np.array([label.split(":")[0] for label in labels])
    plate = face == "plate"
    faces = sorted(set(face[~plate])) if by_face else [None]
    out = [(f"{'block' if f is None else f} z {a}-{b}", ~plate & (f is None or face == f) & (xyz[:, 2] >= a)
            & (xyz[:, 2] < b)) for f in faces for a, b in BLOCK_BANDS]
    distance = footprint_distance(xyz)
    return out + [(f"plate {a}-{b} mm out", plate & (distance >= a - 1e-9) & (distance < b - 1e-9))
                  for a, b in PLATE_BANDS]


def where(labels: list[str], xyz: np.ndarray, coarse: np.ndarray, fine: np.ndarray) -> list[dict]:
    """Per region of the points, the end of the pull's differences fine - coarse (values (2, n, 9)): RMS in noise
    levels and share of the kind's sum of squares, displacements and strains."""
    rows = []
    plate = np.array([label.startswith("plate:") for label in labels])
    for name, mask in [("block faces", ~plate), ("plate", plate), *regions(labels, xyz)]:
        row = {"region": name, "points": int(mask.sum())}
        for kind, (cols, noise) in KINDS.items():
            d = (fine[1][:, cols] - coarse[1][:, cols]) / noise
            if np.all(np.isnan(d)):                         # a kind one of the exports does not have
                continue
            total, part = np.nansum(d ** 2), d[mask]
            row[f"{kind}_rms"] = round(float(np.sqrt(np.nanmean(part ** 2))), 2)
            row[f"{kind}_share"] = round(float(np.nansum(part ** 2) / total), 3)
        rows.append(row)
    return rows


def in_noise(values: np.ndarray, force: np.ndarray) -> dict[str, list[np.ndarray]]:
    """Per kind, per stage: the observed values in noise levels (flattened, empty cells dropped)."""
    out = {}
    for kind, (cols, noise) in KINDS.items():
        out[kind] = [v[~np.isnan(v)] / noise for v in values[:, :, cols].reshape(2, -1)]
    out["force"] = [np.array([f / dense.NOISE_F]) for f in force]
    return out


def rigid(labels: list[str], values: np.ndarray) -> dict[str, float]:
    """The block's rigid motion at the end of the pull in noise levels: ``slide`` the block faces' mean uy,
    ``tilt`` the mean uz of the face y = -5 minus that of y = +5, ``roll`` x = -5's minus x = +5's; and the block
    faces' mean uz at the end of the press and of the pull (``sink_press``, ``sink_pull``)."""
    face = np.array([label.split(":")[0] for label in labels])
    mean = lambda name, axis: float(np.mean(values[1, face == name, axis]) / dense.NOISE_U)
    sink = lambda stage: float(np.mean(values[stage, face != "plate", 2]) / dense.NOISE_U)
    return {"slide": float(np.mean(values[1, face != "plate", 1]) / dense.NOISE_U),
            "tilt": mean("y-5", 2) - mean("y+5", 2), "roll": mean("x-5", 2) - mean("x+5", 2),
            "sink_press": sink(0), "sink_pull": sink(1)}


def differences(coarse, fine, raw: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """RMS and largest difference fine - coarse per kind and stage, and the slide's change, in noise levels; with
    ``raw`` (the two exports' values (2, n, 9)) also each displacement component's RMS over both stages and all
    points (``ux_rms`` ...: what the per-kind consistency test of a fit sees)."""
    row = {}
    if raw is not None:
        for axis, component in enumerate(("ux", "uy", "uz")):
            d = (raw[1][:, :, axis] - raw[0][:, :, axis]) / dense.NOISE_U
            row[f"{component}_rms"] = round(float(np.sqrt(np.nanmean(d ** 2))), 3)
    for kind in ("u", "e", "force"):
        for s in (0, 1):
            d = fine[1][kind][s] - coarse[1][kind][s]
            if d.size:                                      # empty: a kind one of the exports does not have
                row[f"{kind}{s + 1}_rms"], row[f"{kind}{s + 1}_max"] = round(rms(d), 3), round(float(np.abs(d).max()), 3)
    row.update({k: round(fine[2][k] - coarse[2][k], 3) for k in ("slide", "tilt", "roll", "sink_press", "sink_pull")})
    return row


def splitting(values: list[np.ndarray], labels: list[str], p: float) -> dict:
    """``--splitting``: ``values`` (2, n, 9) of the reference, a model and its directional refinements by 2; the
    model's displacement error against the reference and the splitting extrapolation's estimate of it,
    sum_d (f - f_d) 2^p / (2^p - 1) (the discretisation control's error as given), in noise levels: per
    component RMS over both stages, the block faces' mean uz at the press / the pull (``sink_*``), and the RMS
    left when the estimate is taken off (``*_left``)."""
    reference, model, refined = values[0][:, :, :3], values[1][:, :, :3], [v[:, :, :3] for v in values[2:]]
    actual = (model - reference) / dense.NOISE_U
    estimate = sum(model - f for f in refined) * 2 ** p / (2 ** p - 1) / dense.NOISE_U
    faces = np.array([not label.startswith("plate:") for label in labels])
    row = {"order": p, "directions": len(refined)}
    for name, d in (("actual", actual), ("estimate", estimate), ("left", actual - estimate)):
        for axis, component in enumerate(("ux", "uy", "uz")):
            row[f"{component}_{name}"] = round(rms(d[:, :, axis]), 3)
        row[f"sink_press_{name}"], row[f"sink_pull_{name}"] = (round(float(np.mean(d[s, faces, 2])), 3)
                                                                for s in (0, 1))
    return row


def is_level(name: str) -> bool:
    """A level of tilt_ccx.py's LEVELS ("2") or of its graded family ("g5")."""
    return name.isdigit() or any(family.fullmatch(name) for family in (dense.tilt.GRADED, dense.tilt.EDGE))


def size(name: str) -> float:
    """The element size's scale h ~ 1 / n of a level: n the block's divisions per half side of the footprint (the
    graded family's k); of an edge-refined level ``e<m>`` the edges' element size EDGE_RATIO^-m."""
    graded, edge = dense.tilt.GRADED.fullmatch(name), dense.tilt.EDGE.fullmatch(name)
    if edge:                                                # the edge-refined family: the edges' element size
        return dense.tilt.EDGE_RATIO ** -int(edge.group(1))
    return 1.0 / (int(graded.group(1)) if graded else LEVELS[int(name)][0])


def rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(v ** 2)))


def observed_order(d_ab: float, d_bc: float, h: tuple[float, float, float]) -> tuple[float, str]:
    """Order p with (h_a^p - h_b^p) / (h_b^p - h_c^p) = d_ab / d_bc, by bisection on [0.25, 4]."""
    ratio = lambda p: (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p)
    target = d_ab / d_bc
    lo, hi = 0.25, 4.0
    if target <= ratio(lo):
        return lo, "order at its lower limit (differences not shrinking)"
    if target >= ratio(hi):
        return hi, "order at its upper limit"
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ratio(mid) < target else (lo, mid)
    return 0.5 * (lo + hi), ""


def families(named: list[tuple[str, Path]]) -> dict[str, list[str]]:
    """Level names by family: the graded levels' GRADED flags ("Qrp" of "g3Qrp"), the edge-refined levels' "e"
    and flags ("eQp" of "e2Qp"), "" for the numbered levels."""
    out = {}
    for name, _ in named:
        graded, edge = dense.tilt.GRADED.fullmatch(name), dense.tilt.EDGE.fullmatch(name)
        out.setdefault("e" + edge.group(2) if edge else graded.group(2) if graded else "", []).append(name)
    return out


def richardson(levels: list[dict], h: list[float]) -> tuple[dict, dict]:
    """Of three levels' values in noise levels (in_noise's dicts, coarse to fine) at element sizes h: per kind and
    stage the observed order, the finest level's estimated error (its RMS and largest value) and note; and the
    extrapolated limit (same layout as in_noise's), the finest level plus its estimated error per value."""
    row, limit = {}, {}
    for kind in ("u", "e", "force"):
        limit[kind] = []
        for s in (0, 1):
            fa, fb, fc = (level[kind][s] for level in levels)
            if not fc.size:                                 # a kind the exports do not have
                limit[kind].append(fc)
                continue
            p, note = observed_order(rms(fb - fa), rms(fc - fb), tuple(h))
            error = (fc - fb) * h[2] ** p / (h[1] ** p - h[2] ** p)
            limit[kind].append(fc + error)
            row[f"{kind}{s + 1}"] = {"order": round(p, 2), "error_rms": round(rms(error), 3),
                                     "error_max": round(float(np.abs(error).max()), 3),
                                     **({"note": note} if note else {})}
    return row, limit


def at_order(levels: list[dict], h: list[float], p: float) -> dict:
    """The limit (in_noise's layout) of two levels' values (coarse, fine) at element sizes h, extrapolated at a
    given order p: f_fine + (f_fine - f_coarse) h_fine^p / (h_coarse^p - h_fine^p) per value."""
    coarse, fine = levels
    w = h[1] ** p / (h[0] ** p - h[1] ** p)
    return {kind: [fine[kind][s] + (fine[kind][s] - coarse[kind][s]) * w for s in (0, 1)] for kind in fine}


def gap(one: dict, other: dict) -> dict:
    """RMS and largest difference per kind and stage of two sets of values in noise levels (in_noise's layout)."""
    row = {}
    for kind in ("u", "e", "force"):
        for s in (0, 1):
            d = one[kind][s] - other[kind][s]
            if not d.size:                                  # a kind the exports do not have
                continue
            row[f"{kind}{s + 1}_rms"], row[f"{kind}{s + 1}_max"] = round(rms(d), 3), round(float(np.abs(d).max()), 3)
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("exports", nargs="+", help="level=folder holding that level's measured.csv")
    parser.add_argument("--out", type=Path, help="append the JSON lines here")
    parser.add_argument("--where", action="store_true", help="also where the differences sit (regions of points)")
    parser.add_argument("--splitting", type=float, metavar="P", help="the first export the reference, the second a "
                        "model, the others that model refined by 2 in one direction each: the model's error against "
                        "the reference and the splitting extrapolation's estimate of it at order P (module docstring)")
    parser.add_argument("--order", type=float, help="also each family's limit from its two finest levels at this "
                        "order (e.g. another family's), named '<family>@<order>', in the comparisons of limits")
    args = parser.parse_args(argv)
    named = [(a.split("=", 1)[0], Path(a.split("=", 1)[1])) for a in args.exports]
    exports = {name: read(folder) for name, folder in named}
    # a column one export lacks (displacements only, say) is compared in none
    missing = np.any([np.all(np.isnan(values), axis=(0, 1)) for _, values, _ in exports.values()], axis=0)
    data, raw = {}, {}
    for name, (labels, values, force) in exports.items():
        values[:, :, missing] = np.nan
        data[name] = (labels, in_noise(values, force), rigid(labels, values))
        raw[name] = values
    if any(data[name][0] != data[named[0][0]][0] for name, _ in named):
        sys.exit("the exports do not hold the same points")
    if args.splitting:
        emit(splitting([raw[name] for name, _ in named], data[named[0][0]][0], args.splitting), args.out)
        return 0
    if not all(is_level(name) for name, _ in named):
        base = named[0][0]
        for name, _ in named[1:]:
            emit({"variant": name, "against": base, **differences(data[base], data[name], (raw[base], raw[name]))},
                 args.out)
            if args.where:
                for row in where(data[base][0], coordinates(dict(named)[base]), raw[base], raw[name]):
                    emit({"variant": name, "against": base, **row}, args.out)
        return 0
    h = {name: size(name) for name, _ in named}
    limits = {}
    for family, members in families(named).items():
        order = sorted(members, key=lambda name: -h[name])
        for coarse, fine in zip(order, order[1:]):
            emit({"levels": [coarse, fine], **differences(data[coarse], data[fine])}, args.out)
            if args.where:
                for row in where(data[coarse][0], coordinates(dict(named)[coarse]), raw[coarse], raw[fine]):
                    emit({"levels": [coarse, fine], **row}, args.out)
        if len(order) >= 3:
            row, limits[family] = richardson([data[level][1] for level in order[-3:]], [h[l] for l in order[-3:]])
            emit({"richardson_of_level": order[-1], "from_levels": order[-3:], **row}, args.out)
        if args.order and len(order) >= 2:
            limits[f"{family}@{args.order:g}"] = at_order([data[level][1] for level in order[-2:]],
                                                          [h[l] for l in order[-2:]], args.order)
    if len(limits) >= 2:
        names = list(limits)
        for i, one in enumerate(names):
            for other in names[i + 1:]:
                emit({"limit": one, "against_limit": other, **gap(limits[one], limits[other])}, args.out)
        for name, _ in named:
            for family in names:
                emit({"level": name, "against_limit": family, **gap(data[name][1], limits[family])}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
