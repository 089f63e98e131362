"""Axial stiffness of a free (unengaged) thread: the 3-D model's helix against the axisymmetric model's rings and
the engineering relations F L / (E A) with A = A_d3 (VDI 2230's free loaded thread) or A = As (the stress area,
Shigley's threaded portion).

A rod of the 3-D bolt's own geometry (the shank cylinder at r_shank = d/2 - |es|/2 and the helical grooves of
:mod:`frictionid.builders.bolt3d_geometry`, mid-side nodes on the curved faces as the builder puts them) is
clamped at one end (y = 0) and pulled by a uniform traction on the other (y = length); the thread runs from
``y_thread`` to ``y_end``, plain shank below and above it, so that both ends of the thread are the same kind of
transition and the thread between them carries the force in its core. The ring thread is the same groove outline
(:func:`groove_section`) turned about the axis, on quadratic triangles (axisymmetric). No contact, no nut: only
the thread's own stiffness. uy is read on the axis, where the helix's field is the same at every height away
from the ends (the geometry is invariant under the screw motion, which leaves the axis in place), and the rings'
field repeats every pitch, so the stretch over whole pitches is the thread's per-pitch compliance. The same rod
without grooves checks the read-out against F L / (E pi r_shank^2). Every cross-section of the helix has the same
area, A_sec = pi <r^2> over the profile (the rings' volume per length): away from the ends a uniform axial strain
with free lateral contraction is admissible, so E A_sec bounds both threads' axial stiffness from above.

Run: .venv/bin/python benchmarks/thread_stiffness.py [size [h_3d ...]] [--rings-only]   (default M6, 0.3 0.2)
h_3d: the 3-D mesh size on the thread's faces [mm], growing by 0.3 per mm to ``SIZE_MAX``; the rings are meshed
at h_3d and at RING_FINE. ``--rings-only``: the axisymmetric rods alone (seconds).
"""

import math
import sys
import time

import gmsh
import numpy as np
import skfem

from _measure import peak_memory_mb
from frictionid.builders.bolt import STEEL
from frictionid.builders.bolt3d_geometry import _wire, cylinder, groove, groove_section
from frictionid.builders.bolt3d_mesh import SIZE_GROWTH, curved_tetra10, mesh_with_fallback
from frictionid.builders.bolt_layout import bolt_layout
from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh, use_size_fields
from frictionid.fem.assembly import load_channels, stiffness
from frictionid.fem.cholesky import Cholesky
from frictionid.fem.interface import model_space
from frictionid.fem.points import point_operator
from frictionid.model import Mesh, Model, Stage, Support, SurfaceForce

FORCE = 1500.0          # [N]
SIZE_MAX = 1.0          # [mm] the largest element (the rod's core)
RING_FINE = 0.025       # [mm] the rings' reference mesh on the thread's faces
_TOL = 1e-3          # [mm] OCC bounding boxes are enlarged by the shapes' tolerances


def _size_field(dim: int, tags: list[int], size: float, size_max: float = SIZE_MAX, growth: float = SIZE_GROWTH,
                alone: bool = True) -> int:
    """Size ``size`` on the entities, growing by ``growth`` per mm to ``size_max``; the only size field unless
    ``alone`` is false (then the caller combines the returned fields)."""
    field = gmsh.model.mesh.field
    near = field.add("Distance")
    field.setNumbers(near, "SurfacesList" if dim == 2 else "CurvesList", tags)
    field.setNumber(near, "Sampling", 30)
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", near)
    for name, value in (("SizeMin", size), ("SizeMax", size_max), ("DistMin", 0.0),
                        ("DistMax", (size_max - size) / growth)):
        field.setNumber(threshold, name, value)
    if alone:
        use_size_fields(threshold)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size_max)
    return threshold


def _name_faces(dim: int, entities, y_thread: float, y_end: float, length: float, P: float) -> list[int]:
    """Physical groups "bolt", "bottom" (y = 0), "top" (y = length); the tags of the boundary entities of the
    threaded part (refined)."""
    bottom, top, thread = [], [], []
    for _, tag in gmsh.model.getBoundary(entities, combined=False, oriented=False):
        box = gmsh.model.getBoundingBox(dim - 1, abs(tag))
        y_min, y_max = box[1], box[4]
        if y_max < _TOL:
            bottom.append(abs(tag))
        elif y_min > length - _TOL:
            top.append(abs(tag))
        elif y_min > y_thread - P and y_max < y_end + P:
            thread.append(abs(tag))
    gmsh.model.addPhysicalGroup(dim, [t for _, t in entities], name="bolt")
    gmsh.model.addPhysicalGroup(dim - 1, bottom, name="bottom")
    gmsh.model.addPhysicalGroup(dim - 1, top, name="top")
    return thread


