"""Conversion of the current gmsh model (or a .msh file) into a frictionid Mesh, physical groups as names."""

from __future__ import annotations

import contextlib
import logging
from pathlib import Path

import gmsh
import numpy as np
from meshio.gmsh.common import _gmsh_to_meshio_order, _gmsh_to_meshio_type

from ..errors import InputError
from ..model.mesh import CELL_DIM, FACET_NODES, FACET_TYPE, Mesh

log = logging.getLogger(__name__)


@contextlib.contextmanager
def gmsh_session(name: str = "frictionid"):
    """Initialise gmsh quietly for the duration of a block and always finalise it.

    ``interruptible=False``: otherwise gmsh sets SIGINT to the system default (Ctrl-C kills the process without
    a result or a message) and, in gmsh 4.15, never restores Python's handler at finalize."""
    gmsh.initialize(["-noenv"], readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(name)
        yield gmsh
    finally:
        gmsh.finalize()


def distance_size_field(curves, size_min: float, size_max: float, distance: float, sampling: int = 20) -> int:
    """A gmsh Threshold field: size ``size_min`` on the curves, growing linearly to ``size_max`` at ``distance``
    [mm] from them; returns its tag (see :func:`use_size_fields`)."""
    field = gmsh.model.mesh.field
    near = field.add("Distance")
    field.setNumbers(near, "CurvesList", list(curves))
    field.setNumber(near, "Sampling", sampling)
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", near)
    for name, value in (("SizeMin", size_min), ("SizeMax", max(size_min, size_max)), ("DistMin", 0.0),
                        ("DistMax", max(distance, 1e-12))):
        field.setNumber(threshold, name, value)
    return threshold


def use_size_fields(*fields: int) -> None:
    """Mesh with the smallest of the given fields' sizes, and with them alone (no sizes from points or curvature)."""
    field = gmsh.model.mesh.field
    if len(fields) > 1:
        minimum = field.add("Min")
        field.setNumbers(minimum, "FieldsList", list(fields))
        fields = (minimum,)
    field.setAsBackgroundMesh(fields[0])
    for option in ("Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature", "Mesh.MeshSizeExtendFromBoundary"):
        gmsh.option.setNumber(option, 0)


def _elements(dim: int, tag: int = -1) -> dict[str, np.ndarray]:
    """Node tags per meshio cell type (meshio node order) of the entities of dimension dim (or one entity)."""
    out = {}
    types, _, node_tags = gmsh.model.mesh.getElements(dim, tag)
    for gmsh_type, nodes in zip(types, node_tags):
        cell_type = _gmsh_to_meshio_type[int(gmsh_type)]
        n = gmsh.model.mesh.getElementProperties(int(gmsh_type))[3]
        out[cell_type] = _gmsh_to_meshio_order(cell_type, np.asarray(nodes, dtype=np.int64).reshape(-1, n))
    return out


def _groups(dim: int, source: str) -> dict[str, list[np.ndarray]]:
    groups: dict[str, list[np.ndarray]] = {}
    for d, tag in gmsh.model.getPhysicalGroups(dim):
        name = gmsh.model.getPhysicalName(d, tag) or f"{d}:{tag}"
        for entity in gmsh.model.getEntitiesForPhysicalGroup(d, tag):
            for cells in _elements(d, int(entity)).values():
                groups.setdefault(name, []).append(cells)
    return groups


def mesh_from_gmsh(source: str = "gmsh model") -> Mesh:
    """The mesh of the current gmsh model as a :class:`Mesh`.

    Regions are the physical groups of the top dimension, boundaries those one dimension lower.
    Nodes not used by any cell are dropped and the rest numbered 0..n-1.
    """
    return mesh_and_node_sets_from_gmsh(source)[0]


def mesh_and_node_sets_from_gmsh(source: str = "gmsh model") -> tuple[Mesh, dict[str, np.ndarray]]:
    """:func:`mesh_from_gmsh` and the node sets: the nodes (0-based, as in the mesh) of each physical group of
    points, and in 3-D of curves, i.e. of every group below the boundaries' dimension."""
    dim = gmsh.model.getDimension()
    if dim not in (2, 3):
        raise InputError(f"{source}: has no 2-D or 3-D mesh (dimension {dim})")
    cells_by_type = _elements(dim)
    if len(cells_by_type) != 1:
        raise InputError(f"{source}: needs exactly one cell type, found {sorted(cells_by_type) or 'none'}")
    (cell_type, cells), = cells_by_type.items()
    if cell_type not in FACET_TYPE or CELL_DIM[cell_type] != dim:
        raise InputError(f"{source}: cell type {cell_type!r} is not supported; expected one of {sorted(FACET_TYPE)}")
    node_tags, coords, _ = gmsh.model.mesh.getNodes()
    coords = np.asarray(coords).reshape(-1, 3)[:, :dim]
    used = np.unique(cells)
    index = np.full(int(max(node_tags.max(), used.max())) + 1, -1, dtype=np.int64)
    index[used] = np.arange(len(used))
    points = np.empty((len(used), dim))
    points[index[node_tags[np.isin(node_tags, used)]]] = coords[np.isin(node_tags, used)]

    # cells of a region are found by their sorted node tags: gmsh numbers elements globally
    key_of = {tuple(sorted(c)): i for i, c in enumerate(cells.tolist())}
    regions = {}
    for name, parts in _groups(dim, source).items():
        regions[name] = np.array([key_of[tuple(sorted(c))] for part in parts for c in part.tolist()], dtype=np.int64)
    boundaries = {}
    for name, parts in _groups(dim - 1, source).items():
        facets = [p for p in parts if p.shape[1] == FACET_NODES[FACET_TYPE[cell_type]]]
        if not facets:
            continue
        stacked = np.vstack(facets)
        if np.any(index[stacked] < 0):
            raise InputError(f"{source}: boundary {name!r} has nodes that belong to no cell")
        boundaries[name] = index[stacked]
    mesh = Mesh(points=points, cell_type=cell_type, cells=index[cells], regions=regions, boundaries=boundaries)
    return mesh, _node_sets(dim, index, source)


def _node_sets(dim: int, index: np.ndarray, source: str) -> dict[str, np.ndarray]:
    """Mesh nodes of the physical groups of dimension below dim - 1, by name (``index``: gmsh tag -> node).

    Nodes of no cell (construction geometry outside the mesh) are left out; a group with none left is not a
    node set (a warning names it), so a file with such groups still reads as before."""
    sets: dict[str, np.ndarray] = {}
    for d in range(dim - 1):
        for _, tag in gmsh.model.getPhysicalGroups(d):
            name = gmsh.model.getPhysicalName(d, tag) or f"{d}:{tag}"
            tags = np.asarray(gmsh.model.mesh.getNodesForPhysicalGroup(d, tag)[0], dtype=np.int64)
            nodes = index[tags[tags < len(index)]]
            if not np.any(nodes >= 0):
                log.warning("%s: physical group %r (%s) has no node of a cell; it is no node set", source, name,
                            "points" if d == 0 else "curves")
                continue
            sets[name] = np.union1d(sets.get(name, np.zeros(0, np.int64)), nodes[nodes >= 0])
    return sets


def read_msh(path: str | Path) -> Mesh:
    """Read a gmsh .msh file; physical groups become regions and boundaries."""
    return read_gmsh_file(path)[0]


def read_geo(path: str | Path) -> Mesh:
    """Mesh a gmsh .geo file with the installed gmsh (its own options, e.g. ``Mesh.ElementOrder``, apply) in the
    dimension of its geometry; physical groups become regions and boundaries."""
    return read_gmsh_file(path)[0]


def read_gmsh_file(path: str | Path, size_factor: float = 1.0) -> tuple[Mesh, dict[str, np.ndarray]]:
    """A .msh read or a .geo meshed (see :func:`read_msh`, :func:`read_geo`): the mesh and its node sets
    (:func:`mesh_and_node_sets_from_gmsh`); a .geo's element sizes are multiplied by ``size_factor`` (on top of
    its own ``Mesh.MeshSizeFactor``)."""
    path = Path(path)
    geo = path.suffix.lower() == ".geo"
    if not path.is_file():
        raise InputError(f"{path}: {'geometry' if geo else 'mesh'} file not found")
    with gmsh_session():
        try:
            gmsh.open(str(path))
            if geo:
                factor = gmsh.option.getNumber("Mesh.MeshSizeFactor")
                gmsh.option.setNumber("Mesh.MeshSizeFactor", factor * size_factor)
                gmsh.model.mesh.generate(gmsh.model.getDimension())
        except Exception as exc:  # gmsh raises a bare Exception with its own message
            raise InputError(f"{path}: gmsh could not {'mesh' if geo else 'read'} it ({exc})") from None
        return mesh_and_node_sets_from_gmsh(str(path))
