"""Abaqus / CalculiX input decks (.inp) read as a mesh file: nodes, one cell type, *ELSET, *NSET and *SURFACE.

Names are case-insensitive in an .inp (Abaqus and CalculiX fold case): a set defined again under the same
spelling is extended, two spellings that differ only in case are refused. A region is an *ELSET (or the
``ELSET=`` of an *ELEMENT block), a boundary an element-face *SURFACE (``element or elset, S1 ... S6``), a node set
an *NSET (or a ``TYPE=NODE`` surface). Keywords of a whole deck (*MATERIAL, *STEP, ...) are skipped with a note.
Node order: Abaqus and meshio agree on every element type read here (see
:mod:`frictionid.backends.calculix.elements`, whose face numbers are used).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..backends.calculix.elements import FACES, SHAPE
from ..errors import InputError

logger = logging.getLogger(__name__)

#: meshio cell type of each Abaqus / CalculiX element type read (the formulation comes from the [model] table's
#: kind and element; :func:`element_meaning` says what a type's letters mean there)
CELL_TYPE = {
    "C3D4": "tetra", "C3D10": "tetra10", "C3D8": "hexahedron", "C3D8I": "hexahedron", "C3D8R": "hexahedron",
    **{f"{family}3": "triangle" for family in ("CPE", "CPS", "CAX")},
    **{f"{family}6": "triangle6" for family in ("CPE", "CPS", "CAX")},
    **{f"{family}4{suffix}": "quad" for family in ("CPE", "CPS", "CAX") for suffix in ("", "R", "I")},
}
#: the [model] kind each element family of a deck is made for (plane stress has no counterpart here)
FAMILY_KIND = {"C3D": "3d", "CPE": "plane_strain", "CAX": "axisymmetric", "CPS": "plane stress"}
N_NODES = {"tetra": 4, "tetra10": 10, "hexahedron": 8, "triangle": 3, "triangle6": 6, "quad": 4}
#: mid-node of each edge (pair of local corners) of the quadratic cells, meshio (= Abaqus) order
_MID = {"tetra10": {(0, 1): 4, (1, 2): 5, (0, 2): 6, (0, 3): 7, (1, 3): 8, (2, 3): 9},
        "triangle6": {(0, 1): 3, (1, 2): 4, (0, 2): 5}}


@dataclass
class InpSets:
    """What a deck defines, under the names as first spelled in the file (all indices 0-based).

    Attributes
    ----------
    points : (n_nodes, dim) [mm]; cell_type : meshio name; cells : (n_cells, n_cell_nodes)
    elsets : name -> cell indices; nsets : name -> node indices; surfaces : name -> facets (meshio order)
    ignored : keywords skipped (each once, in the order met)
    element_type : the deck's element type (e.g. "C3D8I"), the first one met of its cell type
    """

    points: np.ndarray
    cell_type: str
    cells: np.ndarray
    elsets: dict[str, np.ndarray] = field(default_factory=dict)
    nsets: dict[str, np.ndarray] = field(default_factory=dict)
    surfaces: dict[str, np.ndarray] = field(default_factory=dict)
    ignored: tuple[str, ...] = ()
    element_type: str = ""


def element_meaning(element_type: str, kind: str) -> tuple[str, list[str]]:
    """(frictionid's element technology, notes on what differs) for a deck's element type under [model] ``kind``.

    C3D8I is a hexahedron with incompatible modes ("incompatible"); every other type is read as the full-integration
    Lagrange element of its cell ("standard"): reduced integration (the R types: one point, hourglass control) and
    the incompatible modes of 4-node quads (CPE4I, CPS4I, CAX4I) are not available, a plane-stress deck (CPS) or a
    family made for another kind (CAX under "plane_strain", ...) is computed as ``kind`` says; each such
    difference is a note.

    >>> element_meaning("C3D8I", "3d")
    ('incompatible', [])
    >>> element, (note,) = element_meaning("CPE4R", "plane_strain")
    >>> element, note.endswith("read as full-integration CPE4")
    ('standard', True)
    """
    name = element_type.upper()
    if name == "C3D8I":
        return "incompatible", []
    notes = []
    base = name[:-1] if name[-1:] in ("R", "I") and name[:-1] in CELL_TYPE else name
    if name.endswith("R") and base != name:
        notes.append(f"{name} has reduced integration (one point, hourglass control), which frictionid does not "
                     f"have: read as full-integration {base}")
    elif name.endswith("I") and base != name:
        notes.append(f"{name} has incompatible modes, which frictionid has for 8-node hexahedra (C3D8I) only: read "
                     f"as plain {base}")
    family = FAMILY_KIND.get(name[:3])
    if family is not None and family != kind:
        notes.append(f"{name} is a{'n' if family[0] in 'a' else ''} {family} element, [model] kind = {kind!r}: "
                     f"computed as {kind}")
    return "standard", notes


class _Names:
    """Case-insensitive set names: the first spelling is kept, another spelling of the same name is refused."""

    def __init__(self, what: str):
        self.what, self.spelling, self.members = what, {}, {}

    def add(self, name: str, members, where: str):
        key = name.casefold()
        first = self.spelling.setdefault(key, name)
        if first != name:
            raise InputError(f"{where}: {self.what} {name!r} and {first!r} differ only in case; .inp names are "
                             "case-insensitive, so they would be one set: rename one of them")
        self.members.setdefault(key, []).extend(members)

    def get(self, name: str):
        return self.members.get(name.casefold())

    def as_dict(self) -> dict:
        return {self.spelling[k]: v for k, v in self.members.items()}


def _keyword(line: str) -> tuple[str, dict[str, str]]:
    """Keyword (upper case, without '*') and parameters (upper-case keys, values as written) of a keyword line."""
    parts = [p.strip() for p in line[1:].split(",")]
    params = {}
    for part in parts[1:]:
        if part:
            key, _, value = part.partition("=")
            params[key.strip().upper()] = value.strip()
    return parts[0].upper(), params


def _blocks(path: Path, seen: tuple = ()):
    """(keyword, params, data lines as token lists, location) of a deck, *INCLUDE files read in place."""
    if path.resolve() in seen:
        raise InputError(f"{path}: *INCLUDE includes itself")
    try:
        lines = path.read_text(errors="replace").splitlines()
    except OSError as exc:
        raise InputError(f"{path}: cannot read it ({exc.strerror})") from None
    current = None
    for number, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or line.startswith("**"):
            continue
        if line.startswith("*"):
            if current:
                yield current
            keyword, params = _keyword(line)
            if keyword == "INCLUDE":
                current = None
                include = Path(params.get("INPUT", ""))
                yield from _blocks(include if include.is_absolute() else path.parent / include,
                                   seen + (path.resolve(),))
                continue
            current = (keyword, params, [], f"{path}, line {number}")
        elif current:
            current[2].append((number, [t.strip() for t in line.split(",")]))
    if current:
        yield current


def _int(token: str, where: str) -> int:
    try:
        return int(token)
    except ValueError:
        raise InputError(f"{where}: expected a whole number, got {token!r}") from None


class _Deck:
    """The reading state: nodes and elements by their ids, the three kinds of named sets."""

    def __init__(self, path: Path):
        self.path = path
        self.node_ids, self.coords = [], []
        self.element_ids, self.connectivity, self.element_types = [], [], {}
        self.elsets, self.nsets = _Names("element set"), _Names("node set")
        self.surfaces, self.node_surfaces = _Names("surface"), _Names("surface")
        self.ignored: dict[str, None] = {}

    def node(self, params, data, where):
        ids = []
        for number, tokens in data:
            tokens = [t for t in tokens if t]
            if len(tokens) < 3:
                raise InputError(f"{self.path}, line {number}: a *NODE line needs an id and 2 or 3 coordinates")
            ids.append(_int(tokens[0], f"{self.path}, line {number}"))
            try:
                self.coords.append([float(t) for t in tokens[1:4]] + [0.0] * (4 - len(tokens)))
            except ValueError:
                raise InputError(f"{self.path}, line {number}: coordinates must be numbers, got {tokens[1:4]}") \
                    from None
        self.node_ids += ids
        if "NSET" in params:
            self.nsets.add(params["NSET"], ids, where)

    def element(self, params, data, where):
        name = params.get("TYPE", "").upper()
        if name not in CELL_TYPE:
            raise InputError(f"{where}: element type {name or '(none)'!r} has no matching cell in frictionid; "
                             f"supported are {', '.join(sorted(CELL_TYPE))}")
        cell_type = CELL_TYPE[name]
        self.element_types.setdefault(cell_type, name)
        n = N_NODES[cell_type] + 1
        tokens, ids = [], []
        for number, line in data:
            tokens += [t for t in line if t]
            if len(tokens) >= n:
                if len(tokens) > n:
                    raise InputError(f"{self.path}, line {number}: element of type {name} needs {n - 1} nodes, "
                                     f"got {len(tokens) - 1}")
                values = [_int(t, f"{self.path}, line {number}") for t in tokens]
                ids.append(values[0])
                self.connectivity.append((cell_type, values[1:]))
                tokens = []
        if tokens:
            raise InputError(f"{where}: the last element of type {name} is incomplete ({len(tokens)} numbers)")
        self.element_ids += ids
        if "ELSET" in params:
            self.elsets.add(params["ELSET"], ids, where)

    def member_set(self, names: _Names, key: str, params, data, where):
        if key not in params:
            raise InputError(f"{where}: *{key} needs {key}=name")
        members = []
        if "GENERATE" in params:
            for number, line in data:
                values = [_int(t, f"{self.path}, line {number}") for t in line if t]
                if len(values) not in (2, 3):
                    raise InputError(f"{self.path}, line {number}: a GENERATE line is 'first, last[, step]'")
                start, stop, step = (values + [1])[:3]
                members += list(range(start, stop + 1, step))
        else:
            for number, token in [(number, t) for number, line in data for t in line if t]:
                if token.lstrip("-").isdigit():
                    members.append(int(token))
                elif names.get(token) is not None:
                    members += names.get(token)
                else:
                    raise InputError(f"{self.path}, line {number}: {names.what} {token!r} is not defined before "
                                     f"it is used")
        names.add(params[key], members, where)

    def surface(self, params, data, where):
        if "NAME" not in params:
            raise InputError(f"{where}: *SURFACE needs NAME=name")
        if params.get("TYPE", "ELEMENT").upper() == "NODE":
            members = []
            for number, line in data:
                token = line[0]
                members += [int(token)] if token.isdigit() else self._named(self.nsets, token, number)
            self.node_surfaces.add(params["NAME"], members, where)
            return
        faces = []
        for number, line in data:
            tokens = [t for t in line if t]
            if len(tokens) != 2 or not tokens[1].upper().startswith("S") or not tokens[1][1:].isdigit():
                raise InputError(f"{self.path}, line {number}: an element-face *SURFACE line is "
                                 f"'element or element set, S1 ... S6', got {', '.join(tokens)!r}")
            face = int(tokens[1][1:])
            elements = [int(tokens[0])] if tokens[0].isdigit() else self._named(self.elsets, tokens[0], number)
            faces += [(e, face, number) for e in elements]
        self.surfaces.add(params["NAME"], faces, where)

    def _named(self, names: _Names, name: str, number: int) -> list:
        if names.get(name) is None:
            raise InputError(f"{self.path}, line {number}: {names.what} {name!r} is not defined before it is used")
        return names.get(name)


def read_inp(path: str | Path) -> InpSets:
    """Read the mesh of an Abaqus / CalculiX deck (see the module docstring for what is read)."""
    path = Path(path)
    deck = _Deck(path)
    readers = {"NODE": deck.node, "ELEMENT": deck.element, "SURFACE": deck.surface,
               "NSET": lambda p, d, w: deck.member_set(deck.nsets, "NSET", p, d, w),
               "ELSET": lambda p, d, w: deck.member_set(deck.elsets, "ELSET", p, d, w)}
    for keyword, params, data, where in _blocks(path):
        if keyword in readers:
            readers[keyword](params, data, where)
        else:
            deck.ignored.setdefault(keyword)
    if deck.ignored:
        logger.warning("%s: keywords ignored (materials, supports, loads and steps come from [model]): %s",
                       path, ", ".join(f"*{k}" for k in deck.ignored))
    return _assemble(deck)


def _assemble(deck: _Deck) -> InpSets:
    path = deck.path
    if not deck.connectivity:
        raise InputError(f"{path}: has no elements (*ELEMENT)")
    if len(deck.element_types) > 1:
        raise InputError(f"{path}: needs one cell type, the deck mixes {sorted(deck.element_types.values())}")
    (cell_type, element_type), = deck.element_types.items()
    _index(deck.node_ids, "node", path)
    cells = np.array([nodes for _, nodes in deck.connectivity], dtype=np.int64)
    if np.any(~np.isin(cells, deck.node_ids)):
        raise InputError(f"{path}: an element refers to node {int(cells[~np.isin(cells, deck.node_ids)][0])}, "
                         "which *NODE does not define")
    element_index = _index(deck.element_ids, "element", path)
    dim = 3 if cell_type in ("tetra", "tetra10", "hexahedron") else 2
    coords = np.array(deck.coords)[:, :dim]
    if dim == 2 and np.any(np.array(deck.coords)[:, 2] != 0):
        raise InputError(f"{path}: a 2-D model needs every node at z = 0")
    # nodes numbered by id; nodes that no element uses are dropped
    used = np.unique(cells)
    order = np.argsort(deck.node_ids)
    ids = np.asarray(deck.node_ids)[order]
    keep = np.isin(ids, used)
    new = {int(i): k for k, i in enumerate(ids[keep])}
    points = coords[order][keep]
    cells = np.searchsorted(ids[keep], cells)
    elsets = {name: _lookup(element_index, members, name, "element", path)
              for name, members in deck.elsets.as_dict().items()}
    nsets = {name: np.unique([new[n] for n in members if n in new])
             for name, members in (deck.nsets.as_dict() | deck.node_surfaces.as_dict()).items()}
    surfaces = {name: _faces(cell_type, cells, element_index, faces, name, path)
                for name, faces in deck.surfaces.as_dict().items()}
    return InpSets(points=points, cell_type=cell_type, cells=cells, elsets=elsets, nsets=nsets,
                   surfaces=surfaces, ignored=tuple(deck.ignored), element_type=element_type)


def _index(ids: list[int], what: str, path: Path) -> dict[int, int]:
    index = {}
    for position, i in enumerate(ids):
        if index.setdefault(i, position) != position:
            raise InputError(f"{path}: {what} {i} is defined twice")
    return index


def _lookup(index: dict[int, int], members, name: str, what: str, path: Path) -> np.ndarray:
    missing = [m for m in members if m not in index]
    if missing:
        raise InputError(f"{path}: set {name!r} names {what} {missing[0]}, which the deck does not define")
    return np.unique([index[m] for m in members]).astype(np.int64)


def _faces(cell_type: str, cells: np.ndarray, element_index: dict, faces, name: str, path: Path) -> np.ndarray:
    """Facets (meshio order of the facet type, mid-nodes after corners) of an element-face surface."""
    shape = FACES[SHAPE[cell_type]]
    out = []
    for element, face, number in faces:
        if element not in element_index:
            raise InputError(f"{path}, line {number}: surface {name!r} names element {element}, which the deck "
                             "does not define")
        if not 1 <= face <= len(shape):
            raise InputError(f"{path}, line {number}: surface {name!r}: a {cell_type} element has faces S1 ... "
                             f"S{len(shape)}, got S{face}")
        out.append(facet_nodes(cell_type, cells[element_index[element]], shape[face - 1]))
    return np.array(out, dtype=np.int64).reshape(len(out), -1)


def facet_nodes(cell_type: str, cell: np.ndarray, corners: tuple[int, ...]) -> list[int]:
    """Node indices of one face of a cell: its corners, then (quadratic cells) the mid-nodes of its edges.

    >>> facet_nodes("triangle6", np.array([10, 11, 12, 13, 14, 15]), (2, 0))
    [12, 10, 15]
    """
    nodes = [int(cell[c]) for c in corners]
    if cell_type in _MID:
        edges = list(zip(corners, corners[1:] + corners[:1])) if len(corners) > 2 else [tuple(corners)]
        nodes += [int(cell[_MID[cell_type][tuple(sorted(edge))]]) for edge in edges]
    return nodes
