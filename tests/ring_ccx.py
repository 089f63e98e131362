"""A 3-D CalculiX deck of :func:`frictionid.builders.torsion.turned_rings_model` (two rings pressed and turned): the
independent reference of the "axisymmetric_twist" kind, which CalculiX has no element for.

The rings are revolved into a structured hexahedral mesh (C3D8I, or C3D20R with ``quadratic``; full ring:
``n_theta`` cells around, ``n_r`` across, ``n_y`` along the axis each), coincident nodes on y = 0. Contact: the upper
ring's bottom, split at the mean radius into "inside" and "outside" (one *CONTACT PAIR each, surface to surface,
penalty), on the lower ring's top. Held: the lower ring's bottom in y and in the circumferential direction (one
*EQUATION per node: u_t = (-z ux + x uz) / r = 0), as the twist model's Support("lower_bottom", (1, 2)). Step 1: the
pressure on the upper ring's top (*DSLOAD). Steps 2, ...: the top turned to each of ``angles`` [rad] about the axis:
u_t = r * theta at each top node, theta the prescribed x displacement of a node of no element (one *EQUATION per top
node); the top's u_r, u_y stay free, as the twist model's Rotation. The torque is read as the moment about y of each
pair's contact force (ccx prints no reaction for equation-held dofs; measured once with the bottom held in x, y, z
instead, the moment of its nodal reactions agreed with it to 0.04 %). Geometry: x = r cos(phi), z = r sin(phi), so
+phi is the twist kind's +t direction ((-z, 0, x) / r) and the points at phi = 0 (z = 0, x = r) have ux = u_r, uz = u_t.

``cone_deg`` turns the face into a cone (both meshes moved by :func:`~frictionid.builders.torsion.cone_shift`). A
faceted cone turned on a faceted cone locks where the facets meet, so CalculiX transmits torque without friction
(docs/models.md); the flat face has no such effect.
"""

from __future__ import annotations

import numpy as np

from frictionid.backends.calculix.parse import read_dat
from frictionid.backends.calculix.runner import remove_work, run_ccx
from frictionid.builders.torsion import cone_shift

#: C3D8 faces (ccx numbering) with the node order below: S3 = nodes 1, 5, 6, 2 lies at the cell's lower y, S5 = 3, 7, 8,
#: 4 at its upper y
BOTTOM, TOP = "S3", "S5"


