"""Correlated Solutions VIC-3D (and VIC-2D) data exported as CSV.

Layout implemented (VIC's "export data to CSV": a quoted, comma-separated header of its variable names, one row
per subset; as read by public readers such as PeriPyDIC's ``DICreader2D``, which drops rows with sigma = -1):
``x, y`` (image pixels, not read), ``X, Y, Z`` (metric coordinates), ``U, V, W`` (metric displacements), ``sigma``
(the correlation's confidence interval, -1 where no correlation was found), ``exx, eyy, exy`` (strain tensor
components, VIC's default Lagrange strain, as fractions), ``e1, e2, gamma`` (not read). VIC writes no units: the
metric values are in the calibration's unit, taken as mm (reported). Rows with ``sigma = -1`` are dropped.
"""

from __future__ import annotations

from .layout import Layout

NAME = "vic3d"
TITLE = "VIC-3D / VIC-2D CSV"
KEY_COLUMNS = "X, Y, (Z,) U, V, (W,) sigma, exx, eyy, exy"
#: columns in image pixels: sigma is the correlation's 1-sigma confidence interval in pixels, with no conversion
#: to a displacement in mm in the export (a [data] columns mapping of it as sigma_<q> is refused)
PIXEL_COLUMNS = {"x": "px", "y": "px", "sigma": "px"}
_MAP = {"x": "X", "y": "Y", "z": "Z", "ux": "U", "uy": "V", "uz": "W", "exx": "exx", "eyy": "eyy", "exy": "exy"}


def recognise(names: tuple[str, ...]) -> bool:
    return {"X", "Y", "U", "V", "sigma"} <= set(names)


def layout(names: tuple[str, ...]) -> Layout:
    columns = {t: c for t, c in _MAP.items() if c in names}
    units = {t: "mm" for t in columns if t[0] in "xyzu"}
    return Layout(NAME, columns, "green-lagrange", "VIC's default Lagrange strain; set [data] strain if the "
                  "project used another", (("sigma", lambda v: v == -1.0, "with sigma = -1 (no correlation)"),),
                  units, PIXEL_COLUMNS)
