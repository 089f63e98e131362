"""LaVision DaVis (StrainMaster) vector and strain fields exported as CSV.

Layouts implemented (map a variant with ``[data] columns``), ``;``-separated with Latin-1 text:

- the export of a vector field: ``x [mm];y [mm];z [mm];Vx [mm];Vy [mm];Vz [mm]`` (the displacement vector), an
  optional ``isValid`` flag (0 where the vector was disabled or rejected), optional strains ``Exx``, ``Eyy``,
  ``Exy`` (with ``[-]`` or ``[%]``) whose definition the export does not name: strains then need
  ``[data] strain``;
- StrainMaster's strain export, as public readers of DaVis 10 files show it (e.g. the pycoatl project's DaVis
  importer): ``x[mm];y[mm];z[mm];x-displacement[mm];y-displacement[mm];z-displacement[mm];Transverse strain Exx -
  GL[S];Axial strain Eyy - GL[S];Shear strain Exy - GL[S]``; "GL" names the Green-Lagrange strain, "[S]" a pure
  number.

Rows with ``isValid = 0`` are dropped. DaVis has no point id: points are labelled by their row number, the same in
the export of every stage.
"""

from __future__ import annotations

import re

from .layout import Layout

NAME = "davis"
TITLE = "LaVision DaVis CSV"
KEY_COLUMNS = "x, y, (z,) Vx, Vy, (Vz,) isValid, Exx, Eyy, Exy; or x-displacement, ..., Transverse strain Exx - GL"
_MAP = {"x": "x", "y": "y", "z": "z", "ux": "Vx", "uy": "Vy", "uz": "Vz", "exx": "Exx", "eyy": "Eyy", "exy": "Exy"}
#: StrainMaster's names: displacement per axis, strains "<word> strain E<ij> - <measure>"
_DISPLACEMENT = {"ux": "x-displacement", "uy": "y-displacement", "uz": "z-displacement"}
_NAMED_STRAIN = re.compile(r"\w+ strain (?P<component>E(xx|yy|zz|xy|yz|xz)) - (?P<measure>\w+)")
_MEASURES = {"GL": "green-lagrange", "Eng": "engineering", "Log": "log"}


def recognise(names: tuple[str, ...]) -> bool:
    return {"x", "y"} <= set(names) and ({"Vx", "Vy"} <= set(names) or {"x-displacement", "y-displacement"}
                                         <= set(names))


def layout(names: tuple[str, ...]) -> Layout:
    columns = {t: c for t, c in _MAP.items() if c in names}
    columns.update({t: c for t, c in _DISPLACEMENT.items() if c in names})
    measures = set()
    for name in names:
        match = _NAMED_STRAIN.fullmatch(name)
        if match and match["measure"] in _MEASURES:
            columns["e" + match["component"][1:]] = name
            measures.add(_MEASURES[match["measure"]])
    measure = measures.pop() if len(measures) == 1 else None      # a mix: [data] strain must choose, or refuse
    invalid = (("isValid", lambda v: v == 0.0, "with isValid = 0"),) if "isValid" in names else ()
    return Layout(NAME, columns, measure, "DaVis's strain names (GL: Green-Lagrange)" if measure else "", invalid)
