"""Points of a plane model's data (plane strain: the x-y plane): a stereo DIC export scatters its points out of the
plane by its noise; within ``[data] plane_tolerance`` they are projected onto it (counted, the largest |z|
reported), beyond it refused with both numbers and the remedy (docs/data.md, "Points and models")."""

from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np

from ..errors import InputError
from .table import Measurements

#: default ``[data] plane_tolerance`` [mm]: a few times a stereo DIC's out-of-plane noise on a flat face
PLANE_TOLERANCE = 0.005

log = logging.getLogger(__name__)


def plane_tolerance(value, where: str = "[data]") -> float:
    """``[data] plane_tolerance`` [mm] checked (None: :data:`PLANE_TOLERANCE`)."""
    if value is None:
        return PLANE_TOLERANCE
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise InputError(f"{where}: [data] plane_tolerance must be a length >= 0 [mm] (the out-of-plane scatter "
                         f"projected onto a plane model's plane, default {PLANE_TOLERANCE}), got {value!r}")
    return float(value)


def onto_plane(m: Measurements, tolerance: float, kind: str) -> tuple[Measurements, str | None]:
    """``m`` with z = 0 where every point is within ``tolerance`` [mm] of the plane z = 0, and the report line
    (None where every z is 0 already).

    Raises
    ------
    InputError
        A point farther out: how many are, the largest |z| and its point, the tolerance and the remedy.
    """
    z = np.abs(m.coordinates[:, 2])
    if not np.any(z > 0):
        return m, None
    worst = int(np.argmax(z))
    off = int(np.count_nonzero(z > tolerance))
    if off:
        raise InputError(
            f"{m.source}: a {kind.replace('_', '-')} model needs points on its plane z = 0: {off} of {m.n_rows} "
            f"point rows are farther out than [data] plane_tolerance = {tolerance:g} mm, the largest |z| "
            f"{z[worst]:.3g} mm (point {m.points[worst]!r}); give the export a transform that puts the measured "
            f"face on z = 0 (rotation_deg, translation or fit = \"points\"), or raise plane_tolerance to the "
            "out-of-plane scatter of your DIC if that is what it is")
    line = (f"{int(np.count_nonzero(z > 0))} of {m.n_rows} point rows projected onto the plane z = 0 of the "
            f"{kind.replace('_', '-')} model: largest |z| {z[worst]:.3g} mm (point {m.points[worst]!r}), within "
            f"[data] plane_tolerance = {tolerance:g} mm")
    log.info("%s", line)
    coordinates = m.coordinates.copy()
    coordinates[:, 2] = 0.0
    return replace(m, coordinates=coordinates, comments=m.comments + (line,)), line
