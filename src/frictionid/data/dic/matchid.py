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


def recognise(names: tuple[str, ...]) -> bool:
    return "coor.X" in names and any(n.startswith("disp.") for n in names)


def layout(names: tuple[str, ...]) -> Layout:
    columns = {}
    for target, pattern in _PATTERNS.items():
        found = [n for n in names if re.fullmatch(pattern, n)]
        if found:
            columns[target] = found[0]
    return Layout(NAME, columns, None, "")
