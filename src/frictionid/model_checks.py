"""What a command says about the model it built, before any solve: the model's line and the contact set-up
checks with one line per interface (:func:`frictionid.fem.interface.contact_setup`)."""

from __future__ import annotations

from .errors import InputError
from .fem.interface import contact_setup
from .model import Model


def model_line(model: Model, builder: str, seconds: float) -> str:
    """The console's line about a built model: builder, kind, size, cells and element technology, zones."""
    return (f"model: builder {builder!r}, {model.kind}, {model.mesh.n_nodes:,} nodes, {model.mesh.cell_type} cells, "
            f"element {model.element!r}, zones {', '.join(model.zone_names)} ({seconds:.1f} s)")


def checked_contact(model: Model, where: str, echo, sliding: str = "small") -> tuple:
    """The model's contact map (:func:`~frictionid.fem.interface.contact_setup`), one line per interface to
    ``echo``; a failed set-up check is an :class:`InputError` naming ``where`` (the config file). With
    ``sliding = "finite"`` the lines say that the solve re-couples the interfaces by dual mortar in the deformed
    configuration (fem/sliding.py), whatever the pairing checked here."""
    try:
        contact = contact_setup(model)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    for entry in contact:
        echo(entry.line() + ("; finite sliding: re-coupled by dual mortar in the deformed configuration at every "
                             "increment" if sliding == "finite" else ""))
    return contact
