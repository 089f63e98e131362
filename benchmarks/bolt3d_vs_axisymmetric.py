"""The 3-D bolt-nut model without window and jaws against the axisymmetric model of the same layout: load share per
engaged thread and bolt elongation (uy averaged over a section at the bolt end minus that over one in the head),
at the same machine force and coefficients, with Sopwith's closed form fitted to each.

uy is averaged over the same sections in both models (discs of 0.9 times the shank's radius, or the root's in the
thread; 4 Gauss radii, 8 angles in 3-D): a point on the axis also carries the section's warping, which the 3-D
cells resolve only roughly (on the axisymmetric M6, from y 3 to 9.8 mm: 1.8280 um on the axis, 1.8199 over the
section, F L / (E A) 1.8195).

The helix's load per engaged thread is counted against the rings cut midway between the axisymmetric model's
flanks (frictionid.report.bolt.pitch_loads, the same cut for both models): per pitch of axial position, and per
turn of the helix by its helical coordinate y - P theta / 2 pi (each turn, seam at theta = +-pi, with the ring it
passes at theta = 0, the axisymmetric section); the helix's part turns below the first cut (down to the nut's
bearing face) and above the last (up to its top) are counted to the first and last thread, and apart.

Run: .venv/bin/python benchmarks/bolt3d_vs_axisymmetric.py '<bolt_model options as JSON>' [model.pkl [factorisation]]
         [--phases N] [--axisymmetric-only] [--axis Y1,Y2,... [--head-radius R]]
(options for both models; the 3-D one gets model = "3d", cutout = false, jaws = false; a second argument as in
benchmarks/bolt3d.py; the third the 3-D model's factorisation, e.g. "mumps"). Run it under
/usr/bin/time -v for the peak. ``--phases N`` also solves the axisymmetric model with its bolt and nut teeth
moved by P theta / 2 pi at N angles theta of the helix (faces, countersinks and the bolt's thread run-out where
they are) and compares the helix per turn with the average of their rings, and each of N sectors of the helix
with the ring model of its centre's phase; ``--axisymmetric-only`` stops before the 3-D model. ``--axis Y1,Y2,...``
instead compares the change of uy's section average between those stations [mm], with ``--phases N`` also against
the ring model averaged over the N phases, ``--head-radius R`` with the ring model's head of radius R [mm]
instead of the hexagon's area-equivalent ring (the hexagon lies between R = s/2 and s/sqrt 3), and
``--axisymmetric-only`` with the ring model alone.
"""

import dataclasses
import json
import sys
import time
from unittest import mock

import numpy as np
from numpy.polynomial.legendre import leggauss

from _measure import peak_memory_mb
from bolt3d import built, layout_of
from frictionid.builders.bolt import bolt_model
from frictionid.builders.thread import ThreadSize, engaged_flanks, nut_bore
from frictionid.fem.problem import Problem
from frictionid.report.bolt import (fit_sopwith, flank_of_pairs, pair_forces, pitch_loads, ring_gap, sopwith_shares,
                                    thread_loads)

MU = 0.15
AXISYMMETRIC_ONLY = ("flank_size", "contact_size", "mesh_size", "root_size", "head_size", "root_refinement",
                     "nut_mesh")


#: the sections averaged: a disc of SECTION_FRACTION of the bolt's radius there (the shank's below the thread's
#: start, the root's above), N_RADII Gauss-Legendre radii weighted by r, N_ANGLES equally spaced angles in 3-D
SECTION_FRACTION, N_RADII, N_ANGLES = 0.9, 4, 8


def section_radius(layout, y: float) -> float:
    """The radius [mm] of the disc averaged at height y: SECTION_FRACTION of the shank's (y below the thread's
    start) or of the bolt's root (d3 / 2 less the profile's shift; above it), so inside the bolt in both models."""
    r = layout.r_shank if y < layout.y_thread else layout.size.d3 / 2 - layout.shift
    return SECTION_FRACTION * r


