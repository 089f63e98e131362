"""Contact pairs whose tangential relative motion the supports hold (symmetry planes): the support carries the
tangential force there, the friction force in that direction is zero and the remaining direction sticks or slips
as usual (fem/contact.py, free_tangents).

The check is symmetry: a block on a plate, loaded symmetrically about the planes x = 0 (and y = 0), modelled
whole and as its half (quarter) with those planes held in the normal displacement of both bodies, must give the
same displacements, contact pressures, tractions and reactions (times 2 or 4) in stick, partial and gross slip.
The meshes are structured, the half (quarter) mesh exactly the x >= 0 (and y >= 0) part of the whole one, so the
two agree to round-off and the solver tolerance: 1e-8 of each quantity's range.
"""

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

import frictionid.fem.interface as interface_module
import frictionid.fem.problem as problem_module
from frictionid.backends.calculix.backend import CalculixBackend
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.errors import SolverError
from frictionid.fem.contact import SLIP, STICK, free_tangents
from frictionid.fem.problem import Problem
from frictionid.model import ContactInterface, Displacement, Material, Mesh, Model, Pressure, Stage, Support
from frictionid.model.mesh import CELL_FACETS

from helpers import check_sensitivities, needs_ccx
from test_calculix_run import rms_of_range

PLATE, BLOCK = Material(3500.0, 0.35), Material(71000.0, 0.33)
MU = np.array([0.3, 0.45])          # zones "centre" (|x|, |y| < 2.5 mm) and "rim" of the block's bottom
A, L = 5.0, 10.0                    # block half-width and plate half-width [mm]


def _lines(half: float, inner: float, n_inner: int, n_outer: int, whole: bool) -> np.ndarray:
    """Grid lines on [0, half] (mirrored onto [-half, half] if ``whole``): n_inner cells up to ``inner``, then
    n_outer cells."""
    lines = np.concatenate([np.linspace(0.0, inner, n_inner + 1), np.linspace(inner, half, n_outer + 1)[1:]])
    return np.concatenate([-lines[:0:-1], lines]) if whole else lines


def _grid(axes: list[np.ndarray], offset: int):
    """Structured grid of hexahedra (3 axes) or quadrilaterals (2) in meshio's node order."""
    dim = len(axes)
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    index = np.arange(len(points)).reshape([len(a) for a in axes]) + offset
    if dim == 2:
        c = index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]
    else:
        c = (index[:-1, :-1, :-1], index[1:, :-1, :-1], index[1:, 1:, :-1], index[:-1, 1:, :-1],
             index[:-1, :-1, 1:], index[1:, :-1, 1:], index[1:, 1:, 1:], index[:-1, 1:, 1:])
    return points, np.stack([a.ravel() for a in c], axis=1)


def _outer_facets(cell_type: str, cells: np.ndarray) -> np.ndarray:
    facets = np.concatenate([cells[:, list(local)] for local in CELL_FACETS[cell_type]])
    _, index, count = np.unique(np.sort(facets, axis=1), axis=0, return_index=True, return_counts=True)
    return facets[index[count == 1]]


def block_on_plate(dim: int, whole: bool, n: int = 2) -> Mesh:
    """A block (half-width A, height 5) on a plate (half-width L, thickness 3), the block's bottom on the plate's
    top at the vertical coordinate 0 with coincident but separate nodes; the whole model or its x >= 0 half (2-D)
    / x, y >= 0 quarter (3-D). Boundaries: ``{body}_top``, ``plate_bottom``, ``{body}_x0`` / ``_y0`` (symmetry
    planes), ``plate_x+`` / ``plate_x-`` / ``plate_y+`` / ``plate_y-`` (the plate's sides), zones ``centre`` and
    ``rim`` on the block's bottom, target ``plate_top``."""
    lateral = _lines(A, A / 2, n, n, whole), _lines(L, A, 2 * n, n, whole)      # block, plate
    vertical = (np.linspace(0.0, 5.0, 2 * n + 1), np.linspace(-3.0, 0.0, n + 1))
    bodies = {}
    for b, name in enumerate(("block", "plate")):
        axes = [lateral[b]] * (dim - 1) + [vertical[b]]
        bodies[name] = _grid(axes, sum(len(p) for p, _ in bodies.values()))
    points = np.vstack([p for p, _ in bodies.values()])
    cells = np.vstack([c for _, c in bodies.values()])
    cell_type = "hexahedron" if dim == 3 else "quad"
    regions = {"block": np.arange(len(bodies["block"][1])),
               "plate": np.arange(len(bodies["block"][1]), len(cells))}
    boundaries = {}
    up = dim - 1
    for name in ("block", "plate"):
        facets = _outer_facets(cell_type, cells[regions[name]])
        x = points[facets]                                                     # (n_facets, n_nodes, dim)

        def on(axis, value):
            return np.all(np.abs(x[:, :, axis] - value) < 1e-9, axis=1)

        top = vertical[name == "plate"][-1]
        boundaries[f"{name}_top" if name == "block" else "plate_top"] = facets[on(up, top)]
        for axis, label in enumerate("xy"[:dim - 1]):
            if not whole:
                boundaries[f"{name}_{label}0"] = facets[on(axis, 0.0)]
            if name == "plate":
                boundaries[f"plate_{label}+"] = facets[on(axis, L)]
                if whole:
                    boundaries[f"plate_{label}-"] = facets[on(axis, -L)]
        if name == "plate":
            boundaries["plate_bottom"] = facets[on(up, vertical[1][0])]
        else:
            bottom = facets[on(up, 0.0)]
            centre = np.all(np.abs(points[bottom].mean(axis=1)[:, :dim - 1]) < A / 2, axis=1)
            boundaries["centre"], boundaries["rim"] = bottom[centre], bottom[~centre]
    return Mesh(points, cell_type, cells, regions, boundaries)


