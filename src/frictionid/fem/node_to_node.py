"""Node-to-node contact pairs for conforming interfaces, weighted by tributary area (= dual mortar, diagonal D).

Quadratic triangle facets (tetra10 cells) go through the basis transformation of dual quadratic mortar methods
(:func:`surface_transform`): on 6-node triangles the consistent tributary area of a corner node is zero, so
the constraints and contact forces act on transformed nodal values whose tributary areas are all positive.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import skfem
from scipy.spatial import cKDTree

from ..errors import InputError
from ..model import Model
from .contact_map import FACING_DEG, check_gaps, coefficient_columns, gap_tolerance
from .pairs import ContactPairs, relative_operator, tangent_frames
from .space import Space


class MeshesDoNotMatch(InputError):
    """Contact nodes without a target node facing them: the interface is not conforming (``discretisation =
    "auto"`` then takes mortar; a failed set-up check, e.g. a gap beyond the tolerance, is not this)."""


def facet_integral(space: Space, boundary: str, vector: bool = False) -> np.ndarray:
    """Per-node integrals over a boundary: int N_i dS (n_nodes,) or int N_i n dS (n_nodes, dim) [mm^2].

    Axisymmetric integrals include the ring factor 2 pi r; ``n`` is the outward normal of the adjacent cell.
    """
    basis = space.facet_basis(boundary, vector=False)
    if not vector:
        return space.nodal(skfem.asm(skfem.LinearForm(lambda v, w: v * space.ring(w.x)), basis))
    out = np.column_stack([
        space.nodal(skfem.asm(skfem.LinearForm(lambda v, w, c=c: v * w.n[c] * space.ring(w.x)), basis))
        for c in range(space.dim)])
    return out


#: the transformation parameter of 6-node triangles: tributary areas 2 alpha A / 3 (corner), (1 - 2 alpha) A / 3
#: (mid-side) of a facet of area A; 1/5 as in Popp, Wohlmuth, Gee & Wall (2012), see :func:`surface_transform`;
#: any 0 < alpha < 1/2 gives positive areas, and the tests hold for any such value (the patch test exactly)
TRI6_ALPHA = 0.2


def surface_transform(mesh, facets: np.ndarray,
                      alpha: float = TRI6_ALPHA) -> tuple[sp.csr_matrix, sp.csr_matrix] | None:
    """(M, P = M^-T), both (n_nodes, n_nodes), of the basis transformation on 6-node triangle facets; None else.

    The consistent tributary area int N_i dS of a 6-node triangle's corner is zero (mid-side nodes A / 3), so
    a node-to-node constraint there carries no area: no pressure, no zone share, no normal. Dual quadratic mortar
    methods transform the surface basis instead (Wohlmuth, Popp, Gee & Wall, Comput. Mech. 49 (2012) 735-747;
    Popp, Wohlmuth, Gee & Wall, SIAM J. Sci. Comput. 34 (2012) B421-B446): element by element,

        N^_c = N_c + alpha (N_m1 + N_m2)    (corner c, m1 and m2 the mid-side nodes of its two edges)
        N^_m = (1 - 2 alpha) N_m            (mid-side node m),

    i.e. ``N^ = M N``, still a partition of unity, with tributary areas int N^_c = 2 alpha A / 3 and
    int N^_m = (1 - 2 alpha) A / 3 per facet (alpha = 1/5: 2A/15 and A/5), all positive. A field u = sum N_j u_j =
    sum N^_j u^_j has the transformed nodal values ``u^ = P u`` with ``P = M^-T``: u^_c = u_c and
    u^_m = (u_m - alpha (u_a + u_b)) / (1 - 2 alpha) on the edge (a, b). The contact constraints (gap, slip) act
    on transformed values and the contact forces lam are their conjugates; the nodal forces are ``P^T lam``, whose
    sum is the sum of lam (the rows of P sum to 1), so reactions and zone forces balance as before. A uniform
    pressure p gives lam_j = p int N^_j at every node, so lam / tributary area reproduces it
    (tests/test_tetra10_contact.py; with the same areas but the constraints on untransformed values the corners
    carry no force and the mid-side nodes 5/3 of p).

    ``facets``: (n_facets, n_facet_nodes) node indices in meshio order (triangle6: corners 0-2, then the
    mid-side nodes of edges 0-1, 1-2, 2-0).
    """
    if mesh.facet_type != "triangle6" or not len(facets):
        return None
    mids = np.concatenate([facets[:, 3 + e] for e in range(3)])
    ends = np.concatenate([facets[:, [e, (e + 1) % 3]] for e in range(3)])
    mids, first = np.unique(mids, return_index=True)                       # an edge of two facets counts once
    a, b = ends[first, 0], ends[first, 1]
    n, others = mesh.n_nodes, np.setdiff1d(np.arange(mesh.n_nodes), mids)
    ones, scale = np.ones(len(others)), 1.0 / (1 - 2 * alpha)
    M = sp.csr_matrix((np.concatenate([ones, np.full(len(mids), 1 - 2 * alpha), np.full(2 * len(mids), alpha)]),
                       (np.concatenate([others, mids, a, b]), np.concatenate([others, mids, mids, mids]))),
                      shape=(n, n))
    P = sp.csr_matrix((np.concatenate([ones, np.full(len(mids), scale), np.full(2 * len(mids), -alpha * scale)]),
                       (np.concatenate([others, mids, mids, mids]), np.concatenate([others, mids, a, b]))),
                      shape=(n, n))
    return M, P


def _transformed(transform, nodal: np.ndarray) -> np.ndarray:
    """Integrals of the transformed basis N^ = M N from those of N (rows: nodes); unchanged without a transform."""
    return nodal if transform is None else transform[0] @ nodal


def _pair_targets(space: Space, contact: np.ndarray, target: np.ndarray, normal: np.ndarray,
                  contact_normal: np.ndarray, h: float, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Index into ``target`` of the node facing each contact node (an initial gap is allowed), and the angle
    [deg] between the contact normal and the reversed target normal there.

    Among the 32 nearest target nodes, those whose outward normal opposes the contact node's within
    :data:`~frictionid.fem.contact_map.FACING_DEG` are candidates (a target spanning two bodies, e.g. the pads
    above and below a clamped strip, offers the far body's face too, facing the same way as the contact node: it
    is never a partner); of these, the one closest to the contact node across the bisector of the target normal
    and the reversed contact normal is taken. Along the target normal alone, curved surfaces that gape apart
    (Hertz: gap x^2 / 2R, tilt x / R) picked the neighbour once gap * tilt exceeded half the node spacing, inside
    the contact on fine meshes. The pick must lie within 5 % of the facet size ``h`` [mm] plus the initial gap
    across that direction.
    """
    points = space.mesh.points
    k = min(32, len(target))
    _, near = cKDTree(points[target]).query(points[contact], k=k)
    near = near.reshape(len(contact), k)
    offset = points[contact][:, None, :] - points[target][near]              # (n_contact, k, dim)
    cosine = -np.sum(normal[near] * contact_normal[:, None, :], axis=2)       # 1: facing exactly
    facing = cosine >= np.cos(np.radians(FACING_DEG))
    n = normal[near] - contact_normal[:, None, :]                             # |n| >= 2 sin(67.5 deg) if facing
    n = np.divide(n, np.linalg.norm(n, axis=2)[:, :, None], out=np.zeros_like(n), where=facing[:, :, None])
    tangential = np.linalg.norm(offset - np.sum(offset * n, axis=2)[:, :, None] * n, axis=2)
    tangential[~facing] = np.inf
    best = np.argmin(tangential, axis=1)
    pick = np.arange(len(contact)), best
    gap = np.abs(np.sum(offset * n, axis=2))[pick]
    miss = ~(tangential[pick] <= 0.05 * h + gap)
    if np.any(miss):
        i = int(np.argmax(miss))
        faced = "no target node facing it" if facing[i].any() else \
            f"no target node whose surface faces it (normals opposed within {FACING_DEG:g} deg)"
        raise MeshesDoNotMatch(f"[[model.interfaces]] {name!r}: {int(miss.sum())} of {len(contact)} contact nodes "
                               f"have no partner, e.g. the node at {np.round(points[contact[i]], 6).tolist()}: {faced} "
                               f"(within {0.05 * h:.3g} mm across the normal); the meshes do not match: use "
                               "discretisation = 'mortar' or make the meshes conforming")
    return near[pick], np.degrees(np.arccos(np.clip(cosine[pick], -1.0, 1.0)))


