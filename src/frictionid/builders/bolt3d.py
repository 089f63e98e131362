"""Reference test 2 in 3-D: the bolt-nut tensile test with a helical thread, the nut's window and its jaws.

The set-up is the axisymmetric one's (:mod:`frictionid.builders.bolt_layout`: heights, plates, 6g/6H clearance
as a radial shift of the bolt profile) with real hexagons for head and nut. The section through the window's
centre is the axisymmetric section (same tooth phases), so the seed's measurement points P1-P5 of flanks 1 and 2
lie where the axisymmetric model has them. By default every interface is conforming (node-to-node pairs at zero
gap, the nodes duplicated per body, :mod:`frictionid.builders.bolt3d_mesh`); with ``nut_mesh`` = "separate" the
thread is not (:mod:`frictionid.builders.bolt3d_separate`). The nut's teeth are the bolt grooves'
complement outside the nut crest D1/2, so free flanks and the nut root touch the bolt with separate nodes and
no contact (in tension they open).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..model import ContactInterface, Mesh, Model, Rotation, Stage, Support, SurfaceForce
from .arguments import checked_table, positive
from .bolt import STEEL, measurement_points
from .bolt3d_geometry import Window, to_xyz
from .bolt3d_mesh import Options3d, bolt3d_mesh
from .bolt3d_separate import BOLT_CONTACT, separate_mesh
from .bolt_layout import BoltLayout

#: the window's default angular width [deg] (the seed's Fig. 3 and 8 show a narrow slot; its text gives no size)
WINDOW_WIDTH = 60.0
#: angle [deg] of the window's centre: the +x direction (the camera looks along -x)
WINDOW_CENTRE = 0.0
#: angle [deg] of the normal of the flat the jaws hold (and of the opposite one): +-z, either side of the window;
#: the hexagons' flats are at this angle + k 60 deg, so the window faces a corner
JAW_ANGLE = 90.0
#: how the nut is meshed: with the bolt (conforming, node-to-node thread) or on its own (mortar thread)
NUT_MESHES = ("conforming", "separate")
#: how far along the bolt its roots are meshed at ``root_size`` (up to a pitch above the nut's top): from the
#: thread's start, or from a pitch below the nut's bearing face (the engaged part)
ROOT_REFINEMENTS = ("thread", "engaged")


def window_of(layout: BoltLayout, cutout) -> Window | None:
    """The nut's window from the ``cutout`` option: true (defaults), false (none) or a table ``{ width = deg,
    depth = mm }``; depth from the nut's flats inwards, default to the nut crest D1/2 so that the bolt's flanks
    show."""
    s = layout.size
    default = {"width": WINDOW_WIDTH, "depth": s.nut_s / 2 - s.d1 / 2}
    if cutout is False or cutout is None:
        return None
    table = default if cutout is True else checked_table(cutout, default, "[model] cutout")
    width = positive("cutout.width", table["width"])
    depth = positive("cutout.depth", table["depth"])
    if width >= 180:
        raise InputError(f"`cutout.width` = {width:g} deg: expected less than 180 deg")
    if depth > s.nut_s / 2 - s.d1 / 2 + 1e-9:
        raise InputError(f"`cutout.depth` = {depth:g} mm reaches into the bore: expected at most "
                         f"{s.nut_s / 2 - s.d1 / 2:.4g} mm (flats s/2 to the nut crest D1/2)")
    return Window(width, depth, WINDOW_CENTRE)


def bolt3d_model(layout: BoltLayout, engaged_top: float, values: tuple[float, ...], n_increments: int,
                 flank_size: float, contact_size: float, mesh_size: float, cutout, jaws: bool,
                 root_size: float, load: str = "tension", head_size: float | None = None,
                 nut_mesh: str = "conforming", root_refinement: str = "thread") -> Model:
    """The 3-D tensile test, or with ``load`` = "tightening" the tightening test (options as
    :func:`frictionid.builders.bolt.bolt_model`, ``model`` = "3d"); ``values`` the stages' machine forces [N] or
    nut rotations [deg]. ``root_refinement``: the bolt's roots meshed at ``root_size`` from the thread's start
    ("thread") or from a pitch below the nut's bearing face ("engaged"), up to a pitch above the nut's top.

    Regions "bolt", "nut", "plate1", "plate2"; interfaces "thread" (zones on the bolt's load flanks, target
    "nut_contact"), "head" ("head_plate" on "plate2_head"), "nut_bearing" ("nut_plate" on "plate1_nut").
    Boundaries "thread_<i>" (bolt load flank of turn i from the bearing face, a turn running from the seam
    opposite the window to the seam), "plate1_rim" (loaded in +y), "plate2_rim" (held), "nut_jaws" (the two
    flats normal to z (held in z when ``jaws``)), "window_nut", "window_bolt" (the window's DIC surfaces),
    "nut_outer" and "head_side" (the six flats of nut and head).

    ``nut_mesh`` = "separate": the nut (with plate 1) meshed on its own, without the bolt's root refinement
    (:mod:`frictionid.builders.bolt3d_separate`); the interface "thread" is then a dual mortar one with the zones
    and "thread_<i>" on the nut's load flanks (the contact side), target "bolt_contact" (the bolt's load flanks).
    Not with ``load`` = "tightening", whose lead needs node-to-node pairs.

    Tightening (ISO 16047 like, as the axisymmetric model's): both plates' rims held (x, y, z; the clamp force is
    the reaction "plate1_rim.y"), the head held against turning at its flats (x, z), the nut's flats turned as a
    rigid body about the axis by the stage's angle (a :class:`~frictionid.model.Rotation`: u_x = -z a, u_z = x a,
    u_y free; wrench torque: reaction "nut_outer.torque" [N mm]). The preload comes from the helix of the mesh:
    the thread's pairs get the lead P (:attr:`~frictionid.model.ContactInterface.lead`), which makes each pair's
    normal normal to the helix through its node (the facets' own normals scatter about the helicoid's, and the
    turned nut would load the steepest ones). The pairs are made once (small sliding): the nut's slide on the
    flanks, r a, must stay under the local element length (the solver stops otherwise).
    """
    window = window_of(layout, cutout)
    if not isinstance(jaws, bool):
        raise InputError(f"`jaws` must be true or false, got {jaws!r}")
    if nut_mesh not in NUT_MESHES:
        raise InputError(f"`nut_mesh` must be one of {list(NUT_MESHES)}, got {nut_mesh!r}")
    if nut_mesh == "separate" and load == "tightening":
        raise InputError("`nut_mesh` = \"separate\" couples the thread by mortar, and load = \"tightening\" needs "
                         "the helix's lead on node-to-node pairs: expected nut_mesh = \"conforming\" with tightening")
    if root_refinement not in ROOT_REFINEMENTS:
        raise InputError(f"`root_refinement` must be one of {list(ROOT_REFINEMENTS)}, got {root_refinement!r}")
    options = Options3d(flank_size, contact_size, mesh_size, window, math.radians(WINDOW_CENTRE),
                        math.radians(JAW_ANGLE), root_size, head_size,
                        layout.y_thread if root_refinement == "thread" else None)
    mesh = separate_mesh(layout, options, engaged_top) if nut_mesh == "separate" else \
        bolt3d_mesh(layout, options, engaged_top)
    return bolt3d_model_on(mesh, layout, values, n_increments, jaws, load)


def bolt3d_model_on(mesh: Mesh, layout: BoltLayout, values: tuple[float, ...], n_increments: int, jaws: bool,
                    load: str = "tension") -> Model:
    """The model of :func:`bolt3d_model` on a mesh it made (supports, loads, interfaces, zones and stages; the
    arguments as there): a stored mesh gives the same model as the build that made it."""
    supports = [Support("plate2_rim", (0, 1, 2))]
    if jaws:
        supports.append(Support("nut_jaws", (2,)))
    if load == "tightening":
        supports += [Support("plate1_rim", (0, 1, 2)), Support("head_side", (0, 2))]
        loads, names = (Rotation("nut_outer", tuple(np.radians(values).tolist())),), [f"{a:g}deg" for a in values]
    else:
        loads, names = (SurfaceForce("plate1_rim", 1, values),), [f"F{i + 1}" for i in range(len(values))]
    zones = tuple(z for z in layout.thread_zones if z in mesh.boundaries)
    lead = layout.size.P if load == "tightening" else 0.0
    if BOLT_CONTACT in mesh.boundaries:
        # separate nut: one helicoid meshed twice, the gaps are the meshes' (adjusted to zero); coupled within P/4,
        # the next turn's flank lies 0.87 P behind the nut's tooth
        thread = ContactInterface("thread", zones, BOLT_CONTACT, "mortar", gap_tolerance=layout.size.P / 4,
                                  adjust=True)
    else:
        thread = ContactInterface("thread", zones, "nut_contact", "node-to-node", lead)
    interfaces = (thread,
                  ContactInterface("head", ("head_plate",), "plate2_head", "node-to-node"),
                  ContactInterface("nut_bearing", ("nut_plate",), "plate1_nut", "node-to-node"))
    return Model(mesh=mesh, kind="3d", materials={name: STEEL for name in ("bolt", "nut", "plate1", "plate2")},
                 supports=tuple(supports), loads=loads, stages=tuple(Stage(name, n_increments) for name in names),
                 interfaces=interfaces)


def measurement_points_3d(layout: BoltLayout, flanks=(1, 2), n_per_flank: int = 5, depth: float = 0.0) -> np.ndarray:
    """(n, 3) [mm] the seed's P1-P5 on each listed flank: in the window's centre section, which is the
    axisymmetric section, at 1/(n+1) ... n/(n+1) of the straight part of the bolt load flank, moved ``depth`` [mm]
    radially into the bolt tooth (points on the exact helicoid may lie a few um outside a mesh's facets)."""
    section = measurement_points(layout, None, flanks, n_per_flank)
    return to_xyz(section[:, 0] - depth, section[:, 1], math.radians(WINDOW_CENTRE))
