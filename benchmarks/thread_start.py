"""The 3-D bolt's threaded end alone against the rings: where the helix and the axisymmetric model differ along the
axis when no nut, contact, head or plates are in the way (docs/bolt-study.md, "Against the axisymmetric model").

The M6 bolt of tests/test_bolt3d_verification.py without head: a rod of the shank's radius from y = 0 to the bolt's
end (24 mm), threaded from the layout's y_thread (14.5 mm) to the end, clamped at y = 0 and pulled by 1,500 N spread
over the end face. The helix is the 3-D builder's (:func:`frictionid.builders.bolt3d_geometry.thread_grooves`,
seams at theta = pi, mid-side nodes on the curved faces where the cells stay valid), meshed with the 3-D model's
kind of size fields: every face of the thread at ``flank``, growing by 0.3 per mm, the faces reaching below the nut
crest D1/2 (the roots) at ``root``, growing by 2.5 per mm, the largest element ``largest``. The rings are the same
groove outline turned about the axis from the plane y_thread, at 16 phases of the teeth (the helix's sections, as
benchmarks/bolt3d_vs_axisymmetric.py --phases 16 averages them), quadratic triangles at 0.025 mm on the thread.
uy's change on the axis between the test's stations is printed for the rings and, in % against them, for each 3-D
mesh. The segment 21-23.5 mm is not one the models share here: the force is spread over the end face, which is a
disc with a helical notch in 3-D and a whole disc of the profile's radius at each phase of the rings.

Run: .venv/bin/python benchmarks/thread_start.py FLANK,ROOT,LARGEST[,whole] ...   (sizes in mm; ``whole``: the
grooves as whole turns from the seam, as the builder cut them before the thread started at the plane y_thread)
"""

import math
import sys
import time

import gmsh
import numpy as np

from _measure import peak_memory_mb
from frictionid.builders.bolt3d_geometry import _wire, cylinder, groove, groove_section, thread_grooves
from frictionid.builders.bolt3d_mesh import ROOT_GROWTH, SIZE_GROWTH, curved_tetra10, face_points, mesh_with_fallback
from frictionid.builders.bolt_layout import bolt_layout
from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh, use_size_fields
from frictionid.model import Mesh
from thread_stiffness import _name_faces, _size_field, _tooth_range, axis_uy

LAYOUT = bolt_layout("M6", length=24.0, n_axial=2, thread_length=9.5)
#: stations on the axis [mm] (tests/test_bolt3d_verification.py's and docs/bolt-study.md's table's above the head)
STATIONS = np.array([3.0, 9.8, 14.0, 15.8, 18.4, 21.0, 23.5])
N_PHASES = 16
RING_SIZE = 0.025         # [mm] the rings' mesh on the thread's faces


def whole_turns(layout, theta0: float) -> list[tuple[int, int]]:
    """The grooves as whole turns from the seam, the lowest the first whose centre at theta0 + pi lies at or
    above y_thread (the builder's cut before the thread started at the plane y_thread)."""
    P = layout.size.P
    return [(3, groove(layout, layout.bolt_phase + (k - 0.5) * P, theta0))
            for k in _tooth_range(layout, layout.y_thread, layout.length)]


def helix(flank: float, root: float, largest: float, whole: bool = False) -> Mesh:
    """tetra10 mesh of the rod with the 3-D builder's helical thread (see the module docstring)."""
    layout, s = LAYOUT, LAYOUT.size

    def make():
        occ = gmsh.model.occ
        grooves = whole_turns(layout, math.pi) if whole else thread_grooves(layout, math.pi)
        rod, _ = occ.cut([(3, cylinder(layout.r_shank, 0.0, layout.length))], grooves)
        occ.synchronize()
        faces = _name_faces(3, rod, layout.y_thread, layout.length, layout.length, s.P)
        roots = [f for f in faces if np.any(np.hypot(*face_points(f, 6)[:, [0, 2]].T) < s.d1 / 2)]
        use_size_fields(_size_field(2, faces, flank, largest, SIZE_GROWTH, alone=False),
                        _size_field(2, roots, min(root, flank), largest, ROOT_GROWTH, alone=False))
        gmsh.option.setNumber("Mesh.MeshSizeMax", largest)

    return mesh_with_fallback(make, lambda: curved_tetra10("bolt rod"), "bolt rod")


def rings(delta: float) -> Mesh:
    """triangle6 mesh (x = r, y = axis) of the rod with ring grooves, teeth moved by ``delta`` [mm] from the
    layout's phase, the thread from the plane y_thread (the axisymmetric builder's profile)."""
    layout, P = LAYOUT, LAYOUT.size.P
    with gmsh_session("ring rod"):
        occ = gmsh.model.occ
        shank = (2, occ.addRectangle(0.0, 0.0, 0.0, layout.r_shank, layout.y_thread))
        thread = [(2, occ.addRectangle(0.0, layout.y_thread, 0.0, layout.r_shank, layout.length - layout.y_thread))]
        n_teeth = math.ceil((layout.length - layout.y_thread) / P) + 2
        first = math.floor((layout.y_thread - layout.bolt_phase) / P) - 1
        cuts = [(2, occ.addPlaneSurface([_wire(groove_section(layout, layout.bolt_phase + delta + k * P), 0.0, 0.0)]))
                for k in range(first, first + n_teeth + 1)]
        thread, _ = occ.cut(thread, cuts)
        rod, _ = occ.fragment([shank], thread)
        occ.synchronize()
        _size_field(1, _name_faces(2, rod, layout.y_thread, layout.length, layout.length, P), RING_SIZE)
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.SecondOrderLinear", 0)
        gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh("ring rod")


def changes(mesh: Mesh, kind: str) -> np.ndarray:
    """(n_stations - 1,) uy's change [mm] between consecutive STATIONS."""
    uy, _ = axis_uy(mesh, kind, STATIONS)
    return np.diff(uy)


def main(specs: list[str]):
    P = LAYOUT.size.P
    start = time.process_time()
    deltas = P * ((np.arange(N_PHASES) + 0.5) / N_PHASES - 0.5)
    reference = np.mean([changes(rings(delta), "axisymmetric") for delta in deltas], axis=0)
    print(f"stations {STATIONS.tolist()} mm; rings averaged over {N_PHASES} phases [um]: "
          f"{np.array2string(1000 * reference, precision=4)} ({time.process_time() - start:.0f} s CPU)", flush=True)
    shared = slice(1, len(STATIONS) - 2)                       # 9.8 to 21 mm
    for spec in specs:
        flank, root, largest, *whole = spec.split(",")
        start = time.process_time()
        mesh = helix(float(flank), float(root), float(largest), whole == ["whole"])
        three = changes(mesh, "3d")
        print(f"helix {spec}: {mesh.n_nodes:,} nodes, {time.process_time() - start:.0f} s CPU, peak "
              f"{peak_memory_mb():.0f} MB; against the rings per segment [%] "
              f"{np.array2string(100 * (three / reference - 1), precision=2)}; 9.8-21 mm "
              f"{100 * (three[shared].sum() / reference[shared].sum() - 1):+.2f} %, 9.8-23.5 mm "
              f"{100 * (three[1:].sum() / reference[1:].sum() - 1):+.2f} %", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