def elongation_points(layout, dim: int, heights=None) -> tuple[np.ndarray, np.ndarray]:
    """(points (n_heights m, dim), weights (m,) summing to 1): uy at these points, each height's m weighted,
    is the section's average at ``heights`` [mm]; by default the head 0.5 mm below its top face and the bolt end
    0.5 mm inside it. In 2-D (axisymmetric) the angles are one."""
    s = layout.size
    ends = [-s.head_k + 0.5, layout.length - 0.5] if heights is None else heights
    g, w = leggauss(N_RADII)
    fraction = (g + 1) / 2
    angles = 2 * np.pi * (np.arange(N_ANGLES) + 0.5) / N_ANGLES if dim == 3 else np.zeros(1)
    weights = np.repeat(w * fraction, len(angles))
    points = [[r * np.cos(t), y, -r * np.sin(t)][:dim] for y in ends
              for r in section_radius(layout, y) * fraction for t in angles]
    return np.array(points), weights / weights.sum()


def solved(model, layout, dim: int, factorisation: str = "auto", heights=None):
    """(solution, elongation [mm]) at mu = MU: the change of uy's section average (:func:`elongation_points`)
    from the head to the bolt end; with ``heights`` (n,) [mm] the elongation is (n - 1,) its changes between
    consecutive stations instead."""
    start = time.perf_counter()
    points, weights = elongation_points(layout, dim, heights)
    problem = Problem.build(model, points=points, quantities=("uy",), regions=["bolt"] * len(points),
                            factorisation=factorisation)
    built = time.perf_counter() - start
    solution = problem.solve(np.full(len(model.zone_names), MU))
    uy = np.asarray(solution.observations[-1]).reshape(-1, len(weights)) @ weights
    print(f"  {model.kind}: {model.mesh.n_nodes:,} nodes, {problem.pairs.n_pairs:,} contact pairs; condensation "
          f"{built:.1f} s, solve {time.perf_counter() - start - built:.1f} s, peak {peak_memory_mb():.0f} MB",
          flush=True)
    return solution, (float(uy[-1] - uy[0]) if heights is None else np.diff(uy))


def shares_3d(model, solution, y_start: float, pitch: float, n: int) -> dict[str, np.ndarray]:
    """The 3-D model's load per engaged thread, counted four ways against n rings cut at y_start + k P:
    per pitch of axial position and per turn of the helix (helical coordinate y - P theta / 2 pi, the turn in the
    bin of the ring it passes at theta = 0), each with the part below the first cut and above the last counted to
    the first and last thread; per turn with those end parts on their own (n + 2 values: below, the n turns,
    above; shares of the whole) and the n turns alone (shares of their sum; the last is a part turn where the nut's
    top cuts the helix)."""
    ends = pitch_loads(model, solution, y_start - pitch, pitch, n + 2, lead=pitch)
    return {"pitch": pitch_loads(model, solution, y_start, pitch, n),
            "turn": pitch_loads(model, solution, y_start, pitch, n, lead=pitch),
            "turn, ends apart": ends,
            "turns 1-n alone": ends[1:-1] / ends[1:-1].sum()}


