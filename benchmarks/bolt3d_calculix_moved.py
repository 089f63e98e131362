"""The separately meshed M6 nut against CalculiX with the nut's flank nodes moved onto the bolt's flank, so that
both codes solve one geometry with (nearly) zero initial gaps and no gap adjustment (no `adjust` in the embedded
model, no *CLEARANCE in ccx's deck).

On the stored separate-nut mesh (tests/fixtures/bolt3d_calculix, `mesh_separate.npz`) the thread's two meshes of
one helicoid differ by -7.4 to +0.2 um. The embedded mortar zeroes those gaps (`adjust`), ccx's `*CLEARANCE,
VALUE=0` replaces the gap at each slave integration point; the two adjusted problems disagree (the fixture's
README). Here the nut's two flank slivers are removed first (cells with all four corners on the flank, filling the
wedge between two flank facets; valid only by a mid-side node standing 3-4.5 um off the flank, they would turn
inside out with every flank node on the bolt's flank: `without_slivers`), then every node of the nut's load flanks
(corner and mid-side) is moved along its averaged outward normal onto the bolt's quadratic flank facets
(`facet_shapes.project_along`; where no facet lies along the normal, onto a facet's extension past the flank's
edge), the moves spread smoothly into the nut within SPREAD of the flank (a cell that the moves would spoil keeps
its flank nodes in place; on this mesh none). The two codes are compared on that mesh.

Run (from the repository's root):
    nice -n 10 /usr/bin/time -v .venv/bin/python benchmarks/bolt3d_calculix_moved.py [--stiffness S [S ...]]
    [--order N [N ...]] [--work DIR] [--mesh-only] [--static "INITIAL, 1., MINIMUM, MAXIMUM"] [--stick S]
prints the nodes' moves, the embedded model's initial mortar gaps on the moved mesh, and the comparison
(benchmarks/bolt3d_calculix.py's `report`) per ccx penalty S [N/mm^3] and embedded quadrature order.
"""

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import bolt3d_calculix as calculix                       # noqa: E402
from fixtures import bolt3d_calculix as fixture          # noqa: E402
from frictionid.backends.calculix.backend import CalculixSettings     # noqa: E402
from frictionid.fem.facet_shapes import project_along, shape_functions, triangle_quadrature    # noqa: E402
from frictionid.fem.mortar3d import _Side               # noqa: E402

#: [mm] how far into the nut the flank's moves spread (about two flank elements)
SPREAD = 1.0
#: a move may shrink no cell's smallest Jacobian determinant below this fraction of its own
KEEP = 0.5
#: the candidates per node: the bolt facets with the nearest centres
CANDIDATES = 12
#: the largest move [mm]: the meshes' gaps are a few um; a longer line reaches another turn's flank
REACH = 0.02
#: a parameter this far outside the reference triangle still counts as on the facet
INSIDE = 1e-9
#: how far past a facet's edge (in its parameters) a node may land where no facet lies along its normal
EXTENDED = 0.25


