"""Fitted frames: the rigid map (optionally with a uniform scale) from a file's frame to the model's, fitted to
reference points given in both frames (Kabsch / Umeyama) or to the model's surface (least squares on the points'
distances to its facets), reported with its residual."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..errors import InputError
from .frames import Frame, FrameSpec

#: a fit whose Jacobian has a singular value below this fraction of the largest leaves a motion undetermined
UNDETERMINED = 1e-6


@dataclass(frozen=True)
class FrameFit:
    """A fitted frame and how well it fits: RMS and largest distance [mm] of the ``n_points`` used (to their
    model points, or to the model's surface), the worst point's label."""

    frame: Frame
    fit: str
    n_points: int
    rms: float
    largest: float
    worst: str

    def line(self) -> str:
        f = self.frame
        return (f"frame fitted to {'reference points' if self.fit == 'points' else 'the model surface'} "
                f"({self.n_points} points): rotation_deg = [{', '.join(f'{a:.6f}' for a in f.rotation_deg())}], "
                f"translation = [{', '.join(f'{t:.6f}' for t in f.translation)}] mm, scale {f.scale:.9f}; "
                f"residual RMS {self.rms:.3g} mm, largest {self.largest:.3g} mm (point {self.worst!r})")

    def as_dict(self) -> dict:
        return {"fit": self.fit, **self.frame.as_dict(), "n_points": self.n_points,
                "residual_rms_mm": self.rms, "residual_max_mm": self.largest, "worst_point": self.worst}


def umeyama(source: np.ndarray, target: np.ndarray, with_scale: bool = False) -> Frame:
    """The frame minimising sum |target - (s R source + t)|^2 over proper rotations R (Umeyama 1991, IEEE PAMI
    13(4); Kabsch without the scale). ``source``, ``target``: (n, 3) [mm].

    >>> f = umeyama(np.eye(3), np.eye(3) + 1.0)
    >>> np.round(f.translation, 12).tolist(), round(f.scale, 12)
    ([1.0, 1.0, 1.0], 1.0)
    """
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    s, t = source - mu_s, target - mu_t
    u, d, vt = np.linalg.svd(t.T @ s / len(source))
    flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(u) * np.linalg.det(vt)) or 1.0])
    rotation = u @ flip @ vt
    scale = float(np.trace(np.diag(d) @ flip) / np.mean(np.sum(s ** 2, axis=1))) if with_scale else 1.0
    return Frame(rotation, mu_t - scale * rotation @ mu_s, scale)


def fit_to_points(spec: FrameSpec, labels, xyz: np.ndarray, source: str) -> FrameFit:
    """The frame of ``spec`` (fit = "points") from its reference points: a label of the file (its coordinates
    ``xyz`` (n, 3) in the file's frame) or a point given in both frames.

    Raises
    ------
    InputError
        A reference label that is not a point of the file (naming the key), fewer than 3 points, or points on a
        line (the rotation about it would be free).
    """
    index = {label: i for i, label in enumerate(labels)}
    pairs = []
    for label, value in spec.points.items():
        if isinstance(value, tuple):
            pairs.append(value)
        elif label in index:
            pairs.append((xyz[index[label]], value))
        else:
            shown = ", ".join(list(index)[:8]) + (", ..." if len(index) > 8 else "")
            raise InputError(f"{spec.key}.points.{label}: no point {label!r} in {source} (its points: {shown}); "
                             "name a point of the file or give { file = [x, y, z], model = [x, y, z] }")
    file_xyz, model_xyz = (np.array(p) for p in zip(*pairs))
    spread = np.linalg.svd(file_xyz - file_xyz.mean(axis=0), compute_uv=False)
    if len(pairs) < 3 or spread[1] <= 1e-9 * max(spread[0], 1e-300):
        raise InputError(f"{spec.key}.points: {len(pairs)} reference point(s) "
                         f"{'on one line ' if len(pairs) >= 3 else ''}do not fix a frame; give at least 3 points "
                         "not on one line")
    frame = umeyama(file_xyz, model_xyz, spec.fit_scale)
    distance = np.linalg.norm(frame.points(file_xyz) - model_xyz, axis=1)
    return _fit(frame, "points", distance, list(spec.points))


def fit_to_surface(spec: FrameSpec, labels, xyz: np.ndarray, surface, source: str) -> FrameFit:
    """The frame of ``spec`` (fit = "surface") that brings the points ``xyz`` (n, 3) [mm, file frame] onto
    ``surface`` (:class:`~frictionid.fem.surface.Surface`), by least squares on the vectors from each point to
    its nearest surface point, starting from the spec's frame.

    Raises
    ------
    InputError
        Points that leave a motion free (all on one plane or a cylinder: the frame could slide along it).
    """
    dim, start = surface.dim, spec.frame
    n_turn = 3 if dim == 3 else 1                   # a plane's frame turns about z and moves in x, y only
    size = float(np.ptp(xyz, axis=0).max()) or 1.0

    def frame_of(x):
        turn = Rotation.from_rotvec(x[:3] if dim == 3 else [0.0, 0.0, x[0]]).as_matrix()
        shift = np.r_[x[n_turn:n_turn + dim], start.translation[dim:]]
        return Frame(turn @ start.rotation, shift, float(start.scale * np.exp(x[-1])) if spec.fit_scale
                     else start.scale)

    def residual(x):
        p = frame_of(x).points(xyz)[:, :dim]
        return (p - surface.nearest(p)).ravel()

    x0 = np.r_[np.zeros(n_turn), start.translation[:dim], [0.0] * spec.fit_scale]
    # columns in mm of point motion per unit: a turn moves points by about `size`, a scale step too
    units = np.r_[np.full(n_turn, size), np.ones(dim), [size] * spec.fit_scale]
    fitted = least_squares(residual, x0, x_scale=1.0 / units, xtol=1e-15, ftol=1e-15, gtol=1e-15,
                           max_nfev=100 * len(x0))
    free = _free_motions(fitted.jac / units)
    if free:
        raise InputError(f"{spec.key}: the {len(xyz)} points of {source} do not fix the frame on the model's "
                         f"surface ({free} motion(s) left free: points on one plane can slide along it); use points "
                         "on several faces or fit = \"points\" with reference points")
    frame = frame_of(fitted.x)
    p = frame.points(xyz)[:, :dim]
    return _fit(frame, "surface", np.linalg.norm(p - surface.nearest(p), axis=1), list(labels))


def _free_motions(jac: np.ndarray) -> int:
    """Number of motions (columns in mm of point motion) the residuals do not see."""
    values = np.linalg.svd(jac, compute_uv=False)
    return int(np.sum(values <= UNDETERMINED * values.max()))


def _fit(frame: Frame, fit: str, distance: np.ndarray, labels) -> FrameFit:
    worst = int(np.argmax(distance))
    return FrameFit(frame, fit, len(distance), float(np.sqrt(np.mean(distance ** 2))), float(distance[worst]),
                    str(labels[worst]))
