"""The bolt-nut tensile test set-up of one thread size: heights, radii, thread phases, engaged flanks, zones.

The numbers are those of reference test 2 (docs/models.md) (see :mod:`frictionid.builders.bolt`).
"""

from __future__ import annotations

import math
import string
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .arguments import count, positive
from .thread import SQRT3, Flank, ThreadSize, engaged_flanks, first_tooth_window, nut_bore, thread_size

_TOL = 1e-9  # [mm] coordinates closer than this are the same point


@dataclass(frozen=True)
class BoltLayout:
    """The tensile test set-up of one size: heights and radii [mm], thread phases, engaged flanks.

    ``r_bearing`` is the outer radius of the nut's bearing face (the hexagon ring unless a bearing diameter is
    given, then chamfered at 30 deg up to the ring). ``flanks`` are the engaged load flanks numbered from the nut
    bearing face; ``zone_splits`` the radii [mm] splitting each flank's contact segment radially; ``sections``
    the flank indices (1-based) of each axial section, section 1 next to the bearing face.
    """

    size: ThreadSize
    length: float
    y_thread: float
    y_bearing: float
    y_top: float
    plate2: tuple[float, float]
    plate1: tuple[float, float]
    r_hole: float
    r_bearing: float
    r_outer: float
    r_shank: float
    shift: float
    bolt_phase: float
    nut_phase: float
    bore: np.ndarray
    flanks: tuple[Flank, ...]
    zone_splits: tuple[float, ...]
    sections: tuple[tuple[int, ...], ...]

    @property
    def n_radial(self) -> int:
        return len(self.zone_splits) + 1

    def zone_name(self, radial: int, section: int) -> str:
        """Zone letter of radial part ``radial`` (0 outermost) in axial section ``section`` (0 at the bearing)."""
        return string.ascii_uppercase[radial * len(self.sections) + section]

    @property
    def thread_zones(self) -> tuple[str, ...]:
        return tuple(self.zone_name(i, k) for i in range(self.n_radial) for k in range(len(self.sections)))




def bolt_layout(size: str = "M20", length: float | None = None, engaged_length: float | None = None,
                clearance: float | None = None, n_radial: int = 2, n_axial: int = 3,
                bearing_diameter: float | str | None = None, thread_length: float | None = None) -> BoltLayout:
    """The set-up geometry of a size (see the module docstring); options as in :func:`bolt_model`.

    >>> layout = bolt_layout("M20")
    >>> layout.y_bearing, layout.y_top, len(layout.flanks)
    (94.5, 112.5, 7)
    """
    s = thread_size(size)
    length = 6 * s.d if length is None else positive("length", length)
    m = s.nut_m
    engaged = m if engaged_length is None else positive("engaged_length", engaged_length)
    if engaged > m + _TOL:
        raise InputError(f"`engaged_length` = {engaged:g} mm is longer than the nut: expected at most the "
                         f"{s.name} nut height m = {m:g} mm (ISO 4032)")
    if clearance is not None and not (isinstance(clearance, (int, float)) and 0 <= clearance < s.H / 4):
        raise InputError(f"`clearance` must be a number of mm in [0, H/4 = {s.H / 4:.3g}) (the 6g flank clearance "
                         f"|es|, {-s.es:g} for {s.name}), got {clearance!r}")
    shift = -s.es / 2 if clearance is None else float(clearance) / 2
    y_top = length - 3 * s.P
    y_bearing = y_top - m
    b = s.thread_length(length) if thread_length is None else positive("thread_length", thread_length)
    y_thread = length - b
    if y_thread > y_bearing - s.P:
        raise InputError(f"`thread_length` = {b:g} mm is too short for {s.name}: the thread must reach a pitch "
                         f"below the nut, expected at least {length - y_bearing + s.P:g} mm")
    if y_bearing - s.d < s.d + s.P:
        raise InputError(f"`length` = {length:g} mm is too short for {s.name}: the plates ({s.d:g} mm thick) "
                         f"would not fit between head and nut; expected at least {2 * s.d + m + 4 * s.P:g} mm")
    nut_phase = _nut_phase(s, y_bearing, y_top, shift)
    bolt_phase = nut_phase + s.P / 2 - shift / SQRT3
    bore = nut_bore(s, y_bearing, y_top, nut_phase, engaged)
    flanks = tuple(engaged_flanks(s, bore, nut_phase, bolt_phase, shift, y_thread, length))
    if not flanks:
        raise InputError(f"`engaged_length` = {engaged:g} mm leaves no complete load flank engaged; expected at "
                         f"least about {2 * s.P:g} mm (two pitches)")
    n_radial, n_axial = count("n_radial", n_radial, 1, 4), count("n_axial", n_axial, 1, len(flanks))
    if n_radial * n_axial > 26:
        raise InputError(f"`n_radial` x `n_axial` = {n_radial * n_axial} zones: at most 26 (letters A-Z)")
    splits = _zone_splits(s, shift, n_radial)
    sections = tuple(tuple(int(i) + 1 for i in part) for part in np.array_split(np.arange(len(flanks)), n_axial))
    return BoltLayout(s, length, y_thread, y_bearing, y_top, (0.0, s.d), (y_bearing - s.d, y_bearing),
                      s.hole / 2, _bearing_radius(s, bearing_diameter), 2 * s.d, s.d / 2 - shift, shift, bolt_phase, nut_phase, bore, flanks,
                      splits, sections)


def _bearing_radius(s: ThreadSize, diameter) -> float:
    """Outer radius [mm] of the nut bearing face: the ring (None), ISO 4032 dw ("dw") or a diameter."""
    if diameter is None:
        return s.hex_radius
    value = s.nut_dw if diameter == "dw" else diameter
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not s.hole < value <= 2 * s.hex_radius:
        raise InputError(f"`bearing_diameter` must be \"dw\" or a number of mm in ({s.hole:g}, "
                         f"{2 * s.hex_radius:.4g}] (clearance hole to hexagon ring), got {diameter!r}")
    return float(value) / 2


def _nut_phase(s: ThreadSize, y_bearing: float, y_top: float, shift: float) -> float:
    """Nut tooth phase [mm]: bolt teeth centred in the nut (bolt tooth at mid-height), the nut moved up by
    shift / sqrt(3); moved down into :func:`first_tooth_window` when the countersink would cut a load flank
    part-way (M20 keeps the centred phase)."""
    phase = (y_bearing + y_top) / 2 + shift / SQRT3
    z_min, z_max = first_tooth_window(s, y_bearing, shift)
    first = phase + math.ceil((z_min - phase) / s.P - 1e-12) * s.P
    return phase if first <= z_max else phase - (first - (z_min + z_max) / 2)


def _zone_splits(s: ThreadSize, shift: float, n_radial: int) -> tuple[float, ...]:
    """Radii [mm] splitting a full contact segment (d1/2 to d/2 - shift), outermost first: d2/2 for 2 parts,
    else equal radial parts."""
    if n_radial == 2:
        return (s.d2 / 2,)
    return tuple(float(r) for r in np.linspace(s.d1 / 2, s.d / 2 - shift, n_radial + 1)[1:-1][::-1])
