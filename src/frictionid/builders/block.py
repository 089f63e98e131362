"""Reference test 1: the block on a plane (3-D hexahedra) and its plane-strain analogue, with conforming contact."""

from __future__ import annotations

import logging
import math
import string

import gmsh
import numpy as np

from ..errors import InputError
from ..model import ContactInterface, Displacement, Material, Mesh, Model, Pressure, Stage, Support
from ..model.model import ELEMENTS
from .arguments import count, positive
from .block_mesh import (BLOCK_HEIGHT, BLOCK_SIDE, DEFAULT_GRADING, PLATE_THICKNESS, QUADRANT_ZONES, Bands,
                         block_mesh, checked_grading, layout, set_order)
from .gmsh_mesh import distance_size_field, gmsh_session, mesh_from_gmsh, use_size_fields

logger = logging.getLogger(__name__)

#: plate / base material (DESIGN.md, reference test 1)
EPOXY = Material(E=3500.0, nu=0.35, name="epoxy")
#: block material (DESIGN.md, reference test 1)
ALUMINIUM = Material(E=71000.0, nu=0.33, name="aluminium")

# ---------------------------------------------------------------------------------------------- arguments



def _order(value) -> int:
    if isinstance(value, bool) or value not in (1, 2):
        raise InputError(f"`order` must be 1 or 2, got {value!r}")
    return int(value)


def _element(value, order: int) -> str:
    if value is None:
        return "incompatible" if order == 1 else "standard"
    if value not in ELEMENTS:
        raise InputError(f"`element` must be one of {', '.join(map(repr, ELEMENTS))}, got {value!r}")
    if value == "incompatible" and order != 1:
        raise InputError(f"`element` 'incompatible' needs `order` 1 (linear hexahedra), got order {order}")
    return value


def _stages(n_press: int, n_pull: int) -> tuple[Stage, Stage]:
    return Stage("press", count("n_press", n_press)), Stage("pull", count("n_pull", n_pull))


def _pull_levels(levels, pull: float) -> tuple[float, ...]:
    """Intermediate pull displacements: finite, increasing, strictly between 0 and ``pull``."""
    if isinstance(levels, (str, bytes)) or not hasattr(levels, "__iter__"):
        raise InputError(f"`pull_levels` must be a list of displacements [mm], got {levels!r}")
    levels = tuple(levels)
    for level in levels:
        if isinstance(level, bool) or not isinstance(level, (int, float, np.integer, np.floating)) \
                or not 0 < level < pull:
            raise InputError(f"`pull_levels` must lie strictly between 0 and pull = {pull:g} mm, got {level!r}")
    if any(b <= a for a, b in zip(levels, levels[1:])):
        raise InputError(f"`pull_levels` must increase, got {list(levels)}")
    return tuple(float(level) for level in levels)


def _pull_stages(n_press: int, n_pull: int, pull: float, levels: tuple[float, ...]):
    """Stages press, pull 1, ..., pull (the last one named "pull") and the pull displacement at each stage end.

    Each pull stage gets increments of about the size ``pull / n_pull`` (at least one), so that the stage ends
    lie on the load path of a single pull stage whenever the levels are multiples of that size.
    """
    press, whole = _stages(n_press, n_pull)
    if not levels:
        return (press, whole), (0.0, pull)
    ends = levels + (pull,)
    starts = (0.0,) + levels
    counts = [max(1, round((b - a) / pull * whole.n_increments)) for a, b in zip(starts, ends)]
    names = [f"pull {k}" for k in range(1, len(levels) + 1)] + ["pull"]
    return (press, *(Stage(n, c) for n, c in zip(names, counts))), (0.0,) + ends


# ---------------------------------------------------------------------------------------------- 3-D model