def symmetric_model(dim: int, whole: bool, stretch=(0.0, 0.004, 0.03), n: int = 2) -> Model:
    """Press the block's top (20 MPa; its top held laterally), then stretch the plate symmetrically: its sides
    driven outwards by ``stretch`` [mm] per stage, its bottom held vertically. With :data:`STRETCH` the stages
    are: press (every pair sticks), a small stretch (partial slip), a large one (gross slip)."""
    mesh = block_on_plate(dim, whole, n)
    up = dim - 1
    supports = [Support("plate_bottom", (up,)), Support("block_top", tuple(range(dim - 1)))]
    loads = [Pressure("block_top", (20.0,) * len(stretch))]
    for axis, label in enumerate("xy"[:dim - 1]):
        loads.append(Displacement(f"plate_{label}+", axis, tuple(stretch)))
        if whole:
            loads.append(Displacement(f"plate_{label}-", axis, tuple(-s for s in stretch)))
        else:
            supports += [Support(f"block_{label}0", (axis,)), Support(f"plate_{label}0", (axis,))]
    stages = tuple(Stage(name, k) for name, k in zip(("press", "partial", "gross"), (1, 2, 2)))
    return Model(mesh, "3d" if dim == 3 else "plane_strain", {"block": BLOCK, "plate": PLATE},
                 supports=tuple(supports), loads=tuple(loads), stages=stages[:len(stretch)],
                 interfaces=(ContactInterface("contact", ("centre", "rim"), "plate_top",
                                              discretisation="node-to-node"),))


STRETCH = (0.0, 0.015, 0.05)


def _node_map(whole: Mesh, part: Mesh) -> np.ndarray:
    """Index of each node of ``part`` in ``whole``: same position, same body (the interface nodes coincide)."""
    out = np.full(part.n_nodes, -1)
    for body in ("block", "plate"):
        nodes = np.unique(part.cells[part.regions[body]])
        candidates = np.unique(whole.cells[whole.regions[body]])
        distance = np.linalg.norm(part.points[nodes][:, None, :] - whole.points[candidates][None], axis=2)
        out[nodes] = candidates[np.argmin(distance, axis=1)]
        assert np.all(distance.min(axis=1) < 1e-12)
    return out


@pytest.fixture(scope="module", params=[2, 3], ids=["plane-strain-half", "3d-quarter"])
def solved(request):
    """(whole problem, its solution, part problem, its solution) with sensitivities."""
    dim = request.param
    out = []
    for whole in (True, False):
        problem = Problem.build(symmetric_model(dim, whole, STRETCH))
        out += [problem, problem.solve(MU, sensitivities=True)]
    return out


def test_the_supports_hold_the_symmetry_planes_pairs_in_their_normal_direction_only(solved):
    """The held directions found are exactly the pairs on the planes, in the plane's normal (the frames' t1 = x,
    t2 = y), the corner pair of the 3-D quarter in both; the condensed compliance W is zero there and only there."""
    whole, _, part, _ = solved
    dim = part.pairs.dim
    assert free_tangents(whole.pairs.B, whole.condensed.free, dim) is None
    E = free_tangents(part.pairs.B, part.condensed.free, dim)
    position = part.pairs.position
    on_plane = np.abs(position[:, :dim - 1]) < 1e-12                         # (n_pairs, dim - 1): x = 0, y = 0
    np.testing.assert_allclose(part.pairs.frames[:, 1:, :dim - 1], np.broadcast_to(np.eye(dim - 1),
                                                                                    on_plane.shape + (dim - 1,)))
    np.testing.assert_array_equal(E, np.einsum("ij,ni->nij", np.eye(dim - 1), (~on_plane).astype(float)))
    compliance = np.diag(part.condensed.gap_ops.on_lam).reshape(-1, dim)[:, 1:]
    assert np.all(compliance[on_plane] == 0.0)
    assert compliance[~on_plane].min() > 1e-3 * compliance.max()
    if dim == 3:
        assert np.all(on_plane, axis=1).sum() == 1 and np.any(on_plane, axis=1).sum() == 9