def _unit_normals(integrals: np.ndarray, nodes: np.ndarray, points: np.ndarray, what: str) -> np.ndarray:
    """Unit normals (len(nodes), dim) at ``nodes`` from the nodal integrals int N n dS (n_nodes, dim); an
    :class:`InputError` where they cancel (facets of opposite normals meeting at a node: a surface folded back)."""
    normal = integrals[nodes]
    length = np.linalg.norm(normal, axis=1)
    cancel = length <= 1e-9 * np.abs(integrals).max(initial=0.0)
    if cancel.any():
        node = int(nodes[np.argmax(cancel)])
        raise InputError(f"[[model.interfaces]]: {int(cancel.sum())} node(s) of {what} have no normal (the normals "
                         f"of their facets cancel), e.g. the node at {np.round(points[node], 6).tolist()}: a surface "
                         "folded back on itself; give each side of a thin part its own boundary")
    return normal / length[:, None]


def _pair_normals(offset: np.ndarray, target_normal: np.ndarray, h: float) -> np.ndarray:
    """Unit normal of each pair: the direction joining its nodes where they are apart, else the target normal.

    The gap is measured along the line joining the nodes, so that line must be the normal: with the target's
    surface normal instead, closing a gap between curved surfaces paired along another direction (Hertz,
    Cattaneo-Mindlin: nodes at the same abscissa) would show up as spurious tangential slip, gap * sin(tilt).
    The direction is oriented like the target normal (an interference points the other way). Nodes closer
    than 1e-6 of the facet size ``h`` [mm] count as coincident (their offset is round-off), and so do nodes whose
    offset lies more across the target normal than along it (over 45 deg from it): that is a mismatch of the two
    meshes along the surface, not a gap, and the line joining them is no normal (it would lie in the surface).
    """
    length = np.linalg.norm(offset, axis=1)
    along = np.abs(np.sum(offset * target_normal, axis=1))
    apart = (length > 1e-6 * h) & (along >= length / np.sqrt(2.0))
    direction = np.divide(offset, length[:, None], out=np.zeros_like(offset), where=apart[:, None])
    direction *= np.sign(np.sum(direction * target_normal, axis=1))[:, None]
    return np.where(apart[:, None], direction, target_normal)


