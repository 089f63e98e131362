"""The contact set-up of a model before any solve: the checks of each interface's pairing (target facing, initial
gaps) and the contact map (zones, pairs, initial state) that the command line prints and result.json
(``model.contact``), the HTML report and the fields carry."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..model import ContactInterface, Mesh, Model
from .pairs import ContactPairs

#: largest angle [deg] between a contact node's outward normal and the reversed outward normal of the target it
#: pairs with; a target facing away (a second body behind the contact body, 180 deg) is never a partner
FACING_DEG = 45.0
#: default ``gap_tolerance``: this fraction of the contact side's median facet size
GAP_FRACTION = 0.5
#: initial gaps within this fraction of the facet size count as closed (round-off of coincident nodes)
CLOSED_FRACTION = 1e-6


def facet_size(mesh: Mesh, boundaries) -> float:
    """Median corner-to-corner length [mm] of the first edge of the facets of ``boundaries``."""
    facets = np.vstack([mesh.boundary(b) for b in boundaries])
    return float(np.median(np.linalg.norm(mesh.points[facets[:, 1]] - mesh.points[facets[:, 0]], axis=1)))


def gap_tolerance(mesh: Mesh, interface: ContactInterface) -> float:
    """The interface's ``gap_tolerance`` [mm], by default :data:`GAP_FRACTION` of its contact facet size."""
    if interface.gap_tolerance is not None:
        return float(interface.gap_tolerance)
    return GAP_FRACTION * facet_size(mesh, interface.zones)


def coefficient_columns(model: Model, interface: ContactInterface) -> np.ndarray:
    """(n_interface_zones, n_zones) 0/1: which of the model's coefficients each zone of the interface takes."""
    out = np.zeros((len(interface.zones), model.n_zones))
    out[np.arange(len(interface.zones)), [model.zone_names.index(c) for c in interface.coefficients]] = 1.0
    return out


def check_gaps(interface: ContactInterface, gap: np.ndarray, position: np.ndarray, tolerance: float,
               how: str) -> None:
    """An :class:`InputError` where a pair's initial gap |gap| [mm] exceeds ``tolerance``, naming the interface,
    the number of such pairs, the largest gap and where it is; ``how`` names the discretisation."""
    beyond = np.abs(gap) > tolerance
    if not beyond.any():
        return
    worst = int(np.argmax(np.abs(gap)))
    raise InputError(
        f"[[model.interfaces]] {interface.name!r}: {int(beyond.sum())} of {len(gap)} contact pairs ({how}) have an "
        f"initial gap beyond gap_tolerance = {tolerance:.3g} mm, the largest {gap[worst]:.4g} mm at "
        f"{np.round(position[worst], 6).tolist()}; zones {list(interface.zones)} are not paired with the facing "
        f"surface of target {interface.target!r} within the tolerance: check that the target is the surface "
        "facing the zones (a target spanning two bodies pairs each zone with the one it faces), or state the "
        "geometry's gap as [[model.interfaces]] gap_tolerance [mm]")


