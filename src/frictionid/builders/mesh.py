"""A user's own mesh as a model (``builder = "mesh"``): a gmsh .msh / .geo or an Abaqus / CalculiX .inp whose named
groups are the regions, boundaries and friction zones; materials, supports, loads and stages from [model]."""

from __future__ import annotations

import difflib
import logging
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..model import ContactInterface, Displacement, Material, Mesh, Model, Pressure, Stage, SurfaceForce, Support
from ..model.mesh import FACET_NODES, FACET_TYPE
from ..model.model import ELEMENTS, KINDS
from .arguments import checked_table
from .gmsh_mesh import read_gmsh_file
from .mesh_checks import check_contact_sides, check_held
from .mesh_inp import element_meaning, read_inp
from .subdivide import subdivided
from .zone_rules import split_facets, zone_rules

logger = logging.getLogger(__name__)

LOAD_TYPES = {"pressure": Pressure, "force": SurfaceForce, "displacement": Displacement}


@dataclass(frozen=True)
class MeshFile:
    """The named sets of a mesh file, before the [model] table picks the ones it uses.

    Attributes
    ----------
    path : the file; points : (n_nodes, dim) [mm]; cell_type : meshio name; cells : (n_cells, n_cell_nodes)
    regions : name -> cell indices (physical groups of the top dimension / *ELSET)
    boundaries : name -> facets (physical groups one dimension lower / element-face *SURFACE)
    node_sets : name -> node indices (*NSET, gmsh groups of points or, in 3-D, curves; supports and
        displacements only)
    case_insensitive : names match whatever their case (.inp)
    element_type : the element type an .inp names (e.g. "C3D8I"); "" for gmsh files
    """

    path: Path
    points: np.ndarray
    cell_type: str
    cells: np.ndarray
    regions: dict
    boundaries: dict
    node_sets: dict
    case_insensitive: bool = False
    element_type: str = ""

    def find(self, name, kinds: tuple[str, ...], where: str) -> tuple[str, str]:
        """(kind, the file's spelling) of a configured name among the given kinds of set, else an
        :class:`InputError` naming what the file has, with a "did you mean"."""
        if not isinstance(name, str):
            raise InputError(f"{where}: must be a name (a string), got {name!r}")
        fold = str.casefold if self.case_insensitive else (lambda s: s)
        for kind in kinds:
            for known in getattr(self, kind):
                if fold(known) == fold(name):
                    return kind, known
        wanted = " or ".join(_WHAT[k] for k in kinds)
        for kind in set(_WHAT) - set(kinds):
            if any(fold(known) == fold(name) for known in getattr(self, kind)):
                raise InputError(f"{where} = {name!r}: {self.path.name} has {name!r} as a {_WHAT[kind]}, this "
                                 f"needs a {wanted}{_NEEDS.get(kinds, '')}")
        names = sorted(n for kind in kinds for n in getattr(self, kind))
        by_fold = {fold(n): n for n in names}
        close = difflib.get_close_matches(fold(name), list(by_fold), n=1)
        hint = f" (did you mean {by_fold[close[0]]!r}?)" if close else ""
        raise InputError(f"{where} = {name!r}: {self.path.name} has no {wanted} of that name{hint}; it has "
                         f"{names or 'none'}")


_WHAT = {"regions": "region", "boundaries": "boundary", "node_sets": "node set"}
_NEEDS = {("boundaries",): " (a physical group of facets, in an .inp an element-face *SURFACE)"}


_GEO_READS = re.compile(r'^\s*(?:Include|Merge)\s*"([^"]+)"', re.MULTILINE)
_INP_INCLUDE = re.compile(r"^\s*\*INCLUDE\b[^\n]*?\bINPUT\s*=\s*([^,\n]+)", re.MULTILINE | re.IGNORECASE)


def source_files(path: str | Path) -> list[Path]:
    """The mesh file and every file it reads that exists: an .inp's *INCLUDE files and a .geo's Include / Merge
    files, recursively (a quick scan of keyword lines; the reader reports missing or circular includes)."""
    found, pending = [], [Path(path)]
    while pending:
        current = pending.pop()
        if current in found or not current.is_file():
            continue
        found.append(current)
        suffix = current.suffix.lower()
        if suffix not in (".inp", ".geo"):
            continue
        text = current.read_text(errors="replace")
        names = [n.strip().strip('"') for n in (_INP_INCLUDE if suffix == ".inp" else _GEO_READS).findall(text)]
        pending += [name if name.is_absolute() else current.parent / name for name in map(Path, names)]
    return found