def test_half_model_gives_the_whole_models_solution(solved):
    """Displacements at every node, pressure and tangential traction at every pair, reactions (the part's times
    2 or 4) and their sensitivities at the end of each stage: press (all stick), partial slip, gross slip (all
    but the centre pair, which symmetry keeps still), to 1e-8 of each quantity's largest value. The friction
    force in a held direction is zero."""
    whole, sw, part, sp_ = solved
    dim = part.pairs.dim
    nodes = _node_map(whole.model.mesh, part.model.mesh)
    pair = np.searchsorted(whole.pairs.nodes, nodes[part.pairs.nodes])
    assert np.array_equal(whole.pairs.nodes[pair], nodes[part.pairs.nodes])
    counts = [np.bincount(sp_.state[sp_.stage_end(s)], minlength=3) for s in range(3)]
    assert counts[0][STICK] == part.pairs.n_pairs                                             # stick
    assert counts[1][STICK] > 0 and counts[1][SLIP] > 0                                       # partial slip
    assert counts[2][SLIP] == part.pairs.n_pairs - 1                                          # gross slip
    factor = {"plate_bottom": 2 ** (dim - 1), "plate_x+": 2 ** (dim - 2), "plate_y+": 2}
    labels = [label for label in sp_.reaction_labels if label.split(".")[0] in factor]
    assert len(labels) == dim
    scale = np.array([factor[label.split(".")[0]] for label in labels])
    rw = [sw.reaction_labels.index(label) for label in labels]
    rp = [sp_.reaction_labels.index(label) for label in labels]
    on_plane = np.abs(part.pairs.position[:, :dim - 1]) < 1e-12
    for s in range(3):
        iw, ip = sw.stage_end(s), sp_.stage_end(s)
        np.testing.assert_array_equal(sp_.state[ip], sw.state[iw][pair])
        uw, up = whole.displacement(sw, iw), part.displacement(sp_, ip)
        np.testing.assert_allclose(up, uw[nodes], rtol=0, atol=1e-8 * np.abs(uw).max())
        np.testing.assert_allclose(sp_.pressure[ip], sw.pressure[iw][pair], rtol=0,
                                   atol=1e-8 * sw.pressure[iw].max())
        traction_w = sw.lam[iw, :, 1:] / whole.pairs.weight[:, None]
        traction_p = sp_.lam[ip, :, 1:] / part.pairs.weight[:, None]
        np.testing.assert_allclose(traction_p, traction_w[pair], rtol=0, atol=1e-8 * np.abs(traction_w).max())
        assert np.all(np.abs(sp_.lam[ip, :, 1:][on_plane]) <= 1e-12 * np.abs(sp_.lam[ip]).max())
        np.testing.assert_allclose(sp_.reactions[ip, rp] * scale, sw.reactions[iw, rw], rtol=1e-8)
        np.testing.assert_allclose(sp_.d_reactions[ip, rp] * scale[:, None], sw.d_reactions[iw, rw], rtol=0,
                                   atol=1e-8 * np.abs(sw.d_reactions[iw, rw]).max())


@pytest.mark.parametrize("dim", [2, 3], ids=["plane-strain-half", "3d-quarter"])
def test_sensitivities_with_held_pairs_match_central_differences(dim):
    """d reactions / d mu of the part model at every increment against central differences (rtol 1e-6,
    h = 1e-6, the helper of the other solver tests): stick, partial and gross slip with held pairs."""
    problem = Problem.build(symmetric_model(dim, False, STRETCH))
    solution = check_sensitivities(problem, MU)
    assert np.abs(solution.d_reactions).max() > 0


def _rotated(pairs, angle: float):
    """The pairs with their tangent vectors turned by ``angle`` about the normal (3-D)."""
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])
    frames = np.einsum("ij,njk->nik", turn, pairs.frames)
    B = (sp.block_diag([turn] * pairs.n_pairs, format="csr") @ pairs.B).tocsr()
    return dataclasses.replace(pairs, frames=frames, B=B)


