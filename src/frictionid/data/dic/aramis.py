"""ZEISS ARAMIS (GOM ARAMIS Professional) nodemaps as DLR's aramis-data-exporter writes them (``nodemap.txt``).

Layout implemented (the exporter's README, "Nodemap", and its ``utils.py``, ``_write_header`` and ``_write_data``):
``#`` metadata blocks (process, calibration, stage data, rigid body motion compensation, then ``# SIGNALS:`` with
one line per value element, ``# force                         : value_element       : 597.6``), then the column
header as the last ``#`` line, ``;``-separated fixed-width fields::

    #        ID;         x_undef [mm];         y_undef [mm];         z_undef [mm];               u [mm]; ...
             1;       -80.0564567626;        84.9779203814;         0.1509636527;    0.003655774286017; ...

``x_undef``, ``y_undef``, ``z_undef`` are the reference positions (the exporter subtracts the displacement from
ARAMIS's facet coordinates), ``u``, ``v``, ``w`` the displacements [mm], ``epsx``, ``epsy`` [%] and ``epsxy`` [1]
(dimensionless, as the README warns) GOM's technical strain, ``epseqv`` the equivalent strain (not read). A facet
ARAMIS did not compute is written ``nan`` in every field but ID and dropped. The machine force of the stage is the
SIGNALS value element named ``force`` (the exporter writes no unit: taken as N, reported).
"""

from __future__ import annotations

import math

from ...errors import InputError
from .layout import Layout
from .text import ExportText

NAME = "aramis"
TITLE = "ZEISS ARAMIS nodemap (DLR aramis-data-exporter)"
KEY_COLUMNS = "# ID; x_undef [mm]; y_undef [mm]; z_undef [mm]; u [mm]; v [mm]; w [mm]; epsx [%]; epsy [%]; epsxy [1]"
_MAP = {"point": "ID", "x": "x_undef", "y": "y_undef", "z": "z_undef", "ux": "u", "uy": "v", "uz": "w",
        "exx": "epsx", "eyy": "epsy", "exy": "epsxy"}
#: the SIGNALS line that gives the machine force
FORCE_KEY = "force"


def recognise(names: tuple[str, ...]) -> bool:
    return {"x_undef", "y_undef", "u", "v"} <= set(names)


def layout(names: tuple[str, ...]) -> Layout:
    return Layout(NAME, {t: c for t, c in _MAP.items() if c in names}, "engineering", "GOM's technical strain eps",
                  variant="aramis-data-exporter nodemap")


def header_force(text: ExportText) -> tuple[float, str] | None:
    """The stage's machine force [N] from the SIGNALS line ``# force : value_element : <value>``, with the line
    the report prints; None where the metadata has none."""
    values = text.meta(FORCE_KEY)
    if values is None:
        return None
    try:
        force = float(values[-1])
    except (IndexError, ValueError):
        force = math.nan
    if not math.isfinite(force):
        raise InputError(f"{text.source}: metadata line '# {FORCE_KEY} : {' : '.join(values)}': the force must be a "
                         "finite number [N] as its last field")
    return force, (f"force {force!r} N from the metadata line '# {FORCE_KEY} : {' : '.join(values)}' "
                   "(no unit written: taken as N)")
