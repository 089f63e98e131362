"""ZEISS (GOM) ARAMIS and ZEISS Correlate (GOM Correlate) point or surface data exported as CSV.

Layout implemented (the CSV table export of ARAMIS / Correlate as we know it; map a variant with
``[data] columns``): ``;``-separated (decimal comma in a German or French locale), Latin-1 when written by
Windows, an optional point id (``ID``, ``Id``, ``Point ID``, ``Punkt-ID``), then ``x [mm]``, ``y [mm]``, ``z [mm]``,
``dx [mm]``, ``dy [mm]``, ``dz [mm]`` (``dX`` ... also), and the surface strains ``epsX [%]``, ``epsY [%]``,
``epsXY [%]`` (technical, i.e. engineering, strain) or ``phiX``, ``phiY``, ``phiXY`` (true, i.e. logarithmic, strain,
GOM's phi). A file with both eps and phi columns is refused (say which with ``columns``). Points without a
value (empty cells) are dropped.

ZEISS (GOM) Correlate's CSV export of a stage with its project preamble: key/value lines ``Project;...``,
``Element;...``, ``Stage;...``, ``Date;...``, ``Unit;mm;%`` (the length and the strain unit of every column), then
the user's columns ``x;y;z;displacement_x;displacement_y;displacement_z;epsilon_x;epsilon_y;epsilon_xy``, German
locale (``;``, decimal comma, CRLF). Public analysis scripts read it with ``skiprows=5`` and subtract the
displacement from ``x``, ``y``, ``z``, the points' positions at that stage: the reader does the same (reported).
``epsilon`` is GOM's technical (engineering) strain.
"""

from __future__ import annotations

from dataclasses import replace

from ...errors import InputError
from .layout import Layout

NAME = "gom"
TITLE = "ZEISS / GOM ARAMIS or Correlate CSV"
KEY_COLUMNS = "x, y, (z,) dx, dy, (dz,) epsX / epsY / epsXY or phiX / phiY / phiXY, with [mm] / [%] units"
IDS = ("ID", "Id", "id", "Point ID", "Punkt-ID", "Point id")
_STRAINS = {"eps": ("engineering", "technical strain eps"), "phi": ("log", "true strain phi")}


#: Correlate's long names (target -> column)
LONG_NAMES = {"x": "x", "y": "y", "z": "z", "ux": "displacement_x", "uy": "displacement_y", "uz": "displacement_z",
              "exx": "epsilon_x", "eyy": "epsilon_y", "exy": "epsilon_xy"}
DEFORMED = "ZEISS Correlate's x, y, z are the points' positions at the exported stage"


def recognise(names: tuple[str, ...]) -> bool:
    return "x" in names and (any(n in names for n in ("epsX", "phiX", "dx", "dX", "displacement_x")))


def from_text(layout: Layout, text) -> Layout:
    """The preamble's ``Unit;<length>;<strain>`` line gives the unit of every column that states none."""
    unit = text.meta("Unit")
    if not unit:
        return layout
    length, strain = (unit + (None,))[:2]
    units = {t: length if t in "xyz" or t.startswith("u") else strain for t in layout.columns if t != "point"}
    return replace(layout, units={t: u for t, u in units.items() if u is not None}, variant=layout.variant +
                   f"{', ' if layout.variant else ''}units from the preamble line 'Unit;{';'.join(unit)}'")


def layout(names: tuple[str, ...]) -> Layout:
    if "displacement_x" in names:
        columns = {t: c for t, c in LONG_NAMES.items() if c in names}
        return Layout(NAME, columns, "engineering", "GOM's technical strain epsilon", deformed=DEFORMED,
                      variant="ZEISS Correlate with project preamble")
    columns = {"point": next(n for n in names if n in IDS)} if any(n in IDS for n in names) else {}
    columns.update({c: c for c in "xyz" if c in names})
    for c in "xyz":
        found = [n for n in (f"d{c}", f"d{c.upper()}") if n in names]
        if found:
            columns["u" + c] = found[0]
    kinds = [k for k in _STRAINS if any(f"{k}{a}" in names for a in ("X", "Y", "XY"))]
    if len(kinds) > 1:
        raise InputError(f"{NAME}: a mix of strain measures: {', '.join(n for n in names if n[:3] in _STRAINS)} "
                         "(eps: engineering, phi: logarithmic); read one of them with [data] columns")
    for kind in kinds:
        for axis in ("X", "Y", "XY"):
            if f"{kind}{axis}" in names:
                columns["e" + (axis * 2 if len(axis) == 1 else axis).lower()] = f"{kind}{axis}"
    measure, why = _STRAINS[kinds[0]] if kinds else (None, "")
    return Layout(NAME, columns, measure, f"GOM's {why}")
