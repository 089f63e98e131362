"""The 3-D bolt mesh's shank between two heights: how much of the cylinder the mesh holds, and why.

For the bolt's cells reaching into y0 <= y <= y1 (default 3 to 9.8 mm): the volume of the isoparametric cells there
(a collapsed Gauss rule of n^3 points per cell, points outside the span dropped; n = 24 and 48 show its
convergence) against pi R^2 (y1 - y0), R the largest node radius of the bolt between y0 + 1 and y1 - 1, and the
integral of dy / A(y) over 0.2 mm slabs against (y1 - y0) / (pi R^2) (the stretch of a bar under uniform stress,
relative); the mid-side nodes of the lateral surface's edges (edges of boundary faces with three corners at R) that
are not on the circle, and the cells using them that fail builders/curved.py's rules (SAGITTA, DET_RANGE on the
determinant's Bernstein bounds) with those nodes put on their arc's midpoint (the position gmsh gives them on a
cylinder).

With ``--stretch RMAX`` each model (a .pkl, or ``axi``: the axisymmetric model of the test's M6 layout) is solved
instead at mu = 0.15 and uy's change from y0 to y1 printed on the axis, on circles of radius 1, 2 and 0.98 RMAX
(the outermost Gauss radius; mean over 16 angles, and the first harmonic: bending) and averaged over the disc
r <= RMAX (8 Gauss radii, 16 angles).

Run: .venv/bin/python benchmarks/shank_section.py model.pkl [model.pkl ...] [--span Y0,Y1] [--stretch RMAX]
(a .pkl as written by benchmarks/bolt3d.py's ``built``, e.g. by bolt3d_vs_axisymmetric.py).
"""

import pickle
import sys

import numpy as np
from numpy.polynomial.legendre import leggauss

from frictionid.builders.curved import DET_RANGE, EDGES, SAGITTA, jacobian_bounds

FACES = ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3))


