"""The surface of a mesh (the facets of its regions that no second cell of the same region shares, as straight
segments or triangles through their corners) and the nearest point on it to given points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from ..model.mesh import CELL_FACETS

#: facets (by nearest centre) searched for the one nearest to a point
N_NEAREST = 16
#: points handled at once (about 100 MB of candidates)
CHUNK = 20_000


@dataclass(frozen=True)
class Surface:
    """Straight facets: ``corners`` (n_facets, 2 or 3, dim) [mm] (segments in 2-D, triangles in 3-D; a
    quadrilateral face is two triangles); quadratic facets are taken through their corners."""

    corners: np.ndarray

    @property
    def dim(self) -> int:
        return self.corners.shape[2]

    def nearest(self, points) -> np.ndarray:
        """(n, dim) [mm] the point of the surface nearest to each of ``points`` (n, dim), among the N_NEAREST
        facets with the nearest centres."""
        return self.closest(points)[0]

    def closest(self, points) -> tuple[np.ndarray, np.ndarray]:
        """The nearest surface points (n, dim) [mm] (see :meth:`nearest`) and the unit normals (n, dim) of the
        facets they lie on."""
        points = np.asarray(points, float)
        if len(points) > CHUNK:                 # bounded memory: (CHUNK, N_NEAREST, 4, dim) candidates at a time
            parts = [self.closest(points[i:i + CHUNK]) for i in range(0, len(points), CHUNK)]
            return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
        k = min(N_NEAREST, len(self.corners))
        near = np.reshape(self._tree.query(points, k=k)[1], (len(points), k))
        corners = self.corners[near]                                      # (n, k, m, dim)
        p = np.repeat(points[:, None, :], k, axis=1)
        best = _on_segment(p, corners[:, :, 0], corners[:, :, 1])
        if self.dim == 3:
            candidates = [_on_plane(p, corners), best,
                          _on_segment(p, corners[:, :, 1], corners[:, :, 2]),
                          _on_segment(p, corners[:, :, 2], corners[:, :, 0])]
            distance = np.stack([np.linalg.norm(c - p, axis=2) for c in candidates])      # (4, n, k)
            choice = np.nan_to_num(distance, nan=np.inf).argmin(axis=0)
            best = np.choose(choice[..., None], candidates)
        which = np.linalg.norm(best - p, axis=2).argmin(axis=1)
        rows = np.arange(len(points))
        return best[rows, which], self._normals[near[rows, which]]

    @property
    def _normals(self) -> np.ndarray:
        normals = self.__dict__.get("_unit_normals")
        if normals is None:
            c = self.corners
            edge = c[:, 1] - c[:, 0]
            normals = np.cross(edge, c[:, 2] - c[:, 0]) if self.dim == 3 else np.c_[-edge[:, 1], edge[:, 0]]
            normals = normals / np.linalg.norm(normals, axis=1)[:, None]
            object.__setattr__(self, "_unit_normals", normals)
        return normals

    @property
    def _tree(self) -> cKDTree:
        tree = self.__dict__.get("_kd")
        if tree is None:
            tree = cKDTree(self.corners.mean(axis=1))
            object.__setattr__(self, "_kd", tree)
        return tree


def _on_segment(p, a, b):
    ab = b - a
    t = np.einsum("...d,...d->...", p - a, ab) / np.maximum(np.einsum("...d,...d->...", ab, ab), 1e-300)
    return a + np.clip(t, 0.0, 1.0)[..., None] * ab


def _on_plane(p, triangle):
    """The projection of p onto each triangle's plane where it falls inside the triangle, nan elsewhere."""
    a, b, c = triangle[:, :, 0], triangle[:, :, 1], triangle[:, :, 2]
    normal = np.cross(b - a, c - a)
    area2 = np.einsum("...d,...d->...", normal, normal)
    q = p - (np.einsum("...d,...d->...", p - a, normal) / area2)[..., None] * normal
    inside = np.ones(q.shape[:2], bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("...d,...d->...", np.cross(v - u, q - u), normal) >= 0
    return np.where(inside[..., None], q, np.nan)


def mesh_surface(mesh, regions=None) -> Surface:
    """The surface of each of ``regions`` (default: every region of ``mesh``): where two bodies touch, both
    faces of the interface belong to it.

    Raises
    ------
    InputError
        A region the mesh does not have.
    """
    names = list(mesh.region_names if regions is None else regions)
    unknown = [r for r in names if r not in mesh.regions]
    if unknown:
        raise InputError(f"regions {unknown} are not regions of the model; it has {list(mesh.region_names)}")
    facets = []
    for name in names:
        cells = mesh.cells[mesh.regions[name]]
        local = np.concatenate([cells[:, list(f)] for f in CELL_FACETS[mesh.cell_type]])
        _, index, count = np.unique(np.sort(local, axis=1), axis=0, return_index=True, return_counts=True)
        facets.append(local[index[count == 1]])
    facets = np.concatenate(facets)
    if facets.shape[1] == 4:                                # quadrilaterals (corners in cyclic order)
        facets = np.concatenate([facets[:, [0, 1, 2]], facets[:, [0, 2, 3]]])
    return Surface(np.asarray(mesh.points)[facets])