@dataclass(frozen=True)
class InterfaceMap:
    """The contact set-up of one interface (pairs as built, before any solve).

    Attributes
    ----------
    name, target : the interface and its target boundary
    discretisation : "node-to-node" | "mortar" (the one used; "auto" resolved)
    n_pairs : pairs (contact nodes that carry a constraint); n_left_out : contact nodes without one (mortar:
        not covered by the target)
    gap : (smallest, largest) initial gap [mm]; negative: an interference
    adjusted_from : (smallest, largest) initial gap as meshed [mm] where the interface set the gaps to zero
        (``adjust``; ``gap`` is then 0 to 0), else None
    gap_tolerance : [mm] the largest |gap| accepted
    facing_deg : largest angle [deg] between the contact normal and the reversed target normal (NaN: not given)
    state : number of pairs initially "closed", "open", "interference"
    zones : zone -> {"pairs": pairs it takes part in, "area": its contact area [mm^2], "gap": [min, max] [mm]}
    """

    name: str
    target: str
    discretisation: str
    n_pairs: int
    n_left_out: int
    gap: tuple[float, float]
    gap_tolerance: float
    facing_deg: float
    state: dict
    zones: dict
    adjusted_from: tuple[float, float] | None = None

    def line(self) -> str:
        """One line for the console: pairs, initial gap range, facing check."""
        facing = "" if np.isnan(self.facing_deg) else f", facing within {self.facing_deg:.3g} deg"
        left = f" ({self.n_left_out} contact nodes not covered)" if self.n_left_out else ""
        adjusted = ("" if self.adjusted_from is None else
                    f", set to zero from {self.adjusted_from[0]:.3g} to {self.adjusted_from[1]:.3g} mm as meshed")
        return (f"contact {self.name!r}: {self.n_pairs} pairs {self.discretisation}{left} on target "
                f"{self.target!r}, initial gap {self.gap[0]:.3g} to {self.gap[1]:.3g} mm (tolerance "
                f"{self.gap_tolerance:.3g}{adjusted}){facing}; " + ", ".join(f"{n} {k}" for k, n in self.state.items() if n))

    def as_dict(self) -> dict:
        """The entry of result.json ``model.contact``."""
        return {"name": self.name, "target": self.target, "discretisation": self.discretisation,
                "n_pairs": self.n_pairs, "n_left_out": self.n_left_out, "gap": list(self.gap),
                "gap_tolerance": self.gap_tolerance,
                "adjusted_from": None if self.adjusted_from is None else list(self.adjusted_from),
                "facing_deg": None if np.isnan(self.facing_deg) else self.facing_deg,
                "state": dict(self.state), "zones": {z: dict(v) for z, v in self.zones.items()}}


def initial_state(pairs: ContactPairs, size: np.ndarray | float) -> np.ndarray:
    """(n_pairs,) 0 closed, 1 open, -1 interference: the sign of the initial gap beyond round-off of ``size``."""
    closed = CLOSED_FRACTION * np.asarray(size)
    return np.where(pairs.gap > closed, 1, np.where(pairs.gap < -closed, -1, 0))


def contact_map(model: Model, parts) -> tuple[InterfaceMap, ...]:
    """The :class:`InterfaceMap` of each interface of ``model`` from its pairs: ``parts`` lists, in interface
    order, (pairs of that interface, discretisation used), as :func:`frictionid.fem.interface.interface_pairs`
    gives them."""
    return tuple(_interface_map(model, interface, pairs, how)
                 for interface, (pairs, how) in zip(model.interfaces, parts))


def _interface_map(model: Model, interface: ContactInterface, pairs: ContactPairs, how: str) -> InterfaceMap:
    share, weight = pairs.zone_share, pairs.weight
    size = facet_size(model.mesh, interface.zones)
    state = initial_state(pairs, size)
    gap = np.where(state == 0, 0.0, pairs.gap)                  # round-off of coincident nodes (1e-58 mm) is 0
    contact_nodes = np.unique(np.concatenate([model.mesh.boundary_nodes(z) for z in interface.zones]))
    zones = {}
    for zone, coefficient in zip(interface.zones, interface.coefficients):
        column = share[:, model.zone_names.index(coefficient)]
        member = column > 0
        zones[zone] = {"coefficient": coefficient, "pairs": int(member.sum()), "area": float(column @ weight),
                       "gap": [float(gap[member].min()), float(gap[member].max())] if member.any() else None}
    facing = pairs.facing if pairs.facing is not None else np.full(pairs.n_pairs, np.nan)
    return InterfaceMap(
        name=interface.name, target=interface.target, discretisation=how, n_pairs=pairs.n_pairs,
        n_left_out=int(len(contact_nodes) - len(np.unique(pairs.nodes))),
        gap=(float(gap.min()), float(gap.max())) if pairs.n_pairs else (np.nan, np.nan),
        gap_tolerance=gap_tolerance(model.mesh, interface),
        facing_deg=float(np.nanmax(facing)) if np.isfinite(facing).any() else np.nan,
        state={"closed": int(np.sum(state == 0)), "open": int(np.sum(state == 1)),
               "interference": int(np.sum(state == -1))}, zones=zones, adjusted_from=pairs.meshed_gap)