def read_mesh_file(path: Path, refine: int = 0) -> MeshFile:
    """The named sets of a .msh, .geo or .inp file, refined ``refine`` times: a .msh or .inp by uniform
    subdivision (:mod:`.subdivide`), a .geo meshed by gmsh with its element sizes divided by 2^refine."""
    suffix = path.suffix.lower()
    if isinstance(refine, bool) or not isinstance(refine, int) or refine < 0:
        raise InputError(f"[model] refine = {refine!r}: must be a whole number >= 0 (uniform subdivisions of the "
                         "mesh, each halving its element size)")
    if suffix == ".inp":
        sets = read_inp(path)
        return subdivided(MeshFile(path, sets.points, sets.cell_type, sets.cells, sets.elsets, sets.surfaces,
                                   sets.nsets, True, sets.element_type), refine)
    if suffix not in (".msh", ".geo"):
        raise InputError(f"[model] file = {str(path)!r}: a mesh file must be a gmsh .msh or .geo or an "
                         "Abaqus / CalculiX .inp")
    geo = suffix == ".geo"
    mesh, node_sets = read_gmsh_file(path, 0.5 ** refine if geo else 1.0)
    source = MeshFile(path, mesh.points, mesh.cell_type, mesh.cells, dict(mesh.regions), dict(mesh.boundaries),
                      node_sets)
    return source if geo else subdivided(source, refine)


def mesh_model(file, kind: str = "3d", stages=("load",), increments=1, materials=None, supports=(), loads=(),
               interfaces=(), element: str | None = None, refine: int = 0) -> Model:
    """A model on a user's mesh file; every name is a region, boundary or node set of the file.

    Parameters
    ----------
    file : str or Path
        gmsh .msh (physical groups name regions and boundaries), .geo (meshed by the installed gmsh) or
        Abaqus / CalculiX .inp (*ELSET regions, element-face *SURFACE boundaries, *NSET node sets; names
        case-insensitive). Relative to the config file's folder.
    kind : "3d" | "plane_strain" | "axisymmetric"
        Axisymmetric: x = r >= 0, y the axis, forces for the whole ring; plane strain: forces per mm thickness.
    stages : list of str
        Stage names, in order.
    increments : int or list of int
        Load increments per stage (one number: the same for each stage).
    materials : table region -> { E [MPa], nu }
        One per region of the file that has cells; regions must not overlap and must cover every cell.
    supports : list of { boundary, components }
        Components ("x", "y", "z") held at zero; default all.
    loads : list of { type, boundary, component, values }
        ``type`` "pressure" [MPa, positive pushing into the body], "force" [N, total over the boundary, spread
        uniformly; ``component``] or "displacement" [mm; ``component``]; ``values`` one per stage.
    interfaces : list of { name, zones, contact, zone_rules, target, discretisation, gap_tolerance }
        Contact-side boundaries (``zones``, one per friction zone) and/or contact-side boundaries (``contact``)
        split into zones by ``zone_rules`` (see :mod:`frictionid.builders.zone_rules`), and the target boundary
        on the other body; ``discretisation`` "auto" (default), "node-to-node" or "mortar";
        ``gap_tolerance`` [mm] the largest initial gap of a contact pair (default half the contact facet size).
    element : "standard" | "incompatible" | None
        Element technology (incompatible modes need linear hexahedra); None (default): as the file says, i.e.
        "incompatible" for an .inp of C3D8I, else "standard" (:func:`~frictionid.builders.mesh_inp.element_meaning`;
        what frictionid computes differently from the deck's type, e.g. reduced integration, is a warning, as is
        an ``element`` that contradicts the deck).
    refine : int
        Refinements of the file's mesh, each halving the element size: a .msh or .inp by uniform subdivision
        of every cell (groups carried over), a .geo meshed with gmsh's sizes divided by 2^refine
        (``identify.model_error`` and ``refine_target`` raise it).

    Raises
    ------
    InputError
        Naming the [model] key: a missing file, a name the file does not have (with the names it has and a "did
        you mean"), a region without a material, bodies sharing nodes at an interface, a zone not on the contact
        side, supports that leave a mechanism, zone rules that leave a facet without a zone or a zone empty.

    See Also
    --------
    docs/models.md, "`mesh`: your own mesh", and tests/fixtures/user_block (reference test 1 as a user's mesh).
    """
    path = Path(file) if isinstance(file, (str, Path)) else None
    if path is None:
        raise InputError(f"[model] file: must be the name of a mesh file, got {file!r}")
    if not path.is_file():
        raise InputError(f"[model] file = {str(file)!r}: no such file ({path.resolve()})")
    if kind not in KINDS:
        raise InputError(f"[model] kind = {kind!r}: must be one of {list(KINDS)}")
    if kind == "axisymmetric_twist":
        raise InputError("[model] kind = 'axisymmetric_twist': not available for a user's mesh yet (no rotation "
                         "load, no checks of its rigid modes); builder 'bolt' with load = \"tightening\" has it")
    stages = _stages(stages, increments)
    source = read_mesh_file(path, refine)
    dim = source.points.shape[1]
    if (kind == "3d") != (dim == 3):
        raise InputError(f"[model] kind = {kind!r} does not fit {path.name}, a {dim}-D mesh "
                         f"({source.cell_type} cells)")
    if kind == "axisymmetric" and source.points[:, 0].min() < -1e-9 * np.ptp(source.points):
        raise InputError(f"[model] kind = 'axisymmetric': {path.name} has nodes at x < 0 (x is the radius)")
    element = _element(source, element, kind)
    regions, material_of = _materials(source, materials)
    used: dict[str, tuple[str, str]] = {}            # configured name -> (kind of set, file's name)
    ruled: dict[str, np.ndarray] = {}                # zone by rule -> its facets
    model_interfaces = tuple(_interface(source, entry, i, used, ruled)
                             for i, entry in enumerate(_list(interfaces, "interfaces"), 1))
    # supports and loads may name the zones rules made (boundaries of the model, not of the file)
    model_supports = tuple(_support(source, entry, i, dim, used, ruled)
                           for i, entry in enumerate(_list(supports, "supports"), 1))
    model_loads = tuple(_load(source, entry, i, len(stages), used, ruled)
                        for i, entry in enumerate(_list(loads, "loads"), 1))
    mesh = Mesh(points=source.points, cell_type=source.cell_type, cells=source.cells, regions=regions,
                boundaries={**{name: _facets(source, kind_, known) for name, (kind_, known) in used.items()},
                            **ruled})
    check_contact_sides(mesh, model_interfaces)
    model = Model(mesh=mesh, kind=kind, materials=material_of, supports=model_supports, loads=model_loads,
                  stages=stages, interfaces=model_interfaces, element=element)
    check_held(model)
    logger.info("%s: %d nodes, %d %s cells, regions %s", path.name, mesh.n_nodes, mesh.n_cells, mesh.cell_type,
                list(regions))
    return model


