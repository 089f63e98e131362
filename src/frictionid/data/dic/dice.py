"""DICe (Sandia's Digital Image Correlation Engine) solution files, ``DICe_solution_<n>.txt``.

Layout implemented (from DICe's output: a ``***`` preamble, then a comma-separated header of field names, as
read by public post-processing scripts such as aa55865/DIC_scripts' ``data_parser.py``, and DICe's field names):
``SUBSET_ID`` (the point id), ``COORDINATE_X/Y`` and ``DISPLACEMENT_X/Y`` (image coordinates, pixels),
stereo / calibrated runs add ``MODEL_COORDINATES_X/Y/Z`` and ``MODEL_DISPLACEMENT_X/Y/Z`` (in the units of the
calibration, taken as mm), ``VSG_STRAIN_XX/YY/XY`` (virtual strain gauge, Green-Lagrange tensor components),
``SIGMA`` (-1 where the correlation failed), ``MATCH``, ``STATUS_FLAG``, ``GAMMA``, ``BETA``, ... The model columns
are read when present; pixel columns alone are refused (a pixel is not a length). ``NORMAL_STRAIN_X`` etc. are
the subset shape function's parameters, not the strain field, and are not read.

Invalid points, as DICe marks them (its ``Schema::record_failed_step`` sets ``SIGMA``, ``MATCH``, ``GAMMA`` and
``BETA`` to -1 and ``STATUS_FLAG`` to the reason; the reasons are DICe's ``Status_Flag`` enumeration in
``DICe_Types.h``): rows with ``SIGMA = -1``, with ``MATCH = -1``, or with a ``STATUS_FLAG`` other than the
successful ones (0 correlation successful, 1-4 initialised from the previous frame / a connected subset / a
neighbour / successfully, 6 search successful, 18 search using the previous step successful, 26 reference subset
reset) are dropped, each counted under its marker. Code 15 (a value averaged from connected subsets, not
correlated) is dropped as well: it is not a measurement of that point.
"""

from __future__ import annotations

import math
import re

import numpy as np

from . import window
from .layout import Layout
from .text import ExportText
from .window import HeaderWindow

NAME = "dice"
TITLE = "DICe solution file"
KEY_COLUMNS = "SUBSET_ID, COORDINATE_X or MODEL_COORDINATES_X, ..., SIGMA"
_AXES = {"X": "x", "Y": "y", "Z": "z"}
#: columns in image pixels; SIGMA is DICe's predicted standard deviation of the displacement solution (from the
#: image noise and interpolation bias) in pixels, with no conversion to mm in the export
PIXEL_COLUMNS = {"COORDINATE_X": "px", "COORDINATE_Y": "px", "DISPLACEMENT_X": "px", "DISPLACEMENT_Y": "px",
                 "SIGMA": "px"}
#: DICe's Status_Flag values of a point whose values were correlated (see the module docstring)
SUCCESS_FLAGS = frozenset({0, 1, 2, 3, 4, 6, 18, 26})
#: (column, test, reason) of DICe's invalid-point markers, tried in this order
INVALID = (("SIGMA", lambda v: v == -1.0, "with SIGMA = -1 (correlation failed)"),
           ("MATCH", lambda v: v == -1.0, "with MATCH = -1 (correlation failed)"),
           ("STATUS_FLAG", lambda v: not math.isnan(v) and v not in SUCCESS_FLAGS,
            "with a STATUS_FLAG of failure (not 0-4, 6, 18 or 26: DICe's Status_Flag)"))


#: preamble lines DICe writes about the correlation's geometry (Schema's output header), all in image pixels
_HEADER = {"subset": re.compile(r"Subset size:\s*(\d+)"),
           "step": re.compile(r"Step size:\s*x\s*(-?\d+)\s*y\s*(-?\d+)"),
           "window": re.compile(r"Strain window size in pixels:\s*(\d+)")}


def _header(text: ExportText) -> dict:
    return {key: pattern.search(line) for line in text.preamble for key, pattern in _HEADER.items()
            if pattern.search(line)}