def node_to_node_pairs(space: Space, model: Model, interface_index: int) -> ContactPairs:
    """Contact pairs of a conforming interface: each contact-side node paired with its coincident target node.

    The frame normal is the direction joining the two nodes where they are apart (see :func:`_pair_normals`),
    else the area-weighted outward normal of the target side at the target node; the initial gap is the
    distance between the nodes along it (negative for an interference).

    On 6-node triangle facets (tetra10 cells) every quantity of a pair is that of the transformed basis of
    :func:`surface_transform`, on both sides alike: tributary areas, zone shares and normals are integrals of
    N^, and the relative displacement, the initial offset and hence the gap are the transformed values
    ``P (u_contact - u_target)`` at the pair's node.
    """
    interface = model.interfaces[interface_index]
    mesh = space.mesh
    contact = np.unique(np.concatenate([mesh.boundary_nodes(zone) for zone in interface.zones]))
    transform = surface_transform(mesh, np.vstack([mesh.boundary(zone) for zone in interface.zones]))
    target_transform = surface_transform(mesh, mesh.boundary(interface.target))
    area = _transformed(transform, np.column_stack([facet_integral(space, zone) for zone in interface.zones]))
    # shape functions of nodes off a facet evaluate to round-off (1e-36) there: not part of the zone
    area[np.abs(area) <= 1e-12 * np.abs(area).max(initial=0.0)] = 0.0
    weight = area[contact].sum(axis=1)
    if np.any(weight <= 0):
        raise InputError(f"interface {interface.name!r}: contact node {int(contact[np.argmin(weight)])} has a "
                         f"tributary area of {weight.min():.3g} mm^2 ({mesh.facet_type} facets): a facet of "
                         "zero area or folded over; check the mesh there")
    target_all = mesh.boundary_nodes(interface.target)
    if np.intersect1d(target_all, contact).size:
        raise InputError(f"interface {interface.name!r}: zones and target {interface.target!r} share nodes; "
                         "the two bodies must have separate nodes at the interface")
    normal_all = _unit_normals(_transformed(target_transform, facet_integral(space, interface.target, vector=True)),
                               target_all, mesh.points, f"target {interface.target!r} of interface {interface.name!r}")
    contact_normal = _unit_normals(_transformed(transform, sum(facet_integral(space, zone, vector=True)
                                                               for zone in interface.zones)),
                                   contact, mesh.points, f"the zones of interface {interface.name!r}")
    facets = mesh.boundary(interface.target)
    h = np.median(np.linalg.norm(mesh.points[facets[:, 1]] - mesh.points[facets[:, 0]], axis=1))
    index, facing = _pair_targets(space, contact, target_all, normal_all, contact_normal, h, interface.name)
    target = target_all[index]
    points = mesh.points
    # pair j couples the contact nodes k with P[j, k] and their targets with -P[j, k] (identity if untransformed)
    mix = None if transform is None else transform[1][contact][:, contact].tocsr()
    offset = points[contact] - points[target]
    if mix is not None:
        offset = mix @ offset
    normal = _pair_normals(offset, normal_all[index], h)
    if interface.lead and space.dim == 3:
        from .twist import on_helicoid
        normal = on_helicoid(normal, points[contact], interface.lead)
    frames = tangent_frames(normal)
    gap = np.sum(offset * normal, axis=1)
    check_gaps(interface, gap, points[contact], gap_tolerance(mesh, interface), "node-to-node")
    return ContactPairs(
        nodes=contact, position=points[contact].copy(), frames=frames, weight=weight,
        zone_share=(area[contact] / weight[:, None]) @ coefficient_columns(model, interface), gap=gap,
        B=_pair_operator(frames, contact, target, mix, space.n_dofs), interface=np.full(len(contact), interface_index),
        facing=facing)



def _pair_operator(frames: np.ndarray, contact: np.ndarray, target: np.ndarray, mix: sp.csr_matrix | None,
                   n_dofs: int) -> sp.csr_matrix:
    """B of the pairs: ``w_j = frames[j] . sum_k mix[j, k] (u[contact[k]] - u[target[k]])`` (mix: identity if
    None, else the transformed values of :func:`surface_transform` restricted to the contact nodes)."""
    ones = np.ones((len(contact), 1))
    if mix is None:
        return relative_operator(frames, contact, target[:, None], ones, n_dofs)
    dim = frames.shape[1]
    difference = relative_operator(np.broadcast_to(np.eye(dim), frames.shape), contact, target[:, None], ones,
                                   n_dofs)
    return (sp.block_diag(list(frames), format="csr") @ sp.kron(mix, sp.eye(dim), format="csr")
            @ difference).tocsr()
