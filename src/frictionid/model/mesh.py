"""Mesh: nodes, one cell type, named regions (volumes) and named boundaries (facet sets)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Mapping

import numpy as np

from ..errors import InputError

#: facet type (meshio name) of each supported cell type (meshio name)
FACET_TYPE = {
    "triangle": "line",
    "triangle6": "line3",
    "quad": "line",
    "quad9": "line3",
    "tetra": "triangle",
    "tetra10": "triangle6",
    "hexahedron": "quad",
    "hexahedron27": "quad9",
}

#: spatial dimension of each supported cell type
CELL_DIM = {"triangle": 2, "triangle6": 2, "quad": 2, "quad9": 2,
            "tetra": 3, "tetra10": 3, "hexahedron": 3, "hexahedron27": 3}

#: number of nodes per facet type
FACET_NODES = {"line": 2, "line3": 3, "triangle": 3, "triangle6": 6, "quad": 4, "quad9": 9}

_TRI, _QUAD = ((0, 1), (1, 2), (2, 0)), ((0, 1), (1, 2), (2, 3), (3, 0))
_TET = ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3))
_HEX = ((0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
#: corner nodes of each facet of a cell, in meshio's local node numbering
CELL_FACETS = {"triangle": _TRI, "triangle6": _TRI, "quad": _QUAD, "quad9": _QUAD,
               "tetra": _TET, "tetra10": _TET, "hexahedron": _HEX, "hexahedron27": _HEX}


def _frozen(array, dtype):
    out = np.array(array, dtype=dtype)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class Mesh:
    """A finite element mesh with named regions and boundaries.

    Parameters
    ----------
    points : (n_nodes, dim) [mm]
        Undeformed node coordinates. Axisymmetric meshes use x = r >= 0, y = axis.
    cell_type : str
        meshio name of the (single) cell type, a key of :data:`FACET_TYPE`.
    cells : (n_cells, n_cell_nodes) int
        Node indices per cell in meshio (= gmsh) order.
    regions : mapping name -> (n,) int
        Cell indices of each named region (gmsh physical group of the top dimension).
    boundaries : mapping name -> (n_facets, n_facet_nodes) int
        Node indices of the facets of each named boundary (physical group of dimension dim - 1),
        in meshio order of :attr:`facet_type`.
    """

    points: np.ndarray
    cell_type: str
    cells: np.ndarray
    regions: Mapping[str, np.ndarray]
    boundaries: Mapping[str, np.ndarray]
    cell_region: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        if self.cell_type not in FACET_TYPE:
            raise InputError(f"mesh: cell type {self.cell_type!r} is not supported; "
                             f"expected one of {sorted(FACET_TYPE)}")
        points = _frozen(self.points, float)
        dim = CELL_DIM[self.cell_type]
        if points.ndim != 2 or points.shape[1] != dim:
            raise InputError(f"mesh: points must have shape (n_nodes, {dim}) for {self.cell_type} cells, "
                             f"got {points.shape}")
        cells = _frozen(self.cells, np.int64)
        if cells.size and (cells.min() < 0 or cells.max() >= len(points)):
            raise InputError("mesh: a cell refers to a node that does not exist")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "cells", cells)
        object.__setattr__(self, "regions", MappingProxyType(
            {k: _frozen(v, np.int64) for k, v in self.regions.items()}))
        n_facet = FACET_NODES[FACET_TYPE[self.cell_type]]
        boundaries = {}
        for name, facets in self.boundaries.items():
            facets = _frozen(np.reshape(facets, (-1, n_facet)), np.int64)
            if facets.size and facets.max() >= len(points):
                raise InputError(f"mesh: boundary {name!r} refers to a node that does not exist")
            boundaries[name] = facets
        object.__setattr__(self, "boundaries", MappingProxyType(boundaries))
        object.__setattr__(self, "cell_region", self._cell_region())

    def __reduce__(self):
        return rebuild, (type(self), init_arguments(self))

    def _cell_region(self) -> np.ndarray:
        """(n_cells,) index into :attr:`region_names`, -1 for a cell in no region."""
        out = np.full(len(self.cells), -1, dtype=np.int64)
        for index, (name, cells) in enumerate(self.regions.items()):
            clash = cells[out[cells] >= 0]
            if clash.size:
                other = self.region_names[out[clash[0]]]
                raise InputError(f"mesh: cell {clash[0]} is in both regions {other!r} and {name!r}; "
                                 "regions must not overlap")
            out[cells] = index
        out.setflags(write=False)
        return out

    @property
    def dim(self) -> int:
        return self.points.shape[1]

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @property
    def n_cells(self) -> int:
        return len(self.cells)

    def __repr__(self) -> str:
        return (f"Mesh({self.n_nodes:,} nodes, {self.n_cells:,} {self.cell_type} cells, regions "
                f"{sorted(self.regions)}, boundaries {sorted(self.boundaries)})")

    @property
    def facet_type(self) -> str:
        return FACET_TYPE[self.cell_type]

    @property
    def region_names(self) -> tuple[str, ...]:
        return tuple(self.regions)

    def boundary(self, name: str) -> np.ndarray:
        """Facets of the named boundary; an :class:`InputError` naming the known ones if it does not exist."""
        try:
            return self.boundaries[name]
        except KeyError:
            raise InputError(f"mesh: no boundary named {name!r}; the mesh has "
                             f"{sorted(self.boundaries) or 'no named boundaries'}") from None

    def surface_nodes(self, region: str) -> np.ndarray:
        """Sorted corner nodes on the surface of a region: its facets that no second cell of it shares."""
        if region not in self.regions:
            raise InputError(f"mesh: no region named {region!r}; the mesh has {sorted(self.regions)}")
        cells = self.cells[self.regions[region]]
        facets = np.concatenate([cells[:, list(local)] for local in CELL_FACETS[self.cell_type]])
        _, index, count = np.unique(np.sort(facets, axis=1), axis=0, return_index=True, return_counts=True)
        return np.unique(facets[index[count == 1]])

    def boundary_nodes(self, name: str) -> np.ndarray:
        """Sorted unique node indices of the named boundary."""
        return np.unique(self.boundary(name))


def init_arguments(instance) -> dict:
    """The constructor arguments of a frozen dataclass instance, read-only mappings as plain dicts (so that the
    instance can be pickled, e.g. into the condensation cache, and rebuilt, validated, by :func:`rebuild`)."""
    return {f.name: dict(v) if isinstance(v := getattr(instance, f.name), MappingProxyType) else v
            for f in fields(instance) if f.init}


def rebuild(cls, arguments: dict):
    """``cls(**arguments)``: the unpickling half of :func:`init_arguments`."""
    return cls(**arguments)