def _tooth_range(layout, y_thread: float, length: float) -> range:
    P = layout.size.P
    first = math.ceil((y_thread - layout.bolt_phase) / P + 0.5)
    last = math.floor((length - layout.bolt_phase) / P + 0.5)
    return range(first - 1, last + 1)


def rod_3d(layout, y_thread: float, y_end: float, length: float, size: float, grooves: bool = True):
    """(tetra10 mesh of the 3-D bolt's thread as a rod (see the module docstring), the solid's volume [mm^3])."""
    P = layout.size.P
    volume = []

    def make():
        occ = gmsh.model.occ
        rod = [(3, cylinder(layout.r_shank, 0.0, length))]
        if grooves:        # whole turns, seams at theta = pi (the builder cuts them off at its y_thread)
            cuts = [(3, groove(layout, layout.bolt_phase + (k - 0.5) * P, math.pi))
                    for k in _tooth_range(layout, y_thread, y_end)]
            rod, _ = occ.cut(rod, cuts)
        occ.synchronize()
        volume[:] = [sum(occ.getMass(3, tag) for _, tag in rod)]
        _size_field(2, _name_faces(3, rod, y_thread, y_end, length, P), size)

    return mesh_with_fallback(make, lambda: curved_tetra10("thread rod"), "thread rod"), volume[0]


def rod_axisymmetric(layout, y_thread: float, y_end: float, length: float, size: float, grooves: bool = True):
    """(triangle6 mesh (x = r, y = axis) of the same rod with ring grooves of the same outline, the solid of
    revolution's volume [mm^3] (Pappus))."""
    P = layout.size.P
    with gmsh_session("ring rod"):
        occ = gmsh.model.occ
        rod = [(2, occ.addRectangle(0.0, 0.0, 0.0, layout.r_shank, length))]
        if grooves:        # the ring between the teeth at z and z + P, teeth where the helix has them at theta = 0
            cuts = [(2, occ.addPlaneSurface([_wire(groove_section(layout, layout.bolt_phase + k * P), 0.0, 0.0)]))
                    for k in _tooth_range(layout, y_thread, y_end)
                    if y_thread - P < layout.bolt_phase + k * P < y_end]
            rod, _ = occ.cut(rod, cuts)
        occ.synchronize()
        volume = sum(2 * math.pi * occ.getCenterOfMass(2, tag)[0] * occ.getMass(2, tag) for _, tag in rod)
        _size_field(1, _name_faces(2, rod, y_thread, y_end, length, P), size)
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.SecondOrderLinear", 0)
        gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh("ring rod"), volume


