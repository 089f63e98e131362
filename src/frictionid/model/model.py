"""Model: mesh + materials + supports + load path + contact interfaces split into friction zones."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Mapping

import numpy as np

from ..errors import InputError
from .mesh import Mesh, init_arguments, rebuild

KINDS = ("3d", "plane_strain", "axisymmetric", "axisymmetric_twist")
#: kinds of revolution about the y axis (x = r): whole-ring (2 pi r) integrals, u_r = 0 on the axis
AXISYMMETRIC_KINDS = ("axisymmetric", "axisymmetric_twist")
#: element technologies: "standard" (the mesh's Lagrange elements), "incompatible" (linear hexahedra with
#: Wilson-Taylor incompatible modes, CalculiX/Abaqus C3D8I)
ELEMENTS = ("standard", "incompatible")
_COMPONENTS = {"x": 0, "y": 1, "z": 2, "r": 0, "t": 2}
#: the reaction entry of a :class:`Rotation` in a 3-D model: the moment about the y axis of its x and z reactions
TORQUE = "torque"


def n_components(kind: str, dim: int) -> int:
    """Displacement components per node: the mesh's dimension, 3 for "axisymmetric_twist" (u_r, u_y, u_t).

    >>> n_components("axisymmetric_twist", 2), n_components("axisymmetric", 2)
    (3, 2)
    """
    return 3 if kind == "axisymmetric_twist" else dim


def component_index(component, dim: int, where: str) -> int:
    """Index of a displacement component given as 0..dim-1 or 'x', 'y', 'z' ('r' = 'x' in axisymmetry; 't' = 2,
    the circumferential component u_t of "axisymmetric_twist", along +z on the x-y plane); ``dim`` is the number
    of components per node (:func:`n_components`)."""
    index = _COMPONENTS.get(component, component) if isinstance(component, str) else component
    if not isinstance(index, (int, np.integer)) or not 0 <= index < dim:
        raise InputError(f"{where}: component {component!r} is not one of x, y{', z' if dim == 3 else ''}")
    return int(index)


def reaction_label(boundary: str, component: int, kind: str = "") -> str:
    """Label of the reaction sum of one boundary component (index 0..2): "boundary.axis"; the circumferential
    component of an "axisymmetric_twist" model sums moments about the axis: "boundary.torque" [N mm].

    >>> reaction_label("block_top", 1), reaction_label("nut_top", 2, "axisymmetric_twist")
    ('block_top.y', 'nut_top.torque')
    """
    if component == TORQUE or (kind == "axisymmetric_twist" and component == 2):
        return f"{boundary}.torque"
    return f"{boundary}.{'xyz'[component]}"


def check_element(element, cell_type: str, where: str) -> str:
    """``element`` if it is one of :data:`ELEMENTS` and fits the cell type, else an :class:`InputError`."""
    if element not in ELEMENTS:
        raise InputError(f"{where}: element {element!r} is not one of {ELEMENTS}")
    if element == "incompatible" and cell_type != "hexahedron":
        raise InputError(f"{where}: element 'incompatible' needs linear hexahedra (cell type 'hexahedron'), "
                         f"the mesh has {cell_type!r}; use element 'standard'")
    return element


@dataclass(frozen=True)
class Material:
    """Linear elastic isotropic material: Young's modulus E [MPa], Poisson's ratio nu."""

    E: float
    nu: float
    name: str = ""

    def __post_init__(self):
        if not self.E > 0 or not -1.0 < self.nu < 0.5:
            raise InputError(f"material {self.name!r}: need E > 0 and -1 < nu < 0.5, got E={self.E}, nu={self.nu}")

    @property
    def lame(self) -> tuple[float, float]:
        """(lambda, mu) [MPa]."""
        lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        return lam, self.E / (2 * (1 + self.nu))


@dataclass(frozen=True)
class Support:
    """Displacement components held at zero on a named boundary for the whole load path."""

    boundary: str
    components: tuple = (0, 1, 2)


@dataclass(frozen=True)
class Displacement:
    """Prescribed displacement [mm] of one component on a boundary; ``values[s]`` is reached at the end of stage s."""

    boundary: str
    component: int | str
    values: tuple[float, ...]


@dataclass(frozen=True)
class Pressure:
    """Normal pressure [MPa] on a boundary, positive pushing into the body; ``values[s]`` at the end of stage s."""

    boundary: str
    values: tuple[float, ...]


@dataclass(frozen=True)
class SurfaceForce:
    """Total force [N] in one component, spread uniformly over a boundary's area; ``values[s]`` at end of stage s.

    Axisymmetric models count the whole ring (360 deg); plane-strain models count per mm of thickness.
    """

    boundary: str
    component: int | str
    values: tuple[float, ...]


@dataclass(frozen=True)
class Rotation:
    """Prescribed rotation [rad] of a boundary about the y axis of an "axisymmetric_twist" or "3d" model: u_t =
    r * values[s] at each of its nodes at the end of stage s (u_r, u_y free; in 3-D u_x = -z values[s], u_z =
    x values[s], u_y free: a small rigid rotation from +x towards +z); its reaction is the torque [N mm] about the
    axis, positive in the +t sense (t = r x y: +z on the x-y plane at x > 0), "boundary.torque"."""

    boundary: str
    values: tuple[float, ...]

    component = 2

    @staticmethod
    def components(kind: str) -> tuple[int, ...]:
        """The displacement components it prescribes: u_t (2) in "axisymmetric_twist", u_x and u_z in 3-D."""
        return (0, 2) if kind == "3d" else (2,)

    @staticmethod
    def unit(points: np.ndarray, component: np.ndarray, kind: str) -> np.ndarray:
        """(n,) [mm/rad] the prescribed displacement per radian of ``component`` (n,) at nodes ``points`` (n, dim);
        also the weights that sum the reactions of those dofs into the torque about the axis."""
        points = np.asarray(points, dtype=float)
        if kind != "3d":
            return points[:, 0].copy()
        return np.where(np.asarray(component) == 0, -points[:, 2], points[:, 0])


@dataclass(frozen=True)
class Stage:
    """One stage of the load path: loads ramp linearly from the previous stage's end values in n_increments."""

    name: str
    n_increments: int = 1

    def __post_init__(self):
        if int(self.n_increments) < 1:
            raise InputError(f"stage {self.name!r}: n_increments must be at least 1, got {self.n_increments}")


