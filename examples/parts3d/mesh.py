"""Mesh the block and the plate of this example as two separate gmsh parts: hexahedra, the block's footprint with
5 elements per half side, the plate's with 4, so the interface nodes do not match (the 3-D dual mortar couples
them). ``--fine`` writes the finer pair the twin data are made on (7 and 5 per half side).

Run: python mesh.py            -> block_plate.msh
     python mesh.py --fine     -> block_plate_fine.msh

Geometry [mm]: plate 40 x 40 x 5 (top at z = 0), block 10 x 10 x 10 standing on its middle. Physical groups:
volumes "plate", "block"; faces "plate_bottom", "plate_top", "block_top" and the block's bottom by quadrant
"A" (x < 0, y < 0), "B" (x > 0, y < 0), "C" (x < 0, y > 0), "D" (x > 0, y > 0).
"""

import sys

import gmsh
import numpy as np

TOL = 1e-6
QUADRANTS = {(-1, -1): "A", (1, -1): "B", (-1, 1): "C", (1, 1): "D"}
#: elements per half side of the footprint (block, plate), along the block's height and the plate's thickness,
#: and in the plate outside the footprint (growing by 1.3 away from it)
COARSE = dict(block=5, plate=4, block_z=6, plate_z=4, outer=4)
FINE = dict(block=7, plate=5, block_z=9, plate_z=5, outer=6)


def boxes(breaks, z0, z1):
    """The boxes between consecutive x and y breaks, fragmented among themselves only (one part)."""
    occ = gmsh.model.occ
    parts = [(3, occ.addBox(x0, y0, z0, x1 - x0, y1 - y0, z1 - z0))
             for x0, x1 in zip(breaks, breaks[1:]) for y0, y1 in zip(breaks, breaks[1:])]
    pieces, _ = occ.fragment(parts[:1], parts[1:])
    return [tag for dim, tag in pieces if dim == 3]


def faces_at(volumes, axis, value):
    faces = {abs(t) for _, t in gmsh.model.getBoundary([(3, v) for v in volumes], combined=False, oriented=False)}
    return [f for f in sorted(faces)
            if np.allclose(np.reshape(gmsh.model.getBoundingBox(2, f), (2, 3))[:, axis], value, atol=TOL)]


def main(fine: bool = False):
    n = FINE if fine else COARSE
    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        plate = boxes([-20, -5, 0, 5, 20], -5, 0)
        block = boxes([-5, 0, 5], 0, 10)          # a second part: not fragmented with the plate, own nodes
        gmsh.model.occ.synchronize()
        block_faces = gmsh.model.getBoundary([(3, v) for v in block], combined=False, oriented=False)
        block_curves = {abs(c) for _, c in gmsh.model.getBoundary(block_faces, combined=False, oriented=False)}
        for _, curve in gmsh.model.getEntities(1):
            ends = [np.array(gmsh.model.getValue(0, abs(p), []))
                    for _, p in gmsh.model.getBoundary([(1, curve)], oriented=False)]
            axis = int(np.argmax(np.abs(ends[1] - ends[0])))
            if axis == 2:
                gmsh.model.mesh.setTransfiniteCurve(curve, (n["block_z"] if curve in block_curves else
                                                            n["plate_z"]) + 1)
            elif max(abs(ends[0][axis]), abs(ends[1][axis])) <= 5 + TOL:
                gmsh.model.mesh.setTransfiniteCurve(curve, (n["block"] if curve in block_curves else n["plate"]) + 1)
            else:           # outside the footprint: growing away from the block
                growth = 1.3 if abs(ends[0][axis]) < abs(ends[1][axis]) else 1 / 1.3
                gmsh.model.mesh.setTransfiniteCurve(curve, n["outer"] + 1, "Progression", growth)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface)
            gmsh.model.mesh.setRecombine(2, surface)
        for _, volume in gmsh.model.getEntities(3):
            gmsh.model.mesh.setTransfiniteVolume(volume)
        add = gmsh.model.addPhysicalGroup
        add(3, plate, name="plate")
        add(3, block, name="block")
        add(2, faces_at(plate, 2, -5), name="plate_bottom")
        add(2, faces_at(plate, 2, 0), name="plate_top")
        add(2, faces_at(block, 2, 10), name="block_top")
        for face in faces_at(block, 2, 0):
            x, y, _ = gmsh.model.occ.getCenterOfMass(2, face)
            add(2, [face], name=QUADRANTS[(int(np.sign(x)), int(np.sign(y)))])
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write("block_plate_fine.msh" if fine else "block_plate.msh")
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main("--fine" in sys.argv[1:])
