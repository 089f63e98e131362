"""Frames: the rigid map (rotation, translation, optionally a uniform scale) from a DIC export's frame to the model's
frame, read from a ``transform`` table, and its application to coordinates, displacement vectors and strain tensors
(docs/data.md, "Frames")."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .table import DISPLACEMENTS, STRAINS, Measurements

#: largest |R^T R - I| and |det R - 1| of a matrix taken as a rotation (a matrix typed to 6 digits passes)
ROTATION_TOL = 1e-6
#: keys of a ``transform`` table: given frames, fitted frames
GIVEN_KEYS = ("rotation_deg", "rotation", "translation", "scale")
FIT_KEYS = ("fit", "points", "regions", "scale", "rotation_deg", "rotation", "translation")
#: the ways to fit a frame
FITS = ("points", "surface")
#: tensor components as index pairs, in the order of STRAINS (exx, eyy, ezz, exy, eyz, exz)
_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))


@dataclass(frozen=True)
class Frame:
    """p_model = scale R p_file + translation.

    Attributes
    ----------
    rotation : (3, 3) proper rotation (R^T R = I, det R = 1)
    translation : (3,) [mm]
    scale : uniform scale (1 for a rigid frame)

    >>> f = Frame.of(rotation_deg=[0, 0, 90], translation=[1, 0, 0])
    >>> f.points([[1.0, 0.0, 0.0]]).tolist()
    [[1.0, 1.0, 0.0]]
    """

    rotation: np.ndarray
    translation: np.ndarray
    scale: float = 1.0

    @classmethod
    def of(cls, rotation_deg=(0.0, 0.0, 0.0), translation=(0.0, 0.0, 0.0), scale: float = 1.0) -> "Frame":
        return cls(rotation_from_degrees(rotation_deg), np.asarray(translation, float), float(scale))

    def points(self, xyz) -> np.ndarray:
        """(n, 3) [mm] points of the file's frame in the model's frame."""
        return self.scale * np.asarray(xyz, float) @ self.rotation.T + self.translation

    def inverse(self) -> "Frame":
        rotation = self.rotation.T
        return Frame(rotation, -rotation @ self.translation / self.scale, 1.0 / self.scale)

    def rotation_deg(self) -> list[float]:
        """[rx, ry, rz] [deg] with R = Rz(rz) Ry(ry) Rx(rx) (rotations about the fixed model axes, x first)."""
        r = self.rotation
        ry = math.asin(max(-1.0, min(1.0, -r[2, 0])))
        if abs(math.cos(ry)) > 1e-9:
            rx, rz = math.atan2(r[2, 1], r[2, 2]), math.atan2(r[1, 0], r[0, 0])
        else:                                   # gimbal lock: rx and rz turn about the same axis; rx = 0
            rx, rz = 0.0, math.atan2(-r[0, 1], r[1, 1])
        return [math.degrees(a) for a in (rx, ry, rz)]

    def as_dict(self) -> dict:
        """The frame as a ``transform`` table would give it (and result.json reports it)."""
        return {"rotation": self.rotation.tolist(), "rotation_deg": self.rotation_deg(),
                "translation": self.translation.tolist(), "scale": self.scale}


def _cos_sin(degrees: float) -> tuple[float, float]:
    """cos and sin of an angle in degrees, exact at multiples of 90 (so that [180, 0, 0] keeps z = 0 exactly)."""
    quarter = degrees / 90.0
    if quarter == round(quarter):
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(round(quarter)) % 4]
    radians = math.radians(degrees)
    return math.cos(radians), math.sin(radians)


def rotation_from_degrees(angles) -> np.ndarray:
    """R = Rz(rz) Ry(ry) Rx(rx) from [rx, ry, rz] [deg]; one number is a rotation about z (a plane's frame).

    >>> rotation_from_degrees(90).round(12).tolist()
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    rx, ry, rz = (0.0, 0.0, float(angles)) if np.isscalar(angles) else (float(a) for a in angles)
    (cx, sx), (cy, sy), (cz, sz) = _cos_sin(rx), _cos_sin(ry), _cos_sin(rz)
    x = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    y = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    z = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return z @ y @ x


def _numbers(value, sizes, key: str) -> list[float]:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = [value]
    if not isinstance(value, list) or len(value) not in sizes or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value):
        raise InputError(f"{key} must be {' or '.join(map(str, sizes))} finite numbers, got {value!r}")
    return [float(v) for v in value]


