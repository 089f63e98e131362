"""Node-to-node contact pairs for conforming interfaces, weighted by tributary area (= dual mortar, diagonal D)."""

from __future__ import annotations

import numpy as np
import skfem
from scipy.spatial import cKDTree

from ..errors import InputError
from ..model import Model
from .pairs import ContactPairs, relative_operator, tangent_frames
from .space import Space


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


def _pair_targets(space: Space, contact: np.ndarray, target: np.ndarray, normal: np.ndarray,
                  contact_normal: np.ndarray, h: float, name: str) -> np.ndarray:
    """Index into ``target`` of the node facing each contact node (an initial gap is allowed).

    Among the 32 nearest target nodes, the one closest to the contact node across the bisector of the target
    normal and the reversed contact normal is taken. Along the target normal alone, curved surfaces that gape
    apart (Hertz: gap x^2 / 2R, tilt x / R) picked the neighbour once gap * tilt exceeded half the node
    spacing, inside the contact on fine meshes. The pick must lie within 5 % of the facet size ``h`` [mm]
    plus the initial gap across that direction.
    """
    points = space.mesh.points
    k = min(32, len(target))
    _, near = cKDTree(points[target]).query(points[contact], k=k)
    near = near.reshape(len(contact), k)
    offset = points[contact][:, None, :] - points[target][near]              # (n_contact, k, dim)
    n = normal[near] - contact_normal[:, None, :]
    n /= np.linalg.norm(n, axis=2)[:, :, None]
    tangential = np.linalg.norm(offset - np.sum(offset * n, axis=2)[:, :, None] * n, axis=2)
    best = np.argmin(tangential, axis=1)
    pick = np.arange(len(contact)), best
    gap = np.abs(np.sum(offset * n, axis=2))[pick]
    miss = tangential[pick] > 0.05 * h + gap
    if np.any(miss):
        i = int(np.argmax(miss))
        raise InputError(f"interface {name!r}: contact node at {np.round(points[contact[i]], 6).tolist()} has no "
                         f"target node facing it (within {0.05 * h:.3g} mm across the normal); the meshes do not "
                         "match: use discretisation = 'mortar' (2-D) or make the meshes conforming")
    return near[np.arange(len(contact)), best]


def _pair_normals(offset: np.ndarray, target_normal: np.ndarray, h: float) -> np.ndarray:
    """Unit normal of each pair: the direction joining its nodes where they are apart, else the target normal.

    The gap is measured along the line joining the nodes, so that line must be the normal: with the target's
    surface normal instead, closing a gap between curved surfaces paired along another direction (Hertz,
    Cattaneo-Mindlin: nodes at the same abscissa) would show up as spurious tangential slip, gap * sin(tilt).
    The direction is oriented like the target normal (an interference points the other way). Nodes closer
    than 1e-6 of the facet size ``h`` [mm] count as coincident (their offset is round-off).
    """
    length = np.linalg.norm(offset, axis=1)
    apart = length > 1e-6 * h
    direction = np.divide(offset, length[:, None], out=np.zeros_like(offset), where=apart[:, None])
    direction *= np.sign(np.sum(direction * target_normal, axis=1))[:, None]
    return np.where(apart[:, None], direction, target_normal)


def node_to_node_pairs(space: Space, model: Model, interface_index: int) -> ContactPairs:
    """Contact pairs of a conforming interface: each contact-side node paired with its coincident target node.

    The frame normal is the direction joining the two nodes where they are apart (see :func:`_pair_normals`),
    else the area-weighted outward normal of the target side at the target node; the initial gap is the
    distance between the nodes along it (negative for an interference).
    """
    interface = model.interfaces[interface_index]
    zone_offset = model.zone_names.index(interface.zones[0])
    contact = np.unique(np.concatenate([space.mesh.boundary_nodes(zone) for zone in interface.zones]))
    area = np.column_stack([facet_integral(space, zone) for zone in interface.zones])
    # shape functions of nodes off a facet evaluate to round-off (1e-36) there: not part of the zone
    area[np.abs(area) <= 1e-12 * np.abs(area).max(initial=0.0)] = 0.0
    weight = area[contact].sum(axis=1)
    if np.any(weight <= 0):
        raise InputError(f"interface {interface.name!r}: contact node {int(contact[np.argmin(weight)])} has a "
                         f"tributary area of {weight.min():.3g} mm^2; {space.mesh.facet_type} facets give corner "
                         "nodes zero or negative weights: use hexahedra or linear tetrahedra in 3-D")
    target_all = space.mesh.boundary_nodes(interface.target)
    if np.intersect1d(target_all, contact).size:
        raise InputError(f"interface {interface.name!r}: zones and target {interface.target!r} share nodes; "
                         "the two bodies must have separate nodes at the interface")
    normal_all = facet_integral(space, interface.target, vector=True)[target_all]
    normal_all /= np.linalg.norm(normal_all, axis=1)[:, None]
    contact_normal = sum(facet_integral(space, zone, vector=True) for zone in interface.zones)[contact]
    contact_normal /= np.linalg.norm(contact_normal, axis=1)[:, None]
    facets = space.mesh.boundary(interface.target)
    h = np.median(np.linalg.norm(space.mesh.points[facets[:, 1]] - space.mesh.points[facets[:, 0]], axis=1))
    index = _pair_targets(space, contact, target_all, normal_all, contact_normal, h, interface.target)
    target = target_all[index]
    normal = _pair_normals(space.mesh.points[contact] - space.mesh.points[target], normal_all[index], h)
    frames = tangent_frames(normal)
    points = space.mesh.points
    share = np.zeros((len(contact), model.n_zones))
    share[:, zone_offset:zone_offset + len(interface.zones)] = area[contact] / weight[:, None]
    return ContactPairs(
        nodes=contact, position=points[contact].copy(), frames=frames, weight=weight, zone_share=share,
        gap=np.sum((points[contact] - points[target]) * normal, axis=1),
        B=relative_operator(frames, contact, target[:, None], np.ones((len(contact), 1)), space.n_dofs),
        interface=np.full(len(contact), interface_index))