# ---------------------------------------------------------------------------------------------- the [model] keys

def _element(source: MeshFile, element, kind: str) -> str:
    """The element technology: ``element`` if given, else the deck's (:func:`element_meaning`); warnings where the
    deck's element type means something frictionid computes otherwise, or ``element`` contradicts it."""
    if element is not None and element not in ELEMENTS:
        raise InputError(f"[model] element = {element!r}: must be one of {list(ELEMENTS)}")
    if not source.element_type:
        return element or "standard"
    meaning, notes = element_meaning(source.element_type, kind)
    for note in notes:
        logger.warning("%s: %s", source.path.name, note)
    if element is not None and element != meaning:
        logger.warning("[model] element = %r contradicts %s, whose %s elements mean element %r; computing with "
                       "element %r as the config says (leave element out to follow the deck)", element,
                       source.path.name, source.element_type, meaning, element)
    return element or meaning


def _list(value, key: str) -> list:
    if isinstance(value, dict) or not isinstance(value, (list, tuple)):
        raise InputError(f"[[model.{key}]]: must be a list of tables, got {value!r}")
    return list(value)


def _stages(names, increments) -> tuple[Stage, ...]:
    if isinstance(names, str) or not isinstance(names, (list, tuple)) or not names \
            or not all(isinstance(n, str) and n for n in names):
        raise InputError(f"[model] stages: must be a list of stage names, e.g. [\"press\", \"pull\"], got {names!r}")
    if len(set(names)) != len(names):
        raise InputError(f"[model] stages: a stage name is used twice in {list(names)}")
    counts = [increments] * len(names) if not isinstance(increments, (list, tuple)) else list(increments)
    if len(counts) != len(names) or any(isinstance(c, bool) or not isinstance(c, int) or c < 1 for c in counts):
        raise InputError(f"[model] increments: must be a whole number >= 1 or one per stage ({len(names)}), "
                         f"got {increments!r}")
    return tuple(Stage(n, c) for n, c in zip(names, counts))


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{where}: must be a finite number, got {value!r}")
    return float(value)