def test_held_directions_that_are_not_frame_axes(monkeypatch):
    """The 3-D quarter with every pair's tangent vectors turned by 30 deg about the normal: on the planes the
    held direction is then a mix of t1 and t2, its projector not diagonal, the friction force still the same
    vector, so displacements and reactions are those of the unturned frames (1e-8); sensitivities by central
    differences."""
    straight = Problem.build(symmetric_model(3, False, STRETCH))
    reference = straight.solve(MU)
    monkeypatch.setattr(problem_module, "contact_pairs",
                        lambda space, model: _rotated(interface_module.contact_pairs(space, model), np.pi / 6))
    turned = Problem.build(symmetric_model(3, False, STRETCH))
    E = free_tangents(turned.pairs.B, turned.condensed.free, 3)
    partly = (np.trace(E, axis1=1, axis2=2) > 0.5) & (np.trace(E, axis1=1, axis2=2) < 1.5)
    assert partly.sum() == 8 and np.abs(E[partly][:, 0, 1]).min() > 0.4                       # cos 30 sin 30
    solution = check_sensitivities(turned, MU)
    np.testing.assert_array_equal(solution.state, reference.state)
    for i in range(solution.n_increments):
        u = straight.displacement(reference, i)
        np.testing.assert_allclose(turned.displacement(solution, i), u, rtol=0, atol=1e-8 * np.abs(u).max())
    np.testing.assert_allclose(solution.reactions, reference.reactions, rtol=0,
                               atol=1e-8 * np.abs(reference.reactions).max())


@needs_ccx
@pytest.mark.parametrize("dim, n", [(2, 4), (3, 2)], ids=["plane-strain-half", "3d-quarter"])
def test_part_model_against_calculix(dim, n):
    """The part model in CalculiX (surface-to-surface penalty contact; the symmetry planes are plain supports
    there) against the embedded solver: block displacements within 0.5 % of their range (RMS) and every reaction,
    the symmetry planes' included, within 2 % of the stage's largest at each stage end. Measured: displacements
    0.05-0.14 %; reactions up to 1.6 % (2-D, the planes' share in gross slip: the tangential traction jumps at
    x = 0 and the two discretisations spread it differently; 0.14 % with twice the cells), 0.4 % (3-D); ccx
    about 1 s (2-D) and 1.6 s (3-D) per run."""
    model = symmetric_model(dim, False, STRETCH, n)
    if dim == 2:
        points, quantities = np.array([[x, y] for x in (1.0, 3.0, 4.5) for y in (0.5, 2.0)]), ("ux", "uy")
    else:
        points = np.array([[x, y, z] for x in (1.0, 4.5) for y in (1.0, 4.5) for z in (0.5, 2.0)])
        quantities = ("ux", "uy", "uz")
    regions = ["block"] * len(points)
    embedded = EmbeddedBackend(model, points, quantities, regions).problem.solve(MU)
    ccx = CalculixBackend(model, points, quantities, regions).solve(MU)
    assert ccx.reaction_labels == embedded.reaction_labels
    for s in range(3):
        end = embedded.stage_end(s)
        assert rms_of_range(embedded.observations[end], ccx.observations[s]) < 0.005
        reactions = embedded.reactions[end]
        np.testing.assert_allclose(ccx.reactions[s], reactions, rtol=0, atol=0.02 * np.abs(reactions).max())


@pytest.mark.parametrize("overlap", [0.0, 1e-3], ids=["touching", "overlapping"])
def test_pairs_whose_gap_the_supports_hold(overlap):
    """Supports holding both sides of the rim's pairs in the normal direction fix their gap: touching, they stay
    open with no force (the supports carry it) and the centre's pairs take the press; overlapping, no increment
    has a solution and the error names the cause and a pair."""
    model = symmetric_model(2, False, STRETCH)
    mesh = model.mesh
    points = np.array(mesh.points)
    points[np.unique(mesh.cells[mesh.regions["block"]]), 1] -= overlap
    model = dataclasses.replace(model, mesh=Mesh(points, mesh.cell_type, mesh.cells, dict(mesh.regions),
                                                 dict(mesh.boundaries)),
                                supports=model.supports + (Support("rim", (1,)), Support("plate_top", (1,))))
    problem = Problem.build(model)
    rim = problem.pairs.zone_share[:, 1] > 0                     # x = 2.5, 3.75, 5: the nodes of the rim's facets
    assert rim.sum() == 3
    if overlap:
        with pytest.raises(SolverError, match=r"supports hold both sides of 3 overlapping contact pair\(s\) in the "
                                              r"normal direction \(first at node \d+, position \[[\d.]+, -0\.001\]\)"):
            problem.solve(MU)
        return
    solution = problem.solve(MU)
    assert np.all(solution.state[:, rim] == 0) and np.all(solution.lam[:, rim] == 0.0)
    assert np.all(solution.state[:, ~rim] != 0)
