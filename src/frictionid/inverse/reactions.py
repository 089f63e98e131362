"""The model reaction each per-stage observable measures: the machine force, and the torque and clamp force of a
tightening test (``[data] reactions``)."""

from __future__ import annotations

import difflib

from ..data.table import CHANNELS
from ..errors import InputError
from ..model import Displacement, Model, Rotation
from ..model.model import TORQUE, component_index, reaction_label

#: the observable for the measurement file's `force` column: the machine force of each stage [N]
FORCE = "force"
#: observables of one value per stage, each a reaction sum of the model: the machine force and the channels of
#: a tightening test (`torque`, `clamp` columns; :data:`frictionid.data.table.CHANNELS`)
STAGE_OBSERVABLES = (FORCE,) + tuple(CHANNELS)


def machine_force(model: Model) -> str:
    """Label ("boundary.axis") of the reaction sum the machine's load cell measures.

    It is the reaction of the one boundary component driven by a non-zero prescribed displacement (the block
    test: "block_top.y"), in the model's frame: positive when the machine pushes the body in +axis.

    Raises
    ------
    InputError
        When the model has no such component (e.g. it is loaded by a prescribed force, which is then known and
        not measured) or more than one.
    """
    driven = list(dict.fromkeys(
        reaction_label(load.boundary, component_index(load.component, model.dim, load.boundary))
        for load in model.loads if isinstance(load, Displacement) and any(v != 0 for v in load.values)))
    if len(driven) != 1:
        raise InputError(f"data.observables: 'force' needs a model driven by one prescribed displacement whose "
                         f"reaction the machine measures; this model drives {driven or 'none'}")
    return driven[0]


def check_reaction_keys(reactions: dict | None, where: str = "data.reactions") -> dict:
    """The ``[data] reactions`` table, its keys checked to be channels (:data:`~frictionid.data.table.CHANNELS`).

    >>> check_reaction_keys({"clamp": "plate1_rim.y"})
    {'clamp': 'plate1_rim.y'}
    """
    reactions = dict(reactions or {})
    unknown = [key for key in reactions if key not in CHANNELS]
    if unknown:
        close = difflib.get_close_matches(str(unknown[0]), list(CHANNELS), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise InputError(f"{where}: {unknown[0]!r} is not a per-stage observable with a reaction to name{hint}; "
                         f"expected {', '.join(CHANNELS)}")
    return reactions


def channel_reaction(model: Model, channel: str, reactions: dict | None = None,
                     where: str = "data.reactions") -> str:
    """Label of the reaction sum of ``model`` that the per-stage observable ``channel`` measures.

    "force": :func:`machine_force`. "torque", "clamp": the label ``reactions`` (the ``[data] reactions`` table)
    gives for it, e.g. ``{ clamp = "plate1_rim.y" }``; without one, "torque" is the torque about the axis of the
    one boundary turned by a prescribed rotation (the tightening bolt: "nut_outer.torque") and "clamp" has no
    default (where the load cell sits is the rig's choice).

    Raises
    ------
    InputError
        A channel with no reaction to measure, or a label that is not one of the model's reactions.
    """
    reactions = check_reaction_keys(reactions, where)
    if channel == FORCE:
        return machine_force(model)
    label = reactions.get(channel)
    if label is None and channel == "torque":
        turned = list(dict.fromkeys(reaction_label(load.boundary, TORQUE) for load in model.loads
                                    if isinstance(load, Rotation)))
        label = turned[0] if len(turned) == 1 else None
    if label is None:
        example = model.reaction_labels[0] if model.reaction_labels else "boundary.y"
        raise InputError(f"{where}: the observable {channel!r} ({CHANNELS[channel][0]}) needs the reaction it "
                         f"measures, e.g. reactions = {{ {channel} = \"{example}\" }}; the model's reactions are "
                         f"{list(model.reaction_labels)}")
    if label not in model.reaction_labels:
        close = difflib.get_close_matches(str(label), list(model.reaction_labels), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise InputError(f"{where}.{channel}: {label!r} is not a reaction of the model{hint}; the model's "
                         f"reactions are {list(model.reaction_labels)}")
    return label