def shape(L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """tetra10 shape functions (m, 10) and their derivatives (m, 10, 3) at barycentric points L (m, 4)."""
    dL = np.array([[-1.0, -1, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    N, dN = np.empty((len(L), 10)), np.empty((len(L), 10, 3))
    N[:, :4] = L * (2 * L - 1)
    for i in range(4):
        dN[:, i] = (4 * L[:, i] - 1)[:, None] * dL[i]
    for k, (a, b) in enumerate(EDGES):
        N[:, 4 + k] = 4 * L[:, a] * L[:, b]
        dN[:, 4 + k] = 4 * (L[:, b, None] * dL[a] + L[:, a, None] * dL[b])
    return N, dN


def collapsed_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric points (n^3, 4) and weights summing to 1/6 of the unit tetrahedron (Duffy's collapse)."""
    g, w = leggauss(n)
    g, w = (g + 1) / 2, w / 2
    u, v, t = np.meshgrid(g, g, g, indexing="ij")
    wu, wv, wt = np.meshgrid(w, w, w, indexing="ij")
    X = np.c_[u.ravel(), (v * (1 - u)).ravel(), (t * (1 - u) * (1 - v)).ravel()]
    return np.c_[1 - X.sum(1), X], (wu * wv * wt * (1 - u) ** 2 * (1 - v)).ravel()


def shank_measures(P, cells, y0, y1, R, n) -> dict:
    """The cells' volume [mm^3] in the span y0 <= y <= y1 by an n^3-point rule, pi R^2 (y1 - y0) ("bar"), the mean
    area [mm^2] of each 0.2 mm slab ("area") and the integral of dy / A over (y1 - y0) / (pi R^2) ("compliance")."""
    L, W = collapsed_rule(n)
    N, dN = shape(L)
    x = np.einsum("mk,nkd->nmd", N, P[cells])
    dv = np.abs(np.linalg.det(np.einsum("nkd,mke->nmde", P[cells], dN))) * W
    inside = (x[..., 1] >= y0) & (x[..., 1] <= y1)
    edges = np.linspace(y0, y1, max(2, round((y1 - y0) / 0.2)) + 1)
    area = np.histogram(x[..., 1].ravel(), edges, weights=dv.ravel())[0] / np.diff(edges)
    return {"volume": float(np.sum(dv * inside)), "bar": np.pi * R ** 2 * (y1 - y0), "area": area,
            "compliance": float(np.sum(np.diff(edges) / area) / ((y1 - y0) / (np.pi * R ** 2)))}


def volume(P, cells, y0, y1, R, n):
    """Lines on the cells' volume in the span and the bar's compliance integral, by an n^3-point rule."""
    m = shank_measures(P, cells, y0, y1, R, n)
    v, bar, area = m["volume"], m["bar"], m["area"]
    return (f"  {n}^3 points per cell: volume {v:.3f} mm^3, pi R^2 L {bar:.3f}: {100 * (v / bar - 1):+.3f} %; "
            f"slabs' area {area.min():.3f} to {area.max():.3f} mm^2 (pi R^2 {np.pi * R ** 2:.3f}), "
            f"integral dy / A {100 * (m['compliance'] - 1):+.3f} % over L / (pi R^2)")


def shank_cells(mesh, y0: float, y1: float) -> tuple[np.ndarray, float]:
    """(the bolt's cells (n, 10) reaching into y0 <= y <= y1, the shank's radius R [mm]: the largest node radius
    of the bolt between y0 + 1 and y1 - 1)."""
    P, C = mesh.points, mesh.cells[mesh.regions["bolt"]]
    r, nodes = np.hypot(P[:, 0], P[:, 2]), np.unique(C)
    R = r[nodes[(P[nodes, 1] > y0 + 1) & (P[nodes, 1] < y1 - 1)]].max()
    y = P[C][..., 1]
    return C[(y.max(1) > y0) & (y.min(1) < y1)], float(R)


def surface_nodes(P, C, r, on, y0, y1):
    """(mid-side nodes of the lateral surface's edges in the span, the same at their arc's midpoint)."""
    faces = np.sort(np.concatenate([C[:, f] for f in FACES]), axis=1)
    unique, count = np.unique(faces, axis=0, return_counts=True)
    lateral = unique[(count == 1) & on[unique].all(1)]
    on_surface = {tuple(sorted(e)) for f in lateral for e in ((f[0], f[1]), (f[1], f[2]), (f[0], f[2]))}
    curved, nodes = P.copy(), set()
    R = r[on].mean()
    for k, (a, b) in enumerate(EDGES):
        for i, j, m in zip(C[:, a], C[:, b], C[:, 4 + k]):
            if (min(i, j), max(i, j)) in on_surface and y0 < P[m, 1] < y1:
                ti, tj = np.arctan2(P[i, 2], P[i, 0]), np.arctan2(P[j, 2], P[j, 0])
                t = ti + 0.5 * np.angle(np.exp(1j * (tj - ti)))
                curved[m] = [R * np.cos(t), 0.5 * (P[i, 1] + P[j, 1]), R * np.sin(t)]
                nodes.add(m)
    return np.array(sorted(nodes), dtype=int), curved


def stretch(source: str, y0: float, y1: float, r_max: float) -> None:
    """uy's change from y0 to y1 on the axis, on circles and over the disc r <= r_max of the bolt."""
    from frictionid.builders.bolt import bolt_model
    from frictionid.fem.problem import Problem
    options = {"size": "M6", "length": 24.0, "thread_length": 9.5, "n_axial": 2, "forces": [1500.0],
               "n_increments": 1}
    model = bolt_model(**options) if source == "axi" else pickle.loads(open(source, "rb").read())
    dim = 2 if source == "axi" else 3
    theta = 2 * np.pi * (np.arange(16) + 0.5) / 16
    g, w = leggauss(8)
    radii = np.r_[0.0, 1.0, 2.0, r_max * (g[-1] + 1) / 2, r_max * (g + 1) / 2]   # circles inside the faces' chords
    weights = w / 2 * r_max * radii[4:]                                  # of f r dr over the disc
    angles = theta if dim == 3 else theta[:1]
    points = np.array([[r * np.cos(t), y, -r * np.sin(t)][:dim] for y in (y0, y1) for r in radii for t in angles])
    problem = Problem.build(model, points=points, quantities=("uy",), regions=["bolt"] * len(points),
                            **({"factorisation": "mumps"} if dim == 3 else {}))
    uy = np.asarray(problem.solve(np.full(len(model.zone_names), 0.15)).observations[-1]).ravel()
    change = 1000 * np.diff(uy.reshape(2, len(radii), len(angles)), axis=0)[0]      # (radius, angle) [um]
    disc = np.sum(weights * change[4:].mean(axis=1)) / weights.sum()
    print(f"{source}: {model.mesh.n_nodes:,} nodes; uy from y {y0:g} to {y1:g} mm [um]: axis {change[0, 0]:.5f}; "
          f"disc r <= {r_max:g} averaged {disc:.5f}")
    for k in (1, 2, 3):
        harmonic = 2 * np.abs(np.mean(change[k] * np.exp(1j * angles))) if dim == 3 else 0.0
        print(f"  r {radii[k]:g}: mean over the angles {change[k].mean():.5f}, first harmonic {harmonic:.5f}")


def report(path: str, y0: float, y1: float) -> None:
    mesh = pickle.loads(open(path, "rb").read()).mesh
    P, C = mesh.points, mesh.cells[mesh.regions["bolt"]]
    span, R = shank_cells(mesh, y0, y1)
    r = np.hypot(P[:, 0], P[:, 2])
    print(f"{path}: {mesh.n_nodes:,} nodes; {len(span)} bolt cells reach into y {y0:g} to {y1:g} mm; R {R:.4f} mm")
    for n in (24, 48):
        print(volume(P, span, y0, y1, R, n), flush=True)
    on = np.abs(r - R) < 1e-6
    mids, curved = surface_nodes(P, C, r, on, y0, y1)
    off = mids[~on[mids]]
    inset = (R - r[off]).max() if len(off) else 0.0
    print(f"  lateral surface mid-side nodes in the span {len(mids)}, put back off the circle {len(off)} (inside it "
          f"by up to {inset:.3f} mm)")
    if not len(off):
        return
    cells = C[np.isin(C[:, 4:], off).any(1)]
    lower, upper = jacobian_bounds(curved, cells)
    bad = (lower <= DET_RANGE[0]) | (upper >= DET_RANGE[1])
    ends = P[cells[:, [[a, b] for a, b in EDGES]]]
    length = np.linalg.norm(ends[:, :, 1] - ends[:, :, 0], axis=-1)
    sagitta = np.linalg.norm(curved[cells[:, 4:]] - ends.mean(axis=2), axis=-1) / length
    print(f"  with them on their arcs: largest offset {sagitta.max():.3f} of the edge (SAGITTA {SAGITTA}); "
          f"{bad.sum()} of the {len(cells)} cells using them leave DET_RANGE {DET_RANGE}:")
    for cell, low, high in zip(cells[bad], lower[bad], upper[bad]):
        print(f"    det J / straight bounded by {low:+.3f} and {high:.2f}, corners at R {on[cell[:4]].sum()}, "
              f"surface mid-side nodes {np.isin(cell[4:], off).sum()}, longest edge "
              f"{np.linalg.norm(P[cell[:4], None] - P[cell[None, :4]], axis=-1).max():.2f} mm")


if __name__ == "__main__":
    args, span = sys.argv[1:], (3.0, 9.8)
    if "--span" in args:
        at = args.index("--span")
        span = tuple(float(v) for v in args[at + 1].split(","))
        args = args[:at] + args[at + 2:]
    if "--stretch" in args:
        at = args.index("--stretch")
        r_max = float(args[at + 1])
        for source in args[:at] + args[at + 2:]:
            stretch(source, *span, r_max)
    else:
        for path in args:
            report(path, *span)
