"""The block's tilt at the truth in CalculiX on its own graded, non-matching meshes (issue 31): mesh, penalty, slide.

Reference test 1 (block on a plate, A 0.35, B 0.20, C 0.45, D 0.15, 20 MPa, pull 0.2 mm) written as a ccx deck by
tests/fixtures/independent_block/generate.py's deck writer (no frictionid mesh or deck), on tensor-product meshes
made here: every half side of the footprint divided by ``1 - cos`` spacing (elements smallest at the footprint's
edges and at the zone borders x, y = 0), the block with ``n`` and the plate under it with ``n + 1`` divisions
per half side (so the interface does not match, except on the lines x, y = 0, +-5); the plate outside the
footprint growing by 1.5 per element; both bodies' layers smallest at the interface. ``--mesh`` gives such a
mesh by its LEVELS fields; ``--graded K`` a level of a family whose lines are fixed maps of uniform grids
(:func:`graded_lines`), ``--quadratic-block`` its block in C3D20R, ``--quadratic`` both bodies, ``--ring`` the plate
outside the footprint by :func:`ring_map`, ``--cubic`` the same lines graded with exponent 3 (edges ~ n^-3
instead of n^-2); ``--edge M`` level m of the edge-refined family instead (:func:`edge_lines`: a fixed coarse mesh
whose elements next to the footprint's edges and the interface are split geometrically); ``--slave plate`` the
plate top as the contact's slave instead of the block bottom (tests/fixtures/dense_block/README.md compares them).

Printed per run (one line each, also appended as JSON to ``--out``): nodes, ccx seconds, increments, and at the
end of the pull

- tilt: uz(x = 0, y = -5, z = 5) - uz(x = 0, y = +5, z = 5) [um] (linear in z between the two nearest layers);
- N_A, N_B: normal contact force of the rear zones [N] (``*CONTACT PRINT`` CF);
- uy at (x = +-5, y = 0, z = 1) [um], and the machine force [N].

``--scale 0.01`` runs ccx at 1 % of the pressure and the pull and multiplies its results by 100: ccx's
small-sliding limit (docs/calculix.md). Run (one thread, niced):

    OMP_NUM_THREADS=1 nice .venv/bin/python benchmarks/tilt_ccx.py --level 1 --scale 0.01 --work /tmp/tilt/l1s
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import _tests  # noqa: F401  (tests/ importable)
from _measure import emit
from fixtures.independent_block import generate as gen
from frictionid.backends.calculix.parse import read_dat, read_frd


#: mesh levels: divisions per half side (block; the plate gets one more), block layers, plate layers, the
#: first block / plate layer [mm]
LEVELS = {1: (4, 8, 5, 0.4, 0.3), 2: (5, 10, 6, 0.3, 0.25), 3: (6, 12, 7, 0.25, 0.2), 4: (8, 16, 9, 0.19, 0.15)}
GROWTH = 1.5


def half_side(n: int) -> np.ndarray:
    """Node positions on [0, 5] with ``1 - cos`` spacing: smallest elements at 0 and at 5."""
    return 2.5 * (1.0 - np.cos(np.pi * np.arange(n + 1) / n))


def cubic_half_side(n: int) -> np.ndarray:
    """Node positions on [0, 5] graded with exponent 3 at both ends: 5 t^3 / (t^3 + (1 - t)^3) of a uniform t, so
    the elements at 0 and at 5 are about 5 / n^3 (``1 - cos``: about 12 / n^2), those in the middle 3x the
    average."""
    t = np.arange(n + 1) / n
    return 5.0 * t ** 3 / (t ** 3 + (1.0 - t) ** 3)


def cubic_start(t: np.ndarray) -> np.ndarray:
    """[0, 1] -> [0, 1] graded with exponent 3 at 0 (h ~ a t^3, a = 3.72): the twin of 1 - cos(pi t / 2) with the
    same slope pi / 2 and zero curvature at t = 1, but first element ~ n^-3 instead of n^-2. The quintic
    a t^3 + b t^4 + c t^5 with c = 3 (2 - pi / 2), b = -1 - 7 c / 3, a = 1 - b - c; h' > 0 on (0, 1]."""
    t = np.asarray(t, float)
    c = 3.0 * (2.0 - np.pi / 2)
    b = -1.0 - 7.0 * c / 3.0
    a = 1.0 - b - c
    return a * t ** 3 + b * t ** 4 + c * t ** 5


def footprint_lines(n: int, cubic: bool = False) -> np.ndarray:
    s = cubic_half_side(n) if cubic else half_side(n)
    return np.unique(np.round(np.concatenate([-s[::-1], s]), 12))


