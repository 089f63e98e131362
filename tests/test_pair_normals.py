"""The normal of a node-to-node pair (fem/node_to_node.py ``_pair_normals``): the line joining the two nodes where
they are apart along the surface's normal (a gap between curved surfaces), the target's normal where they coincide
or are offset along the surface (a mismatch of the two meshes, not a gap)."""

import dataclasses

import numpy as np

from frictionid.builders.block import block_model
from frictionid.fem.node_to_node import _pair_normals, node_to_node_pairs
from frictionid.fem.space import Space

UP = np.array([[0.0, 1.0, 0.0]])


def test_a_gap_is_measured_along_the_line_joining_the_nodes():
    tilt = np.radians(30.0)
    offset = 1e-3 * np.array([[np.sin(tilt), np.cos(tilt), 0.0]])
    np.testing.assert_allclose(_pair_normals(offset, UP, 1.0), offset / 1e-3)
    np.testing.assert_allclose(_pair_normals(-offset, UP, 1.0), offset / 1e-3)      # oriented like the target's


def test_an_offset_along_the_surface_keeps_the_target_normal():
    """Above the round-off threshold (1e-6 h) but across the normal: the target's normal, not the offset's
    direction (which would be the surface's tangent), also where the offset has no normal part at all."""
    for offset in ([5e-6, 0.0, 0.0], [5e-6, 1e-6, -2e-6], [0.0, 0.0, 1e-3]):
        np.testing.assert_array_equal(_pair_normals(np.array([offset]), UP, 1.0), UP)


def test_contact_nodes_moved_along_the_surface_leave_the_pairs_normals_and_gaps():
    """The block on its plate (reference test 1, its meshed gaps, not adjusted): every contact node moved 1.4e-4 mm
    along the surface (far above the round-off threshold 1e-6 h, h the facet size of 5 mm) keeps its pair's normal
    and a zero gap; moved 1e-4 mm off the plate, its gap is 1e-4 mm along the same normal."""
    model = block_model(mesh_size=5.0)
    pairs = node_to_node_pairs(Space.build(model.mesh, model.kind, model.element), model, 0)
    normals = pairs.frames[:, 0]
    for move, gap in ((pairs.frames[:, 1] + pairs.frames[:, 2], 0.0), (normals, 1e-4)):
        points = model.mesh.points.copy()
        points[pairs.nodes] += 1e-4 * move
        moved = dataclasses.replace(model, mesh=dataclasses.replace(model.mesh, points=points))
        again = node_to_node_pairs(Space.build(moved.mesh, moved.kind, moved.element), moved, 0)
        np.testing.assert_allclose(again.frames[:, 0], normals, atol=1e-12)
        np.testing.assert_allclose(again.gap, pairs.gap + gap, atol=1e-12)
