"""LaVision DaVis (StrainMaster) vector and strain fields exported as CSV.

Layout implemented (DaVis's export of a vector field to a text table; map a variant with ``[data] columns``):
``;``-separated names with units ``x [mm];y [mm];z [mm];Vx [mm];Vy [mm];Vz [mm]`` (the displacement vector), an
optional ``isValid`` flag (0 where the vector was disabled or rejected), optional strains ``Exx``, ``Eyy``, ``Exy``
(with ``[-]`` or ``[%]``). DaVis offers several strain definitions and the export does not name the one used:
strains need ``[data] strain``. Rows with ``isValid = 0`` are dropped. DaVis has no point id: points are
labelled by their row number, the same in the export of every stage.
"""

from __future__ import annotations

from .layout import Layout

NAME = "davis"
TITLE = "LaVision DaVis CSV"
KEY_COLUMNS = "x, y, (z,) Vx, Vy, (Vz,) isValid, Exx, Eyy, Exy"
_MAP = {"x": "x", "y": "y", "z": "z", "ux": "Vx", "uy": "Vy", "uz": "Vz", "exx": "Exx", "eyy": "Eyy", "exy": "Exy"}


def recognise(names: tuple[str, ...]) -> bool:
    return {"x", "y", "Vx", "Vy"} <= set(names)


def layout(names: tuple[str, ...]) -> Layout:
    columns = {t: c for t, c in _MAP.items() if c in names}
    invalid = (("isValid", lambda v: v == 0.0, "with isValid = 0"),) if "isValid" in names else ()
    return Layout(NAME, columns, None, "", invalid)
