"""Issue 24's clamp: a plane-strain strip clamped between two pads, three friction zones per pad, as a user's
.inp deck (structured CPE4 quads, each body with its own nodes, conforming at both interfaces).

Strip x in [0, 16], y in [-1, 1] (aluminium); pads x in [0, 12] above (y in [1, 3]) and below (y in [-3, -1])
(steel). Zones on the strip: T1, T2, T3 on its top face (x in [0, 4], [4, 8], [8, 12]), B1, B2, B3 on its bottom
face. Targets: PAD_TOP_FACE (the upper pad's lower face), PAD_BOTTOM_FACE (the lower pad's upper face) and PADS
(both faces in one surface: the set-up that paired half the nodes with the opposite pad, 2 mm away). The lower
pad's BASE is fixed; the upper pad's LID is pressed and held in x; the strip's free END is pulled in x. LOWER_LEFT
(the lower pad's left face) shares a corner node with BASE.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

ZONES = {"T": ("T1", "T2", "T3"), "B": ("B1", "B2", "B3")}
TRUE = {"T1": 0.35, "T2": 0.2, "T3": 0.3, "B1": 0.15, "B2": 0.4, "B3": 0.25}


class _Deck:
    """Nodes and CPE4 elements of rectangles of quads, numbered from 1, with element-face surfaces."""

    def __init__(self):
        self.nodes, self.elements, self.elsets, self.surfaces = [], [], {}, {}

    def block(self, name: str, x: tuple[float, float], y: tuple[float, float], size: float) -> dict:
        nx, ny = (max(1, round((b - a) / size)) for a, b in (x, y))
        xs, ys = np.linspace(*x, nx + 1), np.linspace(*y, ny + 1)
        first = len(self.nodes) + 1
        ids = first + np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
        self.nodes += [(float(a), float(b)) for b in ys for a in xs]
        start = len(self.elements) + 1
        grid = np.zeros((ny, nx), dtype=int)
        for j in range(ny):
            for i in range(nx):
                grid[j, i] = len(self.elements) + 1
                self.elements.append((ids[j, i], ids[j, i + 1], ids[j + 1, i + 1], ids[j + 1, i]))
        self.elsets[name] = list(range(start, len(self.elements) + 1))
        return {"grid": grid, "xs": xs}

    def face(self, name: str, block: dict, side: str, x_range=(-np.inf, np.inf)) -> None:
        """Element faces of a block's side ("bottom" S1, "right" S2, "top" S3, "left" S4) whose centres lie in
        x_range."""
        grid, xs = block["grid"], block["xs"]
        if side in ("right", "left"):
            column, label = (grid[:, -1], "S2") if side == "right" else (grid[:, 0], "S4")
            self.surfaces.setdefault(name, []).extend((int(e), label) for e in column)
            return
        row, label = (grid[0], "S1") if side == "bottom" else (grid[-1], "S3")
        centre = (xs[:-1] + xs[1:]) / 2
        keep = (centre > x_range[0]) & (centre < x_range[1])
        self.surfaces.setdefault(name, []).extend((int(e), label) for e in row[keep])

    def text(self) -> str:
        lines = ["** issue 24's clamp (tests/clamp_case.py); units mm, N, MPa", "*NODE"]
        lines += [f"{k}, {x!r}, {y!r}" for k, (x, y) in enumerate(self.nodes, 1)]
        lines.append("*ELEMENT, TYPE=CPE4")
        lines += [f"{k}, " + ", ".join(str(int(n)) for n in e) for k, e in enumerate(self.elements, 1)]
        for name, members in self.elsets.items():
            lines.append(f"*ELSET, ELSET={name}")
            lines += [", ".join(map(str, members[i:i + 16])) for i in range(0, len(members), 16)]
        for name, faces in self.surfaces.items():
            lines.append(f"*SURFACE, NAME={name}, TYPE=ELEMENT")
            lines += [f"{e}, {s}" for e, s in faces]
        return "\n".join(lines) + "\n"


def write_clamp(path: Path, size: float = 0.5, gap: float = 0.0, thickness: float = 2.0) -> Path:
    """The clamp deck at element size ``size`` [mm] (a divisor of 1) written to ``path``; the pads ``gap`` [mm]
    away from a strip ``thickness`` [mm] thick."""
    deck = _Deck()
    t = thickness / 2
    strip = deck.block("STRIP", (0.0, 16.0), (-t, t), size)
    upper = deck.block("UPPER", (0.0, 12.0), (t + gap, t + gap + 2.0), size)
    lower = deck.block("LOWER", (0.0, 12.0), (-t - gap - 2.0, -t - gap), size)
    for k in range(3):
        deck.face(ZONES["T"][k], strip, "top", (4.0 * k, 4.0 * (k + 1)))
        deck.face(ZONES["B"][k], strip, "bottom", (4.0 * k, 4.0 * (k + 1)))
    deck.face("PAD_TOP_FACE", upper, "bottom")
    deck.face("PAD_BOTTOM_FACE", lower, "top")
    deck.face("PADS", upper, "bottom")
    deck.face("PADS", lower, "top")
    deck.face("LID", upper, "top")
    deck.face("BASE", lower, "bottom")
    deck.face("END", strip, "right")
    deck.face("LOWER_LEFT", lower, "left")                     # shares its corner node with BASE
    path.write_text(deck.text())
    return path


def interfaces(one_target: bool) -> str:
    """The [[model.interfaces]] tables: one interface on PADS, or one per pad."""
    if one_target:
        return ('[[model.interfaces]]\nname = "clamp"\nzones = ["T1", "T2", "T3", "B1", "B2", "B3"]\n'
                'target = "PADS"\n')
    return ('[[model.interfaces]]\nname = "upper"\nzones = ["T1", "T2", "T3"]\ntarget = "PAD_TOP_FACE"\n'
            '[[model.interfaces]]\nname = "lower"\nzones = ["B1", "B2", "B3"]\ntarget = "PAD_BOTTOM_FACE"\n')


def model_table(mesh: str, one_target: bool) -> str:
    """The [model] of the clamp on deck ``mesh``: press the lid (20 MPa), then pull the strip's end 0.05 mm."""
    return (f'[model]\nbuilder = "mesh"\nfile = "{mesh}"\nkind = "plane_strain"\nstages = ["press", "pull"]\n'
            'increments = [1, 5]\n'
            '[model.materials]\nSTRIP = { E = 70000, nu = 0.33 }\nUPPER = { E = 200000, nu = 0.3 }\n'
            'LOWER = { E = 200000, nu = 0.3 }\n'
            '[[model.supports]]\nboundary = "BASE"\ncomponents = ["x", "y"]\n'
            '[[model.supports]]\nboundary = "LID"\ncomponents = ["x"]\n'
            '[[model.loads]]\ntype = "pressure"\nboundary = "LID"\nvalues = [20.0, 20.0]\n'
            '[[model.loads]]\ntype = "displacement"\nboundary = "END"\ncomponent = "x"\nvalues = [0.0, 0.05]\n'
            + interfaces(one_target))


def model_options(mesh: Path, one_target: bool) -> dict:
    """The same [model] as a table (for build_model)."""
    return tomllib.loads(model_table(str(mesh), one_target))["model"]


#: observation points: three rows along the strip and one in each pad (plane strain, z = 0)
POINTS = {**{f"S{k}": (1.0 + 2.0 * (k % 8), (-0.5, 0.0, 0.5)[k // 8]) for k in range(24)},
          "U1": (6.0, 2.0), "L1": (6.0, -2.0)}


def points_csv(quantities=("ux", "uy")) -> str:
    """A measurement file of the points at stage 2 (values are placeholders `frictionid simulate` fills)."""
    rows = "".join(f"{p},{x},{y},0.0,2" + ",0.0" * len(quantities) + "\n" for p, (x, y) in POINTS.items())
    return f"point,x,y,z,stage,{','.join(quantities)}\n" + rows


#: [data] regions: the points by body
REGIONS = "regions = { " + ", ".join(f'{p} = "{"UPPER" if p == "U1" else "LOWER" if p == "L1" else "STRIP"}"'
                                      for p in POINTS) + " }\n"