def block_model(pull: float = 0.2, force: float = 2000.0, mesh_size: float = 1.0, order: int = 1,
                n_press: int = 1, n_pull: int = 10, block_divisions: int | None = None,
                grading: float = DEFAULT_GRADING, pull_levels=(), element: str | None = None,
                edge_splits: int = 1, edge_band: float = 1.0, interface_splits: int = 1,
                interface_band: float = 1.0, interior_splits: int = 1) -> Model:
    """The 3-D block-on-plate reference test (DESIGN.md, reference test 1) on a conforming hexahedral mesh.

    Parameters
    ----------
    pull : float [mm]
        Displacement of the block's top face in y at the end of the "pull" stage.
    force : float [N]
        Total normal force on the block's top face (uniform pressure ``force / 100 mm^2``).
    mesh_size : float [mm]
        Element size in the block and under it; the block height has ``ceil(10 / mesh_size)`` layers,
        the plate thickness ``ceil(5 / mesh_size)`` (at least 2 each); the plate outside the footprint grows
        geometrically (ratio 1.2) away from the block.
    order : 1 | 2
        1: "hexahedron" (8 nodes), 2: "hexahedron27".
    n_press, n_pull : int
        Increments of the two stages.
    block_divisions : int, optional
        Elements along each side of the block's bottom (x and y), even; default ``2 * round(5 / mesh_size)``.
    grading : float >= 1
        Ratio of the largest to the smallest element size (approximately, exact as the divisions grow)
        along each half side of the footprint and along the block height and the plate thickness. The nodes
        of block and plate under the footprint are moved in x and y by the same smooth map of each coordinate
        (so the interface stays conforming): elements are smallest at the footprint edges and at the
        quadrant borders, largest half-way between; in z they are smallest at the interface, largest at the
        block top and the plate bottom. The plate outside the footprint grows from the graded edge size.
        Quadratic elements keep their mid-nodes at the mapped positions (isoparametric, straight faces).
        1: uniform. Default :data:`DEFAULT_GRADING` (4), see "Accuracy of the defaults".
    pull_levels : sequence of float [mm], optional
        Intermediate pull displacements, increasing, strictly between 0 and ``pull``: the pull is split into
        stages "pull 1", "pull 2", ... ending at these levels and a last stage "pull" ending at ``pull``, so
        that measurements can be taken (and fitted) at several pull levels, e.g. while the lightly loaded
        trailing zones already slide and the leading ones still partly stick. The increments keep the size
        ``pull / n_pull`` (each stage at least one), so stage ends on multiples of that size lie on the
        default load path. Default: one pull stage.
    element : "standard" | "incompatible", optional
        Element technology (:attr:`Model.element`): "incompatible" (order 1 only) adds Wilson-Taylor
        incompatible modes to the hexahedra (as CalculiX's C3D8I), which do not lock in bending.
        Default: "incompatible" for order 1, "standard" for order 2.
    edge_splits : int >= 1
        Local refinement at the footprint's edges: the element intervals in x and in y (of the mesh the options
        above give) whose middle lies within ``edge_band`` of x or y = +-5 mm, in the block and in the plate
        inside and outside the footprint, are split into this many equal parts. The mesh stays a tensor product,
        so each split interval adds a plane of nodes across the plate, but only the band's few intervals are
        split (:class:`frictionid.builders.block_mesh.Bands`). Default 1 (no split).
    edge_band : float [mm]
        Half-width of that band (kept as the splits grow, so its element size falls as 1 / ``edge_splits``).
        Default 1.0.
    interface_splits : int >= 1
        Local refinement at the interface: the element layers of block and plate whose middle lies within
        ``interface_band`` of z = 0 are split into this many equal layers. Default 1.
    interface_band : float [mm]
        Depth of that band on each side of the interface. Default 1.0.
    interior_splits : int >= 1
        The other intervals across the footprint (x and y, outside ``edge_band``; block and plate under it) split
        into this many equal parts: the footprint's interior, where the pull's lift-off front lies (the back of
        zones A and B lifts off) and which the edge band does not refine. Default 1.

    Notes
    -----
    Accuracy of the defaults (mesh_size 1, grading 4, incompatible modes; 7,865 nodes). Measured with
    ``.venv/bin/python benchmarks/block_strains.py --cache DIR`` at A 0.35 B 0.2 C 0.45 D 0.15 on the 120
    points of tests/fixtures/independent_block (F: block side faces at 0.5-7.1 mm above the contact, T: plate
    top 0.3-11.4 mm outside the footprint), as RMS difference to a much finer model (order 2, grading 4,
    55,736 nodes) in units of the noise (strains 2e-5, displacements 5e-4 mm), press / pull 0.2 mm:

    - strains F: 0.97 / 1.99 (the former default, uniform standard hexahedra: 1.69 / 3.76); at the points
      1.5 mm and more above the contact 0.58 / 0.98 (former 0.97 / 1.76); the row 0.5 mm above the contact
      edge 4.0 at the pull (former 7.7): out of reach, two quadratic reference meshes (grading 3 and 4)
      differ there by 4.0 themselves (at 1.5 mm and above by 0.16);
    - strains T: 2.1 / 3.9 (former 8.3 / 18.2), worst next to the block;
    - displacements F 0.42 / 2.5, T 0.02 / 0.07 (former 1.1 / 7.9 and 0.29 / 0.44).

    So the default's strains are *not* accurate to a fraction of 2e-5: the block-face strains are within about
    one noise level (RMS) from 1.5 mm above the contact and several noise levels off next to the contact
    edge. Nothing at a similar cost did better (the benchmark's candidates: grading 1-6, mesh_size 0.8,
    block_divisions 12, quadratic 2.5 mm meshes); the condensation costs about what the former default
    did (8.4 s vs 8.9 s, same machine). Quadratic hexahedra of 1 mm graded 3 reach 0.1 noise from 1.5 mm above
    the contact, at 45 times the condensation time (381 s, 5.8 GB).

    Returns
    -------
    Model
        Regions "plate", "block"; boundaries "plate_bottom", "plate_top", "block_top" and the zones
        "A", "B", "C", "D" (block bottom by quadrant, see :data:`QUADRANT_ZONES`); one interface
        "block_plate" with target "plate_top". Block and plate have separate, coincident interface nodes.

    Examples
    --------
    >>> model = block_model(mesh_size=2.5)
    >>> model.zone_names
    ('A', 'B', 'C', 'D')
    """
    pull, force = positive("pull", pull), positive("force", force)
    order = _order(order)
    element = _element(element, order)
    stages, pulled = _pull_stages(n_press, n_pull, pull, _pull_levels(pull_levels, pull))
    divisions, n_block_z, n_plate_z, grading, bands = _mesh_arguments(
        mesh_size, block_divisions, grading, edge_splits, edge_band, interface_splits, interface_band,
        interior_splits)
    mesh = block_mesh(divisions, n_block_z, n_plate_z, order, grading, bands)
    pressure = force / BLOCK_SIDE ** 2
    return Model(
        mesh=mesh, kind="3d", materials={"plate": EPOXY, "block": ALUMINIUM},
        supports=(Support("plate_bottom", (0, 1, 2)),),
        loads=(Pressure("block_top", (pressure,) * len(stages)),
               Displacement("block_top", 0, (0.0,) * len(stages)),
               Displacement("block_top", 1, pulled)),
        stages=stages,
        interfaces=(ContactInterface("block_plate", tuple(QUADRANT_ZONES.values()), "plate_top"),),
        element=element,
    )


