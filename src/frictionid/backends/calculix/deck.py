"""The CalculiX input deck (.inp) of a frictionid model at given zone coefficients.

Numbering: CalculiX node k + 1 is frictionid node k, element e + 1 is cell e. Sets and surfaces get
upper-case names from their position (``N3``, ``SZ2``) because CalculiX folds case and limits names;
a ``**`` comment next to each gives the frictionid name. Loads are written as nodal forces (``*CLOAD``)
computed by the same consistent load integration as the embedded solver, so that both backends see identical
loads. Axisymmetric models: ccx 2.20 takes *CLOAD values as whole-ring forces (it expands CAX elements into a
2-degree segment and divides them by 180 itself) but prints reactions and contact forces for that segment, so
the readers multiply those by :data:`AXISYMMETRIC_SEGMENTS` (measured: a whole-ring load written /180 came back
180 times too small).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...fem.space import N_CORNERS
from ...model import Displacement, Model, Rotation
from ...model.model import component_index
from .elements import calculix_cells, element_type, face_lookup, lump_dropped_forces

#: CalculiX prints axisymmetric reactions and contact forces for a 2-degree segment: whole ring = 180 x printed
AXISYMMETRIC_SEGMENTS = 180.0
_PER_LINE = 8


@dataclass(frozen=True)
class ContactSettings:
    """Penalty contact parameters of every pair.

    Attributes
    ----------
    normal_stiffness : float [N/mm^3]
        Slope of the linear pressure-overclosure law (penetration = pressure / slope).
    stick_slope : float [N/mm^3]
        Tangential penalty of *FRICTION (elastic slip = shear stress / slope while sticking).
    pair_type : str
        "SURFACE TO SURFACE" (per-zone contact forces are only printed for it) or "NODE TO SURFACE".
    """

    normal_stiffness: float
    stick_slope: float
    pair_type: str = "SURFACE TO SURFACE"


def _lines(values, per_line: int = _PER_LINE) -> list[str]:
    values = list(values)
    return [", ".join(str(v) for v in values[i:i + per_line]) for i in range(0, len(values), per_line)]


def _nodes(model: Model) -> list[str]:
    points = np.asarray(model.mesh.points)
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    out = ["*NODE, NSET=NALL"]
    out += [f"{i + 1}, {x:.13g}, {y:.13g}, {z:.13g}" for i, (x, y, z) in enumerate(points)]
    return out


def _elements(model: Model, cells: np.ndarray) -> list[str]:
    mesh = model.mesh
    calculix_type = element_type(model.kind, mesh.cell_type, model.element)
    out = []
    for index, (name, region_cells) in enumerate(mesh.regions.items(), start=1):
        out += [f"** region {name}", f"*ELEMENT, TYPE={calculix_type}, ELSET=E{index}"]
        for cell in region_cells:
            out += _lines([cell + 1] + [n + 1 for n in cells[cell]], per_line=16)
    return out


def _node_sets(model: Model, names: list[str]) -> list[str]:
    out = []
    for name in names:
        out += [f"** boundary {name}", f"*NSET, NSET={set_name(model, name)}"]
        out += _lines(model.mesh.boundary_nodes(name) + 1)
    axis = axis_nodes(model)
    if axis.size:
        out += ["** nodes on the axis of revolution", "*NSET, NSET=NAXIS"] + _lines(axis + 1)
    return out


def set_name(model: Model, boundary: str) -> str:
    """The CalculiX node set name of a named boundary."""
    return f"N{list(model.mesh.boundaries).index(boundary) + 1}"


def axis_nodes(model: Model) -> np.ndarray:
    """Nodes on the axis (r = 0) of an axisymmetric model, whose radial displacement is held (as embedded)."""
    if model.kind != "axisymmetric":
        return np.zeros(0, dtype=np.int64)
    points = model.mesh.points
    scale = np.ptp(points[:, 1]) or 1.0
    return np.flatnonzero(np.abs(points[:, 0]) <= 1e-9 * scale)


def _surface(model: Model, boundary: str, name: str, faces: dict) -> list[str]:
    n_corners = N_CORNERS[model.mesh.facet_type]
    out = [f"** boundary {boundary}", f"*SURFACE, NAME={name}, TYPE=ELEMENT"]
    for facet in model.mesh.boundary(boundary):
        key = frozenset(facet[:n_corners].tolist())
        if key not in faces:
            raise InputError(f"CalculiX deck: boundary {boundary!r} has a facet (nodes {facet.tolist()}) that is "
                             "not a face of any cell")
        cell, face = faces[key]
        out.append(f"{cell + 1}, S{face}")
    return out


def _materials(model: Model) -> list[str]:
    out = []
    thickness = [] if model.kind == "3d" else ["1."]
    for index, name in enumerate(model.mesh.regions, start=1):
        material = model.materials[name]
        out += [f"** region {name}: {material.name or 'material'}", f"*MATERIAL, NAME=M{index}", "*ELASTIC",
                f"{material.E:.13g}, {material.nu:.13g}",
                f"*SOLID SECTION, ELSET=E{index}, MATERIAL=M{index}"] + thickness
    return out


def _contact(model: Model, mu: np.ndarray, contact: ContactSettings) -> list[str]:
    out = []
    zone_index = 0
    for interface in model.interfaces:
        if interface.adjust and contact.pair_type != "SURFACE TO SURFACE":
            raise InputError(f"interface {interface.name!r} sets its initial gaps to zero (adjust), which the "
                             f"CalculiX deck writes as *CLEARANCE, for SURFACE TO SURFACE pairs only (got "
                             f"{contact.pair_type}): use [solver] contact = \"surface-to-surface\"")
        target = f"ST{model.interfaces.index(interface) + 1}"
        for zone, coefficient in zip(interface.zones, interface.coefficients):
            zone_index += 1
            value = float(mu[model.zone_names.index(coefficient)])
            shared = f" (coefficient {coefficient})" if coefficient != zone else ""
            out += [f"** zone {zone} of interface {interface.name}{shared}, mu = {value:.13g}",
                    f"*SURFACE INTERACTION, NAME=I{zone_index}",
                    "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{contact.normal_stiffness:.13g}"]
            if value > 0:
                out += ["*FRICTION", f"{value:.13g}, {contact.stick_slope:.13g}"]
            out += [f"*CONTACT PAIR, INTERACTION=I{zone_index}, TYPE={contact.pair_type}", f"SZ{zone_index}, {target}"]
            if interface.adjust:
                # ccx 2.20 manual, *CLEARANCE: the value replaces the gap at each slave integration point (face-to-face)
                out.append(f"*CLEARANCE, MASTER={target}, SLAVE=SZ{zone_index}, VALUE=0")
    return out


def _surfaces(model: Model, cells: np.ndarray) -> list[str]:
    faces = face_lookup(model.mesh.cell_type, cells)
    out = []
    zone_index = 0
    for k, interface in enumerate(model.interfaces, start=1):
        out += _surface(model, interface.target, f"ST{k}", faces)
        for zone in interface.zones:
            zone_index += 1
            out += _surface(model, zone, f"SZ{zone_index}", faces)
    return out


def _supports(model: Model) -> list[str]:
    out = ["*BOUNDARY"]
    for support in model.supports:
        for c in support.components:
            k = component_index(c, model.dim, f"support on {support.boundary!r}") + 1
            out.append(f"{set_name(model, support.boundary)}, {k}, {k}")
    if axis_nodes(model).size:
        out.append("NAXIS, 1, 1")
    return out if len(out) > 1 else []


def stage_forces(model: Model, forces: np.ndarray, amplitudes: np.ndarray) -> np.ndarray:
    """(n_stages, n_nodes, dim) [N] nodal forces at each stage end (axisymmetric: whole ring, as ccx takes them),
    none on nodes CalculiX's elements do not have.

    ``forces`` (n_channels, n_dofs) unit nodal force of each load channel, ``amplitudes`` (n_stages, n_channels).
    """
    total = (amplitudes @ forces).reshape(model.n_stages, -1, model.dim)
    # forces on nodes CalculiX's elements do not have (hexahedron27 face centres) go to the nodes it has
    return np.array([lump_dropped_forces(model.mesh.cell_type, model.mesh.cells, f) for f in total])


def _step(model: Model, stage: int, forces: np.ndarray, loaded: np.ndarray, reaction_sets: list[str],
          contact: ContactSettings, observed: bool, load_scale: float = 1.0) -> list[str]:
    n = model.stages[stage].n_increments
    dt = 1.0 / n
    out = [f"** stage {stage + 1}: {model.stages[stage].name}", "*STEP, INC=10000",
           "** up to 20 cutbacks per increment (ccx default 5 stopped an axisymmetric contact run; 20 passed)",
           "*CONTROLS, PARAMETERS=TIME INCREMENTATION", "4, 8, 9, 16, 10, 4, , 20",
           "*STATIC", f"{dt:.13g}, 1., {dt * 1e-6:.13g}, {dt:.13g}"]
    moves = [load for load in model.loads if isinstance(load, Displacement)]
    if moves:
        out.append("*BOUNDARY")
        for load in moves:
            k = component_index(load.component, model.dim, f"Displacement on {load.boundary!r}") + 1
            out.append(f"{set_name(model, load.boundary)}, {k}, {k}, {load_scale * load.values[stage]:.13g}")
    if loaded.size:
        out.append("*CLOAD")
        for node, c in loaded:
            out.append(f"{node + 1}, {c + 1}, {forces[stage, node, c]:.13g}")
    out += ["*NODE FILE", "U"] + (["*NODE PRINT, NSET=NOBS", "U"] if observed else [])
    for name in reaction_sets:
        out += [f"*NODE PRINT, NSET={name}, TOTALS=ONLY", "RF"]
    if contact.pair_type == "SURFACE TO SURFACE":
        for slave, master in contact_pairs(model):
            out += [f"*CONTACT PRINT, SLAVE={slave}, MASTER={master}", "CF"]
    return out + ["*END STEP"]


def contact_pairs(model: Model) -> list[tuple[str, str]]:
    """(slave, master) surface names of the contact pair of each zone, zones in interface order (one pair and one
    friction per zone, also where zones share a coefficient: :func:`zone_columns`)."""
    return [(f"SZ{z + 1}", f"ST{model.interfaces.index(i) + 1}")
            for z, i in enumerate(i for i in model.interfaces for _ in i.zones)]


def zone_columns(model: Model) -> list[int]:
    """Index into ``model.zone_names`` (the coefficients) of each zone's contact pair of :func:`contact_pairs`."""
    return [model.zone_names.index(c) for i in model.interfaces for c in i.coefficients]


