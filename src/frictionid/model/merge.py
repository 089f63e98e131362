"""Merged zones: several friction zones of one interface that share one coefficient (``[friction] merge``).

A merged zone is the union of its members' facets under a new name; the model is otherwise unchanged, so every
solver, the CalculiX deck and the reports treat it as one zone. This is how an identification runs on a coarser
partition than the mesh was made with, e.g. the one ``frictionid design`` reports as resolvable.
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
    """The model with each group of zones (merged name -> zones of one interface) made one zone."""
    groups = check_groups(groups, model.zone_names, where)
    if not groups:
        return model
    interface_of = {z: i.name for i in model.interfaces for z in i.zones}
    for name, members in groups.items():
        apart = sorted({interface_of[m] for m in members})
        if len(apart) > 1:
            raise InputError(f"{where}.{name}: zones {list(members)} lie on different interfaces {apart}; only "
                             "zones of one interface can share a coefficient")
    mesh = model.mesh
    boundaries = dict(mesh.boundaries)
    for name, members in groups.items():
        boundaries[name] = np.concatenate([mesh.boundary(m) for m in members])
    merged_mesh = Mesh(**{**init_arguments(mesh), "boundaries": boundaries})
    interfaces = tuple(replace(i, zones=merged_names(i.zones, groups)) for i in model.interfaces)
    return replace(model, mesh=merged_mesh, interfaces=interfaces)