def header_notes(text: ExportText) -> list[str]:
    """What DICe's preamble says about the subset, the step and the VSG strain window (image pixels), for the
    report (the window's conversion to mm is :func:`header_window`'s)."""
    found = _header(text)
    if not found:
        return []
    parts = []
    if "subset" in found:
        parts.append(f"subset {found['subset'][1]} px")
    if "step" in found:
        parts.append(f"step {found['step'][1]} x {found['step'][2]} px")
    if "window" in found:
        parts.append(f"VSG strain window {found['window'][1]} px (a circle in the image)")
    return [f"DICe header: {', '.join(parts)}"]


#: DICe's pixel and physical coordinates of a point: the pixel size is the scale between them
PIXEL_XY, MODEL_XYZ = ("COORDINATE_X", "COORDINATE_Y"), ("MODEL_COORDINATES_X", "MODEL_COORDINATES_Y",
                                                         "MODEL_COORDINATES_Z")


def header_window(text: ExportText, layout: Layout, lines: tuple[int, ...], xyz) -> HeaderWindow | None:
    """The VSG strain window of DICe's preamble (``Strain window size in pixels``), with the pixel size fitted
    between the valid points' ``COORDINATE_X/Y`` [px] and their coordinates ``xyz`` [mm] read from
    ``MODEL_COORDINATES_X/Y/Z`` (``lines``: the file line of each); None where the preamble gives no window.

    DICe's VSG post-processor takes, for each subset, the subsets whose image coordinates lie within half the
    window of its own (a circle of that diameter in the image) and fits a plane to their displacements over their
    model coordinates: the window is a circle of diameter window x pixel size on the specimen."""
    found = _header(text).get("window")
    if found is None:
        return None
    pixels = float(found[1])
    if any(name not in text.names for name in PIXEL_XY):
        return window.fitted(text.source, pixels, None, None, "the file has no pixel coordinates "
                                                              "(COORDINATE_X, COORDINATE_Y)")
    if layout.columns.get("x") != MODEL_XYZ[0] or layout.columns.get("y") != MODEL_XYZ[1]:
        return window.fitted(text.source, pixels, None, None, "the points' coordinates are not DICe's physical "
                             "MODEL_COORDINATES_X/Y (a calibrated run's), so the file gives no scale")
    columns = [text.index(name) for name in PIXEL_XY]
    rows = dict(text.rows)
    uv = np.array([[_number(rows[line], i) for i in columns] for line in lines]).reshape(-1, 2)
    return window.fitted(text.source, pixels, uv, np.asarray(xyz, dtype=float))


def _number(fields: tuple[str, ...], i: int) -> float:
    try:
        return float(fields[i])
    except (IndexError, ValueError):
        return math.nan


def recognise(names: tuple[str, ...]) -> bool:
    return "SUBSET_ID" in names and ("COORDINATE_X" in names or "MODEL_COORDINATES_X" in names)


def layout(names: tuple[str, ...]) -> Layout:
    model = "MODEL_COORDINATES_X" in names
    coordinates, displacements = ("MODEL_COORDINATES_", "MODEL_DISPLACEMENT_") if model else \
        ("COORDINATE_", "DISPLACEMENT_")
    columns = {"point": "SUBSET_ID"}
    for axis, c in _AXES.items():
        for prefix, target in ((coordinates, c), (displacements, "u" + c)):
            if prefix + axis in names:
                columns[target] = prefix + axis
    for component in ("XX", "YY", "XY"):
        if f"VSG_STRAIN_{component}" in names:
            columns["e" + component.lower()] = f"VSG_STRAIN_{component}"
    unit = "mm" if model else "px"
    units = {t: unit for t in columns if t in ("x", "y", "z", "ux", "uy", "uz")}
    invalid = tuple(marker for marker in INVALID if marker[0] in names)
    return Layout(NAME, columns, "green-lagrange", "DICe's VSG_STRAIN_* are Green-Lagrange", invalid, units,
                  PIXEL_COLUMNS)
