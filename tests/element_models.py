"""Coarse block models of every cell type and model kind the CalculiX backend writes (its element types in
src/frictionid/backends/calculix/elements.py), shared by the deck and the ccx tests.

- plane strain: the 2-D block builder (``block2d``) at 4 mm, triangles or quadrilaterals, linear or quadratic;
- axisymmetric: the same meshes moved to r in [5, 45] (a ring-shaped block on a ring-shaped base);
- 3-D: the block builder (linear hexahedra, standard or with incompatible modes, at 2.5 mm; quadratic at 5 mm)
  and gmsh tetrahedra of the same layout (:func:`write_tet_block`, read as a user's mesh, ``builder = "mesh"``).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import gmsh
import numpy as np

from frictionid.builders.block import block_model, block_model_2d
from frictionid.builders.gmsh_mesh import gmsh_session
from frictionid.builders.mesh import mesh_model
from frictionid.model import Mesh

#: the mesh builder's [model] keys of reference test 1 on a user's mesh (tests/fixtures/user_block/identify.toml)
BLOCK_3D = dict(kind="3d", stages=["press", "pull"], increments=[1, 4],
                materials={"plate": {"E": 3500, "nu": 0.35}, "block": {"E": 71000, "nu": 0.33}},
                supports=[{"boundary": "plate_bottom", "components": ["x", "y", "z"]}],
                loads=[{"type": "pressure", "boundary": "block_top", "values": [20.0, 20.0]},
                       {"type": "displacement", "boundary": "block_top", "component": "x", "values": [0.0, 0.0]},
                       {"type": "displacement", "boundary": "block_top", "component": "y", "values": [0.0, 0.2]}],
                interfaces=[{"name": "block_plate", "zones": ["A", "B", "C", "D"], "target": "plate_top"}])
ZONES_3D = {"A": 0.3, "B": 0.2, "C": 0.4, "D": 0.25}
ZONES_2D = {"A": 0.3, "B": 0.2}

#: CalculiX element (as the deck writes it) -> (model kind, frictionid cell type)
ELEMENTS = {
    "CPE3": ("plane_strain", "triangle"), "CPE6": ("plane_strain", "triangle6"),
    "CPE4": ("plane_strain", "quad"), "CPE8 (quad9)": ("plane_strain", "quad9"),
    "CAX3": ("axisymmetric", "triangle"), "CAX6": ("axisymmetric", "triangle6"),
    "CAX4": ("axisymmetric", "quad"), "CAX8 (quad9)": ("axisymmetric", "quad9"),
    "C3D4": ("3d", "tetra"), "C3D10": ("3d", "tetra10"), "C3D8": ("3d", "hexahedron"),
    "C3D8I": ("3d", "hexahedron"), "C3D20 (hexahedron27)": ("3d", "hexahedron27"),
}


def _block_2d(cell_type: str, n_pull: int = 4):
    order = 2 if cell_type in ("triangle6", "quad9") else 1
    return block_model_2d(mesh_size=4.0, order=order, quads=cell_type.startswith("quad"), n_zones=2,
                          n_pull=n_pull)


def ring(model):
    """The plane block moved to r in [5, 45] as an axisymmetric model (loads become whole-ring loads)."""
    mesh = model.mesh
    moved = Mesh(np.asarray(mesh.points) + [25.0, 0.0], mesh.cell_type, mesh.cells, dict(mesh.regions),
                 dict(mesh.boundaries))
    return dataclasses.replace(model, mesh=moved, kind="axisymmetric")


def _block_on_plate(mesh_curve, path: Path, order: int, recombine: bool) -> Path:
    """Reference test 1's geometry in gmsh with the groups of tests/fixtures/user_block/block.msh (regions "plate",
    "block"; boundaries "plate_bottom", "plate_top", "block_top"; zones "A"-"D" by quadrant), each body fragmented
    on its own so that the bodies keep their own coincident interface nodes; ``mesh_curve(curve, start, end)``
    makes each curve transfinite (start, end: its end points in its parametric direction); with ``recombine``
    transfinite hexahedra, else Delaunay tetrahedra on transfinite surfaces; written to ``path``."""
    with gmsh_session("user_block"):
        occ = gmsh.model.occ

        def boxes(breaks, z0, z1):
            made = [(3, occ.addBox(x0, y0, z0, x1 - x0, y1 - y0, z1 - z0))
                    for x0, x1 in zip(breaks, breaks[1:]) for y0, y1 in zip(breaks, breaks[1:])]
            pieces, _ = occ.fragment(made[:1], made[1:])
            return [tag for dim, tag in pieces if dim == 3]

        plate, block = boxes([-20, -5, 0, 5, 20], -5, 0), boxes([-5, 0, 5], 0, 10)
        occ.synchronize()
        for _, curve in gmsh.model.getEntities(1):
            low, high = gmsh.model.getParametrizationBounds(1, curve)
            mesh_curve(curve, *(np.array(gmsh.model.getValue(1, curve, [t])) for t in (low[0], high[0])))
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface)
            if recombine:
                gmsh.model.mesh.setRecombine(2, surface)
        if recombine:
            for _, volume in gmsh.model.getEntities(3):
                gmsh.model.mesh.setTransfiniteVolume(volume)

        def faces_at(volumes, value):
            faces = {abs(t) for _, t in gmsh.model.getBoundary([(3, v) for v in volumes], combined=False,
                                                               oriented=False)}
            return [f for f in sorted(faces)
                    if np.allclose(np.reshape(gmsh.model.getBoundingBox(2, f), (2, 3))[:, 2], value, atol=1e-6)]

        add = gmsh.model.addPhysicalGroup
        add(3, plate, name="plate")
        add(3, block, name="block")
        add(2, faces_at(plate, -5), name="plate_bottom")
        add(2, faces_at(plate, 0), name="plate_top")
        add(2, faces_at(block, 10), name="block_top")
        for face in faces_at(block, 0):
            x, y, _ = occ.getCenterOfMass(2, face)
            add(2, [face], name={(-1, -1): "A", (1, -1): "B", (-1, 1): "C", (1, 1): "D"}[
                (int(np.sign(x)), int(np.sign(y)))])
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
            gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    return path


def write_tet_block(path: Path, order: int, quarter: int = 4, outer: int = 3, block_z: int = 5,
                    plate_z: int = 3) -> Path:
    """Reference test 1 meshed with gmsh tetrahedra (order 1 or 2) as a user would, in the groups of
    tests/fixtures/user_block/block.msh: every curve transfinite (``quarter`` divisions per half side of the
    footprint, ``outer`` outside it, ``block_z`` / ``plate_z`` through the block / plate), so the block's bottom
    and the plate's top carry identical triangles and the bodies keep their own coincident interface nodes;
    the volumes are meshed freely (Delaunay), so coordinates carry gmsh's round-off."""
    def mesh_curve(curve, start, end):
        axis = int(np.argmax(np.abs(end - start)))
        if axis == 2:
            n = block_z if start[2] + end[2] > 0 else plate_z
        else:
            n = quarter if max(abs(start[axis]), abs(end[axis])) <= 5 + 1e-6 else outer
        gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)

    return _block_on_plate(mesh_curve, path, order, recombine=False)


