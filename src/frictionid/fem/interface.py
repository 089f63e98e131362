"""Contact pairs of all interfaces of a model, each discretised as it asks (node-to-node or mortar)."""

from __future__ import annotations

import dataclasses
import logging
import weakref

import numpy as np

from ..errors import InputError
from ..model import Model
from .contact_map import InterfaceMap, contact_map
from .node_to_node import MeshesDoNotMatch, node_to_node_pairs
from .pairs import ContactPairs
from .space import Space

logger = logging.getLogger(__name__)


#: what :func:`contact_setup` built last: (weak reference to the model, (kind, element), space, pairs), which
#: :func:`model_space` and :func:`contact_pairs` return for that model, so that the check at model build and the
#: solver's condensation build the space and pair the interfaces once; cleared when the model is collected
_LAST: dict = {}


def _cached(model: Model, kind: str, element: str):
    entry = _LAST.get("setup")
    if entry is not None and entry[0]() is model and entry[1] == (kind, element):
        return entry
    return None


def model_space(model: Model) -> Space:
    """``Space.build(model.mesh, model.kind, model.element)``, the one :func:`contact_setup` built if it did."""
    entry = _cached(model, model.kind, model.element)
    return entry[2] if entry is not None else Space.build(model.mesh, model.kind, model.element)


def _mortar(space: Space, model: Model, index: int) -> ContactPairs:
    interface = model.interfaces[index]
    if space.dim == 3 and interface.lead:
        raise InputError(f"interface {interface.name!r}: a lead ({interface.lead:g} mm) needs node-to-node pairs in "
                         "3-D (conforming meshes); its meshes do not match or it asks for mortar")
    if space.dim == 3:
        from .mortar3d import mortar_pairs_3d
        return mortar_pairs_3d(space, model, index)
    from .mortar import mortar_pairs
    return mortar_pairs(space, model, index)


def contact_pairs(space: Space, model: Model) -> ContactPairs:
    """Pairs of every interface in model order (:func:`interface_pairs`: "auto" tries node-to-node and falls
    back to mortar where the meshes do not match, 2-D and 3-D).

    "axisymmetric_twist": the pairs of the (r, y) section with the circumferential tangent added, normals of
    helical interfaces tilted by their lead (:func:`frictionid.fem.twist.with_circumferential_tangent`).
    """
    entry = _cached(model, space.kind, space.element)
    if entry is not None and entry[2].n_dofs == space.n_dofs:
        return entry[3]
    if space.n_components != space.dim:
        from .twist import with_circumferential_tangent
        section = Space.build(model.mesh, "axisymmetric", model.element)
        pairs = contact_pairs(section, model)
        lead = np.array([model.interfaces[i].lead for i in pairs.interface], dtype=float)
        return with_circumferential_tangent(pairs, model.mesh.n_nodes, lead)
    parts = [interface_pairs(space, model, index)[0] for index in range(len(model.interfaces))]
    return ContactPairs.concatenate(parts, space.n_dofs, model.n_zones, space.dim)


def interface_pairs(space: Space, model: Model, index: int) -> tuple[ContactPairs, str]:
    """The pairs of interface ``index`` and the discretisation used ("node-to-node" or "mortar"): "auto" tries
    node-to-node and falls back to mortar where the meshes do not match (2-D and 3-D). Either refuses a pairing that fails the set-up checks of
    :mod:`frictionid.fem.contact_map` (a contact node facing no target, an initial gap beyond gap_tolerance)."""
    interface = model.interfaces[index]
    if interface.discretisation == "mortar":
        return _adjusted(_mortar(space, model, index), interface), "mortar"
    try:
        return _adjusted(node_to_node_pairs(space, model, index), interface), "node-to-node"
    except MeshesDoNotMatch:
        if interface.discretisation == "node-to-node":
            raise
    return _adjusted(_mortar(space, model, index), interface), "mortar"


def _adjusted(pairs: ContactPairs, interface) -> ContactPairs:
    """The pairs with their initial gaps set to zero where the interface asks (``adjust``), else as they are."""
    if not interface.adjust or not pairs.n_pairs:
        return pairs
    logger.info("interface %r: initial gaps adjusted to zero (they were %.3g to %.3g mm, RMS %.3g mm)",
                interface.name, pairs.gap.min(), pairs.gap.max(), np.sqrt(np.mean(pairs.gap ** 2)))
    return dataclasses.replace(pairs, gap=np.zeros_like(pairs.gap),
                               meshed_gap=(float(pairs.gap.min()), float(pairs.gap.max())))


def contact_setup(model: Model) -> tuple[InterfaceMap, ...]:
    """The contact map of ``model`` (:func:`frictionid.fem.contact_map.contact_map`) from its pairs as the
    solver builds them: the set-up checks at model build, before any solve (an :class:`InputError` where they
    fail). "axisymmetric_twist" models are mapped on their (r, y) section."""
    kind = "axisymmetric" if model.kind == "axisymmetric_twist" else model.kind
    space = Space.build(model.mesh, kind, model.element)
    parts = [interface_pairs(space, model, i) for i in range(len(model.interfaces))]
    pairs = ContactPairs.concatenate([p for p, _ in parts], space.n_dofs, model.n_zones, space.dim)
    _LAST["setup"] = (weakref.ref(model, lambda _: _LAST.clear()), (space.kind, space.element), space, pairs)
    return contact_map(model, parts)
