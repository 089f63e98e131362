"""ISO metric coarse threads: dimension tables and the axisymmetric bolt and nut thread profiles (no gmsh).

Axial section, x = r (radius), y = axis [mm]. Sources as reproduced in public tables: ISO 68-1 (basic profile),
ISO 261 (coarse pitch), ISO 965-1 (6g fundamental deviation es, 6H: EI = 0), ISO 4014 (hexagon head bolt:
head height k, width across flats s), ISO 4032 (hexagon nut: height m, s, bearing diameter dw, countersink da),
ISO 273 (medium clearance hole). See docs/design.md (bolt thread geometry) for the formulas.

Profile conventions (docs/design.md): a bolt tooth centred at y = z has its load flank below the centre (facing -y,
towards the nut bearing face and the head) and its free flank above; flanks are 30 deg from the radial
direction, ``y = z -/+ (r_apex - r) / sqrt(3)`` with the fundamental triangle's apex at r_apex = d/2 + H/8.
The bolt root is an arc of radius H/6 tangent to both flanks at r = d1/2. A nut tooth centred at y = z points
inwards; its crest is flat at D1/2 and its root flat at d/2 + H/16 (a radial root clearance; ISO leaves the
internal root free beyond D). The nut load flank is the flank above its tooth centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

SQRT3 = math.sqrt(3.0)

#: ISO 261 coarse pitch P [mm]
COARSE_PITCH = {"M6": 1.0, "M8": 1.25, "M10": 1.5, "M12": 1.75, "M14": 2.0, "M16": 2.0, "M18": 2.5,
                "M20": 2.5, "M22": 2.5, "M24": 3.0, "M27": 3.0, "M30": 3.5, "M33": 3.5, "M36": 4.0}
#: ISO 965-1 fundamental deviation of tolerance position g, |es| [um], by pitch (rounded table values)
ES_G = {1.0: 26, 1.25: 28, 1.5: 32, 1.75: 34, 2.0: 38, 2.5: 42, 3.0: 48, 3.5: 53, 4.0: 60}
#: ISO 4014 head height k (nominal) and width across flats s [mm]
HEAD = {"M6": (4.0, 10.0), "M8": (5.3, 13.0), "M10": (6.4, 16.0), "M12": (7.5, 18.0), "M14": (8.8, 21.0),
        "M16": (10.0, 24.0), "M18": (11.5, 27.0), "M20": (12.5, 30.0), "M22": (14.0, 34.0), "M24": (15.0, 36.0),
        "M27": (17.0, 41.0), "M30": (18.7, 46.0), "M33": (21.0, 50.0), "M36": (22.5, 55.0)}
#: ISO 4032 nut height m (max), s, bearing diameter dw (min), countersink da (min, max) [mm]
NUT = {"M6": (5.2, 10.0, 8.9, 6.0, 6.75), "M8": (6.8, 13.0, 11.6, 8.0, 8.75),
       "M10": (8.4, 16.0, 14.6, 10.0, 10.8), "M12": (10.8, 18.0, 16.6, 12.0, 13.0),
       "M14": (12.8, 21.0, 19.6, 14.0, 15.1), "M16": (14.8, 24.0, 22.5, 16.0, 17.3),
       "M18": (15.8, 27.0, 24.9, 18.0, 19.5), "M20": (18.0, 30.0, 27.7, 20.0, 21.6),
       "M22": (19.4, 34.0, 31.4, 22.0, 23.7), "M24": (21.5, 36.0, 33.3, 24.0, 25.9),
       "M27": (23.8, 41.0, 38.0, 27.0, 29.1), "M30": (25.6, 46.0, 42.8, 30.0, 32.4),
       "M33": (28.7, 50.0, 46.6, 33.0, 35.6), "M36": (31.0, 55.0, 51.1, 36.0, 38.9)}
#: ISO 273 medium-series clearance hole diameter [mm]
CLEARANCE_HOLE = {"M6": 6.6, "M8": 9.0, "M10": 11.0, "M12": 13.5, "M14": 15.5, "M16": 17.5, "M18": 20.0,
                  "M20": 22.0, "M22": 24.0, "M24": 26.0, "M27": 30.0, "M30": 33.0, "M33": 36.0, "M36": 39.0}
#: countersink diameter as a fraction of d (M20: 21, docs/models.md); inside the ISO 4032 da range for every size
DA_RATIO = 1.05
#: nut root radius beyond d/2, in units of H
NUT_ROOT_CLEARANCE = 1.0 / 16.0


@dataclass(frozen=True)
class ThreadSize:
    """Dimensions [mm] of one coarse M size: thread (ISO 68-1, 965), bolt head (ISO 4014), nut (ISO 4032)."""

    name: str
    d: float
    P: float
    es: float
    head_k: float
    head_s: float
    nut_m: float
    nut_s: float
    nut_dw: float
    da_range: tuple[float, float]
    hole: float

    @property
    def H(self) -> float:
        """Fundamental triangle height 0.866025 P."""
        return SQRT3 / 2 * self.P

    @property
    def d2(self) -> float:
        """Pitch diameter d - 0.649519 P."""
        return self.d - 0.75 * self.H

    @property
    def d1(self) -> float:
        """Basic minor diameter d - 1.082532 P (nut crest, bolt flank-root tangent)."""
        return self.d - 1.25 * self.H

    @property
    def d3(self) -> float:
        """Bolt minor diameter d - 1.226869 P (bottom of the rounded root)."""
        return self.d1 - self.root_radius

    @property
    def root_radius(self) -> float:
        """Bolt root radius H/6."""
        return self.H / 6

    @property
    def stress_area(self) -> float:
        """As = pi/4 ((d2 + d3)/2)^2 [mm^2]."""
        return math.pi / 4 * ((self.d2 + self.d3) / 2) ** 2

    @property
    def da(self) -> float:
        """Nut countersink diameter used by the model, :data:`DA_RATIO` d."""
        return DA_RATIO * self.d

    @property
    def hex_radius(self) -> float:
        """Radius of the ring with the area of a hexagon across flats s, s sqrt(sqrt(3) / (2 pi))."""
        return self.nut_s * math.sqrt(SQRT3 / (2 * math.pi))

    @property
    def head_radius(self) -> float:
        """Area-equivalent ring radius of the bolt head hexagon."""
        return self.head_s * math.sqrt(SQRT3 / (2 * math.pi))

    def thread_length(self, length: float) -> float:
        """ISO 4014 thread length b of a bolt of nominal length l: 2d + 6 / 12 / 25 for l <= 125 / 200 / more."""
        return 2 * self.d + (6.0 if length <= 125 else 12.0 if length <= 200 else 25.0)


def thread_size(name: str) -> ThreadSize:
    """Tabulated dimensions of a coarse thread size, e.g. "M20"; InputError naming `size` if not tabulated.

    >>> thread_size("M20").d2
    18.376...
    """
    if not isinstance(name, str) or name.upper() not in COARSE_PITCH:
        raise InputError(f"`size` = {name!r} has no tabulated dimensions; expected one of "
                         f"{', '.join(COARSE_PITCH)} (ISO 261 coarse threads)")
    key = name.upper()
    P = COARSE_PITCH[key]
    m, s, dw, da_min, da_max = NUT[key]
    k, s_head = HEAD[key]
    return ThreadSize(name=key, d=float(key[1:]), P=P, es=-ES_G[P] / 1000.0, head_k=k, head_s=s_head,
                      nut_m=m, nut_s=s, nut_dw=dw, da_range=(da_min, da_max), hole=CLEARANCE_HOLE[key])


# ----------------------------------------------------------------------------------------------- profiles

@dataclass(frozen=True)
class Segment:
    """A piece of a profile from ``a`` to ``b`` (r, y) [mm]; an arc has a ``centre``; ``role`` names the piece.

    Roles: "load", "free" (flanks), "crest", "root"; ``tooth`` is the index of the tooth the flank belongs to.
    """

    a: tuple[float, float]
    b: tuple[float, float]
    role: str
    tooth: int = 0
    centre: tuple[float, float] | None = None


def bolt_tooth_points(size: ThreadSize, z: float, shift: float) -> dict[str, tuple[float, float]]:
    """Corner points of the bolt tooth centred at y = z, profile moved radially inwards by ``shift`` [mm].

    "root_low"/"root_high": flank-root tangent points (r = d1/2 - shift, y = z -/+ 3P/8); "crest_low"/
    "crest_high": crest corners (r = d/2 - shift, y = z -/+ P/16).
    """
    P, r_t, r_c = size.P, size.d1 / 2 - shift, size.d / 2 - shift
    return {"root_low": (r_t, z - 3 * P / 8), "crest_low": (r_c, z - P / 16),
            "crest_high": (r_c, z + P / 16), "root_high": (r_t, z + 3 * P / 8)}


def bolt_load_flank_y(size: ThreadSize, z: float, shift: float, r) -> np.ndarray:
    """y [mm] of the load flank (straight part) of the bolt tooth centred at z at radius r [mm]."""
    apex = size.d / 2 + size.H / 8 - shift
    return z - (apex - np.asarray(r, dtype=float)) / SQRT3


def _bolt_period(size: ThreadSize, k: int, z: float, shift: float) -> list[Segment]:
    """Load flank, crest, free flank of tooth k and the root arc above it."""
    p = bolt_tooth_points(size, z, shift)
    R = size.root_radius
    next_low = (p["root_high"][0], z + 5 * size.P / 8)
    centre = (p["root_high"][0] + R / 2, z + size.P / 2)
    return [Segment(p["root_low"], p["crest_low"], "load", k), Segment(p["crest_low"], p["crest_high"], "crest", k),
            Segment(p["crest_high"], p["root_high"], "free", k),
            Segment(p["root_high"], next_low, "root", k, centre)]


def _clip(segment: Segment, y_low: float, y_high: float) -> Segment | None:
    """The part of a segment (y monotonic along it) with y_low <= y <= y_high, None if empty."""
    (ra, ya), (rb, yb) = segment.a, segment.b
    if max(ya, yb) <= y_low or min(ya, yb) >= y_high:
        return None

    def at(y):
        if segment.centre is None:
            return (ra + (rb - ra) * (y - ya) / (yb - ya), y)
        rc, yc = segment.centre
        R = math.hypot(ra - rc, ya - yc)
        return (rc - math.sqrt(max(R * R - (y - yc) ** 2, 0.0)), y)

    a = segment.a if y_low <= ya <= y_high else at(y_low if ya < y_low else y_high)
    b = segment.b if y_low <= yb <= y_high else at(y_high if yb > y_high else y_low)
    return Segment(a, b, segment.role, segment.tooth, segment.centre)


def bolt_profile(size: ThreadSize, y_low: float, y_high: float, phase: float, shift: float) -> list[Segment]:
    """Bolt thread outline from y_low to y_high [mm], bottom up; tooth k is centred at y = phase + k P.

    A piece shorter than P/50 left at either end by the cut is dropped.

    ``shift`` [mm] moves the whole profile radially inwards (|es|/2 for a 6g bolt on a 6H nut).
    """
    P = size.P
    k_first, k_last = math.floor((y_low - phase) / P) - 1, math.ceil((y_high - phase) / P) + 1
    out = []
    for k in range(k_first, k_last + 1):
        for segment in _bolt_period(size, k, phase + k * P, shift):
            clipped = _clip(segment, y_low, y_high)
            # an end cut just past a corner leaves a sliver: drop it (the outline closes past it)
            if clipped is not None and math.dist(clipped.a, clipped.b) > P / 50:
                out.append(clipped)
    return out


def nut_load_flank_y(size: ThreadSize, z: float, r) -> np.ndarray:
    """y [mm] of the load flank of the nut tooth centred at z at radius r [mm]."""
    apex = size.d / 2 - 7 * size.H / 8
    return z + (np.asarray(r, dtype=float) - apex) / SQRT3


def nut_thread_polyline(size: ThreadSize, y_low: float, y_high: float, phase: float) -> np.ndarray:
    """(n, 2) (r, y) [mm] of the unclipped nut thread, teeth centred at phase + k P, covering [y_low, y_high]."""
    P, H = size.P, size.H
    r_crest, r_root = size.d1 / 2, size.d / 2 + NUT_ROOT_CLEARANCE * H
    half_root = P / 2 - (r_root - (size.d / 2 - 7 * H / 8)) / SQRT3
    out = []
    for k in range(math.floor((y_low - phase) / P) - 1, math.ceil((y_high - phase) / P) + 2):
        z = phase + k * P
        out += [(r_crest, z - P / 8), (r_crest, z + P / 8), (r_root, z + P / 2 - half_root),
                (r_root, z + P / 2 + half_root)]
    return np.array(out)


def upper_envelope(polylines: list[np.ndarray], y_low: float, y_high: float) -> np.ndarray:
    """(n, 2) (r, y) of max_k r_k(y) on [y_low, y_high]; each polyline (m, 2) has increasing y.

    A polyline counts as -inf outside its y range. Breakpoints are the polylines' own and their crossings;
    points collinear with both neighbours are dropped.
    """
    ys = [y_low, y_high] + [y for p in polylines for y in p[:, 1] if y_low < y < y_high]
    ys = np.unique(ys)

    def values(y):
        return np.array([np.interp(y, p[:, 1], p[:, 0], left=-np.inf, right=-np.inf) for p in polylines])

    extra = []
    for y0, y1 in zip(ys[:-1], ys[1:]):
        v0, v1 = values(y0 + 1e-12 * (y1 - y0)), values(y1 - 1e-12 * (y1 - y0))
        finite = np.isfinite(v0) & np.isfinite(v1)
        for i in np.flatnonzero(finite):
            for j in np.flatnonzero(finite):
                d0, d1 = v0[i] - v0[j], v1[i] - v1[j]
                if i < j and d0 * d1 < 0:
                    extra.append(y0 + (y1 - y0) * d0 / (d0 - d1))
    ys = np.unique(np.concatenate([ys, extra]))
    r = np.array([values(y).max() for y in ys])
    return _drop_collinear(np.column_stack([r, ys]))


def _drop_collinear(points: np.ndarray, tol: float = 1e-10) -> np.ndarray:
    keep = [0]
    for i in range(1, len(points) - 1):
        a, b, c = points[keep[-1]], points[i], points[i + 1]
        cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if abs(cross) > tol * max(np.linalg.norm(c - a), 1e-300):
            keep.append(i)
    keep.append(len(points) - 1)
    return points[keep]


def nut_bore(size: ThreadSize, y_bearing: float, y_top: float, phase: float, engaged_length: float) -> np.ndarray:
    """(n, 2) (r, y) [mm] of the nut's inner outline from the bearing face to the top face, bottom up.

    The thread (teeth at phase + k P) is cut by a 120 deg countersink to diameter da at both faces; above
    ``y_bearing + engaged_length`` the bore is relieved to the nut root radius (no teeth).
    """
    cone = (size.da / 2, 0.0)

    def countersink(y_face, sign):
        ys = np.array([y_bearing, y_top])
        return np.column_stack([cone[0] - SQRT3 * sign * (ys - y_face), ys])

    y_end = y_bearing + engaged_length
    thread = nut_thread_polyline(size, y_bearing, y_top, phase)
    cones = [countersink(y_bearing, 1.0), countersink(y_top, -1.0)]
    lower = upper_envelope([thread] + cones, y_bearing, y_end)
    if y_top - y_end <= 1e-9:
        return lower
    r_root = size.d / 2 + NUT_ROOT_CLEARANCE * size.H
    relief = np.array([[r_root, y_end], [r_root, y_top]])
    upper = upper_envelope([relief] + cones, y_end, y_top)
    return np.vstack([lower, upper])


def first_tooth_window(size: ThreadSize, y_bearing: float, shift: float) -> tuple[float, float]:
    """(z_min, z_max) [mm]: where the centre of the first complete nut tooth above the bearing-face countersink
    must lie so that no load flank is cut part-way by the countersink.

    The 120 deg countersink is parallel to the nut free flanks: a tooth centred at z >= z_min is complete; the
    load flank of the tooth below it stays off the bolt flank (r <= d/2 - shift) when z <= z_max.
    z_max - z_min = P/8 + 2 shift / sqrt(3).
    """
    apex = size.d / 2 - 7 * size.H / 8
    z_min = y_bearing + (size.da / 2 - apex) / SQRT3
    return z_min, y_bearing + size.P + (size.da / 2 + apex - 2 * (size.d / 2 - shift)) / SQRT3


# ----------------------------------------------------------------------------------------- engaged flanks

#: a nut load flank cut (by a countersink) to less than this fraction of the full contact width is not engaged
MIN_ENGAGED_FRACTION = 0.05


@dataclass(frozen=True)
class Flank:
    """An engaged load flank pair: the bolt load flank of one tooth on the nut load flank below it.

    Attributes
    ----------
    index : 1-based count from the nut bearing face
    z_bolt, z_nut : [mm] centres of the bolt tooth and of the nut tooth it bears on
    r_contact : (r_low, r_high) [mm] radial range where both flanks exist (the contact segment)
    straight : ((r, y), (r, y)) [mm] the bolt flank's straight part, root tangent to crest corner
    size : the thread size; shift : [mm] radial shift of the bolt profile
    """

    index: int
    z_bolt: float
    z_nut: float
    r_contact: tuple[float, float]
    straight: tuple[tuple[float, float], tuple[float, float]]
    size: ThreadSize
    shift: float

    def point(self, r) -> np.ndarray:
        """(..., 2) (r, y) [mm] on the bolt load flank line at radius r [mm]."""
        r = np.asarray(r, dtype=float)
        return np.stack([r, bolt_load_flank_y(self.size, self.z_bolt, self.shift, r)], axis=-1)

    def along(self, fraction) -> np.ndarray:
        """(..., 2) (r, y) [mm] at ``fraction`` (0 root tangent .. 1 crest corner) of the straight part."""
        (r0, _), (r1, _) = self.straight
        return self.point(r0 + (r1 - r0) * np.asarray(fraction, dtype=float))


def engaged_flanks(size: ThreadSize, bore: np.ndarray, nut_phase: float, bolt_phase: float, shift: float,
                   y_thread: float, y_end: float) -> list[Flank]:
    """Load flanks where the nut bore (see :func:`nut_bore`) lies on a nut load flank facing a bolt flank.

    The bolt teeth are centred at bolt_phase + k P, threaded on [y_thread, y_end]; the nut teeth at
    nut_phase + k P. Flanks are numbered from the bearing face (lowest y) up.
    """
    P, r_high = size.P, size.d / 2 - shift
    apex = size.d / 2 - 7 * size.H / 8
    full = r_high - size.d1 / 2
    flanks = []
    for a, b in zip(bore[:-1], bore[1:]):
        z = (a[1] + b[1]) / 2 - ((a[0] + b[0]) / 2 - apex) / SQRT3
        k = round((z - nut_phase) / P)
        z_nut = nut_phase + k * P
        on_line = [abs(p[1] - nut_load_flank_y(size, z_nut, p[0])) < 1e-9 * max(1.0, size.d) for p in (a, b)]
        if not all(on_line) or abs(b[0] - a[0]) < 1e-12:
            continue
        lo, hi = max(min(a[0], b[0]), size.d1 / 2), min(max(a[0], b[0]), r_high)
        z_bolt = z_nut + P / 2 - shift / SQRT3
        teeth = bolt_tooth_points(size, z_bolt, shift)
        inside = teeth["root_low"][1] >= y_thread - 1e-9 and teeth["crest_low"][1] <= y_end + 1e-9
        if hi - lo > MIN_ENGAGED_FRACTION * full and inside:
            flanks.append(Flank(len(flanks) + 1, z_bolt, z_nut, (float(lo), float(hi)),
                                (teeth["root_low"], teeth["crest_low"]), size, shift))
    for flank in flanks:
        offset = (flank.z_bolt - bolt_phase) / P
        if abs(offset - round(offset)) > 1e-9:
            raise ValueError(f"the nut phase puts flank {flank.index} off the bolt teeth (offset {offset} P)")
    return flanks