@dataclass(frozen=True)
class ContactInterface:
    """A contact interface: the contact side is the union of its zones, each a named boundary of the mesh.

    Each zone carries its own Coulomb coefficient. ``target`` is the named boundary on the other body.
    ``discretisation``: "node-to-node" (conforming meshes: every contact node has a target node at the same
    place, up to an initial gap), "mortar" (non-matching meshes, 2-D and 3-D) or "auto" (node-to-node when conforming, else mortar).
    ``lead`` [mm]: axial advance per turn of a helical interface (a thread: the pitch times the number of starts),
    positive for a right-hand helix; "axisymmetric_twist" and "3d" models. In "axisymmetric_twist" its rings
    stand for the helix: each pair's normal is tilted by the local lead angle
    (:func:`frictionid.fem.twist.helical_normals`), so that turning one side advances it along the axis and the
    normal force carries torque. In "3d" (node-to-node pairs about the y axis) the helix is in the mesh and each
    pair's normal is made normal to the helix through its node (:func:`frictionid.fem.twist.on_helicoid`): the
    facets' normals scatter about the helicoid's, and a nut turned on them closes the pairs whose normals are
    steepest first.
    ``gap_tolerance`` [mm]: the largest initial |gap| a pair may have (default None: half the median contact facet
    size, :func:`frictionid.fem.contact_map.gap_tolerance`); a larger one is refused before any solve.
    ``coefficients``: the name of the friction coefficient of each zone (default: the zone's own name); zones of
    several interfaces that share a coefficient name share one coefficient (``[friction] merge``).
    ``adjust``: the pairs' initial gaps (all within ``gap_tolerance``) are set to zero, as CalculiX's *CONTACT PAIR
    ADJUST moves the slave nodes onto the master surface: for two discretisations of one surface (a thread meshed
    on both sides independently), whose gaps are the meshes' and not the geometry's.
    """

    name: str
    zones: tuple[str, ...]
    target: str
    discretisation: str = "auto"
    lead: float = 0.0
    gap_tolerance: float | None = None
    coefficients: tuple[str, ...] = ()
    adjust: bool = False

    def __post_init__(self):
        object.__setattr__(self, "zones", tuple(self.zones))
        object.__setattr__(self, "coefficients", tuple(self.coefficients) or self.zones)
        if len(self.coefficients) != len(self.zones):
            raise InputError(f"interface {self.name!r}: {len(self.coefficients)} coefficient names for "
                             f"{len(self.zones)} zones {list(self.zones)}")
        tolerance = self.gap_tolerance
        if tolerance is not None and (isinstance(tolerance, bool) or not isinstance(tolerance, (int, float))
                                      or not np.isfinite(tolerance) or tolerance <= 0):
            raise InputError(f"[[model.interfaces]] {self.name!r} gap_tolerance: must be a positive number of mm, "
                             f"got {tolerance!r}")
        if isinstance(self.lead, bool) or not isinstance(self.lead, (int, float)) or not np.isfinite(self.lead):
            raise InputError(f"interface {self.name!r}: lead must be a number of mm, got {self.lead!r}")
        if not isinstance(self.adjust, bool):
            raise InputError(f"interface {self.name!r}: adjust must be true or false, got {self.adjust!r}")
        if self.discretisation not in ("auto", "node-to-node", "mortar"):
            raise InputError(f"interface {self.name!r}: discretisation {self.discretisation!r} is not one of "
                             "'auto', 'node-to-node', 'mortar'")