class RingGrid:
    """Node numbers and coordinates of one revolved ring: a structured grid of ``n_theta`` angles (periodic) x
    ``radii`` x ``ys``; with ``step`` = 2 (quadratic cells) every second grid line is a cell edge and the lines
    between carry the mid-side nodes (on the circle)."""

    def __init__(self, first: int, radii: np.ndarray, ys: np.ndarray, n_theta: int, step: int = 1):
        self.radii, self.ys, self.n_theta, self.first, self.step = radii, ys, n_theta, first, step
        self.shape = (n_theta, len(radii), len(ys))

    def node(self, k: int, i: int, j: int) -> int:
        """ccx number of the node at angle index k (periodic), radius index i, height index j."""
        return self.first + int(np.ravel_multi_index((k % self.n_theta, i, j), self.shape))

    def coordinates(self) -> np.ndarray:
        phi = 2 * np.pi * np.arange(self.n_theta) / self.n_theta
        k, i, j = np.meshgrid(np.arange(self.n_theta), np.arange(len(self.radii)), np.arange(len(self.ys)),
                              indexing="ij")
        r = self.radii[i]
        return np.column_stack([(r * np.cos(phi[k])).ravel(), self.ys[j].ravel(), (r * np.sin(phi[k])).ravel()])

    def cells(self):
        """(cell (k, i, j) in grid indices of its first corner, ccx nodes: 8 corners, then with step 2 the 12
        mid-side nodes in ccx's C3D20 order); local axes (r, y, phi), right-handed."""
        h = self.step
        corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
        edges = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
        for k in range(0, self.n_theta, h):
            for i in range(0, len(self.radii) - 1, h):
                for j in range(0, len(self.ys) - 1, h):
                    at = [(i + h * a, j + h * b, k + h * c) for a, b, c in corners]      # (r, y, phi) indices
                    if h == 2:
                        at += [tuple((p + q) // 2 for p, q in zip(at[m], at[n])) for m, n in edges]
                    yield (k, i, j), [self.node(c, a, b) for a, b, c in at]


def _lines(values, per_line: int = 8) -> list[str]:
    values = list(values)
    return [", ".join(str(v) for v in values[i:i + per_line]) for i in range(0, len(values), per_line)]


def _circumferential(node: int, x: float, z: float, extra: str = "") -> list[str]:
    """*EQUATION lines of (-z ux + x uz) / r (+ extra term) = 0, the dependent dof first (the larger coefficient)."""
    r = np.hypot(x, z)
    terms = [(1, -z / r), (3, x / r)]
    terms.sort(key=lambda t: -abs(t[1]))
    body = ", ".join(f"{node}, {dof}, {c:.15g}" for dof, c in terms if c != 0.0)
    return [str(len([t for t in terms if t[1] != 0.0]) + (1 if extra else 0)), body + (", " + extra if extra else "")]


def ring_deck(inner=6.0, outer=10.0, height=4.0, E=200000.0, nu=0.3, pressure=50.0, angles=(2e-3,),
              mu=(0.15, 0.15), n_theta=72, n_r=4, n_y=4, n_turn=4, penalty=1e7, cone_deg=0.0,
              quadratic=False) -> tuple[str, dict]:
    """The deck text and the node numbers of interest: "observed" {(r, y): node at phi = 0}, "points" (the ccx
    nodes' coordinates, row = number - 1). Steps: the pressure, then one step per angle [rad] (n_turn increments
    each). ``cone_deg``: the face a cone, the nodes moved as the twist model's
    (:func:`~frictionid.builders.torsion.cone_shift`); "observed" keeps the flat (r, y) as keys. ``quadratic``:
    C3D20R (mid-side nodes on the circle) instead of C3D8I: a cone of flat facets (C3D8I) turned on another
    locks where the facets' edges meet (see docs/models.md)."""
    if n_r % 2:
        raise ValueError("n_r must be even (the zones split at the mean radius)")
    h = 2 if quadratic else 1
    radii = np.linspace(inner, outer, h * n_r + 1)
    lower = RingGrid(1, radii, np.linspace(-height, 0.0, h * n_y + 1), h * n_theta, h)
    upper = RingGrid(1 + lower.coordinates().shape[0], radii, np.linspace(0.0, height, h * n_y + 1), h * n_theta, h)
    points = np.vstack([lower.coordinates(), upper.coordinates()])
    if cone_deg:
        points = cone_shift(points, inner, height, cone_deg)
    faces = {"inside": [], "outside": [], "target": [], "top": []}
    element, elements = 0, []
    used = np.zeros(len(points) + 1, bool)                # by ccx number; quadratic: face and cell centres unused
    for name, grid in (("LOWER", lower), ("UPPER", upper)):
        elements.append(f"*ELEMENT, TYPE={'C3D20R' if quadratic else 'C3D8I'}, ELSET={name}")
        for (k, i, j), nodes in grid.cells():
            element += 1
            elements += _lines([element] + nodes, per_line=16)
            used[nodes] = True
            if grid is lower and j == len(grid.ys) - 1 - h:
                faces["target"].append(f"{element}, {TOP}")
            if grid is upper and j == 0:
                faces["inside" if i < len(radii) // 2 else "outside"].append(f"{element}, {BOTTOM}")
            if grid is upper and j == len(grid.ys) - 1 - h:
                faces["top"].append(f"{element}, {TOP}")
    turn = len(points) + 1
    lines = ["*HEADING", "two rings pressed and turned (frictionid twist cross-check); mm, N, MPa", "*NODE, NSET=NALL"]
    lines += [f"{n}, {x:.15g}, {y:.15g}, {z:.15g}" for n, (x, y, z) in zip(np.flatnonzero(used), points[used[1:]])]
    lines += ["*NODE, NSET=NTURN", f"{turn}, 0., {height:.15g}, 0."] + elements
    bottom = [n for k in range(lower.n_theta) for i in range(len(radii)) if used[n := lower.node(k, i, 0)]]
    top = [n for k in range(upper.n_theta) for i in range(len(radii)) if used[n := upper.node(k, i, len(upper.ys) - 1)]]
    observed = {(float(r), float(y)): grid.node(0, i, j) for grid in (lower, upper)
                for i, r in enumerate(grid.radii) for j, y in enumerate(grid.ys) if used[grid.node(0, i, j)]}
    lines += ["*NSET, NSET=NBOT"] + _lines(bottom) + ["*NSET, NSET=NOBS"] + _lines(sorted(set(observed.values())))
    for name, key in (("SIN", "inside"), ("SOUT", "outside"), ("STARGET", "target"), ("STOP", "top")):
        lines += [f"*SURFACE, NAME={name}, TYPE=ELEMENT"] + faces[key]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{E:.15g}, {nu:.15g}",
              "*SOLID SECTION, ELSET=LOWER, MATERIAL=STEEL", "*SOLID SECTION, ELSET=UPPER, MATERIAL=STEEL"]
    for index, (surface, value) in enumerate((("SIN", mu[0]), ("SOUT", mu[1])), start=1):
        lines += [f"*SURFACE INTERACTION, NAME=I{index}", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
                  f"{penalty:.15g}", "*FRICTION", f"{value:.15g}, {penalty:.15g}",
                  f"*CONTACT PAIR, INTERACTION=I{index}, TYPE=SURFACE TO SURFACE", f"{surface}, STARGET"]
    lines.append("*EQUATION")
    for node in bottom:
        x, _, z = points[node - 1]
        lines += _circumferential(node, x, z)
    for node in top:
        x, _, z = points[node - 1]
        lines += _circumferential(node, x, z, f"{turn}, 1, {-np.hypot(x, z):.15g}")
    lines += ["*BOUNDARY", "NBOT, 2, 2", "NTURN, 2, 3"]
    for step, (theta, n) in enumerate([(0.0, 1)] + [(angle, n_turn) for angle in angles], start=1):
        dt = 1.0 / n
        lines += ["*STEP, INC=1000", "*STATIC", f"{dt:.15g}, 1., {dt * 1e-4:.15g}, {dt:.15g}",
                  "*BOUNDARY", f"NTURN, 1, 1, {theta:.15g}"]
        if step == 1:
            lines += ["*DSLOAD", f"STOP, P, {pressure:.15g}"]
        lines += ["*NODE PRINT, NSET=NOBS", "U", "*NODE PRINT, NSET=NBOT, TOTALS=ONLY", "RF",
                  "*CONTACT PRINT, SLAVE=SIN, MASTER=STARGET", "CF",
                  "*CONTACT PRINT, SLAVE=SOUT, MASTER=STARGET", "CF", "*END STEP"]
    return "\n".join(lines) + "\n", {"observed": observed, "points": points}


def run_rings(timeout: float = 900.0, **options) -> list[dict]:
    """Run the deck; per step end: "zone_torques" [N mm] (moment about y of the contact force on "inside",
    "outside": the torque each zone carries), "axial" [N] (y reaction of the held bottom), "u" {(r, y): (ux, uy,
    uz)} at the observed nodes (phi = 0: u_r, u_y, u_t)."""
    deck, nodes = ring_deck(**options)
    work = run_ccx(deck, "ccx", timeout)
    dat = read_dat(work / "job.dat")
    out = []
    for step_key in _step_times(dat, 1 + len(options.get("angles", (2e-3,)))):
        u = dat.nodal[("displacements (vx,vy,vz)", "NOBS")][step_key]
        total = dat.totals[("total force (fx,fy,fz)", "NBOT")][step_key]
        pairs = {key[0]: entries for key, entries in dat.contact.items()}
        moment = [_at_time(pairs[name], step_key)["moment"][1] for name in ("SIN", "SOUT")]
        entries = [_at_time(pairs[name], step_key) for name in ("SIN", "SOUT")]
        out.append({"axial": float(total[1]), "zone_torques": np.array(moment),
                    "zone_normal": np.array([e["normal"] for e in entries]),
                    "zone_shear": np.array([e["shear"] for e in entries]),
                    "zone_force": np.array([e["force"] for e in entries]),
                    "u": {key: np.asarray(u[node]) for key, node in nodes["observed"].items()}})
    remove_work(work)
    return out


def _at_time(entries: dict, time: float):
    times = np.array(sorted(entries))
    return entries[float(times[np.argmin(np.abs(times - time))])]


def _step_times(dat, n_steps: int) -> list[float]:
    """The total times of the step ends (1, 2, ...) among the printed increments."""
    times = np.array(sorted(dat.totals[("total force (fx,fy,fz)", "NBOT")]))
    return [float(times[np.argmin(np.abs(times - end))]) for end in range(1, n_steps + 1)]
