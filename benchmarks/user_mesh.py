"""Reading and preparing a user's 100k-node mesh (builder "mesh") against the block builder at the same size.

The block builder's own mesh (reference test 1, linear hexahedra, graded) is written as a gmsh .msh 4.1 with its
regions, boundaries and zones as physical groups, in a temporary folder; then each case runs in a fresh Python
process, so that its peak resident memory is its own:

- imports: the builders imported, nothing built (the floor under the others);
- block: ``block_model(mesh_size=...)``;
- mesh: ``build_model(ModelSpec("mesh", {"file": <the .msh>, ...}))`` with the block's materials, supports, loads,
  stages and interface: gmsh reads the file, the groups become regions and boundaries, then the checks (bodies
  apart at the interface, zones on the contact side, every body held).

Build only: no assembly or condensation (docs/solver.md has those for the block).

Run: .venv/bin/python benchmarks/user_mesh.py [mesh_size]     (default 0.33 mm: 107,065 nodes)

Measured (2026-11-24, mesh_size 0.33: 107,065 nodes, 97,596 hexahedra, an 11.9 MB .msh):

                                      0.33 mm
    imports only                      0.34 s    84 MB
    block_model                       0.49 s   209 MB
    build_model, builder "mesh"       0.87 s   214 MB
      of which reading the .msh       0.58 s   206 MB

So a 100k-node user mesh is read and prepared in under twice the block builder's time and at its memory. (The
rigid-body check first used scipy's null_space, whose full SVD of the 15,389 x 6 held-components matrix built a
15,389^2 U: 5.5 s and 1.97 GB; it now takes a thin SVD.)
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from _measure import peak_memory_mb, timed
from frictionid.options import ModelSpec

#: gmsh element types of the block's cells and facets (meshio's node order is gmsh's for these)
GMSH_TYPE = {"hexahedron": 5, "quad": 3}


def mesh_options(path: Path) -> dict:
    """[model] of the block builder's reference test 1 on the mesh file ``path`` (docs/models.md)."""
    return {"builder": "mesh", "file": str(path), "kind": "3d", "stages": ["press", "pull"], "increments": [1, 10],
            "element": "incompatible",
            "materials": {"plate": {"E": 3500, "nu": 0.35}, "block": {"E": 71000, "nu": 0.33}},
            "supports": [{"boundary": "plate_bottom", "components": ["x", "y", "z"]}],
            "loads": [{"type": "pressure", "boundary": "block_top", "values": [20.0, 20.0]},
                      {"type": "displacement", "boundary": "block_top", "component": "x", "values": [0.0, 0.0]},
                      {"type": "displacement", "boundary": "block_top", "component": "y", "values": [0.0, 0.2]}],
            "interfaces": [{"name": "block_plate", "zones": ["A", "B", "C", "D"], "target": "plate_top"}]}


def write_msh(mesh, path: Path) -> None:
    """A frictionid Mesh of hexahedra as a gmsh .msh 4.1: one discrete entity and physical group per region and
    per boundary."""
    import gmsh

    from frictionid.builders.gmsh_mesh import gmsh_session

    with gmsh_session("user_mesh_benchmark"):
        model = gmsh.model
        tags = np.arange(1, mesh.n_nodes + 1)
        first = None
        for name, cells in mesh.regions.items():
            entity = model.addDiscreteEntity(3)
            if first is None:
                model.mesh.addNodes(3, entity, tags, mesh.points.ravel())
                first = entity
            model.mesh.addElementsByType(entity, GMSH_TYPE[mesh.cell_type], [], (mesh.cells[cells] + 1).ravel())
            model.addPhysicalGroup(3, [entity], name=name)
        for name, facets in mesh.boundaries.items():
            entity = model.addDiscreteEntity(2)
            model.mesh.addElementsByType(entity, GMSH_TYPE["quad"], [], (facets + 1).ravel())
            model.addPhysicalGroup(2, [entity], name=name)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))


def run_case(case: str, mesh_size: float, path: Path) -> dict:
    """Wall time [s] and peak resident memory [MB] of one case in this process ("write" writes the .msh)."""
    figures = {}
    with timed(figures, "imports"):
        from frictionid.builders.block import block_model
        from frictionid.builders.gmsh_mesh import read_msh
        from frictionid.builders.registry import build_model
    cases = {"imports": lambda: None, "block": lambda: block_model(mesh_size=mesh_size).mesh,
             "mesh": lambda: build_model(ModelSpec.from_table(mesh_options(path))).mesh, "read": lambda: read_msh(path),
             "write": lambda: write_msh(block_model(mesh_size=mesh_size).mesh, path)}
    with timed(figures, "build"):
        mesh = cases[case]()
    seconds = figures["imports"] if case == "imports" else figures["build"]
    return {"seconds": seconds, "peak_mb": peak_memory_mb(), "n_nodes": 0 if mesh is None else mesh.n_nodes,
            "n_cells": 0 if mesh is None else mesh.n_cells}


def in_child(case: str, mesh_size: float, path: Path) -> dict:
    completed = subprocess.run([sys.executable, __file__, "--case", case, str(mesh_size), str(path)],
                               cwd=Path(__file__).parent, capture_output=True, text=True, timeout=1800, check=True)
    return json.loads(completed.stdout.splitlines()[-1])


def main(mesh_size: float = 0.33) -> None:
    # every case in a child started from this light process: Linux keeps a parent's peak memory in its child's
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "block.msh"
        written = in_child("write", mesh_size, path)
        figures = {case: in_child(case, mesh_size, path) for case in ("imports", "block", "mesh", "read")}
        size_mb = path.stat().st_size / 1e6
    block = figures["block"]
    print(f"block layout, mesh size {mesh_size} mm: {block['n_nodes']:,} nodes, {block['n_cells']:,} hexahedra, "
          f".msh {size_mb:.1f} MB (block_model + writing it: {written['seconds']:.1f} s)")
    labels = {"imports": "imports only", "block": "block_model", "mesh": 'build_model, builder "mesh"',
              "read": "  of which reading the .msh"}
    for case, label in labels.items():
        f = figures[case]
        print(f"  {label:32s} {f['seconds']:7.2f} s   {f['peak_mb']:7.0f} MB peak   {f['n_nodes']:,} nodes")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--case"]:
        print(json.dumps(run_case(sys.argv[2], float(sys.argv[3]), Path(sys.argv[4]))))
    else:
        main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.33)