Load = Displacement | Pressure | SurfaceForce | Rotation


@dataclass(frozen=True)
class Model:
    """Everything a forward solver needs except the friction coefficients.

    Parameters
    ----------
    mesh : Mesh
    kind : "3d" | "plane_strain" | "axisymmetric" | "axisymmetric_twist"
        Plane strain counts forces per mm of thickness; axisymmetric uses x = r, y = axis, whole-ring forces;
        "axisymmetric_twist" adds the circumferential displacement u_t (three components per node, as Abaqus
        CGAX; torsion without a theta dependence, see :mod:`frictionid.fem.twist`).
    materials : mapping region name -> Material
    supports : Supports (zero displacement) on named boundaries.
    loads : Displacement, Pressure and SurfaceForce entries, each with one value per stage.
    stages : the load path.
    interfaces : contact interfaces with their friction zones.
    zone_names : (derived) the names of the friction coefficients, in interface and zone order: the zones' own
        names, or the coefficient several zones share (:attr:`ContactInterface.coefficients`).
    element : "standard" | "incompatible"
        Element technology on the mesh: the cell type's Lagrange element, or (linear hexahedra only) hex8 with
        incompatible modes (Wilson-Taylor, as CalculiX's C3D8I), which does not lock in bending.
    """

    mesh: Mesh
    kind: str
    materials: Mapping[str, Material]
    supports: tuple[Support, ...] = ()
    loads: tuple[Load, ...] = ()
    stages: tuple[Stage, ...] = (Stage("load"),)
    interfaces: tuple[ContactInterface, ...] = ()
    element: str = "standard"
    zone_names: tuple[str, ...] = field(init=False)

    def __reduce__(self):
        return rebuild, (type(self), init_arguments(self))

    def __post_init__(self):
        object.__setattr__(self, "materials", MappingProxyType(dict(self.materials)))
        object.__setattr__(self, "supports", tuple(self.supports))
        object.__setattr__(self, "loads", tuple(self.loads))
        object.__setattr__(self, "stages", tuple(self.stages))
        object.__setattr__(self, "interfaces", tuple(self.interfaces))
        object.__setattr__(self, "zone_names", tuple(dict.fromkeys(c for i in self.interfaces
                                                                    for c in i.coefficients)))
        self._validate()

    @property
    def dim(self) -> int:
        return self.mesh.dim

    @property
    def n_components(self) -> int:
        """Displacement components per node (:func:`n_components`)."""
        return n_components(self.kind, self.mesh.dim)

    def with_element(self, element: str) -> "Model":
        """The same model with another element technology (see :data:`ELEMENTS`)."""
        return replace(self, element=element)

    def fingerprint(self) -> str:
        """SHA-256 of the model's whole content (mesh arrays, materials, supports, loads, stages, interfaces,
        element technology):
        equal for two models that every solver treats alike."""
        digest = hashlib.sha256()
        mesh = self.mesh
        arrays = (mesh.points, mesh.cells, *mesh.regions.values(), *mesh.boundaries.values())
        for array in arrays:
            digest.update(np.ascontiguousarray(array).tobytes())
        digest.update(repr((tuple(a.shape for a in arrays), mesh.cell_type, tuple(mesh.regions),
                            tuple(mesh.boundaries), self.kind,
                            sorted(self.materials.items()), self.supports, self.loads, self.stages,
                            self.interfaces, self.element)).encode())
        return digest.hexdigest()

    @property
    def n_stages(self) -> int:
        return len(self.stages)

    def __repr__(self) -> str:
        return (f"Model({self.kind}, {self.mesh.n_nodes:,} nodes, {self.mesh.n_cells:,} {self.mesh.cell_type} "
                f"cells, element {self.element!r}, stages {[s.name for s in self.stages]}, zones "
                f"{list(self.zone_names)})")

    @property
    def n_zones(self) -> int:
        return len(self.zone_names)

    def coefficients(self, mu) -> np.ndarray:
        """(n_zones,) friction coefficients in :attr:`zone_names` order, from a sequence or a mapping zone ->
        value; an InputError unless there is one finite, non-negative value per zone.

        >>> from frictionid.builders.block import block_model_2d
        >>> block_model_2d(mesh_size=4.0).coefficients({"B": 0.3, "A": 0.2}).tolist()
        [0.2, 0.3]
        """
        if isinstance(mu, Mapping):
            unknown = set(mu) - set(self.zone_names)
            if unknown:
                raise InputError(f"friction: unknown zone(s) {sorted(unknown)}; the model's zones are "
                                 f"{list(self.zone_names)}")
            missing = [z for z in self.zone_names if z not in mu]
            if missing:
                raise InputError(f"friction: no coefficient for zone(s) {missing}")
            mu = [mu[z] for z in self.zone_names]
        mu = np.asarray(mu, dtype=float).reshape(-1)
        if mu.shape != (self.n_zones,) or not np.all(np.isfinite(mu)) or np.any(mu < 0):
            raise InputError(f"friction: need {self.n_zones} finite non-negative coefficients, got {mu}")
        return mu

    @property
    def reaction_entries(self) -> tuple[tuple[str, int], ...]:
        """(boundary, component index) of each reaction sum, each once: the supports' components, then those
        driven by a prescribed displacement."""
        entries = [(s.boundary, component_index(c, self.n_components, s.boundary))
                   for s in self.supports for c in s.components]
        entries += [(l.boundary, TORQUE if isinstance(l, Rotation) and self.kind == "3d"
                     else component_index(l.component, self.n_components, l.boundary))
                    for l in self.loads if isinstance(l, (Displacement, Rotation))]
        return tuple(dict.fromkeys(entries))

    @property
    def reaction_labels(self) -> tuple[str, ...]:
        """:func:`reaction_label` of each of :attr:`reaction_entries`, e.g. "block_top.y"."""
        return tuple(reaction_label(boundary, c, self.kind) for boundary, c in self.reaction_entries)

    def _validate(self):
        mesh = self.mesh
        if self.kind not in KINDS:
            raise InputError(f"model: kind {self.kind!r} is not one of {KINDS}")
        if (self.kind == "3d") != (mesh.dim == 3):
            raise InputError(f"model: kind {self.kind!r} does not fit a {mesh.dim}-D mesh")
        check_element(self.element, mesh.cell_type, "model")
        for name in self.materials:
            if name not in mesh.regions:
                raise InputError(f"model: material given for region {name!r}, which the mesh does not have; "
                                 f"regions are {sorted(mesh.regions)}")
        without = [r for r in mesh.regions if r not in self.materials]
        if without:
            raise InputError(f"model: region(s) {without} have no material")
        if np.any(mesh.cell_region < 0):
            raise InputError(f"model: {int(np.sum(mesh.cell_region < 0))} cell(s) belong to no named region, "
                             "so they have no material")
        for support in self.supports:
            mesh.boundary(support.boundary)
            for c in support.components:
                component_index(c, self.n_components, f"support on {support.boundary!r}")
        for load in self.loads:
            mesh.boundary(load.boundary)
            if len(load.values) != self.n_stages:
                raise InputError(f"model: {type(load).__name__} on {load.boundary!r} has {len(load.values)} "
                                 f"value(s), expected one per stage ({self.n_stages})")
            if isinstance(load, Rotation) and self.kind not in ("axisymmetric_twist", "3d"):
                raise InputError(f"model: a Rotation on {load.boundary!r} needs kind 'axisymmetric_twist' or '3d', "
                                 f"the model is {self.kind!r}")
            if hasattr(load, "component"):
                component_index(load.component, self.n_components, f"{type(load).__name__} on {load.boundary!r}")
        self._validate_zones()

    def _validate_zones(self):
        seen: dict[frozenset, str] = {}
        zones = [z for i in self.interfaces for z in i.zones]
        if len(set(zones)) != len(zones):
            raise InputError(f"model: a zone name is used twice in {zones}")
        coefficient_of = {z: c for i in self.interfaces for z, c in zip(i.zones, i.coefficients)}
        for zone, coefficient in coefficient_of.items():
            if coefficient in coefficient_of and coefficient_of[coefficient] != coefficient:
                raise InputError(f"model: zone {zone!r} takes coefficient {coefficient!r}, which is also the name of "
                                 f"zone {coefficient!r} with coefficient {coefficient_of[coefficient]!r}")
        for interface in self.interfaces:
            self.mesh.boundary(interface.target)
            if interface.lead and self.kind not in ("axisymmetric_twist", "3d"):
                raise InputError(f"model: interface {interface.name!r} has a lead ({interface.lead:g} mm), which "
                                 f"needs kind 'axisymmetric_twist' or '3d', the model is {self.kind!r}")
            for zone in interface.zones:
                for facet in self.mesh.boundary(zone):
                    key = frozenset(facet.tolist())
                    if key in seen:
                        raise InputError(f"model: zones {seen[key]!r} and {zone!r} overlap (they share a facet); "
                                         "each contact facet must belong to exactly one zone")
                    seen[key] = zone
