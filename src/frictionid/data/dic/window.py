"""The strain window (virtual strain gauge) of a DIC export's header in mm, and the one window a fit uses.

A header gives the window in image pixels (DICe: ``Strain window size in pixels``). It becomes a length with the
pixel size the export itself gives: the uniform scale of the similarity (Umeyama) that maps the points' pixel
coordinates (u, v, 0) onto their physical coordinates, fitted by least squares over the valid points and reported
with its residual. Without both kinds of coordinates the scale is unknown and the window is not converted (never
guessed). The window of the fit (docs/data.md, "Strain window"): ``[data] strain_window`` [mm] if given, else the
one window every file with strains gives in its header (a circle of that diameter, as DICe's VSG selects its
subsets within half the window of the point in the image), else none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ..frame_fit import umeyama

#: the window shapes frictionid fits over (:data:`frictionid.fem.points.SHAPES`)
SHAPES = ("square", "circle")
#: two files' windows in the model frame [mm] that differ by more than this (relative) are two windows
SAME_RTOL = 1e-6
#: a pixel-to-physical map whose largest residual exceeds this fraction of the window is not a uniform scale
#: (a perspective or curved surface): the converted window is then reported as approximate
SCALE_RTOL = 0.01


@dataclass(frozen=True)
class HeaderWindow:
    """A header's strain window: ``pixels`` as written, ``scale`` [mm/px] fitted over ``n_points`` points with
    residual RMS / largest [mm], or None with the ``reason`` it is unknown; ``shape`` of the window."""

    source: str
    pixels: float
    shape: str = "circle"
    scale: float | None = None
    n_points: int = 0
    rms: float = float("nan")
    largest: float = float("nan")
    reason: str = ""

    @property
    def size(self) -> float | None:
        """The window in the file's physical frame [mm] (None: scale unknown)."""
        return None if self.scale is None else self.pixels * self.scale

    def line(self) -> str:
        if self.scale is None:
            return (f"strain window {self.pixels:g} px from the header, not converted to mm: {self.reason}; the "
                    "pixel size is unknown, so give [data] strain_window in mm (the window in pixels times the "
                    "pixel size)")
        approximate = self.largest > SCALE_RTOL * self.size
        return (f"strain window {self.pixels:g} px from the header = {self.size:.6g} mm ({self.shape}, diameter) "
                f"at {self.scale:.9g} mm/px, the scale fitted between the pixel and the physical coordinates of "
                f"{self.n_points} points: residual RMS {self.rms:.3g} mm, largest {self.largest:.3g} mm"
                + ("; not a uniform scale (perspective or curved surface): the window in mm is approximate"
                   if approximate else ""))

    def as_dict(self) -> dict:
        return {"file": self.source, "pixels": self.pixels, "shape": self.shape, "mm_per_pixel": self.scale,
                "size_mm": self.size, "scale_points": self.n_points, "scale_residual_rms_mm": _finite(self.rms),
                "scale_residual_max_mm": _finite(self.largest), "reason": self.reason or None}


