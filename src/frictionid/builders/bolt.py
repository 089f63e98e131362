"""Reference test 2: the axisymmetric bolt-nut tensile test (ISO 4014 bolt, ISO 4032 nut, two plates) in gmsh.

Axis y, x = r [mm]. Layout (docs/models.md, M20 numbers in brackets, other sizes scale with d): head y in [-k, 0]
(k = 12.5), bolt end y = l (6 d = 120), thread from l - b (74), nut top l - 3 P (112.5), nut bearing face
l - 3 P - m (94.5); plate 2 y in [0, d] and plate 1 y in [bearing - d, bearing], both with the ISO 273 medium
clearance hole (radius 11) and outer radius 2 d (40); hexagons as area-equivalent rings (15.75). The bolt profile
is moved radially inwards by |es|/2 (0.021) and the nut thread axially by |es|/(2 sqrt 3) (0.01212), so load
flanks touch exactly and free flanks are open (axial gap |es|/sqrt 3). Bolt and nut are separate gmsh surfaces;
each contact segment has the same uniform node spacing on both sides (node-to-node pairs at zero gap).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import ContactInterface, Material, Model, Rotation, Stage, Support, SurfaceForce
from .arguments import count, positive
from .bolt_layout import BoltLayout, bolt_layout
from .bolt_mesh import bolt_mesh
from .thread import Flank, thread_size

__all__ = ["BoltLayout", "bolt_layout", "bolt_mesh", "bolt_model", "default_sizes", "fixed_friction",
           "measurement_points"]

#: steel of bolt, nut and plates (docs/models.md)
STEEL = Material(E=200000.0, nu=0.3, name="steel")
#: fixed friction coefficient of the head-plate and nut-plate contacts (docs/models.md)
PLATE_MU = 0.15
#: default element sizes as divisors of the nominal diameter d: plate contacts d / 40, largest element d / 8
SIZE_DIVISORS = {"contact_size": 40, "mesh_size": 8}
#: default flank size [mm] of the axisymmetric model; the 3-D model takes :data:`SIZE_PITCHES_3D`
FLANK_SIZE = 0.1
#: default element sizes of the 3-D model in pitches: flanks 0.75 P, bearing contacts 1.5 P, largest element 2 P,
#: the bolt's roots 0.12 P (0.83 R, R = H/6 the root radius): the M20 (P 2.5) gets 1.875, 3.75, 5.0 and 0.3 mm,
#: the sizes verified against the axisymmetric model and timed (docs/bolt-study.md, "The 3-D default")
SIZE_PITCHES_3D = {"flank_size": 0.75, "contact_size": 1.5, "mesh_size": 2.0, "root_size": 0.12}


def _forces(forces) -> tuple[float, ...]:
    if isinstance(forces, (int, float)) and not isinstance(forces, bool):
        forces = (forces,)
    if not isinstance(forces, (list, tuple)) or not forces:
        raise InputError(f"`forces` must be a list of machine forces [N], one per stage, got {forces!r}")
    return tuple(positive(f"forces[{i}]", f) for i, f in enumerate(forces))


def default_sizes(size: str = "M20", model: str = "axisymmetric") -> dict[str, float]:
    """The element sizes [mm] :func:`bolt_model` takes when ``flank_size``, ``contact_size`` or ``mesh_size`` (and
    in 3-D ``root_size``) is not given.

    >>> default_sizes("M20")
    {'contact_size': 0.5, 'mesh_size': 2.5, 'flank_size': 0.1}
    >>> default_sizes("M20", "3d")
    {'flank_size': 1.875, 'contact_size': 3.75, 'mesh_size': 5.0, 'root_size': 0.3}
    """
    s = thread_size(size)
    if model == "3d":
        return {key: s.P * pitches for key, pitches in SIZE_PITCHES_3D.items()}
    return {**{key: s.d / divisor for key, divisor in SIZE_DIVISORS.items()}, "flank_size": FLANK_SIZE}


def bolt_model(size: str = "M20", forces=(10000.0, 30000.0), n_increments: int = 3,
               flank_size: float | None = None, contact_size: float | None = None, mesh_size: float | None = None,
               n_radial: int = 2, n_axial: int = 3, length: float | None = None,
               engaged_length: float | None = None, clearance: float | None = None,
               bearing_diameter: float | str | None = None, load: str = "tension", angles=(2.0, 4.0), torques=None,
               model: str = "axisymmetric", cutout=True, jaws: bool | None = None,
               thread_length: float | None = None, root_size: float | None = None,
               head_size: float | None = None, nut_mesh: str | None = None, root_refinement: str | None = None) -> Model:
    """The axisymmetric bolt-nut tensile test (reference test 2, docs/models.md) for a coarse M size.

    Parameters
    ----------
    size : str
        "M6" ... "M36" (tables in :mod:`frictionid.builders.thread`); "M20" is the docs/models.md set-up.
    forces : sequence of float [N]
        Machine force at the end of each stage (e.g. the measured force of each DIC stage), applied in +y on
        plate 1's outer rim (whole ring); plate 2's outer rim is held.
    n_increments : int
        Increments per stage.
    flank_size : float [mm], optional
        Element size on the engaged thread (node spacing on the contact flanks, both sides); default 0.1
        (axisymmetric), 0.75 P (3-D: 1.875 for M20).
    contact_size : float [mm], optional
        Node spacing on the head-plate and nut-plate contacts; default d / 40 (0.5 for M20), 3-D 1.5 P (3.75).
    mesh_size : float [mm], optional
        Largest element size; default d / 8, 3-D 2 P.
    n_radial, n_axial : int
        Thread zones: each engaged load flank split radially into n_radial parts (2: at the pitch diameter),
        the flanks grouped axially into n_axial sections (as equal counts as possible, extra flanks near the
        bearing face). Zone letters run over sections first: outer parts A, B, C, inner parts D, E, F.
    length : float [mm], optional
        Nominal bolt length l (bolt end at y = l); default 6 d.
    thread_length : float [mm], optional
        Threaded length b of the bolt from its end; default ISO 4014 (2 d + 6 for l <= 125: 46 for M20). A short
        thread (at least a pitch below the nut) makes a quick 3-D model.
    engaged_length : float [mm], optional
        Threaded length of the nut bore from the bearing face (at most the nut height m); above it the bore is
        relieved to the thread root. Default m.
    clearance : float [mm], optional
        Flank clearance |es| of the 6g bolt; default ISO 965-1 (0.042 for M20).
    bearing_diameter : "dw" or float [mm], optional
        Outer diameter of the nut's bearing face on plate 1; "dw" takes ISO 4032 dw (27.7 for M20). The ring
        beyond it is chamfered at 30 deg (both nut faces). Default: the whole ring face (docs/models.md).
    load : "tension" | "tightening"
        "tension": the tensile test (``forces``). "tightening": the nut turned against the held head (ISO 16047
        like), kind "axisymmetric_twist": both plates' rims held (r, y, t; their reactions are the load cell:
        clamp force "plate1_rim.y"), the head held against turning ("head_side" in t), the nut's hexagon ring
        "nut_outer" turned by ``angles``; the thread is a right-hand helix of lead P (rings with the helicoid's
        normals, :attr:`ContactInterface.lead`). Wrench torque: reaction "nut_outer.torque" [N mm].
    angles : sequence of float [deg]
        Nut rotation from the snug position at the end of each stage (``load`` = "tightening"; ``forces`` is
        then not used).
    model : "axisymmetric" | "3d"
        "3d": the helical thread, real hexagons, the nut's window and jaws (:mod:`frictionid.builders.bolt3d`,
        quadratic tetrahedra; bearings node-to-node, the thread as ``nut_mesh`` says). Tightening in 3-D: the nut's
        six flats "nut_outer" turned rigidly by ``angles`` (u_x = -z a, u_z = x a; ``torques`` not taken), the
        head's six flats "head_side" held in x and z, both plates' rims held; the helix is in the mesh (no ``lead``).
    cutout : bool or table, 3-D only
        The nut's window: true (default: 60 deg wide, from the flats down to the nut crest D1/2), false (none), or
        ``{ width = deg, depth = mm }`` (depth from the flats' radius s/2 inwards).
    jaws : bool, 3-D only
        True (default with ``load`` = "tension"): the nut's two flats normal to z are held in z (jaws against
        rotation); false (default with "tightening", where the nut is turned): free.
    root_size : float [mm], 3-D only, optional
        Element size at the bolt's roots (where ``root_refinement`` says; the size grows from there by 2.5 mm per
        mm); default 0.12 P (0.83 R, R = H/6 the root radius): 0.3 mm for M20, the size verified on it.
    root_refinement : "thread" | "engaged", 3-D only
        How far along the bolt the roots are meshed at ``root_size``, up to a pitch above the nut's top: "thread"
        (default) from the thread's start, so that the free thread below the nut is not too stiff; "engaged"
        from a pitch below the nut's bearing face.
    head_size : float [mm], 3-D only, optional
        Element size in the bolt's head (and its bearing face), growing to ``mesh_size`` over k/2 outside it;
        default none (the head meshed by the other sizes).
    nut_mesh : "conforming" | "separate", 3-D only, optional
        "conforming": the nut meshed with the bolt, node-to-node pairs on the thread. "separate": the nut and
        plate 1 meshed on their own, without the bolt's root refinement, the thread coupled by dual mortar with
        the zones on the nut's load flanks (target "bolt_contact"); not with ``load`` = "tightening". Default
        "separate" with ``load`` = "tension", "conforming" with "tightening".
    torques : sequence of float [N m], optional
        Wrench torque at the end of each stage instead of ``angles``: a uniform circumferential traction on
        "nut_outer" (the hexagon ring, one radius) whose moment about the axis is the torque; the nut's rotation
        is then a result (u_t / r on "nut_outer").

    Returns
    -------
    Model
        Axisymmetric, regions "bolt", "nut", "plate1", "plate2" (steel). Interfaces: "thread" (zones on the
        bolt load flanks, target "nut_contact"), "head" (zone "head_plate", target "plate2_head") and
        "nut_bearing" (zone "nut_plate", target "plate1_nut"). Further boundaries: "thread_<i>" (bolt contact
        segment of engaged flank i, from the bearing face), "nut_thread_<i>", "bolt_load", "bolt_free",
        "nut_load", "nut_free", "nut_outer", "plate1_rim" (loaded), "plate2_rim" (held).
    """
    if model not in ("axisymmetric", "3d"):
        raise InputError(f"`model` must be \"axisymmetric\" or \"3d\", got {model!r}")
    layout = bolt_layout(size, length, engaged_length, clearance, n_radial, n_axial, bearing_diameter,
                         thread_length)
    defaults = default_sizes(size, model)
    flank_size = defaults["flank_size"] if flank_size is None else positive("flank_size", flank_size)
    contact_size = defaults["contact_size"] if contact_size is None else positive("contact_size", contact_size)
    mesh_size = defaults["mesh_size"] if mesh_size is None else positive("mesh_size", mesh_size)
    if model == "3d":
        root_size = defaults["root_size"] if root_size is None else positive("root_size", root_size)
        head_size = None if head_size is None else positive("head_size", head_size)
        return _model_3d(layout, engaged_length, forces, n_increments, (flank_size, contact_size, mesh_size),
                         (load, angles, torques), cutout, jaws, (root_size, head_size, nut_mesh, root_refinement))
    given = [key for key, value in (("root_size", root_size), ("head_size", head_size), ("nut_mesh", nut_mesh),
                                    ("root_refinement", root_refinement)) if value is not None]
    if given:
        raise InputError(f"{', '.join(f'`{key}`' for key in given)}: 3-D only (model = \"3d\"); the axisymmetric "
                         "model has no separate root, head or nut mesh options")
    if flank_size > layout.size.P / 4:
        raise InputError(f"`flank_size` = {flank_size:g} mm is too coarse for {layout.size.name}: expected at most "
                         f"P/4 = {layout.size.P / 4:g} mm (a flank is about 0.6 P long)")
    if load not in ("tension", "tightening"):
        raise InputError(f"`load` must be \"tension\" or \"tightening\", got {load!r}")
    if torques is not None and load != "tightening":
        raise InputError("`torques` needs load = \"tightening\"")
    values = (_forces(forces) if load == "tension" else _angles(angles, "angles") if torques is None
              else _angles(torques, "torques"))
    n_increments = count("n_increments", n_increments, 1, 1000)
    mesh = bolt_mesh(layout, flank_size, contact_size, max(mesh_size, flank_size))
    lead = layout.size.P if load == "tightening" else 0.0
    interfaces = (ContactInterface("thread", layout.thread_zones, "nut_contact", "node-to-node", lead),
                  ContactInterface("head", ("head_plate",), "plate2_head", "node-to-node"),
                  ContactInterface("nut_bearing", ("nut_plate",), "plate1_nut", "node-to-node"))
    if load == "tightening":
        return _tightening(mesh, interfaces, values, n_increments, torques is not None, layout.size.hex_radius)
    forces = values
    return Model(mesh=mesh, kind="axisymmetric",
                 materials={name: STEEL for name in ("bolt", "nut", "plate1", "plate2")},
                 supports=(Support("plate2_rim", (0, 1)),),
                 loads=(SurfaceForce("plate1_rim", 1, forces),),
                 stages=tuple(Stage(f"F{i + 1}", n_increments) for i in range(len(forces))),
                 interfaces=interfaces)


def _model_3d(layout: BoltLayout, engaged_length, forces, n_increments, sizes, loading, cutout, jaws,
              local: tuple) -> Model:
    from .bolt3d import bolt3d_model
    load, angles, torques = loading
    if load not in ("tension", "tightening"):
        raise InputError(f"`load` must be \"tension\" or \"tightening\", got {load!r}")
    if torques is not None:
        raise InputError("`torques`: the 3-D tightening test is driven by `angles` (nut rotations [deg]) only")
    jaws = load == "tension" if jaws is None else jaws
    if load == "tightening" and jaws is True:
        raise InputError("`jaws` = true holds the nut against turning, and load = \"tightening\" turns it: "
                         "expected jaws = false (the default with tightening)")
    values = _forces(forces) if load == "tension" else _angles(angles, "angles")
    flank_size, contact_size, mesh_size = sizes
    if flank_size > layout.size.P:
        raise InputError(f"`flank_size` = {flank_size:g} mm is too coarse for {layout.size.name} in 3-D: expected "
                         f"at most P = {layout.size.P:g} mm")
    engaged = layout.size.nut_m if engaged_length is None else engaged_length
    root_size, head_size, nut_mesh, root_refinement = local
    root_refinement = "thread" if root_refinement is None else root_refinement
    if nut_mesh is None:
        nut_mesh = "separate" if load == "tension" else "conforming"
    return bolt3d_model(layout, layout.y_bearing + engaged, values, count("n_increments", n_increments, 1, 1000),
                        flank_size, contact_size, max(mesh_size, flank_size), cutout, jaws, root_size, load,
                        head_size, nut_mesh, root_refinement)


def _angles(values, name: str) -> tuple[float, ...]:
    """Positive stage values of ``angles`` [deg] or ``torques`` [N m]."""
    if isinstance(values, (int, float)) and not isinstance(values, bool):
        values = (values,)
    unit = "nut rotations [deg]" if name == "angles" else "wrench torques [N m]"
    if not isinstance(values, (list, tuple)) or not values:
        raise InputError(f"`{name}` must be a list of {unit}, one per stage, got {values!r}")
    return tuple(positive(f"{name}[{i}]", a) for i, a in enumerate(values))


def _tightening(mesh, interfaces, values: tuple[float, ...], n_increments: int, by_torque: bool,
                radius: float) -> Model:
    """The tightening test: the nut turned by ``values`` [deg] (or with torques [N m], on its hexagon ring at
    ``radius`` [mm]) against the held head, plates held at their rims."""
    if by_torque:
        load = SurfaceForce("nut_outer", "t", tuple(1000.0 * t / radius for t in values))
        names = [f"{t:g}Nm" for t in values]
    else:
        load = Rotation("nut_outer", tuple(np.radians(values).tolist()))
        names = [f"{a:g}deg" for a in values]
    return Model(mesh=mesh, kind="axisymmetric_twist",
                 materials={name: STEEL for name in ("bolt", "nut", "plate1", "plate2")},
                 supports=(Support("plate2_rim", (0, 1, 2)), Support("plate1_rim", (0, 1, 2)),
                           Support("head_side", (2,))),
                 loads=(load,), stages=tuple(Stage(name, n_increments) for name in names),
                 interfaces=interfaces)


def fixed_friction() -> dict[str, float]:
    """Coefficients of the zones that identification holds fixed: head-plate and nut-plate, 0.15 (docs/models.md)."""
    return {"head_plate": PLATE_MU, "nut_plate": PLATE_MU}


def measurement_points(layout: BoltLayout, points=None, flanks=(1, 2), n_per_flank: int = 5) -> np.ndarray:
    """(n, 2) (r, y) [mm] measurement points on the bolt load flanks.

    Default: ``n_per_flank`` points at 1/(n+1) ... n/(n+1) of the straight part of each listed engaged flank
    (1 = next to the nut bearing face), root tangent to crest corner: 10 points at 1/6 ... 5/6 on flanks 1, 2.
    Given ``points`` are checked to lie on the straight part of an engaged bolt load flank (to 1e-3 mm).
    The points lie on the bolt-nut interface: observe them in region "bolt" (config: regions = { "*" = "bolt" }).
    """
    if points is None:
        n_per_flank = count("n_per_flank", n_per_flank, 1, 100)
        fractions = np.arange(1, n_per_flank + 1) / (n_per_flank + 1)
        for i in flanks:
            if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 1 <= i <= len(layout.flanks):
                raise InputError(f"`flanks`: {i!r} is not an engaged flank; expected 1 ... {len(layout.flanks)}")
        return np.vstack([layout.flanks[i - 1].along(fractions) for i in flanks])
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2:
        raise InputError(f"`points` must be (r, y) pairs [mm], shape (n, 2), got shape {points.shape}")
    for i, point in enumerate(points):
        if min(_flank_distance(f, point) for f in layout.flanks) > 1e-3:
            raise InputError(f"`points`[{i}] = {point.tolist()} is not on an engaged bolt load flank; expected a "
                             f"point on the straight part of one of the {len(layout.flanks)} flanks, e.g. "
                             f"{np.round(layout.flanks[0].along(0.5), 4).tolist()}")
    return points


def _flank_distance(flank: Flank, point: np.ndarray) -> float:
    """Distance [mm] of a point from the straight part of a bolt load flank."""
    a, b = (np.asarray(p) for p in flank.straight)
    t = np.clip(np.dot(point - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(point - (a + t * (b - a))))