def checked_rotation(value, key: str) -> np.ndarray:
    """A 3x3 rotation from a ``rotation`` matrix (3x3, or 2x2 for a plane's frame: a rotation about z).

    Raises
    ------
    InputError
        Naming ``key``: a matrix of the wrong shape, rows that are not orthonormal, a mirror (det -1).
    """
    rows = value if isinstance(value, list) else None
    if rows is None or len(rows) not in (2, 3) or any(not isinstance(r, list) or len(r) != len(rows) for r in rows):
        raise InputError(f"{key} must be a 3x3 matrix [[r11, r12, r13], [r21, ...], [...]] (or 2x2 in a plane), "
                         f"got {value!r}")
    matrix = np.array([_numbers(r, (len(rows),), key) for r in rows])
    if len(rows) == 2:
        matrix = np.block([[matrix, np.zeros((2, 1))], [np.zeros((1, 2)), np.ones((1, 1))]])
    off = float(np.abs(matrix.T @ matrix - np.eye(3)).max())
    det = float(np.linalg.det(matrix))
    if off > ROTATION_TOL:
        raise InputError(f"{key} is not a rotation: R^T R differs from the identity by {off:.3g} (its rows must "
                         f"be orthogonal unit vectors, to {ROTATION_TOL:g}); give a rotation or rotation_deg")
    if det < 0:
        raise InputError(f"{key} is not a rotation: det R = {det:.6g}, a mirror; a frame with an axis flipped "
                         "(an image frame with y down) is a rotation by 180 deg about another axis, e.g. "
                         "rotation_deg = [180, 0, 0] turns y and z")
    return matrix


@dataclass(frozen=True)
class FrameSpec:
    """What a ``transform`` table asks for: a given frame (``fit`` None), or one fitted to reference ``points``
    (file label -> model point (3,), or -> (file point, model point)) or to the model's surface (of ``regions``,
    None: every region), starting from ``start``; ``fit_scale``: fit a uniform scale too."""

    key: str
    frame: Frame
    fit: str | None = None
    points: dict | None = None
    regions: tuple[str, ...] | None = None
    fit_scale: bool = False


def frame_spec(table, key: str) -> FrameSpec:
    """The ``transform`` table at ``key`` (e.g. "config.toml: [data] file entry 2 transform") checked.

    ``{ rotation_deg = [rx, ry, rz] | rotation = [[...], ...], translation = [tx, ty, tz], scale = 1.0 }`` or
    ``{ fit = "points", points = { P1 = [x, y, z], M1 = { file = [...], model = [...] } }, scale = false }`` or
    ``{ fit = "surface", regions = ["block"], rotation_deg = [...], translation = [...] }`` (a start).
    """
    if not isinstance(table, dict):
        raise InputError(f"{key} must be a table {{ rotation_deg = [rx, ry, rz], translation = [tx, ty, tz] }} or "
                         f"{{ fit = \"points\", points = {{ ... }} }}, got {table!r}")
    fit = table.get("fit")
    known = FIT_KEYS if fit is not None else GIVEN_KEYS
    unknown = [k for k in table if k not in known]
    if unknown:
        raise InputError(f"{key}: unknown key {', '.join(map(repr, unknown))}; known: {', '.join(known)}"
                         + ("" if fit is not None else ", fit"))
    if "rotation" in table and "rotation_deg" in table:
        raise InputError(f"{key}: give rotation or rotation_deg, not both")
    rotation = checked_rotation(table["rotation"], f"{key}.rotation") if "rotation" in table else \
        rotation_from_degrees(_angles(table.get("rotation_deg", 0.0), f"{key}.rotation_deg"))
    translation = _numbers(table.get("translation", [0.0, 0.0, 0.0]), (2, 3), f"{key}.translation")
    frame = Frame(rotation, np.array((translation + [0.0])[:3]), 1.0)
    if fit is None:
        scale = _numbers(table.get("scale", 1.0), (1,), f"{key}.scale")[0]
        if not scale > 0:
            raise InputError(f"{key}.scale must be > 0, got {scale!r}")
        return FrameSpec(key, Frame(rotation, frame.translation, scale))
    if fit not in FITS:
        raise InputError(f"{key}.fit must be one of {', '.join(map(repr, FITS))}, got {fit!r}")
    fit_scale = table.get("scale", False)
    if not isinstance(fit_scale, bool):
        raise InputError(f"{key}.scale must be true or false with fit (fit a uniform scale too), got {fit_scale!r}")
    if fit == "points":
        return FrameSpec(key, frame, fit, _reference_points(table.get("points"), f"{key}.points"), None, fit_scale)
    regions = table.get("regions")
    if regions is not None and (not isinstance(regions, list) or not all(isinstance(r, str) for r in regions)):
        raise InputError(f"{key}.regions must be a list of region names, got {regions!r}")
    return FrameSpec(key, frame, fit, None, None if regions is None else tuple(regions), fit_scale)


