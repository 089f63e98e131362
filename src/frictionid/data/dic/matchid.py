"""MatchID (MatchID NV) data exported as CSV.

Layout implemented (MatchID's table export as we know it; check a real export with ``frictionid check-data``
and map a variant with ``[data] columns``): ``;``-separated, decimal comma with a European locale, grouped names
with units, ``coor.X [mm]``, ``coor.Y [mm]``, ``coor.Z [mm]``, ``disp.Horizontal Displacement U [mm]``,
``disp.Vertical Displacement V [mm]``, ``disp.Out-Of-Plane: W [mm]``, ``strain.Strain-xx [%]``,
``strain.Strain-yy [%]``, ``strain.Strain-xy [%]`` or, as MatchID 2024 names them (seen in public readers, e.g.
the pycoatl project's MatchID importer), ``strain.Strain-global frame: Exx [ ]`` (Eyy, Exy), pixel positions
``x_pic``, ``y_pic`` or ``Coordinates.Image X [Pixel]`` (not read). MatchID offers
several strain formulations and the header does not name the one used: strains need ``[data] strain``. Points
MatchID did not correlate have empty or NaN cells and are dropped.

MatchID 2023 names its columns plainly, comma-separated without units: ``x_pic,y_pic,x,y,z,u,v,w,exx,eyy,exy``
(the ``v_2023`` names of mt2py's MatchID importer, ``spatialdata/importmatchid.py``, ``field_lookup``), further
columns after them. Its ``x``, ``y``, ``z`` are the points' positions at the exported stage: mt2py's
``utils/matchidutils.py`` reads these columns and subtracts the displacement ("only actual coordinates in file #0,
but can reconstruct from current position - displacement"); the reader does the same (reported). Lengths are
taken as mm, strains as pure numbers (the file states no unit).
"""

from __future__ import annotations

import re

from .layout import Layout

NAME = "matchid"
TITLE = "MatchID CSV"
KEY_COLUMNS = "coor.X, coor.Y, (coor.Z,) disp.* U / V / W, strain.Strain-xx / -yy / -xy"
_PATTERNS = {"x": r"coor\.X", "y": r"coor\.Y", "z": r"coor\.Z", "ux": r"disp\..*\bU", "uy": r"disp\..*\bV",
             "uz": r"disp\..*\bW", "exx": r"strain\.Strain-(xx|global frame: Exx)",
             "eyy": r"strain\.Strain-(yy|global frame: Eyy)", "exy": r"strain\.Strain-(xy|global frame: Exy)"}


#: MatchID 2023's names (target -> column)
NAMES_2023 = {"x": "x", "y": "y", "z": "z", "ux": "u", "uy": "v", "uz": "w", "exx": "exx", "eyy": "eyy",
              "exy": "exy"}
#: pixel positions in the image: refused as coordinates in mm
PIXEL_COLUMNS = {"x_pic": "px", "y_pic": "px", "Coordinates.Image X": "Pixel", "Coordinates.Image Y": "Pixel"}
DEFORMED_2023 = ("MatchID 2023 writes the position at the stage; mt2py's utils/matchidutils.py subtracts the "
                 "displacement too")


def recognise(names: tuple[str, ...]) -> bool:
    return "coor.X" in names and any(n.startswith("disp.") for n in names) or _is_2023(names)


def _is_2023(names: tuple[str, ...]) -> bool:
    return {"x_pic", "y_pic", "x", "y", "u", "v"} <= set(names) and "coor.X" not in names


def layout(names: tuple[str, ...]) -> Layout:
    if _is_2023(names):
        columns = {t: c for t, c in NAMES_2023.items() if c in names}
        return Layout(NAME, columns, None, "", column_units=PIXEL_COLUMNS, deformed=DEFORMED_2023,
                      variant="MatchID 2023 names")
    columns = {}
    for target, pattern in _PATTERNS.items():
        found = [n for n in names if re.fullmatch(pattern, n)]
        if found:
            columns[target] = found[0]
    return Layout(NAME, columns, None, "", column_units=PIXEL_COLUMNS, variant="MatchID 2024 names")