def _materials(source: MeshFile, materials) -> tuple[dict, dict]:
    """Regions (file cells) and materials under the configured names; every cell must get one."""
    where = "[model.materials]"
    if not isinstance(materials, dict) or not materials:
        raise InputError(f"{where}: needs a table region = {{ E = ..., nu = ... }} for each region of "
                         f"{source.path.name}: {sorted(source.regions)}")
    regions, material_of = {}, {}
    for name, value in materials.items():
        _, known = source.find(name, ("regions",), f"{where} region")
        entry = checked_table(value, {"E": ..., "nu": ...}, f"{where} {name}")
        regions[name] = source.regions[known]
        material_of[name] = Material(_number(entry["E"], f"{where} {name}.E"),
                                     _number(entry["nu"], f"{where} {name}.nu"), name=name)
    covered = np.zeros(len(source.cells), dtype=bool)
    for cells in regions.values():
        covered[cells] = True
    if not covered.all():
        bare = [n for n, cells in source.regions.items() if len(cells) and not covered[cells].any()]
        which = f"region(s) {bare} have" if bare else f"{int((~covered).sum())} cell(s) (in no region given) have"
        raise InputError(f"{where}: {which} no material; give one for every region of {source.path.name} "
                         f"({sorted(source.regions)})")
    return regions, material_of


def _support(source: MeshFile, entry, index: int, dim: int, used: dict, ruled: dict) -> Support:
    where = f"[[model.supports]] {index}"
    entry = checked_table(entry, {"boundary": ..., "components": list("xyz"[:dim])}, where)
    components = entry["components"]
    if isinstance(components, str) or not isinstance(components, (list, tuple)) or not components:
        raise InputError(f"{where} components: must be a list such as [\"x\", \"y\"], got {components!r}")
    return Support(_name(source, entry["boundary"], ("boundaries", "node_sets"), f"{where} boundary", used, ruled),
                   tuple(components))


def _load(source: MeshFile, entry, index: int, n_stages: int, used: dict, ruled: dict):
    where = f"[[model.loads]] {index}"
    entry = checked_table(entry, {"type": ..., "boundary": ..., "component": None, "values": ...}, where)
    kind = entry["type"]
    if kind not in LOAD_TYPES:
        raise InputError(f"{where} type = {kind!r}: must be one of {list(LOAD_TYPES)}")
    values = entry["values"]
    if not isinstance(values, (list, tuple)) or len(values) != n_stages:
        raise InputError(f"{where} values: must give one value per stage ({n_stages}), got {values!r}")
    values = tuple(_number(v, f"{where} values") for v in values)
    sets = ("boundaries", "node_sets") if kind == "displacement" else ("boundaries",)
    boundary = _name(source, entry["boundary"], sets, f"{where} boundary", used, ruled)
    if kind == "pressure":
        if entry["component"] is not None:
            raise InputError(f"{where}: a pressure acts along the normal; it takes no component")
        return Pressure(boundary, values)
    if entry["component"] is None:
        raise InputError(f"{where}: a {kind} needs a component (\"x\", \"y\" or \"z\")")
    return LOAD_TYPES[kind](boundary, entry["component"], values)


def _interface(source: MeshFile, entry, index: int, used: dict, ruled: dict) -> ContactInterface:
    where = f"[[model.interfaces]] {index}"
    entry = checked_table(entry, {"name": f"interface {index}", "zones": None, "contact": None, "zone_rules": None,
                                  "target": ..., "discretisation": "auto", "gap_tolerance": None,
                                  "adjust": False}, where)
    zones = entry["zones"]
    if zones is None and entry["zone_rules"] is None and entry["contact"] is None:
        raise InputError(f"{where}: needs zones (boundaries on the contact side, one per friction zone) or contact "
                         "and zone_rules (a contact-side boundary split into zones by rules)")
    if zones is not None and (isinstance(zones, str) or not isinstance(zones, (list, tuple)) or not zones):
        raise InputError(f"{where} zones: must be a list of boundaries, one per friction zone, got {zones!r}")
    zones = tuple(_name(source, z, ("boundaries",), f"{where} zones", used) for z in zones or ())
    zones += _ruled_zones(source, entry, where, used, ruled, zones)
    target = _name(source, entry["target"], ("boundaries",), f"{where} target", used)
    tolerance = entry["gap_tolerance"]
    if tolerance is not None and (isinstance(tolerance, bool) or not isinstance(tolerance, (int, float))
                                  or not math.isfinite(tolerance) or tolerance <= 0):
        raise InputError(f"{where} gap_tolerance: must be a positive number of mm (the largest initial gap of a "
                         f"contact pair), got {tolerance!r}")
    if not isinstance(entry["adjust"], bool):
        raise InputError(f"{where} adjust: must be true (set the pairs' initial gaps, all within gap_tolerance, to "
                         f"zero) or false, got {entry['adjust']!r}")
    return ContactInterface(str(entry["name"]), zones, target, entry["discretisation"], gap_tolerance=tolerance,
                            adjust=entry["adjust"])