def _mesh_arguments(mesh_size, block_divisions, grading, edge_splits, edge_band, interface_splits, interface_band,
                    interior_splits=1):
    """(block_divisions, n_block_z, n_plate_z, grading, bands) of :func:`block_mesh` from the options, checked."""
    mesh_size = positive("mesh_size", mesh_size)
    if block_divisions is None:
        block_divisions = 2 * max(1, round(BLOCK_SIDE / 2 / mesh_size))
    block_divisions = count("block_divisions", block_divisions, 2)
    if block_divisions % 2:
        raise InputError(f"`block_divisions` must be even (the zones split the block bottom in half), "
                         f"got {block_divisions}")
    n_block_z = max(2, math.ceil(BLOCK_HEIGHT / mesh_size - 1e-9))
    n_plate_z = max(2, math.ceil(PLATE_THICKNESS / mesh_size - 1e-9))
    bands = Bands(count("edge_splits", edge_splits), positive("edge_band", edge_band),
                  count("interface_splits", interface_splits), positive("interface_band", interface_band),
                  count("interior_splits", interior_splits))
    return block_divisions, n_block_z, n_plate_z, checked_grading(grading), bands


def block_layout(**arguments):
    """The :class:`frictionid.builders.block_mesh.Layout` of :func:`block_model` with these keyword arguments (those
    not about the mesh ignored), without meshing: its node count and shortest contact element.

    >>> block_layout().n_nodes(), block_layout(edge_splits=2).n_nodes() < block_layout(block_divisions=20).n_nodes()
    (7865, True)
    >>> round(block_layout().contact_length(), 3), round(block_layout(edge_splits=2).contact_length(), 3)
    (0.546, 0.219)
    """
    sizes = {"mesh_size": 1.0, "block_divisions": None, "grading": DEFAULT_GRADING, "edge_splits": 1,
             "edge_band": 1.0, "interface_splits": 1, "interface_band": 1.0, "interior_splits": 1}
    return layout(*_mesh_arguments(**{key: arguments.get(key, value) for key, value in sizes.items()}))