def _finite(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


def fitted(source: str, pixels: float, pixel_uv: np.ndarray | None, xyz: np.ndarray | None, reason: str = "",
           shape: str = "circle") -> HeaderWindow:
    """The header window ``pixels`` with the pixel size fitted between ``pixel_uv`` (n, 2) [px] and ``xyz``
    (n, 3) [mm] of the same points; either None (with ``reason``) leaves the scale unknown."""
    if pixel_uv is None or xyz is None:
        return HeaderWindow(source, pixels, shape, reason=reason)
    uv = np.column_stack([pixel_uv, np.zeros(len(pixel_uv))])
    keep = np.all(np.isfinite(uv), axis=1) & np.all(np.isfinite(xyz), axis=1)
    uv, xyz = uv[keep], xyz[keep]
    spread = np.linalg.svd(uv - uv.mean(axis=0), compute_uv=False) if len(uv) else np.zeros(3)
    if len(uv) < 3 or spread[1] <= 1e-9 * max(spread[0], 1e-300):
        return HeaderWindow(source, pixels, shape, reason=f"{len(uv)} point(s) with pixel coordinates, not on one "
                                                          "line, are needed to fit the pixel size and there are fewer")
    frame = umeyama(uv, xyz, with_scale=True)
    distance = np.linalg.norm(frame.points(uv) - xyz, axis=1)
    return HeaderWindow(source, pixels, shape, frame.scale, len(uv), float(np.sqrt(np.mean(distance ** 2))),
                        float(distance.max()))


@dataclass(frozen=True)
class FileWindow:
    """One file's part in the choice: its header window (None: its header gives none), the scale of its frame
    to the model's (a window in the file's mm is that times larger in the model), whether it gives strains."""

    source: str
    header: HeaderWindow | None
    frame_scale: float
    strains: bool

    @property
    def size(self) -> float | None:
        return None if self.header is None or self.header.size is None else self.header.size * self.frame_scale


@dataclass(frozen=True)
class WindowChoice:
    """The fit's strain window: ``size`` [mm] and ``shape`` in the model frame (None: strains at the points), where
    it comes from (``origin``), the report lines, and ``problem``: why no window can be chosen though the files'
    headers give one (an error once strains are fitted)."""

    size: float | None
    shape: str
    origin: str
    lines: tuple[str, ...]
    problem: str | None = None
    files: tuple[dict, ...] = ()

    def for_fit(self, observables) -> "WindowChoice":
        """This choice, checked for a fit of ``observables``: a problem is an error if strains are fitted."""
        if self.problem is not None and any(str(q).startswith("e") for q in observables):
            raise InputError(self.problem)
        return self

    def as_dict(self) -> dict:
        """result.json's ``data.strain_window``."""
        return {"size_mm": self.size, "shape": self.shape if self.size is not None else None,
                "origin": self.origin, "files": list(self.files)}


def choose(size, shape: str | None, files: list[FileWindow]) -> WindowChoice:
    """The fit's window: ``size`` (``[data] strain_window`` [mm]) with ``shape`` (default square) if given, else
    the one window of the headers of the files that give strains; refused (``problem``) when those files give
    different windows, some give none, or a window's pixel size is unknown."""
    headers = [f for f in files if f.header is not None]
    records = tuple({**f.header.as_dict(), "frame_scale": f.frame_scale, "size_model_mm": f.size} for f in headers)
    if shape is not None and shape not in SHAPES:
        raise InputError(f"[data] strain_window_shape = {shape!r} is not one of {', '.join(SHAPES)}")
    if size is not None:
        shape = shape or "square"
        overridden = [f"  (the header of {f.source} gives {f.header.pixels:g} px"
                      + (f" = {f.size:.6g} mm, a circle" if f.size is not None else "") + "; overridden)"
                      for f in headers]
        return WindowChoice(float(size), shape, "[data] strain_window",
                            (f"strain window: {size:g} mm ({shape}), from [data] strain_window (the model's strains "
                             "are fitted over it, as the DIC software filtered the measured ones)", *overridden),
                            files=records)
    if shape is not None:
        raise InputError("[data] strain_window_shape needs [data] strain_window [mm]")
    relevant = [f for f in files if f.strains]
    given = [f for f in relevant if f.header is not None]
    if not given:
        return WindowChoice(None, "square", "none", ("strain window: none ([data] strain_window not set, no strain "
                                                     "window in the exports' headers): the model's strains are taken "
                                                     "at the points",), files=records)
    unknown = [f for f in given if f.size is None]
    if unknown:
        f = unknown[0]
        return _refused(f"{f.source}: the header's strain window ({f.header.pixels:g} px) cannot be converted to mm: "
                        f"{f.header.reason}; give [data] strain_window in mm", records)
    missing = [f for f in relevant if f.header is None]
    if missing:
        return _refused(f"{given[0].source} gives a strain window in its header ({given[0].size:.6g} mm) and "
                        f"{missing[0].source} none, but a fit has one window; give [data] strain_window in mm",
                        records)
    first = given[0]
    for other in given[1:]:
        if abs(other.size - first.size) > SAME_RTOL * first.size:
            return _refused(f"{first.source} and {other.source} give different strain windows in their headers "
                            f"({_described(first)} and {_described(other)}), but a fit has one window; give "
                            "[data] strain_window in mm", records)
    return WindowChoice(first.size, first.header.shape, "export header",
                        (f"strain window: {first.size:.6g} mm ({first.header.shape}, diameter), from the header of "
                         f"{first.source}" + (f" and {len(given) - 1} more file(s)" if len(given) > 1 else "")
                         + ": the model's strains are fitted over it, as the DIC software filtered the measured ones",),
                        files=records)


def _described(f: FileWindow) -> str:
    return f"{f.header.pixels:g} px at {f.header.scale:.6g} mm/px = {f.size:.6g} mm"


def _refused(problem: str, records) -> WindowChoice:
    return WindowChoice(None, "square", "refused", (f"strain window: none; {problem} (needed once strains are "
                                                     "fitted)",), problem, records)