def moved_model(verbose: bool = True, model=None):
    """The stored separate-nut model (or ``model``, another separate-nut 3-D bolt model, e.g. one with a finer
    flank) without its flank slivers (:func:`without_slivers`), with the nut's flank nodes on the bolt's flank and
    ``adjust`` off."""
    if model is None:
        model = fixture.stored_model(calculix.layout_of(fixture.OPTIONS), fixture.mesh_file("separate"))
    thread = model.interfaces[0]
    mesh, removed = without_slivers(model.mesh, thread.zones)
    if verbose:
        print(f"flank slivers removed: {len(removed)} nut cells ({removed.tolist()}), their two flank facets replaced "
              "by their two other faces", flush=True)
    nut = np.vstack([mesh.boundaries[z] for z in thread.zones])
    bolt = mesh.boundaries[thread.target]
    side = _Side(mesh, nut, np.zeros(len(nut), int))
    nodes = np.unique(nut)
    normals = side.node_normal[nodes]
    coords = mesh.points[bolt]
    _, near = cKDTree(coords.mean(axis=1)).query(mesh.points[nodes], k=CANDIDATES)
    best_t = np.full(len(nodes), np.nan)
    for margin in (INSIDE, EXTENDED):          # on a facet first; the rest onto a facet's extension past its edge
        for k in range(CANDIDATES):
            rs = project_along(coords[near[:, k]], mesh.facet_type, mesh.points[nodes], normals)
            inside = np.all(rs >= -margin, axis=1) & (rs.sum(axis=1) <= 1 + margin)
            x = np.einsum("qk,qkd->qd", _shape(rs), coords[near[:, k]])
            t = np.einsum("qd,qd->q", x - mesh.points[nodes], normals)
            better = inside & (np.abs(t) <= REACH) & \
                (np.isnan(best_t) | (np.abs(t) < np.abs(np.nan_to_num(best_t, nan=np.inf))))
            if margin != INSIDE:
                better &= ~on_facet
            best_t[better] = t[better]
        if margin == INSIDE:
            on_facet = np.isfinite(best_t)
    found = np.isfinite(best_t)
    move = np.zeros_like(mesh.points)
    move[nodes[found]] = best_t[found, None] * normals[found]
    flank = np.zeros(mesh.n_nodes, bool)
    flank[nodes] = True
    before = _smallest_jacobian(mesh, mesh.points)
    held = np.zeros(mesh.n_nodes, bool)
    while True:
        # a sliver whose four corners lie on the curved flank is valid by its mid-side nodes alone: moving them
        # normal to the flank by more than its thickness turns it inside out; such a cell's flank nodes stay
        extended = _extended(mesh, np.where(held[:, None], 0.0, move), flank)
        ratio = _smallest_jacobian(mesh, mesh.points + extended) / before
        spoilt = mesh.cells[ratio < KEEP].ravel()
        if not len(spoilt):
            break
        held[spoilt[flank[spoilt]]] = True
    points = mesh.points + extended
    if verbose:
        moved = found & ~held[nodes]
        size = np.abs(best_t[moved]) * 1e3
        print(f"nut flank nodes {len(nodes):,}: {moved.sum():,} moved along their normals by {size.min():.3f} to "
              f"{size.max():.3f} um ({int(np.sum(moved & ~on_facet))} of them onto a facet's extension past the "
              f"flank's edge), {int(held.sum())} kept in place (cells the moves would spoil), {int(np.sum(~found))} "
              f"with no bolt flank facet along the normal within {1e3 * REACH:g} um; the moves spread into the nut "
              f"within {SPREAD:g} mm of its flanks; the cells' smallest Jacobian determinants (corners, ccx's and the "
              f"product's quadrature points) keep at least {ratio.min():.3f} of their own", flush=True)
    moved = dataclasses.replace(mesh, points=points)
    interfaces = (dataclasses.replace(thread, adjust=False),) + model.interfaces[1:]
    return dataclasses.replace(model, mesh=moved, interfaces=interfaces)


def without_slivers(mesh, zones: tuple[str, ...]):
    """The mesh without the nut cells whose four corners lie on the flank (``zones``' facets): such a sliver fills
    the wedge between two flank facets that share an edge (on this mesh the zones' radial split at the pitch
    diameter) and is valid only by that edge's mid-side node standing off the flank; with every flank node on one
    smooth surface its Jacobian at the edge's corners vanishes whatever its other nodes do. Each sliver's two flank
    facets are replaced by its two other faces, each put into the zone of the old facet whose centre's radius is
    nearer to its own; the nodes no cell uses any more (the shared edge's mid-side node) are dropped.
    Returns the mesh and the removed cells' indices in the given mesh."""
    flank = np.zeros(mesh.n_nodes, bool)
    for zone in zones:
        flank[mesh.boundaries[zone]] = True
    nut = np.asarray(mesh.regions["nut"])
    slivers = nut[flank[mesh.cells[nut, :4]].all(axis=1)]
    boundaries = {name: facets.copy() for name, facets in mesh.boundaries.items()}
    radius = lambda facet: np.hypot(*mesh.points[facet[:3]].mean(axis=0)[[0, 2]])   # noqa: E731  (axis y)
    for cell in mesh.cells[slivers]:
        old = [(zone, k) for zone in zones
               for k in np.flatnonzero(np.isin(boundaries[zone][:, :3], cell[:4]).all(axis=1))]
        if len(old) != 2:
            raise ValueError(f"a flank sliver with {len(old)} flank facets instead of two: {cell[:4].tolist()}")
        shared = sorted(set(boundaries[old[0][0]][old[0][1], :3]) & set(boundaries[old[1][0]][old[1][1], :3]))
        new = [_face(mesh.points, cell, [c for c in cell[:4] if c != a]) for a in shared]  # without one edge end
        for facet in new:
            zone = min(old, key=lambda o: abs(radius(boundaries[o[0]][o[1]]) - radius(facet)))[0]
            boundaries[zone] = np.vstack([boundaries[zone], facet])
        for zone, k in sorted(old, key=lambda o: -o[1]):
            boundaries[zone] = np.delete(boundaries[zone], k, axis=0)
    keep = np.ones(len(mesh.cells), bool)
    keep[slivers] = False
    used = np.zeros(mesh.n_nodes, bool)
    used[mesh.cells[keep]] = True
    number = np.cumsum(used) - 1
    cell_number = np.cumsum(keep) - 1
    regions = {name: cell_number[np.asarray(cells)[keep[cells]]] for name, cells in mesh.regions.items()}
    return dataclasses.replace(mesh, points=mesh.points[used], cells=number[mesh.cells[keep]], regions=regions,
                               boundaries={name: number[facets] for name, facets in boundaries.items()}), slivers


