"""Contact pairs of all interfaces of a model, each discretised as it asks (node-to-node or mortar)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import Model
from .node_to_node import node_to_node_pairs
from .pairs import ContactPairs
from .space import Space


def _mortar(space: Space, model: Model, index: int) -> ContactPairs:
    if space.dim == 3:
        from .mortar3d import mortar_pairs_3d
        return mortar_pairs_3d(space, model, index)
    from .mortar import mortar_pairs
    return mortar_pairs(space, model, index)


def contact_pairs(space: Space, model: Model) -> ContactPairs:
    """Pairs of every interface in model order; "auto" tries node-to-node and falls back to mortar
    where the meshes do not match (2-D and 3-D).

    "axisymmetric_twist": the pairs of the (r, y) section with the circumferential tangent added, normals of
    helical interfaces tilted by their lead (:func:`frictionid.fem.twist.with_circumferential_tangent`).
    """
    if space.n_components != space.dim:
        from .twist import with_circumferential_tangent
        section = Space.build(model.mesh, "axisymmetric", model.element)
        pairs = contact_pairs(section, model)
        lead = np.array([model.interfaces[i].lead for i in pairs.interface], dtype=float)
        return with_circumferential_tangent(pairs, model.mesh.n_nodes, lead)
    parts = []
    for index, interface in enumerate(model.interfaces):
        if interface.discretisation == "mortar":
            parts.append(_mortar(space, model, index))
            continue
        try:
            parts.append(node_to_node_pairs(space, model, index))
        except InputError:
            if interface.discretisation == "node-to-node":
                raise
            parts.append(_mortar(space, model, index))
    return ContactPairs.concatenate(parts, space.n_dofs, model.n_zones, space.dim)
