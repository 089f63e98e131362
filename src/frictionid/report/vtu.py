"""VTU export of a forward solve's fields for ParaView: per stage end the solid and the contact interface, two
.pvd collections that open them as a time series (one time step per stage), and a README with the units."""

from __future__ import annotations

import logging
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np

from ..backends.base import Backend
from ..errors import SolverError
from ..fem.fields import Fields, StageFields, strain_names

log = logging.getLogger(__name__)
#: the collections written; each lists one ``<name>_<stage number>.vtu`` per stage
COLLECTIONS = ("solid", "contact")
STATE_CODES = "-1 no contact pair at this node (values NaN), 0 open, 1 stick, 2 slip"


def _xyz(values: np.ndarray) -> np.ndarray:
    """(n, 3) from (n, dim): VTK points and vectors have three components; 2-D models get z = 0."""
    return np.hstack([values, np.zeros((len(values), 3 - values.shape[1]))])


def solid_mesh(fields: Fields, stage: StageFields) -> meshio.Mesh:
    """The model's mesh with point data ``displacement_mm`` and cell data: the strain components at each cell's
    centre (named as in the measurement files, e.g. ``exx``) and ``region`` (index into the mesh's regions)."""
    mesh = fields.model.mesh
    cell_data = {name: [values] for name, values in stage.strain.items()}
    cell_data["region"] = [np.asarray(mesh.cell_region, dtype=np.int32)]
    return meshio.Mesh(_xyz(mesh.points), [(mesh.cell_type, np.asarray(mesh.cells))],
                       point_data={"displacement_mm": _xyz(stage.displacement)}, cell_data=cell_data)


def contact_mesh(fields: Fields, stage: StageFields) -> meshio.Mesh:
    """The contact side's facets (every zone of every interface) with the pair values at their nodes.

    Point data: ``pressure_MPa``, ``traction_MPa`` and ``slip_mm`` (tangential vectors, global frame), ``gap_mm``,
    ``state``, ``area_mm2`` (tributary area: sum(pressure_MPa * area_mm2) is the normal force [N]), ``mu_pair``
    (the pair's coefficient, area-weighted at zone borders) and the contact map checked at model build:
    ``initial_gap_mm`` (negative: an interference) and ``facing_deg`` (angle between the contact normal and the
    reversed target normal of the pair); NaN (state -1) at a node without a pair.
    Cell data: ``zone`` (index into the model's zone names, i.e. coefficients), ``mu`` (that zone's coefficient)
    and ``interface`` (index into the model's interfaces).
    """
    model, pairs = fields.model, fields.pairs
    owners = [(i, model.zone_names.index(c), model.mesh.boundary(z))
              for i, interface in enumerate(model.interfaces) for z, c in zip(interface.zones, interface.coefficients)]
    zone = np.concatenate([np.full(len(f), z, dtype=np.int32) for _, z, f in owners])
    interface = np.concatenate([np.full(len(f), i, dtype=np.int32) for i, _, f in owners])
    facets = np.concatenate([f for _, _, f in owners])
    nodes = np.unique(facets)
    at = np.searchsorted(nodes, pairs.nodes)               # every pair's contact node is a node of a zone facet

    def on_nodes(values, fill=np.nan):
        values = np.asarray(values)
        out = np.full((len(nodes),) + values.shape[1:], fill, dtype=values.dtype if fill == -1 else float)
        out[at] = values
        return out

    facing = np.full(pairs.n_pairs, np.nan) if pairs.facing is None else pairs.facing
    point_data = {"pressure_MPa": on_nodes(stage.pressure), "traction_MPa": _xyz(on_nodes(stage.traction)),
                  "slip_mm": _xyz(on_nodes(stage.slip)), "gap_mm": on_nodes(stage.gap),
                  "state": on_nodes(stage.state.astype(np.int32), -1), "area_mm2": on_nodes(pairs.weight),
                  "mu_pair": on_nodes(pairs.mu(fields.mu)), "initial_gap_mm": on_nodes(pairs.gap),
                  "facing_deg": on_nodes(facing)}
    return meshio.Mesh(_xyz(model.mesh.points[nodes]), [(model.mesh.facet_type, np.searchsorted(nodes, facets))],
                       point_data=point_data,
                       cell_data={"zone": [zone], "mu": [np.asarray(fields.mu, dtype=float)[zone]],
                                  "interface": [interface]})