#: local corner pairs of the tetra10's mid-side nodes 4-9 (meshio order)
_EDGES = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))


def _face(points: np.ndarray, cell: np.ndarray, corners: list[int]) -> np.ndarray:
    """The triangle6 facet (corners, then the mid-side nodes of edges 0-1, 1-2, 2-0) of ``cell`` on three of its
    corner nodes, oriented as the flank facets are toward the cell on its other side (its normal away from
    ``cell``'s fourth corner: the flank facets' normals point into the nut)."""
    local = [int(np.flatnonzero(cell[:4] == c)[0]) for c in corners]
    fourth = cell[({0, 1, 2, 3} - set(local)).pop()]
    a, b, c = points[corners]
    if np.dot(np.cross(b - a, c - a), points[fourth] - a) > 0:
        corners, local = [corners[0], corners[2], corners[1]], [local[0], local[2], local[1]]
    return np.array(corners + [cell[4 + _EDGES.index(tuple(sorted((local[i], local[(i + 1) % 3]))))]
                               for i in range(3)])


def _extended(mesh, move: np.ndarray, flank: np.ndarray) -> np.ndarray:
    """The flank nodes' moves spread smoothly into the nut: the graph Laplacian's harmonic extension over the nut's
    cells (every two nodes of a cell neighbours), held at the flank's moves, and at zero beyond SPREAD [mm] from the
    flank and on every other named boundary (the nut's bearing face, whose node-to-node pairs with plate 1 stay
    coincident), so that each small cell moves nearly as a rigid body."""
    cells = mesh.cells[mesh.regions["nut"]]
    inner = np.unique(cells)
    far = cKDTree(mesh.points[flank]).query(mesh.points[inner])[0] > SPREAD
    fixed = np.zeros(mesh.n_nodes, bool)
    fixed[inner[far]] = True
    for facets in mesh.boundaries.values():
        fixed[facets] = True
    fixed |= flank
    k = cells.shape[1]
    rows, cols = np.repeat(cells, k, axis=1).ravel(), np.tile(cells, (1, k)).ravel()
    A = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(mesh.n_nodes,) * 2)
    A.setdiag(0)
    A.data[:] = 1.0
    L = sp.diags(np.asarray(A.sum(axis=1)).ravel()) - A
    free = np.setdiff1d(inner, np.flatnonzero(fixed))
    out = move.copy()
    solve = spla.factorized(L[free][:, free].tocsc())
    rhs = -(L[free][:, np.flatnonzero(fixed)] @ move[fixed])
    for d in range(3):
        out[free, d] = solve(np.ascontiguousarray(rhs[:, d]))
    return out


