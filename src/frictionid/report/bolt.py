"""Bolt-nut results a bolt engineer reads: load share per engaged thread (with Sopwith's closed form and a fit of
lam P), flank pressure and slip along the engagement, nut dilation, stick/slip state per zone, a load-share plot.

Works on any model built by :func:`frictionid.builders.bolt.bolt_model`: engaged flank i is the mesh boundary
"thread_<i>" (bolt contact segment, numbered from the nut bearing face), the nut's outer surface "nut_outer".
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from scipy.optimize import minimize_scalar

from ..errors import InputError
from ..fem.solution import Solution
from ..model import Model, SurfaceForce

#: bounds of the Sopwith fit parameter lam P
LAM_P_BOUNDS = (1e-3, 3.0)


def flank_count(model: Model) -> int:
    """Number of engaged flanks (boundaries "thread_1" ... "thread_n")."""
    n = sum(1 for name in model.mesh.boundaries if re.fullmatch(r"thread_\d+", name))
    if n == 0:
        raise InputError("bolt report: the model has no 'thread_<i>' boundaries; build it with bolt_model")
    return n


def flank_of_pairs(model: Model, solution: Solution) -> np.ndarray:
    """(n_pairs,) engaged flank index (1-based) of each contact pair, 0 for pairs off the thread."""
    out = np.zeros(solution.pairs.n_pairs, dtype=int)
    for i in range(1, flank_count(model) + 1):
        out[np.isin(solution.pairs.nodes, model.mesh.boundary_nodes(f"thread_{i}"))] = i
    return out


def pair_forces(solution: Solution, increment: int = -1) -> np.ndarray:
    """(n_pairs, dim) [N] contact force on the contact side (the bolt) in global components (r, y)."""
    return np.einsum("pkc,pk->pc", solution.pairs.frames, solution.lam[increment])


def machine_force(model: Model, solution: Solution, increment: int = -1) -> float:
    """[N] the applied machine force at an increment: the magnitude of the model's one SurfaceForce (on
    "plate1_rim" in :func:`~frictionid.builders.bolt.bolt_model`; a study may apply it elsewhere)."""
    channels = [c for c, load in enumerate(model.loads) if isinstance(load, SurfaceForce)]
    if len(channels) != 1:
        raise InputError(f"bolt report: expected one SurfaceForce (the machine force), the model has {len(channels)}")
    return abs(float(solution.amplitude[increment, channels[0]]))


@dataclass(frozen=True)
class ThreadLoads:
    """Axial load per engaged thread at one increment.

    Attributes
    ----------
    force : (n_threads,) [N] axial force the nut puts on each bolt flank, thread 1 at the bearing face
    applied : [N] machine force
    share : (n_threads,) force / sum(force)
    lam_p : Sopwith parameter lam P fitted to ``share`` (least squares)
    """

    force: np.ndarray
    applied: float
    share: np.ndarray
    lam_p: float

    @property
    def n_threads(self) -> int:
        return len(self.force)


def sopwith_shares(lam_p: float, n_threads: int) -> np.ndarray:
    """(n,) Sopwith's load share of threads 1..n (1 at the bearing face), engaged length L = n P.

    share_i = [sinh(lam (L - (i-1) P)) - sinh(lam (L - i P))] / sinh(lam L)  (docs/design.md).

    >>> np.round(100 * sopwith_shares(0.406, 6)).astype(int).tolist()
    [34, 23, 16, 11, 9, 7]
    """
    i = np.arange(1, n_threads + 1)
    return (np.sinh(lam_p * (n_threads - i + 1)) - np.sinh(lam_p * (n_threads - i))) / np.sinh(lam_p * n_threads)


def fit_sopwith(share: np.ndarray) -> float:
    """lam P minimising sum (share_i - sopwith_i)^2 within :data:`LAM_P_BOUNDS`."""
    share = np.asarray(share, dtype=float)
    result = minimize_scalar(lambda x: np.sum((sopwith_shares(x, len(share)) - share) ** 2),
                             bounds=LAM_P_BOUNDS, method="bounded", options={"xatol": 1e-8})
    return float(result.x)


def thread_loads(model: Model, solution: Solution, increment: int = -1) -> ThreadLoads:
    """Axial force per engaged thread from the contact forces at an increment, with the Sopwith fit."""
    flank = flank_of_pairs(model, solution)
    axial = pair_forces(solution, increment)[:, 1]
    force = np.array([axial[flank == i].sum() for i in range(1, flank_count(model) + 1)])
    share = force / force.sum()
    return ThreadLoads(force, machine_force(model, solution, increment), share, fit_sopwith(share))


def pitch_loads(model: Model, solution: Solution, y_start: float, pitch: float, n: int,
                increment: int = -1, lead: float = 0.0, where: np.ndarray | None = None) -> np.ndarray:
    """(n,) share of the thread pairs' axial force in each of n pitches of axial position: bin k (1-based) takes
    the pairs at y_start + (k-1) P <= y < y_start + k P, the first and the last bin also those below and above.

    The same cut for a helix and for the axisymmetric model's rings: with y_start between two rings' flanks each
    bin holds one ring's flank, so for the axisymmetric model the shares are :func:`thread_loads`'s, and for a 3-D
    model the load of the helix over the same axial range (per turn, :func:`thread_loads` of a 3-D model, the
    helix's seam decides where a thread starts).

    With ``lead`` (a 3-D model's helix, [mm] per turn) a pair is placed by its helical coordinate
    y - lead theta / (2 pi) instead of y, theta = atan2(-z, x) in [-pi, pi) from the section the axisymmetric one
    is (x > 0, z = 0; :mod:`frictionid.builders.bolt3d_geometry`): the helix's load per turn, each turn (seam at
    theta = +-pi) in the bin of the ring it passes in that section. ``where`` (n_pairs,) bool keeps only those
    pairs (e.g. a sector of theta).
    """
    thread = flank_of_pairs(model, solution) > 0
    if where is not None:
        thread &= np.asarray(where, dtype=bool)
    axial = pair_forces(solution, increment)[thread, 1]
    position = solution.pairs.position[thread]
    y = position[:, 1]
    if lead:
        if position.shape[1] != 3:
            raise InputError("bolt report: a helical coordinate (lead) needs a 3-D model")
        theta = np.mod(np.arctan2(-position[:, 2], position[:, 0]) + np.pi, 2 * np.pi) - np.pi
        y = y - lead * theta / (2 * np.pi)
    k = np.clip(np.floor((y - y_start) / pitch).astype(int), 0, n - 1)
    force = np.bincount(k, weights=axial, minlength=n)
    return force / force.sum()


@dataclass(frozen=True)
class TorqueSplit:
    """Where the wrench torque of a 3-D tightening test goes, from the contact forces at one increment.

    Attributes
    ----------
    thread, bearing : [N mm] moment about the axis (+t sense) of the thread's contact forces on the bolt and of
        the nut bearing's on the nut (negative: friction holds the nut back); wrench torque = thread - bearing
    thread_normal : [N mm] the part of ``thread`` from the normal forces (the helix's lead)
    axial : [N] axial force of the thread's contact forces on the bolt (the preload)
    r_thread, r_bearing : [mm] effective radii, sum(lam_N r) / sum(lam_N), of the thread and the nut bearing
    """

    thread: float
    thread_normal: float
    bearing: float
    axial: float
    r_thread: float
    r_bearing: float


def acting_positions(pairs) -> np.ndarray:
    """(n_pairs, dim) [mm] where each pair's force acts on the contact side: sum_k c_jk x_k over the contact nodes
    k that pair j's row of B couples with weights c_jk (its own node alone on linear facets; on 6-node triangles
    the transformed basis mixes a node with its facets' others, and on curved facets that mix lies off the node).
    The moment of the pairs' forces about any axis at these positions is that of the nodal forces B^T lam."""
    dim = pairs.dim
    nodal = np.zeros(pairs.B.shape[1])
    for d in range(dim):
        nodal[dim * pairs.nodes + d] = pairs.position[:, d]
    coupled = (pairs.B @ nodal).reshape(-1, dim)                  # frames[j] . sum_k c_jk x_k
    return np.einsum("pkc,pk->pc", pairs.frames, coupled)


def torque_split(solution: Solution, thread: int = 0, bearing: int = 2, increment: int = -1) -> TorqueSplit:
    """:class:`TorqueSplit` of a 3-D model (y the axis); ``thread`` and ``bearing`` the interfaces' indices
    (:func:`~frictionid.builders.bolt.bolt_model`: 0 "thread", 2 "nut_bearing"). Moments and radii are taken at
    each pair's :func:`acting_positions`."""
    pairs = solution.pairs
    if pairs.dim != 3:
        raise InputError("bolt report: the torque split needs a 3-D model")
    forces, lam = pair_forces(solution, increment), solution.lam[increment]
    acting = acting_positions(pairs)
    x, z = acting[:, 0], acting[:, 2]
    radius = np.hypot(x, z)

    def moment(f, where):
        return float(np.sum(x[where] * f[where, 2] - z[where] * f[where, 0]))

    def radius_of(where):
        return float(lam[where, 0] @ radius[where] / lam[where, 0].sum())

    on_thread, on_bearing = pairs.interface == thread, pairs.interface == bearing
    normal = lam[:, :1] * pairs.frames[:, 0, :]
    return TorqueSplit(moment(forces, on_thread), moment(normal, on_thread), moment(forces, on_bearing),
                       float(forces[on_thread, 1].sum()), radius_of(on_thread), radius_of(on_bearing))


def vdi_torque(force: float, pitch: float, r_thread: float, r_bearing: float, mu_thread: float,
               mu_bearing: float) -> float:
    """[N mm] VDI 2230's tightening torque at the effective radii, with the screw's exact thread torque:
    F (r_G tan(phi + rho') + mu_K r_K), tan phi = P / (2 pi r_G), tan rho' = mu_G / cos alpha', tan alpha' =
    tan 30 deg cos phi (the ISO flank's half angle in the section normal to the helix).

    >>> round(vdi_torque(1000.0, 2.5, 9.19, 13.3, 0.1, 0.1) / 1000.0, 3)  # VDI 0.16 P + 0.58 mu d2 + mu D/2: 2.796
    2.796
    """
    phi = np.arctan(pitch / (2 * np.pi * r_thread))
    alpha = np.arctan(np.tan(np.pi / 6) * np.cos(phi))
    rho = np.arctan(mu_thread / np.cos(alpha))
    return float(force * (r_thread * np.tan(phi + rho) + mu_bearing * r_bearing))


def ring_gap(model: Model, solution: Solution, pitch: float) -> float:
    """[mm] ``y_start`` for :func:`pitch_loads` from an axisymmetric model: the middle of the gap between its first
    two engaged flanks, one pitch lower, so that each bin holds one flank."""
    flank = flank_of_pairs(model, solution)
    if flank.max() < 2:
        raise InputError("bolt report: the pitch cut needs at least two engaged flanks")
    y = solution.pairs.position[:, 1]
    return float((y[flank == 1].max() + y[flank == 2].min()) / 2 - pitch)


@dataclass(frozen=True)
class FlankProfile:
    """Contact quantities along the engagement (thread pairs, ordered by flank, then by radius).

    Attributes
    ----------
    flank : (n,) engaged flank index; position : (n, 2) (r, y) [mm]
    pressure : (n,) [MPa]; traction : (n,) [MPa] along the flank (frame t1)
    slip : (n,) [mm] accumulated tangential relative displacement (bolt relative to nut, along t1; on the
        load flanks t1 = (cos 30, sin 30) points outwards and up the flank, so slip < 0 is the bolt sliding
        inwards: bolt contraction plus nut dilation)
    state : (n,) 0 open, 1 stick, 2 slip
    """

    flank: np.ndarray
    position: np.ndarray
    pressure: np.ndarray
    traction: np.ndarray
    slip: np.ndarray
    state: np.ndarray


def flank_profile(model: Model, solution: Solution, increment: int = -1) -> FlankProfile:
    """Pressure, traction, slip and state at each thread contact pair at an increment."""
    flank = flank_of_pairs(model, solution)
    pairs = np.flatnonzero(flank > 0)
    order = pairs[np.lexsort((solution.pairs.position[pairs, 0], flank[pairs]))]
    return FlankProfile(flank[order], solution.pairs.position[order], solution.pressure[increment, order],
                        solution.traction[increment, order, 0], solution.slip[increment, order, 0],
                        solution.state[increment, order])


def nut_dilation(model: Model, displacement: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((n,) y [mm], (n,) u_r [mm]) on the nut's outer surface, bottom up; displacement (n_nodes, 2) [mm]."""
    nodes = model.mesh.boundary_nodes("nut_outer")
    nodes = nodes[np.argsort(model.mesh.points[nodes, 1])]
    return model.mesh.points[nodes, 1].copy(), displacement[nodes, 0].copy()


def plot_load_shares(loads: ThreadLoads, path: str | Path, title: str = "", reference: float | None = 0.406) -> Path:
    """Bar chart of the FE load shares [%] with the fitted Sopwith curve; written as PNG.

    ``reference``: a further Sopwith curve at this lam P, dashed (default 0.406, the classic 34/23/16/... %).
    """
    i = np.arange(1, loads.n_threads + 1)
    fig = Figure(figsize=(6, 4))
    ax = fig.subplots()
    ax.bar(i, 100 * loads.share, color="0.6", label="FE (contact forces)")
    ax.plot(i, 100 * sopwith_shares(loads.lam_p, loads.n_threads), "o-", color="C3",
            label=f"Sopwith, fitted lam P = {loads.lam_p:.3f}")
    if reference is not None:
        ax.plot(i, 100 * sopwith_shares(reference, loads.n_threads), "s--", color="C0", alpha=0.7,
                label=f"Sopwith, lam P = {reference:g}")
    ax.set_xlabel("engaged thread (1 = nut bearing face)")
    ax.set_ylabel("load share [%]")
    ax.set_title(title or f"thread load shares at F = {loads.applied / 1000:.3g} kN")
    ax.set_xticks(i)
    ax.legend()
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    return path


def plot_flank_profile(profile: FlankProfile, path: str | Path, title: str = "") -> Path:
    """Flank pressure [MPa] and slip [um] against the axial position of each thread contact pair (PNG);
    slipping pairs as filled markers, sticking ones open."""
    fig = Figure(figsize=(7, 5))
    top, bottom = fig.subplots(2, 1, sharex=True)
    y = profile.position[:, 1]
    for flank in np.unique(profile.flank):
        k = profile.flank == flank
        for state, face in ((2, f"C{flank % 10}"), (1, "none")):
            j = k & (profile.state == state)
            top.plot(y[j], profile.pressure[j], "o", ms=3, mfc=face, mec=f"C{flank % 10}")
            bottom.plot(y[j], 1000 * profile.slip[j], "o", ms=3, mfc=face, mec=f"C{flank % 10}")
    top.set_ylabel("contact pressure [MPa]")
    bottom.set_ylabel("slip along the flank [um]")
    bottom.set_xlabel("axial position y [mm] (nut bearing face at the left)")
    top.set_title(title or "thread flanks: filled = slip, open = stick")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    return path


def bolt_summary(model: Model, solution: Solution, increment: int = -1) -> str:
    """A plain-text summary: load shares vs Sopwith, zone forces and stick/slip fractions."""
    loads = thread_loads(model, solution, increment)
    sop = sopwith_shares(loads.lam_p, loads.n_threads)
    lines = [f"machine force {loads.applied:.6g} N, thread forces sum {loads.force.sum():.6g} N, "
             f"Sopwith fit lam P = {loads.lam_p:.3f}", "thread  force [N]  share [%]  Sopwith [%]"]
    lines += [f"{i + 1:6d}  {f:9.1f}  {100 * s:9.2f}  {100 * p:11.2f}"
              for i, (f, s, p) in enumerate(zip(loads.force, loads.share, sop))]
    lines.append("zone  normal force [N]  open  stick  slip")
    states = solution.zone_state(increment)
    for z, zone in enumerate(solution.zone_names):
        st = states[zone]
        lines.append(f"{zone:10s} {solution.zone_normal_force[increment, z]:10.1f}  {st['open']:.2f}  "
                     f"{st['stick']:.2f}  {st['slip']:.2f}")
    return "\n".join(lines)