# ---------------------------------------------------------------------------------------------- 2-D model

def block_model_2d(kind: str = "plane_strain", pull: float = 0.2, force: float = 200.0, width: float = 10.0,
                   height: float = 10.0, base_width: float = 40.0, base_height: float = 5.0,
                   mesh_size: float = 1.0, contact_size: float | None = None, order: int = 2, n_zones: int = 2,
                   n_press: int = 1, n_pull: int = 10, quads: bool = False) -> Model:
    """Plane-strain analogue of the block test: x lateral and pull direction, y up, forces per mm thickness.

    Parameters
    ----------
    kind : "plane_strain"
        The only kind this geometry has (a block pulled sideways is not axisymmetric).
    pull : float [mm]
        Displacement of the block's top edge in x at the end of the "pull" stage (0 while pressing).
    force : float [N/mm]
        Total normal force on the block's top edge (uniform pressure ``force / width``); its y motion is free.
    width, height : float [mm]
        Block [-width/2, width/2] x [0, height] (aluminium, region "block").
    base_width, base_height : float [mm]
        Base [-base_width/2, base_width/2] x [-base_height, 0] (epoxy, region "base"), bottom fixed.
    mesh_size : float [mm]
        Element size away from the interface.
    contact_size : float [mm], optional
        Element size on the interface (default ``mesh_size``); it grows to ``mesh_size`` within
        ``base_height`` of the interface.
    order : 1 | 2
        Element order: "triangle" / "triangle6", or "quad" / "quad9" with ``quads``.
    n_zones : int
        Equal-width zones on the block bottom, named "A", "B", ... from -x to +x.
    n_press, n_pull : int
        Increments of the two stages.
    quads : bool
        Quadrilaterals (recombined, then subdivided once so that no triangle is left) instead of triangles.

    Returns
    -------
    Model
        Boundaries "base_bottom", "base_top" (the base's whole top edge), "block_top" and the zones; one
        interface "block_base" with target "base_top". Block and base have separate, coincident interface nodes.

    Examples
    --------
    >>> model = block_model_2d(mesh_size=2.0)
    >>> model.mesh.cell_type, model.zone_names
    ('triangle6', ('A', 'B'))
    """
    if kind != "plane_strain":
        raise InputError(f"`kind` must be 'plane_strain' for the 2-D block model, got {kind!r}")
    pull, force = positive("pull", pull), positive("force", force)
    sizes = {name: positive(name, value) for name, value in
             [("width", width), ("height", height), ("base_width", base_width), ("base_height", base_height),
              ("mesh_size", mesh_size), ("contact_size", mesh_size if contact_size is None else contact_size)]}
    if not sizes["base_width"] > sizes["width"]:
        raise InputError(f"`base_width` must exceed `width` ({width}), got {base_width}")
    n_zones = count("n_zones", n_zones)
    if n_zones > len(string.ascii_uppercase):
        raise InputError(f"`n_zones` must be at most {len(string.ascii_uppercase)}, got {n_zones}")
    order, stages = _order(order), _stages(n_press, n_pull)
    mesh = block_mesh_2d(**sizes, n_zones=n_zones, order=order, quads=bool(quads))
    pressure = force / sizes["width"]
    return Model(
        mesh=mesh, kind=kind, materials={"base": EPOXY, "block": ALUMINIUM},
        supports=(Support("base_bottom", (0, 1)),),
        loads=(Pressure("block_top", (pressure, pressure)), Displacement("block_top", 0, (0.0, pull))),
        stages=stages,
        interfaces=(ContactInterface("block_base", zone_names(n_zones), "base_top"),),
    )