def plate_lines(n: int) -> np.ndarray:
    inner = footprint_lines(n)
    edge = inner[-1] - inner[-2]
    grow = gen.geometric(edge * GROWTH, GROWTH, 20.0 - 5.0)
    right = 5.0 + np.cumsum(grow)
    return np.unique(np.round(np.concatenate([-right[::-1], inner, right]), 12))


#: C3D20 nodes as offsets in a quadratic grid's node indices from an element's first corner (ccx's numbering:
#: corners as C3D8, then the bottom face's edges, the top face's, the vertical ones)
C3D20 = ((0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 2), (2, 0, 2), (2, 2, 2), (0, 2, 2),
         (1, 0, 0), (2, 1, 0), (1, 2, 0), (0, 1, 0), (1, 0, 2), (2, 1, 2), (1, 2, 2), (0, 1, 2),
         (0, 0, 1), (2, 0, 1), (2, 2, 1), (0, 2, 1))


class QuadraticGrid(gen.Grid):
    """A structured body of 20-node hexahedra (C3D20 / C3D20R) on the element lines xs, ys, zs: its node lines
    are those and their midpoints; ``ids`` (the node lines' tensor grid) holds 0 where no element has a node (face
    and element centres). ``shape``, ``ijk``, ``eids`` and ``centres`` are the element grid's, as Grid's."""

    def __init__(self, xs, ys, zs, first_node: int, first_element: int, element: str = "C3D20R"):
        super().__init__(xs, ys, zs, first_node=first_node, first_element=first_element)
        mid = lambda v: np.sort(np.concatenate([v, 0.5 * (v[1:] + v[:-1])]))
        self.xs, self.ys, self.zs = mid(self.xs), mid(self.ys), mid(self.zs)
        X, Y, Z = np.meshgrid(self.xs, self.ys, self.zs, indexing="ij")
        I, J, K = np.meshgrid(*(np.arange(len(v)) for v in (self.xs, self.ys, self.zs)), indexing="ij")
        used = (I % 2 + J % 2 + K % 2) <= 1
        self.ids = np.zeros(X.shape, int)
        self.ids[used] = first_node + np.arange(used.sum())
        self.points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
        corner = 2 * self.ijk
        self.cells = np.column_stack([self.ids[corner[:, 0] + a, corner[:, 1] + b, corner[:, 2] + c]
                                      for a, b, c in C3D20])
        self.element = element

    @property
    def n_nodes(self) -> int:
        return int(np.count_nonzero(self.ids))


def mesh_spec(text: str) -> tuple:
    """A mesh given as ``n,block_layers,plate_layers,first_block_layer,first_plate_layer`` (LEVELS' fields)."""
    n, nbz, npz, hb, hp = text.split(",")
    return int(n), int(nbz), int(npz), float(hb), float(hp)


def ring_map(t: np.ndarray, cubic: bool = False) -> np.ndarray:
    """The plate outside the footprint for ``--ring``: [0, 1] -> [5, 20], 5 + 5.5 (1 - cos(pi t / 1.2)) up to
    t = 0.6 (x = 10.5: the DIC points' region, its elements smallest at the footprint's edge and growing to about
    twice the average), then quadratic to 20 with a continuous slope (the far plate, coarse). ``cubic``: the first
    piece 5 + 5.5 cubic_start(t / 0.6) (same value, slope and curvature at t = 0.6, so the same far piece)."""
    t = np.asarray(t, float)
    slope = 5.5 * np.pi / 1.2                                   # d/dt of the first piece at t = 0.6
    s = t - 0.6
    far = 10.5 + slope * s + (9.5 - slope * 0.4) / 0.16 * s ** 2
    near = cubic_start(np.minimum(t, 0.6) / 0.6) if cubic else 1.0 - np.cos(np.pi * t / 1.2)
    return np.where(t <= 0.6, 5.0 + 5.5 * near, far)


