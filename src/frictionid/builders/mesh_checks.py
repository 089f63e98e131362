"""Checks of a model on a user's mesh before anything is assembled: bodies apart at their interfaces, zones on the
contact side, and every group of bodies in contact held against rigid-body motion."""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
from scipy.spatial import cKDTree

from ..errors import InputError
from ..fem.rigid import _candidate_modes, bodies
from ..model import ContactInterface, Displacement, Mesh, Model
from ..model.model import component_index

#: names of the rigid-body modes of :func:`frictionid.fem.rigid._candidate_modes`, in its order
MOTIONS = {"3d": ("translation in x", "translation in y", "translation in z", "rotation about x",
                  "rotation about y", "rotation about z"),
           "plane_strain": ("translation in x", "translation in y", "rotation in the plane"),
           "axisymmetric": ("translation along the axis (y)",)}


def check_contact_sides(mesh: Mesh, interfaces: tuple[ContactInterface, ...]) -> None:
    """Each interface's zones and target lie on different bodies with their own nodes, and each zone faces the
    target (its nearest node within one target facet size, or the interface's gap_tolerance if larger)."""
    label = bodies(mesh)
    for interface in interfaces:
        where = f"[[model.interfaces]] {interface.name!r}"
        target = mesh.boundary_nodes(interface.target)
        zones = {zone: mesh.boundary_nodes(zone) for zone in interface.zones}
        shared = np.intersect1d(np.concatenate(list(zones.values())), target)
        if shared.size:
            raise InputError(f"{where}: {shared.size} node(s) of its zones are also nodes of target "
                             f"{interface.target!r}, so the bodies share nodes at the interface and cannot slide "
                             "or separate; give each body its own, coincident nodes there (gmsh merges touching "
                             "volumes unless they are meshed as separate, unfragmented entities)")
        facets = mesh.boundary(interface.target)
        size = float(np.median(np.linalg.norm(mesh.points[facets[:, 1]] - mesh.points[facets[:, 0]], axis=1)))
        tree = cKDTree(mesh.points[target])
        for zone, nodes in zones.items():
            if np.intersect1d(label[nodes], label[target]).size:
                raise InputError(f"{where} zones: {zone!r} is not on the contact side: it lies on the same body as "
                                 f"target {interface.target!r}; a zone is a boundary of the other body")
            distance = float(tree.query(mesh.points[nodes])[0].min())
            if distance > max(size, interface.gap_tolerance or 0.0):
                raise InputError(f"{where} zones: {zone!r} is not on the contact side: its nearest node is "
                                 f"{distance:.3g} mm from target {interface.target!r} (facet size {size:.3g} mm, "
                                 f"gap_tolerance {interface.gap_tolerance or 'not given'})")


def _prescribed(model: Model) -> np.ndarray:
    """(n_nodes, dim) True where supports or prescribed displacements hold a component."""
    mesh, dim = model.mesh, model.dim
    held = np.zeros((mesh.n_nodes, dim), dtype=bool)
    for support in model.supports:
        for c in support.components:
            held[mesh.boundary_nodes(support.boundary), component_index(c, dim, support.boundary)] = True
    for load in model.loads:
        if isinstance(load, Displacement):
            held[mesh.boundary_nodes(load.boundary), component_index(load.component, dim, load.boundary)] = True
    return held


def _groups(model: Model, label: np.ndarray) -> np.ndarray:
    """(n_bodies,) group of each body: bodies that touch through an interface count as one."""
    group = np.arange(label.max() + 1)
    for interface in model.interfaces:
        nodes = np.concatenate([model.mesh.boundary_nodes(n) for n in (*interface.zones, interface.target)])
        members = np.unique(group[label[nodes]])
        group[np.isin(group, members)] = members[0]
    return group


def check_held(model: Model) -> None:
    """Every group of bodies in contact is held against each rigid-body motion by supports or prescribed
    displacements (contact can hold a body only against another body, never the group as a whole)."""
    mesh = model.mesh
    label = bodies(mesh)
    group = _groups(model, label)[label]
    held = _prescribed(model)
    for g in np.unique(group):
        nodes = np.flatnonzero(group == g)
        modes = _candidate_modes(mesh.points[nodes], model.kind)          # (n, dim, k)
        fixed = modes[held[nodes]]
        kernel = _kernel(fixed, modes.shape[2])
        if kernel.shape[1] == 0:
            continue
        free = la.qr(kernel.T, pivoting=True, mode="r")[1][:kernel.shape[1]]
        regions = [name for name, cells in mesh.regions.items() if np.isin(mesh.cells[cells, 0], nodes).any()]
        raise InputError(f"[[model.supports]]: nothing holds region(s) {regions} against rigid-body motion "
                         f"({', '.join(MOTIONS[model.kind][k] for k in sorted(free))}); the supports and "
                         "prescribed displacements must hold every body or group of bodies in contact: add a "
                         "support or components")


def _kernel(fixed: np.ndarray, n_modes: int, rcond: float = 1e-10) -> np.ndarray:
    """(n_modes, n_free) orthonormal basis of the rigid modes the held components ``fixed`` (m, n_modes) leave free.

    A thin SVD: scipy's null_space forms the full m x m U, 1.9 GB and 5 s for the 15,389 held components of a
    100k-node mesh (benchmarks/user_mesh.py), where only the n_modes x n_modes V is needed.

    >>> _kernel(np.array([[1.0, 0.0, 0.0]] * 4), 3).shape
    (3, 2)
    """
    if not len(fixed):
        return np.eye(n_modes)
    _, s, vt = la.svd(fixed, full_matrices=len(fixed) < n_modes)
    rank = int(np.sum(s > rcond * s.max())) if s.size and s.max() > 0 else 0
    return vt[rank:].T
