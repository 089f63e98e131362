"""Fitted frames: the rigid map (optionally with a uniform scale) from a file's frame to the model's, fitted to
reference points given in both frames (Kabsch / Umeyama) or to the model's surface (least squares on the points'
distances to its facets), reported with its residual."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InputError
from .frames import Frame, FrameSpec

#: a fit whose Jacobian has a singular value below this fraction of the largest leaves a motion undetermined
UNDETERMINED = 1e-6
#: Gauss-Newton steps of a surface fit at most; it stops when a step moves no point by more than STEP_TOL [mm]
MAX_STEPS, STEP_TOL = 100, 1e-12
#: a surface frame is fitted to every k-th point, at most this many (6 or 7 unknowns); its residual is reported
#: over all points
FIT_POINTS = 5000
#: points whose smallest spread (singular value of the centred coordinates) is below this fraction of their
#: largest lie on one plane: a flat face, on which a surface fit cannot fix the in-plane turn and shifts
FLAT = 1e-3
#: a fitted frame whose residual RMS exceeds this many displacement noises (without a stated noise: FAR_FRACTION
#: of the points' extent) does not put the points where they were measured: warned
FAR, FAR_FRACTION = 10.0, 1e-3
#: a plane model's surface fit whose residual RMS exceeds this fraction of the points' extent too is refused: its
#: points lie on the section's flat face, not on its boundary (a real edge's deviation from the model's is smaller)
FACE_FRACTION = 1e-2

log = logging.getLogger(__name__)


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
    ``surface`` (:class:`~frictionid.fem.surface.Surface`): Gauss-Newton on the vectors from each point to its
    nearest surface point (point-to-plane: a point's residual moves along its facet's normal), each step a turn
    about the current frame and a shift (and a scale with ``spec.fit_scale``), halved while it does not lower the
    sum of squares; it starts from the spec's frame.

    Raises
    ------
    InputError
        Points that leave a motion free (all on one plane or a cylinder: the frame could slide along it), or no
        convergence in MAX_STEPS steps.
    """
    dim, frame, every = surface.dim, spec.frame, -(-len(xyz) // FIT_POINTS)
    size = float(np.ptp(xyz, axis=0).max()) or 1.0
    if dim == 3:
        _not_flat(spec, xyz, source)
    sample = xyz[::every]
    residual, jac = _linearised(frame, sample, surface, spec.fit_scale)
    for step in range(MAX_STEPS):
        units = _units(dim, size, spec.fit_scale)
        if _free_motions(jac / units):
            break
        delta = np.linalg.lstsq(jac / units, -residual.ravel(), rcond=None)[0] / units
        cost = float(np.sum(residual ** 2))
        for _ in range(40):
            trial = _moved(frame, delta, dim, spec.fit_scale)
            new_residual, new_jac = _linearised(trial, sample, surface, spec.fit_scale)
            if float(np.sum(new_residual ** 2)) <= cost:
                break
            delta = delta / 2
        frame, residual, jac = trial, new_residual, new_jac
        if np.max(np.abs(delta * units)) <= STEP_TOL * max(size, 1.0):
            break
    else:
        raise InputError(f"{spec.key}: the frame fitted to the model's surface did not settle in {MAX_STEPS} steps; "
                         "start nearer (rotation_deg, translation) or use fit = \"points\"")
    log.info("surface fit: %d Gauss-Newton steps on %d of %d points", step + 1, len(sample), len(xyz))
    free = _free_motions(jac / _units(dim, size, spec.fit_scale))
    if free:
        raise InputError(f"{spec.key}: the {len(xyz)} points of {source} do not fix the frame on the model's "
                         f"surface ({free} motion(s) left free: points on one plane can slide along it); use points "
                         "on several faces or fit = \"points\" with reference points")
    if every > 1:
        residual = _linearised(frame, xyz, surface, spec.fit_scale)[0]
    return _fit(frame, "surface", np.linalg.norm(residual, axis=1), list(labels))


def _not_flat(spec: FrameSpec, xyz: np.ndarray, source: str) -> None:
    spread = np.linalg.svd(xyz - xyz.mean(axis=0), compute_uv=False) / np.sqrt(max(len(xyz), 1))
    if len(spread) == 3 and spread[2] <= FLAT * spread[0]:
        raise InputError(f"{spec.key}: the {len(xyz)} points of {source} do not fix the frame on the model's surface: "
                         f"they lie on one plane (RMS spread {spread[2]:.3g} mm out of it, {spread[0]:.3g} mm in "
                         "it), and a flat face cannot fix the in-plane rotation: the turn about its normal and the "
                         "shifts along it are left free; use fit = \"points\" with 3 reference points, or give "
                         "rotation_deg and translation")


def residual_check(fit: FrameFit, noise: float | None, xyz: np.ndarray, dim: int, key: str) -> str | None:
    """A warning where ``fit``'s residual RMS is far above the displacement ``noise`` [mm] (None: above FAR_FRACTION
    of the points' extent), else None.

    Raises
    ------
    InputError
        A surface fit of a plane (2-D) model far off, also beyond FACE_FRACTION of the points' extent: DIC points
        on the section's face are not on its boundary, which the fit matches by a wrong turn.
    """
    size = float(np.ptp(np.asarray(xyz, float), axis=0).max()) if len(xyz) else 0.0
    limit = FAR * noise if noise else FAR_FRACTION * size
    if not fit.rms > limit:
        return None
    against = f"{fit.rms / noise:.3g} times the displacement noise {noise:g} mm" if noise else \
        f"{fit.rms / size:.3g} of the points' extent {size:.3g} mm (no displacement noise stated)"
    if fit.fit == "surface" and dim == 2 and fit.rms > FACE_FRACTION * size:
        raise InputError(f"{key}: the frame fitted to the model's surface leaves a residual RMS {fit.rms:.3g} mm, "
                         f"{against}: in a plane model the surface is the section's boundary, and DIC points "
                         "measured on the section's flat face lie inside it; a flat face cannot fix the in-plane "
                         "rotation: use fit = \"points\" with 3 reference points, or give rotation_deg and "
                         "translation")
    return (f"warning: the fitted frame's residual RMS {fit.rms:.3g} mm is {against}: the points are not where "
            "the frame puts them (other reference points or surface regions, a unit, or a model that is not the "
            "specimen?)")


def _units(dim: int, size: float, with_scale: bool) -> np.ndarray:
    """mm of point motion per unit of each step's component: turns (rad) and a scale step move points by ~size."""
    return np.r_[np.full(3 if dim == 3 else 1, size), np.ones(dim), [size] * with_scale]


def _linearised(frame: Frame, xyz: np.ndarray, surface, with_scale: bool):
    """Residuals (n, dim) (point minus nearest surface point) and their derivative (n * dim, n_step) by a step
    (turn about the model axes through the frame's origin, shift, log-scale), each point moving along its
    facet's normal."""
    dim = surface.dim
    p = frame.points(xyz)
    nearest, normal = surface.closest(p[:, :dim])
    arm = p - frame.translation
    turns = [np.cross(np.eye(3)[k], arm)[:, :dim] for k in (range(3) if dim == 3 else [2])]
    motion = np.stack(turns + [np.broadcast_to(np.eye(dim)[k], (len(p), dim)) for k in range(dim)]
                      + ([arm[:, :dim]] if with_scale else []), axis=2)                # (n, dim, n_step)
    along = normal[:, :, None] * np.einsum("nd,ndk->nk", normal, motion)[:, None, :]
    return p[:, :dim] - nearest, along.reshape(len(p) * dim, -1)


def _moved(frame: Frame, delta: np.ndarray, dim: int, with_scale: bool) -> Frame:
    n_turn = 3 if dim == 3 else 1
    turn = Rotation.from_rotvec(delta[:3] if dim == 3 else [0.0, 0.0, delta[0]]).as_matrix()
    shift = np.r_[delta[n_turn:n_turn + dim], np.zeros(3 - dim)]
    scale = float(np.exp(delta[-1])) if with_scale else 1.0
    return Frame(turn @ frame.rotation, frame.translation + shift, frame.scale * scale)


def _free_motions(jac: np.ndarray) -> int:
    """Number of motions (columns in mm of point motion) the residuals do not see."""
    values = np.linalg.svd(jac, compute_uv=False)
    return int(np.sum(values <= UNDETERMINED * values.max()))


def _fit(frame: Frame, fit: str, distance: np.ndarray, labels) -> FrameFit:
    worst = int(np.argmax(distance))
    return FrameFit(frame, fit, len(distance), float(np.sqrt(np.mean(distance ** 2))), float(distance[worst]),
                    str(labels[worst]))