def reaction_boundaries(model: Model) -> list[str]:
    """Named boundaries whose reactions are printed: supported ones and driven ones, in the embedded order."""
    names = [s.boundary for s in model.supports] + [l.boundary for l in model.loads if isinstance(l, Displacement)]
    return list(dict.fromkeys(names))


def write_deck(model: Model, mu, contact: ContactSettings, forces: np.ndarray, amplitudes: np.ndarray,
               observed_nodes=(), load_scale: float = 1.0) -> str:
    """The complete .inp text of a model at zone coefficients ``mu`` (n_zones,).

    Parameters
    ----------
    model : Model
    mu : (n_zones,) Coulomb coefficients in ``model.zone_names`` order
    contact : ContactSettings
    forces : (n_channels, n_dofs) [N] unit nodal forces per load channel (frictionid node-major dofs)
    amplitudes : (n_stages, n_channels) channel amplitudes at each stage end
    observed_nodes : 0-based nodes whose displacements are printed to the .dat file (set NOBS)
    load_scale : factor on every applied force and prescribed displacement (see ``CalculixSettings``)

    Returns
    -------
    str
        The deck; it prints reaction totals per supported / driven boundary and contact forces per zone to the
        .dat file and the displacement field to the .frd file at every increment.
    """
    turned = [load.boundary for load in model.loads if isinstance(load, Rotation)]
    if turned and model.kind == "3d":
        raise InputError(f"CalculiX deck: the rotation prescribed on {turned[0]!r} (a tightening model) is not "
                         "written to CalculiX decks; expected a model loaded by forces and displacements")
    mu = np.asarray(mu, dtype=float).reshape(-1)
    if mu.shape != (model.n_zones,):
        raise InputError(f"CalculiX deck: need {model.n_zones} coefficients, got {mu.shape[0]}")
    cells = calculix_cells(np.asarray(model.mesh.points), model.mesh.cell_type, model.mesh.cells)
    per_stage = load_scale * stage_forces(model, forces, amplitudes)
    scale = np.abs(per_stage).max() if per_stage.size else 0.0
    loaded = np.argwhere(np.any(np.abs(per_stage) > 1e-14 * scale, axis=0)) if scale > 0 else np.zeros((0, 2), int)
    boundaries = reaction_boundaries(model)
    used = list(dict.fromkeys(boundaries + [l.boundary for l in model.loads if isinstance(l, Displacement)]))
    sets = [set_name(model, b) for b in boundaries]
    observed = np.unique(np.asarray(observed_nodes, dtype=np.int64))
    lines = ["*HEADING", f"frictionid {model.kind} model, zones {', '.join(model.zone_names)}; units mm, N, MPa"]
    lines += _nodes(model) + _elements(model, cells) + _node_sets(model, used) + _surfaces(model, cells)
    if observed.size:
        lines += ["** nodes of the cells holding observation points", "*NSET, NSET=NOBS"] + _lines(observed + 1)
    lines += _materials(model) + _contact(model, mu, contact) + _supports(model)
    for stage in range(model.n_stages):
        lines += _step(model, stage, per_stage, loaded, sets, contact, observed.size > 0, load_scale)
    return "\n".join(lines) + "\n"