def write_hex_block(path: Path, order: int = 2, quarter: int = 4, outer: int = 12, block_z: int = 6,
                    plate_z: int = 3, bump: float = 0.4, z_ratio: float = 1.35, growth: float = 1.2) -> Path:
    """Reference test 1 meshed with gmsh's transfinite hexahedra (order 2: 27 nodes) graded as a user would
    grade with gmsh's own curve laws, in the groups of tests/fixtures/user_block/block.msh: ``quarter``
    divisions per half side of the footprint with a "Bump" of ``bump`` (smallest at the footprint's edges and
    its quadrant borders), ``outer`` outside it growing by ``growth`` away from the block, ``block_z`` /
    ``plate_z`` layers through block / plate growing by ``z_ratio`` away from the interface. Another layout
    than the block builder's (which maps every coordinate by one smooth function)."""
    def mesh_curve(curve, start, end):
        axis = int(np.argmax(np.abs(end - start)))
        if axis == 2:                          # first element at the interface z = 0
            ratio = z_ratio if abs(start[2]) < 1e-6 else 1 / z_ratio
            gmsh.model.mesh.setTransfiniteCurve(curve, (block_z if start[2] + end[2] > 0 else plate_z) + 1,
                                                "Progression", ratio)
        elif max(abs(start[axis]), abs(end[axis])) <= 5 + 1e-6:
            gmsh.model.mesh.setTransfiniteCurve(curve, quarter + 1, "Bump", bump)
        else:                                  # outside the footprint: growing away from the block
            ratio = growth if abs(start[axis]) < abs(end[axis]) else 1 / growth
            gmsh.model.mesh.setTransfiniteCurve(curve, outer + 1, "Progression", ratio)

    return _block_on_plate(mesh_curve, path, order, recombine=True)


def element_model(element: str, folder: Path, n_pull: int = 4):
    """(model, zone coefficients) of a coarse block of one CalculiX element type (see :data:`ELEMENTS`);
    ``folder`` holds the tetrahedral meshes' .msh files."""
    kind, cell_type = ELEMENTS[element]
    if kind == "plane_strain":
        return _block_2d(cell_type, n_pull), ZONES_2D
    if kind == "axisymmetric":
        return ring(_block_2d(cell_type, n_pull)), ZONES_2D
    if cell_type.startswith("tetra"):
        coarse = dict(order=2, quarter=2, block_z=3, plate_z=2) if cell_type == "tetra10" else dict(order=1)
        path = write_tet_block(Path(folder) / f"{cell_type}.msh", **coarse)
        options = dict(BLOCK_3D, increments=[1, n_pull])
        return mesh_model(path, **options), ZONES_3D
    order = 2 if cell_type == "hexahedron27" else 1
    model = block_model(mesh_size=5.0 if order == 2 else 2.5, order=order, n_pull=n_pull,
                        element="incompatible" if element == "C3D8I" else "standard")
    return model, ZONES_3D