def zone_names(n_zones: int) -> tuple[str, ...]:
    """"A", "B", ... for the zones of the 2-D block from -x to +x."""
    return tuple(string.ascii_uppercase[:n_zones])


def block_mesh_2d(width: float, height: float, base_width: float, base_height: float, mesh_size: float,
                  contact_size: float, n_zones: int, order: int = 2, quads: bool = False) -> Mesh:
    """Triangle (or quadrilateral) mesh of block and base whose interface segments carry identical node rows."""
    # subdividing quadrilaterals halves every edge: mesh twice as coarse first
    scale = 2.0 if quads else 1.0
    borders = np.linspace(-width / 2, width / 2, n_zones + 1)
    with gmsh_session("block_2d"):
        occ = gmsh.model.occ
        base = _polygon([(-base_width / 2, -base_height), (base_width / 2, -base_height), (base_width / 2, 0.0)]
                        + [(x, 0.0) for x in borders[::-1]] + [(-base_width / 2, 0.0)])
        block = _polygon([(x, 0.0) for x in borders] + [(width / 2, height), (-width / 2, height)])
        occ.synchronize()
        n_nodes = max(2, math.ceil(width / n_zones / (scale * contact_size) - 1e-9)) + 1
        interface = base["lines"][3:3 + n_zones] + block["lines"][:n_zones]
        for line in interface:
            gmsh.model.mesh.setTransfiniteCurve(line, n_nodes)
        use_size_fields(distance_size_field(interface, scale * contact_size, scale * mesh_size, base_height,
                                            sampling=100))
        _add_groups_2d(base, block, n_zones)
        _generate_2d(quads)
        set_order(order)
        mesh = mesh_from_gmsh("2-D block model")
    logger.info("2-D block mesh: %d nodes, %d %s cells", mesh.n_nodes, mesh.n_cells, mesh.cell_type)
    return mesh


def _polygon(corners: list[tuple[float, float]]) -> dict:
    """A plane surface bounded by straight lines between consecutive corners: its tag and its line tags in order."""
    occ = gmsh.model.occ
    points = [occ.addPoint(x, y, 0.0) for x, y in corners]
    lines = [occ.addLine(a, b) for a, b in zip(points, points[1:] + points[:1])]
    return {"surface": occ.addPlaneSurface([occ.addCurveLoop(lines)]), "lines": lines}


def _add_groups_2d(base: dict, block: dict, n_zones: int):
    add = gmsh.model.addPhysicalGroup
    add(2, [base["surface"]], name="base")
    add(2, [block["surface"]], name="block")
    add(1, [base["lines"][0]], name="base_bottom")
    add(1, base["lines"][2:-1], name="base_top")
    add(1, [block["lines"][n_zones + 1]], name="block_top")
    for line, name in zip(block["lines"][:n_zones], zone_names(n_zones)):
        add(1, [line], name=name)


def _generate_2d(quads: bool):
    if quads:
        gmsh.option.setNumber("Mesh.Algorithm", 8)             # frontal-Delaunay for quads
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)  # all quadrilaterals
    gmsh.model.mesh.generate(2)