def axis_uy(mesh: Mesh, kind: str, heights: np.ndarray) -> tuple[np.ndarray, float]:
    """(uy [mm] on the axis at ``heights`` under FORCE on "top", "bottom" clamped; the mesh's volume [mm^3])."""
    held = (0, 1, 2)[:mesh.points.shape[1]]
    model = Model(mesh=mesh, kind=kind, materials={"bolt": STEEL}, supports=(Support("bottom", held),),
                  loads=(SurfaceForce("top", 1, (FORCE,)),), stages=(Stage("F"),))
    space = model_space(model)
    K = stiffness(space, model)
    channels = load_channels(space, model)
    free = np.setdiff1d(np.arange(space.n_dofs), channels.prescribed)
    u = np.zeros(space.n_dofs)
    factor = Cholesky(K[free][:, free], np.zeros(0, int), free // space.n_components)
    u[free] = factor.solve(channels.forces[0][free] * channels.amplitudes[-1, 0])
    points = np.zeros((len(heights), mesh.points.shape[1]))
    points[:, 1] = heights
    volume = skfem.asm(skfem.Functional(lambda w: space.ring(w.x)), space.basis)
    return point_operator(space, points, ("uy",), regions=["bolt"] * len(heights)) @ u, float(volume)


def section_area(layout) -> float:
    """A_sec [mm^2]: the shank's area minus one groove's volume of revolution per pitch (the part inside r_shank)."""
    P = layout.size.P
    with gmsh_session("groove"):
        occ = gmsh.model.occ
        groove_face = occ.addPlaneSurface([_wire(groove_section(layout, 0.0), 0.0, 0.0)])
        inside, _ = occ.intersect([(2, groove_face)], [(2, occ.addRectangle(0.0, -P, 0.0, layout.r_shank, 3 * P))])
        occ.synchronize()
        removed = sum(2 * math.pi * occ.getCenterOfMass(2, tag)[0] * occ.getMass(2, tag) for _, tag in inside)
    return math.pi * layout.r_shank ** 2 - removed / P


def areas(layout) -> dict[str, float]:
    """[mm^2] of the model's profile (shifted radially by |es|/2): core d3, stress area As, the helix's section
    A_sec (:func:`section_area`), shank."""
    s, shift = layout.size, layout.shift
    d3, d2 = s.d3 - 2 * shift, s.d2 - 2 * shift
    return {"A_d3": math.pi / 4 * d3 ** 2, "As": math.pi / 4 * ((d2 + d3) / 2) ** 2, "A_sec": section_area(layout),
            "A_shank": math.pi * layout.r_shank ** 2}


def report(name: str, built, kind: str, heights: np.ndarray, middle: slice, area: dict, seconds: float):
    start = time.process_time()
    mesh, exact = built
    uy, volume = axis_uy(mesh, kind, heights)
    per_pitch = 1000 * np.diff(uy)
    dy = np.diff(heights)
    span = heights[middle.stop] - heights[middle.start]
    stretch = 1000 * (uy[middle.stop] - uy[middle.start]) / span                    # [um per mm]
    a_eff = FORCE / (STEEL.E * stretch / 1000)
    print(f"{name}: {mesh.n_nodes:,} nodes, mesh {seconds:.1f} s, solve {time.process_time() - start:.1f} s CPU, "
          f"peak {peak_memory_mb():.0f} MB; volume {volume:.3f} mm^3, the solid's {exact:.3f} "
          f"({volume - exact:+.3f}: {(volume - exact) / (heights[-1] - heights[0]):+.4f} mm^2 over the thread's "
          f"length)", flush=True)
    print(f"  uy change per pitch [um] from y = {heights[0]:g}: {np.array2string(per_pitch / dy, precision=5)}")
    print(f"  y {heights[middle.start]:g}-{heights[middle.stop]:g}: {stretch:.6f} um/mm, effective area "
          f"{a_eff:.3f} mm^2 = " + ", ".join(f"{a_eff / value:.4f} {key}" for key, value in area.items()), flush=True)
    return a_eff


def main(size: str = "M6", sizes=(0.3, 0.2), rings_only: bool = False):
    layout = bolt_layout(size)
    s = layout.size
    P, d = s.P, s.d
    y_thread, y_end, length = 1.0 * d, 3.0 * d, 4.0 * d
    heights = np.arange(y_thread, y_end + 1e-9, P)
    n = len(heights) - 1
    middle = slice(n // 4, n - n // 4)
    area = areas(layout)
    print(f"{size}: rod 0-{length:g} mm, thread {y_thread:g}-{y_end:g} mm, {FORCE:g} N, E {STEEL.E:g} MPa; " +
          ", ".join(f"{k} {v:.4f} mm^2 (F / (E A) {1000 * FORCE / (STEEL.E * v):.6f} um/mm)" for k, v in area.items()))
    for grooves in (False, True):
        label = "helix" if grooves else "plain rod"
        for h in () if rings_only else sizes if grooves else sizes[:1]:
            start = time.process_time()
            mesh = rod_3d(layout, y_thread, y_end, length, h, grooves)
            report(f"3-D {label}, {h:g} mm on the thread", mesh, "3d", heights, middle, area,
                   time.process_time() - start)
        for h in (*sizes, RING_FINE):
            start = time.process_time()
            mesh = rod_axisymmetric(layout, y_thread, y_end, length, h, grooves)
            report(f"axisymmetric {'rings' if grooves else 'plain rod'}, {h:g} mm", mesh, "axisymmetric", heights,
                   middle, area, time.process_time() - start)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--rings-only"]
    main(args[0] if args else "M6", tuple(float(a) for a in args[1:]) or (0.3, 0.2), "--rings-only" in sys.argv)