def _smallest_jacobian(mesh, points) -> np.ndarray:
    """(n_cells,) each tetra10 cell's smallest Jacobian determinant at its corners, at ccx's 4 C3D10 integration
    points and at the product's quadrature points (where either code would see a cell turned inside out)."""
    from skfem.quadrature import get_quadrature
    from skfem.refdom import RefTet
    from frictionid.fem.space import INTORDER
    a, b = (5 + 3 * np.sqrt(5)) / 20, (5 - np.sqrt(5)) / 20         # the 4-point rule, exact for degree 2
    xi = np.vstack([np.eye(4, 3, -1), [[b, b, b], [a, b, b], [b, a, b], [b, b, a]],
                    get_quadrature(RefTet, INTORDER["tetra10"])[0].T])
    jacobian = np.einsum("cnd,pne->cpde", points[mesh.cells], _tetra10_derivatives(xi))
    return np.linalg.det(jacobian).min(axis=1)


def _tetra10_derivatives(xi: np.ndarray) -> np.ndarray:
    """(n_points, 10, 3) the tetra10's shape function derivatives (meshio order) at reference points (n_points, 3)."""
    bary = np.column_stack([1 - xi.sum(axis=1), xi])
    d_bary = np.vstack([-np.ones(3), np.eye(3)])
    out = np.empty((len(xi), 10, 3))
    for i in range(4):
        out[:, i] = (4 * bary[:, i] - 1)[:, None] * d_bary[i]
    for k, (i, j) in enumerate(_EDGES):
        out[:, 4 + k] = 4 * (bary[:, i, None] * d_bary[j] + bary[:, j, None] * d_bary[i])
    return out


def _shape(rs):
    return shape_functions(np.nan_to_num(rs), "triangle6")[0]


def initial_gaps(model) -> np.ndarray:
    """The embedded thread's initial mortar gaps [mm] on the model's mesh."""
    from frictionid.fem.mortar3d import mortar_pairs_3d
    from frictionid.fem.space import Space
    return mortar_pairs_3d(Space.build(model.mesh, "3d"), model, 0).gap