def graded_lines(k: int, ring: bool = False, cubic: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(plate lines in x and y, plate z, block z) of graded family level ``k``: every line a fixed map of a uniform
    grid whose number of intervals is proportional to k, so that the levels are uniform refinements in the mapped
    coordinates. Footprint half sides ``1 - cos`` (k + 1 divisions in the plate; the block's are k); the plate
    outside the footprint 5 + 15 t^2 (k + 2 elements per side), or with ``ring`` :func:`ring_map` (k + 3 elements
    per side, about k of them where the DIC points are); the plate's k + 1 layers and the block's 2k
    graded towards the interface as 1 - cos(pi t / 2), so the footprint's edges are refined quadratically in
    both directions of the section across them. ``cubic``: the same numbers of elements graded with exponent 3
    instead (cubic_half_side, ring_map's cubic start, cubic_start for the layers): the footprint's edges, the
    zone borders and the interface refined cubically."""
    t = lambda m: np.arange(m + 1) / m
    outside = ring_map(t(k + 3), cubic)[1:] if ring else 5.0 + 15.0 * t(k + 2)[1:] ** 2
    inner = footprint_lines(k + 1, cubic)
    xy = np.unique(np.round(np.concatenate([-outside[::-1], inner, outside]), 12))
    layers = cubic_start if cubic else lambda v: 1.0 - np.cos(0.5 * np.pi * v)
    plate_z = -5.0 * layers(t(k + 1))[::-1]
    block_z = 10.0 * layers(t(2 * k))
    return xy, plate_z, block_z


#: the edge-refined family ``e<m>``: a fixed coarse tensor-product mesh (positions on the positive half; the zone
#: borders x, y = 0 and the footprint's edges +-5 mesh lines) whose elements next to the footprint's edges (both
#: sides of x, y = +-5 in the plate, the inside in the block) and next to the interface (plate top layer, block
#: bottom layer) are split m times geometrically by EDGE_RATIO (:func:`edge_split`). Block and plate differ
#: (the interface matches only on x, y = 0, +-5).
EDGE_RATIO = 8.0
EDGE_PLATE_XY = (0.0, 2.0, 4.0, 5.0, 6.0, 8.05, 10.1, 14.1, 20.0)
EDGE_PLATE_Z = (-5.0, -3.0, -1.0, 0.0)
#: with the flag r: the plate's lines from the footprint's edge out past the points (9.6 mm) at 0.5-0.7 mm
EDGE_PLATE_XY_RING = (0.0, 2.0, 4.0, 5.0, 5.6, 6.3, 7.0, 7.7, 8.4, 9.0, 9.6, 10.1, 12.0, 14.1, 20.0)
EDGE_BLOCK_XY = (0.0, 2.2, 4.4, 5.0)
EDGE_BLOCK_Z = (0.0, 1.0, 3.25, 5.5, 7.75, 10.0)


def edge_split(lines, at: float, m: int, ratio: float = EDGE_RATIO) -> np.ndarray:
    """``lines`` with the elements next to the line ``at`` (on each side that has one) split geometrically: lines
    added at at +- h / ratio^j, j = 1..m, h the element's size; the element next to ``at`` is h / ratio^m, each
    next one ``ratio`` times larger except the last step (ratio - 1).

    >>> edge_split([0.0, 1.0, 3.0], 1.0, 1)
    array([0.   , 0.875, 1.   , 1.25 , 3.   ])
    """
    lines = np.asarray(lines, float)
    i = int(np.argmin(np.abs(lines - at)))
    extra = [at + (lines[j] - at) / ratio ** np.arange(1, m + 1) for j in (i - 1, i + 1) if 0 <= j < len(lines)]
    return np.unique(np.round(np.concatenate([lines, *extra]), 12))


def edge_lines(m: int, ring: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(plate x and y, plate z, block x and y, block z) lines of edge-refined level ``m`` (EDGE_*; ``ring``: the
    plate's lines EDGE_PLATE_XY_RING)."""
    mirror = lambda half: np.unique(np.concatenate([-np.asarray(half)[::-1], half]))
    plate_xy, block_xy = mirror(EDGE_PLATE_XY_RING if ring else EDGE_PLATE_XY), mirror(EDGE_BLOCK_XY)
    for edge in (-5.0, 5.0):
        plate_xy, block_xy = edge_split(plate_xy, edge, m), edge_split(block_xy, edge, m)
    return plate_xy, edge_split(EDGE_PLATE_Z, 0.0, m), block_xy, edge_split(EDGE_BLOCK_Z, 0.0, m)


#: edge-refined family level names: ``e<m>`` with GRADED's flags Q (both bodies C3D20R), p (the plate the
#: slave: a label only) and r (the plate's lines EDGE_PLATE_XY_RING)
EDGE = re.compile(r"e(\d+)([Qpr]*)")

#: graded family level names: ``g<k>`` and any of the flags q (block C3D20R), Q (both bodies C3D20R), r (the
#: plate outside the footprint by ring_map), p (the plate the contact's slave: a label only, ``--slave`` decides),
#: c (grading exponent 3: graded_lines' ``cubic``)
GRADED = re.compile(r"g(\d+)([qQrpc]*)")


def meshes(level):
    """(plate, block, median plate facet h) of a level number, of a spec tuple as LEVELS' values, or of graded
    family level ``"g<k>"`` with GRADED's flags (:func:`graded_lines`)."""
    if isinstance(level, str) and EDGE.fullmatch(level):
        m, flags = EDGE.fullmatch(level).groups()
        plate_xy, plate_z, block_xy, block_z = edge_lines(int(m), ring="r" in flags)
        body = QuadraticGrid if "Q" in flags else gen.Grid
        plate = body(plate_xy, plate_xy, plate_z, first_node=1, first_element=1)
        block = body(block_xy, block_xy, block_z, first_node=plate.n_nodes + 1, first_element=len(plate.cells) + 1)
        return plate, block, float(np.min(np.diff(plate_xy)))
    if isinstance(level, str):
        n, flags = GRADED.fullmatch(level).groups()
        n = int(n)
        cubic = "c" in flags
        xy, plate_z, block_z = graded_lines(n, ring="r" in flags, cubic=cubic)
        plate = (QuadraticGrid if "Q" in flags else gen.Grid)(xy, xy, plate_z, first_node=1, first_element=1)
        body = QuadraticGrid if ("q" in flags or "Q" in flags) else gen.Grid
        block = body(footprint_lines(n, cubic), footprint_lines(n, cubic), block_z, first_node=plate.n_nodes + 1,
                     first_element=len(plate.cells) + 1)
        return plate, block, float(np.median(np.diff(footprint_lines(n + 1, cubic))))
    n, nbz, npz, hb, hp = LEVELS[level] if isinstance(level, int) else level
    block_z = np.concatenate([[0.0], np.cumsum(gen.sizes_with_sum(hb, nbz, 10.0))])
    plate_z = -np.concatenate([[0.0], np.cumsum(gen.sizes_with_sum(hp, npz, 5.0))])[::-1]
    plate = gen.Grid(plate_lines(n + 1), plate_lines(n + 1), plate_z, first_node=1, first_element=1)
    block = gen.Grid(footprint_lines(n), footprint_lines(n), block_z, first_node=plate.n_nodes + 1,
                     first_element=len(plate.cells) + 1)
    h = float(np.median(np.diff(footprint_lines(n + 1))))
    return plate, block, h


def at_height(block, disp: dict, x: float, y: float, z: float) -> np.ndarray:
    """Displacement (3,) at a block node line (x, y), linear in z between the two nearest layers."""
    zs = block.zs
    k = int(np.clip(np.searchsorted(zs, z) - 1, 0, len(zs) - 2))
    t = (z - zs[k]) / (zs[k + 1] - zs[k])
    i, j = int(np.argmin(np.abs(block.xs - x))), int(np.argmin(np.abs(block.ys - y)))
    return (1 - t) * disp[int(block.ids[i, j, k])] + t * disp[int(block.ids[i, j, k + 1])]


def run(level: int, scale: float, penalty: float | None, stick: float | None, element: str, work: Path,
        n_pull: int = 10, field: str | None = None, slave: str = "block") -> dict:
    plate, block, h = meshes(level)
    penalty = penalty or gen.PENALTY_FACTOR * gen.E_PLATE / h
    stick = stick or gen.STICK_FACTOR * gen.E_PLATE / h
    gen.PRESSURE, gen.PULL = 20.0 * scale, 0.2 * scale
    work.mkdir(parents=True, exist_ok=True)
    deck = gen.write_deck(plate, block, penalty, stick, n_press=2, n_pull_min=n_pull, element=element, slave=slave)
    if field:                                               # ccx's convergence criteria (*CONTROLS, FIELD) per step
        deck = deck.replace("*STATIC\n", f"*CONTROLS, PARAMETERS=FIELD\n{field}\n*STATIC\n")
    (work / f"{gen.JOB}.inp").write_text(deck)
    env = {**os.environ, "OMP_NUM_THREADS": "1", "CCX_NPROC_EQUATION_SOLVER": "1"}
    start = time.perf_counter()
    with open(work / "ccx.log", "w") as log:
        subprocess.run(["ccx", "-i", gen.JOB], cwd=work, env=env, stdout=log, stderr=subprocess.STDOUT, check=True)
    seconds = time.perf_counter() - start
    frd, dat = read_frd(work / f"{gen.JOB}.frd"), read_dat(work / f"{gen.JOB}.dat")
    last = frd.last_of_step("DISP", 2)
    if abs(last.time - 2) > 1e-6:
        sys.exit(f"ccx stopped at time {last.time}: {work / 'ccx.log'}")
    disp = {int(n): v[:3] / scale for n, v in zip(last.nodes, last.values)}
    contact = {z: next(v for (s, _), v in dat.contact.items() if s.upper() == f"S{z}") for z in gen.MU}
    normal = {z: abs(contact[z][max(contact[z])]["force"][2]) / scale for z in gen.MU}
    totals = next(v for (what, name), v in dat.totals.items() if name.upper() == "NTOP")
    um = lambda v: 1e3 * float(v)
    return {"level": level, "scale": scale, "n_pull": n_pull, "field": field, "slave": slave, "penalty": penalty,
            "stick": stick, "element": {body: getattr(grid, "element", None) or element
                                        for body, grid in (("plate", plate), ("block", block))},
            "nodes": plate.n_nodes + block.n_nodes, "seconds": round(seconds, 1), "increments": gen.increments(work),
            "tilt_um": um(at_height(block, disp, 0, -5, 5)[2] - at_height(block, disp, 0, 5, 5)[2]),
            "N": {z: round(normal[z], 2) for z in gen.MU},
            "uy_x-5_z1_um": um(at_height(block, disp, -5, 0, 1)[1]),
            "uy_x+5_z1_um": um(at_height(block, disp, 5, 0, 1)[1]),
            "force": totals[max(totals)][1] / scale}


def graded_name(args) -> str:
    """The graded level's name (GRADED) of parsed ``--graded``, ``--quadratic[-block]``, ``--ring``, ``--slave``
    (``--cubic``), or with ``--edge`` the edge-refined level's (EDGE)."""
    if getattr(args, "edge", None) is not None:
        return (f"e{args.edge}{'Q' if args.quadratic else ''}{'p' if args.slave == 'plate' else ''}"
                f"{'r' if args.ring else ''}")
    return (f"g{args.graded}{'Q' if args.quadratic else 'q' if args.quadratic_block else ''}"
            f"{'r' if args.ring else ''}{'p' if args.slave == 'plate' else ''}{'c' if args.cubic else ''}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", type=int, choices=sorted(LEVELS), default=1)
    parser.add_argument("--scale", type=float, default=1.0, help="load scale (0.01: small-sliding limit)")
    parser.add_argument("--penalty", type=float, help="normal penalty [N/mm^3] (default 500 E_plate / h)")
    parser.add_argument("--stick", type=float, help="stick slope [N/mm^3] (default 50 E_plate / h)")
    parser.add_argument("--mesh", type=mesh_spec, help="a mesh instead of --level's: 'n,block layers,plate "
                        "layers,first block layer,first plate layer' (e.g. level 2 is '5,10,6,0.3,0.25')")
    parser.add_argument("--graded", type=int, help="graded family level k instead of --level (graded_lines)")
    parser.add_argument("--quadratic-block", action="store_true", help="with --graded: the block in C3D20R")
    parser.add_argument("--quadratic", action="store_true", help="with --graded: both bodies in C3D20R")
    parser.add_argument("--ring", action="store_true", help="with --graded: the plate outside the footprint by "
                        "ring_map (finer where the DIC points are); with --edge: its lines EDGE_PLATE_XY_RING")
    parser.add_argument("--cubic", action="store_true", help="with --graded: grading exponent 3 instead of "
                        "1 - cos (graded_lines' cubic)")
    parser.add_argument("--edge", type=int, help="edge-refined family level m instead of --level (edge_lines; "
                        "with --quadratic both bodies C3D20R)")
    parser.add_argument("--element", default="C3D8I")
    parser.add_argument("--slave", choices=("block", "plate"), default="block",
                        help="the contact's slave body (the zones' surfaces; the other is the master)")
    parser.add_argument("--pull-increments", type=int, default=10, help="least number of pull increments")
    parser.add_argument("--field", help="ccx's *CONTROLS, PARAMETERS=FIELD line, e.g. '5e-5, 1e-4' (R_n, C_n; "
                        "ccx's defaults 0.005, 0.01)")
    parser.add_argument("--work", type=Path, required=True)
    parser.add_argument("--out", type=Path, help="append the result as a JSON line here")
    parser.add_argument("--count", action="store_true", help="print the node count only")
    args = parser.parse_args(argv)
    level = args.mesh or (graded_name(args) if args.graded or args.edge is not None else args.level)
    if args.count:
        plate, block, h = meshes(level)
        print(f"level {level}: plate {plate.n_nodes}, block {block.n_nodes} nodes, h {h:.3f} mm")
        return 0
    result = run(level, args.scale, args.penalty, args.stick, args.element, args.work, args.pull_increments,
                 args.field, args.slave)
    emit(result, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