def write_fields(folder: str | Path, fields: Fields) -> list[Path]:
    """Write ``solid_<k>.vtu`` and ``contact_<k>.vtu`` for every stage k (1-based), ``solid.pvd`` and
    ``contact.pvd`` (time step k = stage k) and ``README.txt`` into ``folder``; returns the paths.

    Files of an earlier export in the folder that this one does not rewrite (more stages) are removed.

    Examples
    --------
    >>> write_fields("fields", EmbeddedBackend(model, None, ()).fields(mu))   # doctest: +SKIP
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name in COLLECTIONS:
        for old in folder.glob(f"{name}_*.vtu"):
            old.unlink()
    paths = []
    for name, build in zip(COLLECTIONS, (solid_mesh, contact_mesh)):
        files = []
        for stage in fields.stages:
            files.append(folder / f"{name}_{stage.stage + 1}.vtu")
            meshio.write(files[-1], build(fields, stage), file_format="vtu")
        paths += files + [_collection(folder / f"{name}.pvd", files, fields.stages)]
    readme = folder / "README.txt"
    readme.write_text(fields_readme(fields))
    return paths + [readme]


def _collection(path: Path, files: list[Path], stages) -> Path:
    """A ParaView collection (.pvd) of the stage files, time step = stage number."""
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    collection = ET.SubElement(root, "Collection")
    for file, stage in zip(files, stages):
        ET.SubElement(collection, "DataSet", timestep=str(stage.stage + 1), part="0", file=file.name,
                      name=stage.name)
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path


def fields_readme(fields: Fields) -> str:
    """What the files hold, with units, the stage, zone and region numbers, and how to open them."""
    model = fields.model
    axisymmetric = model.kind == "axisymmetric"
    lines = [
        f"Fields of a frictionid forward solve: {model.kind} model, {model.mesh.n_nodes} nodes, "
        f"{model.mesh.n_cells} {model.mesh.cell_type} cells, {fields.pairs.n_pairs} contact pairs.",
        "Units: mm, N, MPa; strains dimensionless, tensor shear (exy = gamma_xy / 2). Undeformed coordinates.",
        "Open solid.pvd and contact.pvd in ParaView (File > Open): one time step per stage; "
        "Warp By Vector with displacement_mm shows the deformed shape.", "",
        "stages (time step = stage number):",
        *(f"  {s.stage + 1} {s.name}" for s in fields.stages), "",
        f"solid_<stage>.vtu: point data displacement_mm (vector{', x = u_r, y = u_axis' if axisymmetric else ''});"
        f" cell data {', '.join(strain_names(model.kind))} at each cell's centre"
        + {"plane_strain": " (ezz = 0, plane strain)",
           "axisymmetric": " (x = r, y = axis: exx = e_rr, eyy = e_yy, ezz = hoop strain u_r / r, exy = e_ry)"}
        .get(model.kind, "") + ", region:",
        *(f"  {k} {name}" for k, name in enumerate(model.mesh.region_names)), "",
        "contact_<stage>.vtu: the contact side's facets; point data pressure_MPa, traction_MPa and slip_mm "
        "(tangential vectors in the global frame; slip accumulated since the start), gap_mm (current normal gap), "
        f"state ({STATE_CODES}), area_mm2 (tributary area{', whole ring' if axisymmetric else ''}"
        f"{', per mm thickness' if model.kind == 'plane_strain' else ''}; sum(pressure_MPa * area_mm2) = normal "
        "force [N]), mu_pair (the coefficient at the node, area-weighted at zone borders), initial_gap_mm and "
        "facing_deg (the contact map checked at model build: initial normal gap, negative for an interference, "
        "and the angle between the contact normal and the reversed target normal); cell data zone and mu (the "
        "zone's coefficient):",
        *(f"  {z} {name} mu = {mu:.6g}" for z, (name, mu) in enumerate(zip(model.zone_names, fields.mu))),
        "and interface:", *(f"  {i} {interface.name} (target {interface.target})"
                            for i, interface in enumerate(model.interfaces)), ""]
    return "\n".join(lines)


def export_fields(backend: Backend, mu, folder: str | Path, echo=lambda text: None) -> list[Path]:
    """Solve once at ``mu`` with a backend that provides fields (the embedded one) and write them to ``folder``;
    with another backend, or when the solve fails, say so through ``echo`` and write nothing."""
    if not hasattr(backend, "fields"):
        echo(f"fields: not written; the {backend.name} backend does not provide them yet")
        return []
    start = time.perf_counter()
    try:
        paths = write_fields(folder, backend.fields(mu))
    except SolverError as exc:
        echo(f"fields: not written; the solve at the final coefficients failed: {exc}")
        return []
    size = sum(path.stat().st_size for path in paths)
    echo(f"fields: {len(paths)} files, {size / 1e6:.2g} MB in {folder} ({time.perf_counter() - start:.1f} s)")
    return paths