def _angles(value, key: str):
    angles = _numbers(value, (1, 3), key)
    return angles[0] if len(angles) == 1 else angles


def _reference_points(points, key: str) -> dict:
    if not isinstance(points, dict) or not points:
        raise InputError(f"{key} must be a table of reference points, {{ P1 = [x, y, z], ... }} (a point of the "
                         f"file and where it lies in the model [mm]), or {{ M1 = {{ file = [...], model = [...] }} }}"
                         f", got {points!r}")
    out = {}
    for label, value in points.items():
        where = f"{key}.{label}"
        if isinstance(value, dict):
            if set(value) != {"file", "model"}:
                raise InputError(f"{where} must be [x, y, z] or {{ file = [x, y, z], model = [x, y, z] }}, "
                                 f"got {value!r}")
            out[label] = (_point(value["file"], f"{where}.file"), _point(value["model"], f"{where}.model"))
        else:
            out[label] = _point(value, where)
    return out


def _point(value, key: str) -> np.ndarray:
    return np.array((_numbers(value, (2, 3), key) + [0.0])[:3])


def rotated_columns(columns: dict, names, matrix: np.ndarray, n: int) -> dict:
    """out_i = sum_j matrix[i, j] columns[names[j]]; a missing input (absent or nan) makes an output nan only where
    its coefficient is not zero. Outputs that are nan everywhere and were no input are left out."""
    given = np.column_stack([columns.get(q, np.full(n, np.nan)) for q in names])
    used = np.abs(matrix) > 1e-14 * np.abs(matrix).max()
    out = {}
    for i, name in enumerate(names):
        unknown = np.isnan(given[:, used[i]]).any(axis=1)
        value = np.where(unknown, np.nan, np.nan_to_num(given[:, used[i]]) @ matrix[i, used[i]])
        if name in columns or not np.all(np.isnan(value)):
            out[name] = value
    return out


def tensor_matrix(rotation: np.ndarray) -> np.ndarray:
    """(6, 6) map of the tensor components (exx, eyy, ezz, exy, eyz, exz; tensor shear) under E' = R E R^T."""
    m = np.zeros((6, 6))
    for i, (a, b) in enumerate(_PAIRS):
        for j, (c, d) in enumerate(_PAIRS):
            m[i, j] = rotation[a, c] * rotation[b, d] + (rotation[a, d] * rotation[b, c] if c != d else 0.0)
    return m


def in_model_frame(m: Measurements, frame: Frame, note: str) -> Measurements:
    """``m`` (in a file's frame) in the model's frame: coordinates p -> s R p + t, displacements u -> s R u,
    strains E -> R E R^T (a uniform scale leaves strains as they are); standard deviations propagated as
    independent errors. A component the file does not give leaves unknown (empty) what depends on it."""
    linear = {"u": frame.scale * frame.rotation, "e": tensor_matrix(frame.rotation)}
    values, sigma = {}, {}
    for kind, names in (("u", DISPLACEMENTS), ("e", STRAINS)):
        if not set(names) & set(m.values):
            continue
        values.update(rotated_columns(m.values, names, linear[kind], m.n_rows))
        given = {q: s ** 2 for q, s in m.sigma.items() if q in names}
        if given:
            known = {q: given.get(q, np.zeros(m.n_rows)) for q in names if q in m.values}
            variance = rotated_columns(known, names, linear[kind] ** 2, m.n_rows)
            sigma.update({q: np.sqrt(v) for q, v in variance.items() if q in values})
    values = {q: values[q] for q in DISPLACEMENTS + STRAINS if q in values}
    sigma = {q: np.where(np.isnan(values[q]), np.nan, sigma[q]) for q in values if q in sigma}
    return Measurements(m.points, frame.points(m.coordinates), m.stage, m.force, values, sigma,
                        m.comments + (note,), m.source, m.channels)