def _ruled_zones(source: MeshFile, entry: dict, where: str, used: dict, ruled: dict, zones: tuple) -> tuple:
    """The zones ``zone_rules`` make of the ``contact`` boundaries (none without them), recorded in ``ruled``."""
    contact, tables = entry["contact"], entry["zone_rules"]
    if tables is None and contact is None:
        return ()
    if tables is None:
        raise InputError(f"{where} contact: a contact surface is split into zones by zone_rules, which are "
                         "missing; add [[model.interfaces.zone_rules]] tables, or give the zones as zones = [...]")
    if contact is None:
        raise InputError(f"{where} zone_rules: need contact, the contact-side boundary (or list of boundaries) "
                         "the rules split into zones")
    names = [contact] if isinstance(contact, str) else contact
    if not isinstance(names, (list, tuple)) or not names:
        raise InputError(f"{where} contact: must be a boundary or a list of boundaries, got {contact!r}")
    parts = [source.boundaries[source.find(n, ("boundaries",), f"{where} contact")[1]] for n in names]
    facets = _distinct(np.concatenate(parts))
    if zones:
        given = {frozenset(f) for z in zones for f in _facets(source, *used[z]).tolist()}
        shared = sum(frozenset(f) in given for f in facets.tolist())
        if shared:
            raise InputError(f"{where}: zones and zone_rules are ambiguous: {shared} facet(s) of contact "
                             f"{list(names)} are also in zones {list(zones)}, so they would get two zones; "
                             "split the contact boundaries by rules alone, or give zones of other facets")
    rules = zone_rules(tables, source.points.shape[1], f"{where} zone_rules")
    for k, rule in enumerate(rules, 1):
        _new_name(source, rule.name, f"{where} zone_rules {k} name", set(ruled) | set(zones))
    split = split_facets(source.points, facets, rules, f"{where} zone_rules")
    logger.info("%s: zone_rules split %d facets of %s: %s", where, len(facets), list(names),
                ", ".join(f"{name} {len(f)}" for name, f in split.items()))
    ruled.update(split)
    return tuple(split)


def _distinct(facets: np.ndarray) -> np.ndarray:
    """Facets (n, n_facet_nodes) each once, in the order first met (contact boundaries may overlap)."""
    _, first = np.unique(np.sort(facets, axis=1), axis=0, return_index=True)
    return facets[np.sort(first)]


def _new_name(source: MeshFile, name: str, where: str, taken: set) -> None:
    """A zone made by a rule is a new boundary: its name must be no set of the file and no other zone."""
    fold = str.casefold if source.case_insensitive else (lambda s: s)
    if fold(name) in {fold(t) for t in taken}:
        raise InputError(f"{where} = {name!r}: another zone of the model has that name")
    for kind in _WHAT:
        if any(fold(known) == fold(name) for known in getattr(source, kind)):
            raise InputError(f"{where} = {name!r}: {source.path.name} has a {_WHAT[kind]} of that name; a zone "
                             "made by zone_rules is a new boundary, so give it a name of its own")


def _name(source: MeshFile, name, kinds: tuple[str, ...], where: str, used: dict, ruled: dict | None = None) -> str:
    """The configured name, recorded with the set of the file it stands for; a zone made by rules (a key of
    ``ruled``, spelled as configured) stands for itself."""
    if ruled and "boundaries" in kinds and name in ruled:
        return name
    used[name] = source.find(name, kinds, where)
    return name


def _facets(source: MeshFile, kind: str, known: str) -> np.ndarray:
    """A boundary's facets; a node set becomes facets of one repeated node each (its nodes are all that
    supports and displacements read, through :meth:`Mesh.boundary_nodes`)."""
    if kind == "boundaries":
        return source.boundaries[known]
    n_facet = FACET_NODES[FACET_TYPE[source.cell_type]]
    return np.repeat(np.asarray(source.node_sets[known], dtype=np.int64)[:, None], n_facet, axis=1)