def pointwise_gaps(model, degree: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """The thread's normal gaps [mm] as a face-to-face penalty code sees them: at the points of a triangle rule of
    ``degree`` on each nut flank facet (the slave side), along the facet's outward normal there, to the bolt's
    quadratic flank facets (NaN where no bolt facet lies along the normal within REACH). Negative: overlap.
    Returns gaps (n_facets, n_points) and the points' area weights [mm^2]."""
    found = flank_projection(model, degree)
    return found["gap"].reshape(found["area"].shape), found["area"]


def flank_projection(model, degree: int = 5) -> dict:
    """The nut flank's points of :func:`pointwise_gaps` projected onto the bolt's flank: ``nut`` (n_facets, 6) node
    numbers, ``N`` the facets' shape functions at the points (n_points, 6), ``x`` and ``normal`` (n, 3) the points
    and their outward unit normals, ``area`` (n_facets, n_points) [mm^2], ``gap`` (n,) [mm], and where a bolt facet
    was found ``facet`` (n,) its row of the target boundary and ``at`` (n, 2) its parameters there."""
    mesh, thread = model.mesh, model.interfaces[0]
    nut = np.vstack([mesh.boundaries[z] for z in thread.zones])
    bolt = mesh.points[mesh.boundaries[thread.target]]
    side = _Side(mesh, nut, np.zeros(len(nut), int), node_normals=False)
    bary, weights = triangle_quadrature(degree)
    N, dN = shape_functions(bary[:, 1:], mesh.facet_type)
    x = np.einsum("qk,fkd->fqd", N, side.coords).reshape(-1, 3)
    tangents = np.einsum("qkp,fkd->fqdp", dN, side.coords)
    normal = np.cross(tangents[..., 0], tangents[..., 1])
    area = np.linalg.norm(normal, axis=-1) * weights / 2
    normal = (side.sign[:, None, None] * normal / np.linalg.norm(normal, axis=-1, keepdims=True)).reshape(-1, 3)
    _, near = cKDTree(bolt.mean(axis=1)).query(x, k=CANDIDATES)
    gap, facet, at = np.full(len(x), np.nan), np.zeros(len(x), int), np.zeros((len(x), 2))
    for k in range(CANDIDATES):
        rs = project_along(bolt[near[:, k]], mesh.facet_type, x, normal)
        inside = np.all(rs >= -INSIDE, axis=1) & (rs.sum(axis=1) <= 1 + INSIDE)
        t = np.einsum("qd,qd->q", np.einsum("qk,qkd->qd", _shape(rs), bolt[near[:, k]]) - x, normal)
        better = inside & (np.abs(t) <= REACH) & (np.isnan(gap) | (np.abs(t) < np.abs(np.nan_to_num(gap, nan=np.inf))))
        gap[better], facet[better], at[better] = t[better], near[better, k], rs[better]
    return {"nut": nut, "N": N, "x": x, "normal": normal, "area": area, "gap": gap, "facet": facet, "at": at}


def _report_pointwise(model, stiffness: list[float]) -> None:
    gap, area = pointwise_gaps(model)
    found = np.isfinite(gap)
    um = 1e3 * gap[found]
    overlap = np.sum(np.where(found & (gap < 0), -np.nan_to_num(gap), 0.0) * area)
    worst = np.any(np.nan_to_num(gap) < -5e-4, axis=1)
    print(f"pointwise gaps at {gap.shape[1]} points per nut flank facet ({found.sum():,} of {gap.size:,} points on a "
          f"bolt facet): {um.min():+.3f} .. {um.max():+.3f} um, 1st / 99th percentile {np.percentile(um, 1):+.3f} / "
          f"{np.percentile(um, 99):+.3f} um; {int(worst.sum())} facets overlap beyond 0.5 um somewhere; the overlap's "
          f"integral {overlap:.3e} mm^3 (times the penalty slope: "
          + ", ".join(f"{s * overlap:,.0f} N at {s:g}" for s in stiffness) + ")", flush=True)


def _with_static(static: str):
    """A deck edit: every *STATIC data line replaced by ``static`` ("initial, period, minimum, maximum" time
    increment; the deck's own is the stage's n_increments equal increments)."""
    def edit(deck: str) -> str:
        lines = deck.split("\n")
        at = [k + 1 for k, line in enumerate(lines) if line.strip().upper() == "*STATIC"]
        if not at:
            raise ValueError("the deck has no *STATIC line to change")
        for k in at:
            lines[k] = static
        return "\n".join(lines)
    return edit


def main(stiffness: list[float], orders: list[int], work: str | None, mesh_only: bool,
         static: str | None = None, stick: float | None = None) -> None:
    model = moved_model()
    gap = initial_gaps(model)
    print(f"embedded thread pairs on the moved mesh: {len(gap):,}, initial gaps {1e3 * gap.min():+.4f} .. "
          f"{1e3 * gap.max():+.4f} um, {np.sum(np.abs(gap) > 5e-4)} beyond 0.5 um", flush=True)
    _report_pointwise(model, stiffness)
    if mesh_only:
        return
    points, regions = calculix.observed(fixture.OPTIONS)
    results = [calculix.embedded_result(model, points, regions, fixture.MU, "mumps", order) for order in orders]
    runs = []
    for s in stiffness:
        settings = CalculixSettings(normal_stiffness=s, stick_slope=stick or s, timeout=7200, work_dir=work,
                                    keep_work=work is not None)
        runs.append(calculix.ccx_result(model, points, regions, fixture.MU, settings,
                                        None if static is None else _with_static(static)))
        for result in results:
            calculix.report(model, result, runs[-1])
            print(flush=True)
    if len(runs) > 1:
        limit = {key: calculix.penalty_limit(runs, key) for key in ("ccx", "ccx_reactions", "ccx_zones", "ccx_axial")}
        for result in results:
            calculix.report(model, result, {**runs[-1], **limit}, "ccx extrapolated to an infinite penalty from the "
                            "two stiffest runs (d = d0 + c / k):")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stiffness", type=float, nargs="+", default=[1e7])
    parser.add_argument("--order", type=int, nargs="+", default=[2, 4])
    parser.add_argument("--work", default=None)
    parser.add_argument("--mesh-only", action="store_true")
    parser.add_argument("--static", default=None, help="ccx's *STATIC data line instead of the deck's, e.g. "
                        "'0.05, 1., 1e-7, 0.25' (initial, period, minimum, maximum increment)")
    parser.add_argument("--stick", type=float, default=None, help="ccx's stick slope [N/mm^3] (default: each "
                        "run's --stiffness)")
    a = parser.parse_args()
    main(a.stiffness, a.order, a.work, a.mesh_only, a.static, a.stick)
