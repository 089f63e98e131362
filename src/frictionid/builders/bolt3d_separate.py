"""The 3-D bolt-nut mesh with the nut meshed on its own (``nut_mesh = "separate"``): the thread's two sides are
discretised independently, so that the contact pairs on the nut's load flanks follow ``flank_size`` and not the
bolt's root refinement.

Both gmsh sessions build the fragment of :mod:`.bolt3d_mesh` (the same CAD, so every face is split and named as
in the conforming model), then keep their bodies and drop the others (OCC's recursive removal keeps the faces a
kept body still bounds): bolt and plate 2 in one session (the head's bearing conforming), meshed with the
conforming model's fields (flanks, head contact, roots, head); nut and plate 1 in the other (the nut's bearing
conforming), meshed with the flank and contact sizes alone (no root refinement). The thread's interface is then
non-matching: zones A, B, ... and "thread_<i>" on the nut's load flanks (the contact side, which carries the
multipliers), target "bolt_contact" on the bolt's (3-D dual mortar, :mod:`frictionid.fem.mortar3d`).
"""

from __future__ import annotations

import gmsh
import numpy as np

from ..model import Mesh
from .bolt3d_knife import KNIFE_GROWTH, KNIFE_SIZE, knife_edges
from .bolt3d_mesh import ROOT_GROWTH, Options3d, body_of, classify_faces, curved_tetra10, distance_field, \
    fragment_bodies, head_field, mesh_with_fallback, separate_bodies
from .bolt_layout import BoltLayout
from .gmsh_mesh import use_size_fields

#: the target of the thread's interface: the bolt's load flanks where the nut's touch them
BOLT_CONTACT = "bolt_contact"
#: boundaries each session keeps (the zones and "thread_<i>" go with the nut)
BOLT_NAMES = ("head_plate", "plate2_head", "plate2_rim", "head_side", "window_bolt", "bolt_free")
NUT_NAMES = ("nut_contact", "nut_plate", "plate1_nut", "plate1_rim", "nut_jaws", "nut_outer", "window_nut")


def _kept(volumes: dict, bodies: tuple[str, ...]) -> dict[str, list[int]]:
    """Remove the volumes of the bodies not in ``bodies`` (and the faces no kept body bounds); the kept ones."""
    occ = gmsh.model.occ
    occ.remove([(3, t) for body, tags in volumes.items() if body not in bodies for t in tags], recursive=True)
    occ.synchronize()
    return {body: tags for body, tags in volumes.items() if body in bodies}


def _groups(volumes: dict, names: dict) -> None:
    """Physical groups of the kept volumes and of the named faces that still exist."""
    faces = {tag for _, tag in gmsh.model.getEntities(2)}
    for body, tags in volumes.items():
        gmsh.model.addPhysicalGroup(3, tags, name=body)
    for name, tags in names.items():
        tags = [t for t in tags if t in faces]
        if tags:
            gmsh.model.addPhysicalGroup(2, tags, name=name)


def _bolt_session(layout: BoltLayout, options: Options3d, engaged_top: float, knife: bool = False) -> bool:
    """The gmsh model set-up of bolt and plate 2, sized as in the conforming model (the knife edges refined if
    ``knife``); whether it has knife edges (:mod:`.bolt3d_knife`)."""
    volumes = fragment_bodies(layout, options, engaged_top)
    names = classify_faces(layout, options, volumes)
    root = min(options.flank_size, options.root_size)
    fields = [distance_field(names["thread_shared"], options.flank_size, options.mesh_size),
              distance_field(names["head_plate"], options.contact_size, options.mesh_size),
              distance_field(names["bolt_root"], root, options.mesh_size, ROOT_GROWTH)]
    if options.head_size is not None:
        fields.append(head_field(layout, options.head_size, options.mesh_size))
    kept = {name: names[name] for name in BOLT_NAMES if name in names}
    kept[BOLT_CONTACT] = names["nut_contact"]
    return _sized(layout, options, fields, knife, lambda: _groups(_kept(volumes, ("bolt", "plate2")), kept))


def _nut_session(layout: BoltLayout, options: Options3d, engaged_top: float, knife: bool = False) -> bool:
    """The gmsh model set-up of nut and plate 1: flanks at flank_size, the bearing at contact_size, no roots (the
    knife edges refined if ``knife``); whether it has knife edges."""
    volumes = fragment_bodies(layout, options, engaged_top)
    names = classify_faces(layout, options, volumes)
    fields = [distance_field(names["thread_shared"], options.flank_size, options.mesh_size),
              distance_field(names["nut_plate"], options.contact_size, options.mesh_size)]
    zones = [name for name in names if name in layout.thread_zones or name.startswith("thread_")]
    kept = {name: names[name] for name in (*NUT_NAMES, *zones) if name in names and name != "thread_shared"}
    return _sized(layout, options, fields, knife, lambda: _groups(_kept(volumes, ("nut", "plate1")), kept))


def _sized(layout: BoltLayout, options: Options3d, fields: list[int], knife: bool, keep) -> bool:
    """Keep the session's bodies (``keep()``), then size by the fields and, if ``knife``, by the knife edges left
    (:mod:`.bolt3d_knife`); whether there are any."""
    keep()
    edges = knife_edges(layout, options.theta_match)
    if edges and knife:
        fields = [*fields, distance_field(edges, KNIFE_SIZE * layout.size.P, options.mesh_size, KNIFE_GROWTH,
                                          curves=True)]
    use_size_fields(*fields)
    gmsh.option.setNumber("Mesh.MeshSizeMax", options.mesh_size)
    return bool(edges)


def joined(first: Mesh, second: Mesh) -> Mesh:
    """One mesh of two with no node in common: the second's nodes and cells numbered after the first's."""
    clash = (set(first.regions) & set(second.regions)) | (set(first.boundaries) & set(second.boundaries))
    if clash:
        raise ValueError(f"joined: both meshes name {sorted(clash)}")
    n_nodes, n_cells = first.n_nodes, first.n_cells
    return Mesh(points=np.vstack([first.points, second.points]), cell_type=first.cell_type,
                cells=np.vstack([first.cells, second.cells + n_nodes]),
                regions={**first.regions, **{k: v + n_cells for k, v in second.regions.items()}},
                boundaries={**first.boundaries, **{k: v + n_nodes for k, v in second.boundaries.items()}})


def _own_nodes(mesh: Mesh) -> Mesh:
    """:func:`separate_bodies` of one session's mesh (boundaries of its bodies only)."""
    return separate_bodies(mesh, {name: body_of(name) for name in mesh.boundaries
                                  if body_of(name) in mesh.regions})


def separate_mesh(layout: BoltLayout, options: Options3d, engaged_top: float) -> Mesh:
    """The tetra10 mesh of :func:`frictionid.builders.bolt3d_mesh.bolt3d_mesh` with bolt and plate 2 meshed in one
    gmsh session and nut and plate 1 in another (see the module docstring); curved mid-side nodes where the cells
    stay valid, as there."""
    parts = []
    for name, session in (("bolt", _bolt_session), ("nut", _nut_session)):
        source = f"3-D bolt model {layout.size.name} ({name} on its own)"
        mesh = mesh_with_fallback(lambda knife: session(layout, options, engaged_top, knife),
                                  lambda: curved_tetra10(source), source, refinable=True)
        parts.append(_own_nodes(mesh))
    return joined(*parts)