def difference(share: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(n,) [%] share minus reference in % of the reference's first share."""
    return 100 * (share - reference) / reference[0]


def pct(values) -> str:
    return np.array2string(100 * np.asarray(values), precision=2)


def rings(options: dict, layout, n_phases: int):
    """The axisymmetric model's side: (model, solution, elongation, y_start, phase average or None)."""
    model2 = bolt_model(**options)
    solution2, elongation2 = solved(model2, layout, 2)
    loads2 = thread_loads(model2, solution2)
    P, n = layout.size.P, loads2.n_threads
    y_start = ring_gap(model2, solution2, P)
    print(f"  {n} rings, cut from y = {y_start:.3f} mm ({(y_start - layout.y_bearing) / P:.2f} P above the nut "
          f"bearing face) by P = {P:g}; per ring [%]: {pct(loads2.share)}; Sopwith fit lam P {loads2.lam_p:.3f}, "
          f"its shares {pct(sopwith_shares(loads2.lam_p, n))}, largest difference "
          f"{np.abs(difference(loads2.share, sopwith_shares(loads2.lam_p, n))).max():.2f} % of the first")
    if not n_phases:
        return model2, solution2, elongation2, y_start, None
    print(f"  axisymmetric models at {n_phases} phases of the teeth (the helix's sections):", flush=True)
    per_phase, lengths = phase_average(options, layout, y_start, n, n_phases)
    print(f"  bolt elongation averaged over the phases {1000 * lengths.mean():.3f} um ({1000 * lengths.min():.3f} to "
          f"{1000 * lengths.max():.3f}), at the layout's phase {1000 * elongation2:.3f} um")
    average, moved_down = per_phase.mean(axis=0), per_phase[:, 0] > 0
    merged = np.r_[average[0] + average[1], average[2:-2], average[-2] + average[-1]]
    lam_p = fit_sopwith(merged)
    print(f"  phase average, below / rings / above [%]: {pct(average)}; ends merged {pct(merged)}, Sopwith fit "
          f"lam P {lam_p:.3f}, largest difference from its shares "
          f"{np.abs(difference(merged, sopwith_shares(lam_p, n))).max():.2f} % of the first")
    moved = np.mean(moved_down)
    closed = sopwith_turns(loads2.lam_p, n, moved)
    print(f"  Sopwith at the rings' lam P {loads2.lam_p:.3f} per turn ({100 * moved:.1f} % of the sections have a "
          f"ring below the first cut, their rings counted one turn down), below / turns / above [%]: {pct(closed)};"
          f" the phase average minus it {pct((average - closed) / (closed[0] + closed[1]))} of its first share "
          f"with the part below")
    return model2, solution2, elongation2, y_start, (average, closed, per_phase, lengths.mean())


def main(options: dict, cache: str | None = None, factorisation: str = "auto", n_phases: int = 0,
         axisymmetric_only: bool = False):
    layout = layout_of(options)
    three = {**options, "model": "3d", "cutout": False, "jaws": False}
    axi = {k: v for k, v in options.items() if k not in AXISYMMETRIC_ONLY}
    print(f"3-D {json.dumps(three)} against the axisymmetric model {json.dumps(axi)}, mu = {MU} everywhere")
    model2, solution2, elongation2, y_start, phases = rings(axi, layout, n_phases)
    if axisymmetric_only:
        return
    model3 = built(three, cache, {})
    solution3, elongation3 = solved(model3, layout, 3, factorisation)
    loads2, loads3 = thread_loads(model2, solution2), thread_loads(model3, solution3)
    P, n, ring = layout.size.P, loads2.n_threads, loads2.share
    print(f"  machine force {loads2.applied:.0f} / {loads3.applied:.0f} N; thread forces sum to "
          f"{loads2.force.sum():.0f} / {loads3.force.sum():.0f} N (axisymmetric / 3-D)")
    print(f"  3-D per turn from the seam opposite theta = 0 [%] ({loads3.n_threads} turns, the first and last "
          f"part turns): {pct(loads3.share)}")
    counted = shares_3d(model3, solution3, y_start, P, n)
    for name, share in counted.items():
        if len(share) == n:
            lam_p = fit_sopwith(share)
            print(f"  3-D {name} [%]: {pct(share)}; minus the rings "
                  f"{np.array2string(difference(share, ring), precision=2)} % of the first ring's share (largest {np.abs(difference(share, ring)).max():.2f}); Sopwith fit "
                  f"lam P {lam_p:.3f}, largest difference from its shares "
                  f"{np.abs(difference(share, sopwith_shares(lam_p, n))).max():.2f} % of the first")
        else:
            print(f"  3-D {name} [%]: below the first cut {100 * share[0]:.2f}, turns {pct(share[1:-1])}, above "
                  f"the last cut {100 * share[-1]:.2f}")
    if phases:
        helix = counted["turn, ends apart"]
        for name, reference in zip(("the phase average", "Sopwith per turn"), phases[:2]):
            first = reference[0] + reference[1]
            print(f"  3-D per turn minus {name}: {pct((helix - reference) / first)} % of its first share with the "
                  f"part below ({100 * first:.2f} %; largest {np.abs(100 * (helix - reference) / first).max():.2f})")
        sectors, part = sector_shares(model3, solution3, y_start, P, n, len(phases[2]))
        print("  3-D per turn in each sector of theta (the sector's part of the thread force) against the phase of "
              "its centre, below / turns / above [%]:")
        for j, (share, ring_share) in enumerate(zip(sectors, phases[2])):
            print(f"    theta {360 * ((j + 0.5) / len(sectors) - 0.5):+7.1f} deg ({100 * part[j]:.2f} %): 3-D "
                  f"{pct(share)}, rings {pct(ring_share)}")
    print(f"  bolt elongation {1000 * elongation2:.3f} / {1000 * elongation3:.3f} um: "
          f"{100 * (elongation3 / elongation2 - 1):+.2f} %")
    if phases:
        print(f"  bolt elongation, the phase average {1000 * phases[3]:.3f} um: 3-D "
              f"{100 * (elongation3 / phases[3] - 1):+.2f} %")


def phase_shifted(layout, delta: float, engaged_length: float):
    """The axisymmetric layout with the bolt's and the nut's teeth moved by ``delta`` [mm] along the axis, faces,
    countersinks and thread run-out kept: the helix's section at theta = 2 pi delta / P. One axial section of
    zones (the coefficients are uniform here)."""
    s = layout.size
    nut_phase, bolt_phase = layout.nut_phase + delta, layout.bolt_phase + delta
    bore = nut_bore(s, layout.y_bearing, layout.y_top, nut_phase, engaged_length)
    flanks = tuple(engaged_flanks(s, bore, nut_phase, bolt_phase, layout.shift, layout.y_thread, layout.length))
    sections = (tuple(range(1, len(flanks) + 1)),)      # one axial section: a part flank may miss a radial zone
    return dataclasses.replace(layout, nut_phase=nut_phase, bolt_phase=bolt_phase, bore=bore, flanks=flanks,
                               sections=sections)


def phase_average(options: dict, layout, y_start: float, n: int, n_phases: int,
                  heights=None) -> tuple[np.ndarray, np.ndarray]:
    """(n_phases, n + 2) the axisymmetric models' load per ring at n_phases sections of a helix (teeth moved by
    delta = P theta / 2 pi, theta = -pi + 2 pi (j + 1/2) / n_phases), each ring counted where its teeth were before
    the move (cut at y_start + delta): the part below the first cut, the n rings, the part above the last; and
    (n_phases,) each one's bolt elongation [mm] (with ``heights``: (n_phases, n_heights - 1) uy's changes between
    the stations, :func:`solved`)."""
    P = layout.size.P
    engaged = options.get("engaged_length") or layout.y_top - layout.y_bearing
    shares, lengths = [], []
    for j in range(n_phases):
        delta = P * ((j + 0.5) / n_phases - 0.5)
        shifted = phase_shifted(layout, delta, engaged)
        with mock.patch("frictionid.builders.bolt.bolt_layout", lambda *args: shifted):
            model = bolt_model(**options)
        solution, elongation = solved(model, layout, 2, heights=heights)
        shares.append(pitch_loads(model, solution, y_start + delta - P, P, n + 2))
        lengths.append(elongation)
        print(f"    phase {delta / P:+.3f} P: {len(shifted.flanks)} rings, below / rings / above [%] "
              f"{np.array2string(100 * shares[-1], precision=2)}, elongation {1000 * np.sum(elongation):.3f} um",
              flush=True)
    return np.array(shares), np.array(lengths)


def sector_shares(model, solution, y_start: float, P: float, n: int, n_sectors: int):
    """(n_sectors, n + 2) the helix's load per turn as :func:`shares_3d`'s "turn, ends apart" in each of n_sectors
    equal sectors of theta from -pi (a share of the sector's thread force), and (n_sectors,) each sector's part
    of the whole thread force."""
    x, _, z = solution.pairs.position.T
    theta = np.mod(np.arctan2(-z, x) + np.pi, 2 * np.pi) - np.pi
    sector = np.minimum(((theta + np.pi) / (2 * np.pi) * n_sectors).astype(int), n_sectors - 1)
    thread = flank_of_pairs(model, solution) > 0
    axial = pair_forces(solution)[:, 1]
    part = np.array([axial[thread & (sector == j)].sum() for j in range(n_sectors)]) / axial[thread].sum()
    shares = [pitch_loads(model, solution, y_start - P, P, n + 2, lead=P, where=sector == j)
              for j in range(n_sectors)]
    return np.array(shares), part


def sopwith_turns(lam_p: float, n: int, moved: float) -> np.ndarray:
    """(n + 2,) Sopwith's n thread shares (report.bolt.sopwith_shares) counted per helical turn (below the first
    cut, n turns, above the last) when a fraction ``moved`` of the helix's sections have their n engaged teeth one
    turn lower (a tooth engaged below the first cut, none in the last turn)."""
    share = sopwith_shares(lam_p, n)
    return (1 - moved) * np.r_[0.0, share, 0.0] + moved * np.r_[share, 0.0, 0.0]


def axis(options: dict, heights: list[float], cache: str | None = None, factorisation: str = "auto",
         n_phases: int = 0, head_radius: float | None = None, axisymmetric_only: bool = False):
    """The change of uy's section average between consecutive ``heights``, both models, at mu = MU; with
    ``n_phases`` also the ring model's averaged over that many phases of its teeth (:func:`phase_average`);
    ``head_radius`` [mm] the ring model's head radius instead of the hexagon's area-equivalent one."""
    three = {**options, "model": "3d", "cutout": False, "jaws": False}
    axi = {k: v for k, v in options.items() if k not in AXISYMMETRIC_ONLY}
    ys, layout = np.asarray(heights, float), layout_of(options)
    radius = ThreadSize.head_radius if head_radius is None else property(lambda size: head_radius)
    with mock.patch.object(ThreadSize, "head_radius", radius):
        model2 = bolt_model(**axi)
        solution2, rings = solved(model2, layout, 2, "auto", ys)
        average = spread = None
        if n_phases:
            y_start = ring_gap(model2, solution2, layout.size.P)
            _, per_phase = phase_average(axi, layout, y_start, thread_loads(model2, solution2).n_threads, n_phases,
                                         ys)
            average, spread = per_phase.mean(axis=0), per_phase
    if axisymmetric_only:
        for k in range(len(ys) - 1):
            line = f"  y {ys[k]:7.2f} -> {ys[k + 1]:7.2f} mm: axisymmetric {1000 * rings[k]:8.4f} um"
            print(line + (f", phase average {1000 * average[k]:.4f} um" if n_phases else ""))
        return
    _, helix = solved(built(three, cache, {}), layout, 3, factorisation, ys)
    for k in range(len(ys) - 1):
        line = (f"  y {ys[k]:7.2f} -> {ys[k + 1]:7.2f} mm: axisymmetric {1000 * rings[k]:8.4f} um, 3-D "
                f"{1000 * helix[k]:8.4f} um, {100 * (helix[k] / rings[k] - 1):+.2f} %")
        if n_phases:
            line += (f"; phase average {1000 * average[k]:.4f} um ({1000 * spread[:, k].min():.4f} to "
                     f"{1000 * spread[:, k].max():.4f}), 3-D {100 * (helix[k] / average[k] - 1):+.2f} %")
        print(line)
    for name, reference in (("axisymmetric", rings), ("phase average", average)):
        if reference is None:
            continue
        print(f"  against the {name}: total {1000 * reference.sum():.4f} um, 3-D {1000 * helix.sum():.4f} um, "
              f"{100 * (helix.sum() / reference.sum() - 1):+.2f} %; from the second station "
              f"{100 * (helix[1:].sum() / reference[1:].sum() - 1):+.2f} %")


def _flag(args: list[str], name: str, convert):
    """(value after ``name`` converted, or None; args without the two)."""
    if name not in args:
        return None, args
    at = args.index(name)
    return convert(args[at + 1]), args[:at] + args[at + 2:]


if __name__ == "__main__":
    args = sys.argv[1:]
    phases, args = _flag(args, "--phases", int)
    heights, args = _flag(args, "--axis", lambda v: [float(y) for y in v.split(",")])
    head_radius, args = _flag(args, "--head-radius", float)
    only = "--axisymmetric-only" in args
    args = [a for a in args if a != "--axisymmetric-only"]
    if heights is not None:
        axis(json.loads(args[0]), heights, *args[1:3], n_phases=phases or 0, head_radius=head_radius,
             axisymmetric_only=only)
    else:
        main(json.loads(args[0]), *args[1:3], n_phases=phases or 0, axisymmetric_only=only)
