"""Merged zones: several friction zones that share one coefficient (``[friction] merge``), on one interface or
across interfaces (a two-sided clamp, a bolt head's and nut's bearing faces of the same finish).

Members on one interface become one zone, the union of their facets; zones on different interfaces keep their own
pairs and share the coefficient (:attr:`~frictionid.model.ContactInterface.coefficients`). This is how an
identification runs on a coarser partition than the mesh was made with, e.g. the one ``frictionid design``
reports as resolvable.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InputError
from .mesh import Mesh, init_arguments
from .model import Model


def check_groups(groups, zone_names, where: str = "friction.merge") -> dict[str, tuple[str, ...]]:
    """``groups`` (merged name -> list of at least two zones) checked against ``zone_names``.

    >>> check_groups({"AD": ["A", "D"]}, ("A", "B", "C", "D"))
    {'AD': ('A', 'D')}
    """
    if not isinstance(groups, dict):
        raise InputError(f"{where} must be a table of merged zone = [zones], e.g. {{ AD = [\"A\", \"D\"] }}")
    checked, used = {}, {}
    for name, members in groups.items():
        if not isinstance(members, (list, tuple)) or len(members) < 2 or \
                not all(isinstance(m, str) for m in members):
            raise InputError(f"{where}.{name} must list at least two zone names, got {members!r}")
        unknown = [m for m in members if m not in zone_names]
        if unknown:
            raise InputError(f"{where}.{name}: unknown zone(s) {unknown}; the model's zones are {list(zone_names)}")
        for m in members:
            if m in used:
                raise InputError(f"{where}: zone {m!r} is in both {used[m]!r} and {name!r}")
            used[m] = name
        if name in zone_names and name not in members:
            raise InputError(f"{where}.{name}: the model already has a zone {name!r}; name the merged zone "
                             "otherwise")
        checked[name] = tuple(members)
    return checked


def merged_names(zone_names, groups: dict) -> tuple[str, ...]:
    """The zone names after merging: each group takes the place of its first member.

    >>> merged_names(("A", "B", "C", "D"), {"BD": ("B", "D")})
    ('A', 'BD', 'C')
    """
    member_of = {m: name for name, members in groups.items() for m in members}
    out = []
    for zone in zone_names:
        name = member_of.get(zone, zone)
        if name not in out:
            out.append(name)
    return tuple(out)


def merge_zones(model: Model, groups, where: str = "friction.merge") -> Model:
    """The model with each group of zones (merged name -> zones) sharing one coefficient.

    The members of a group on one interface become one zone, the union of their facets: under the group's name
    when the group lies on that one interface, else (a group spanning several interfaces) under the one member's
    name, or ``<group>@<interface>`` for several members there. Zones on different interfaces share the
    coefficient through :attr:`ContactInterface.coefficients`: each keeps its own contact pairs (and CalculiX
    contact pair and friction card), their sensitivities add up in the one coefficient's column.

    >>> from frictionid.builders.block import block_model_2d
    >>> merge_zones(block_model_2d(mesh_size=4.0, n_zones=3), {"AC": ["A", "C"]}).zone_names
    ('AC', 'B')
    """
    groups = check_groups(groups, model.zone_names, where)
    if not groups:
        return model
    interfaces_of: dict[str, set] = {}
    for interface in model.interfaces:
        for coefficient in interface.coefficients:
            interfaces_of.setdefault(coefficient, set()).add(interface.name)
    member_of = {m: name for name, members in groups.items() for m in members}
    mesh = model.mesh
    boundaries = dict(mesh.boundaries)
    interfaces = []
    for interface in model.interfaces:
        zones: dict[str, str] = {}                                   # zone (boundary) -> coefficient
        for zone, coefficient in zip(interface.zones, interface.coefficients):
            name = member_of.get(coefficient)
            if name is None:
                zones[zone] = coefficient
                continue
            here = [z for z, c in zip(interface.zones, interface.coefficients) if c in groups[name]]
            spans = len(set().union(*(interfaces_of[m] for m in groups[name]))) > 1
            boundary = (here[0] if len(here) == 1 else f"{name}@{interface.name}") if spans else name
            if boundary not in zones:
                if len(here) > 1:
                    boundaries[_new_boundary(boundary, here, mesh, where)] = \
                        np.concatenate([mesh.boundary(z) for z in here])
                zones[boundary] = name
        interfaces.append(replace(interface, zones=tuple(zones), coefficients=tuple(zones.values())))
    merged_mesh = Mesh(**{**init_arguments(mesh), "boundaries": boundaries})
    return replace(model, mesh=merged_mesh, interfaces=tuple(interfaces))


def _new_boundary(name: str, members: list[str], mesh: Mesh, where: str) -> str:
    """The name of a merged zone's boundary: refused where the mesh has another boundary of that name."""
    if name in mesh.boundaries and name not in members:
        raise InputError(f"{where}: the merged zone {name!r} would replace the mesh's boundary of that name; "
                         "name the merged zone otherwise")
    return name
