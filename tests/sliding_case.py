"""A plane-strain block on a long base, meshed separately (non-matching interface): the finite-sliding case of
tests/test_sliding.py. The block's bottom is the contact side (zones "left" and "right"), the base's top the target;
the block's top is pressed by a total force and pulled along x by a prescribed displacement."""

from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh
from frictionid.model import (ContactInterface, Displacement, Material, Model, Stage, Support,
                              SurfaceForce)

STEEL = Material(210000.0, 0.3)
WIDTH, HEIGHT = 10.0, 3.0                 # block [mm]
BASE = (-6.0, 22.0, 3.0)                  # base: x from, x to, depth [mm]


def _rectangle(geo, x0, x1, y0, y1, nx, ny, split=None):
    """Structured rectangle; bottom split at x = split into two curves (for two zones). Returns the
    surface, its bottom curves and its top curve."""
    p = [geo.addPoint(x0, y0, 0), geo.addPoint(x1, y0, 0), geo.addPoint(x1, y1, 0), geo.addPoint(x0, y1, 0)]
    if split is None:
        bottom = [geo.addLine(p[0], p[1])]
        geo.mesh.setTransfiniteCurve(bottom[0], nx + 1)
    else:
        m = geo.addPoint(split, y0, 0)
        bottom = [geo.addLine(p[0], m), geo.addLine(m, p[1])]
        for c, length in zip(bottom, (split - x0, x1 - split)):
            geo.mesh.setTransfiniteCurve(c, round(nx * length / (x1 - x0)) + 1)
    right, top, left = geo.addLine(p[1], p[2]), geo.addLine(p[2], p[3]), geo.addLine(p[3], p[0])
    geo.mesh.setTransfiniteCurve(top, nx + 1)
    for c in (right, left):
        geo.mesh.setTransfiniteCurve(c, ny + 1)
    surface = geo.addPlaneSurface([geo.addCurveLoop(bottom + [right, top, left])])
    geo.mesh.setTransfiniteSurface(surface, cornerTags=p)
    return surface, bottom, top


def block_on_base(n_block=20, n_base=41, force=1000.0, pull=2.0, n_press=1, n_pull=20, order=1):
    """Model: base bottom held; block top pressed by ``force`` [N/mm] in stage "press", then pulled by ``pull``
    [mm] in ``n_pull`` increments (stage "pull") at the same force. Block facets 10/n_block mm, base facets
    28/n_base mm (non-matching)."""
    x0, x1, depth = BASE
    with gmsh_session() as gmsh:
        geo = gmsh.model.geo
        base, base_bottom, base_top = _rectangle(geo, x0, x1, -depth, 0.0, n_base, 4)
        block, zones, block_top = _rectangle(geo, 0.0, WIDTH, 0.0, HEIGHT, n_block, 6, split=WIDTH / 2)
        geo.synchronize()
        gmsh.model.addPhysicalGroup(2, [base], name="base")
        gmsh.model.addPhysicalGroup(2, [block], name="block")
        gmsh.model.addPhysicalGroup(1, base_bottom, name="base_bottom")
        gmsh.model.addPhysicalGroup(1, [base_top], name="target")
        gmsh.model.addPhysicalGroup(1, [block_top], name="block_top")
        gmsh.model.addPhysicalGroup(1, [zones[0]], name="left")
        gmsh.model.addPhysicalGroup(1, [zones[1]], name="right")
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(order)
        mesh = mesh_from_gmsh()
    return Model(mesh, "plane_strain", {"base": STEEL, "block": STEEL},
                 supports=(Support("base_bottom", ("x", "y")),),
                 loads=(SurfaceForce("block_top", "y", (-force, -force)),
                        Displacement("block_top", "x", (0.0, pull))),
                 stages=(Stage("press", n_press), Stage("pull", n_pull)),
                 interfaces=(ContactInterface("contact", ("left", "right"), "target", "mortar"),))
