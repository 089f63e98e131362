"""Readers of CalculiX 2.20 result files: the .dat print file and the ASCII .frd result file.

Both are Fortran formatted: numbers with a three-digit exponent lose their 'E' (``-2.961518-105``), and the
.frd fields are fixed width (``i3, i10, 6e12.5``), so neighbouring values can run together without a blank.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import SolverError

#: a Fortran real: mantissa with a decimal point, exponent with 'E' or (three digits) without it
_REAL = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+)(?:[eEdD][-+]?\d+|[-+]\d{3}(?![\d.]))?|[-+]?(?:NaN|Infinity|Inf)\b",
                   re.IGNORECASE)
_HEADER = re.compile(r"^\s*(?P<what>.+?) for set (?P<set>\S+) and time\s+(?P<time>\S+)\s*$")
_STATISTICS = re.compile(r"^\s*statistics for slave set (?P<slave>\S+), master set (?P<master>\S+) "
                         r"and time\s+(?P<time>\S+)\s*$")


def fortran_float(text: str) -> float:
    """A Fortran formatted real as float, also without the 'E' of a three-digit exponent.

    >>> fortran_float("-2.961518-105")
    -2.961518e-105
    """
    text = text.strip()
    if text.lstrip("+-").lower() in ("nan", "inf", "infinity"):
        return float(text)
    text = text.replace("D", "E").replace("d", "E")
    if "E" not in text.upper():
        cut = max(text.rfind("-"), text.rfind("+"))
        if cut > 0:
            text = f"{text[:cut]}E{text[cut:]}"
    return float(text)


def reals(text: str) -> list[float]:
    """All reals on a line, also where two of them run together (``1.0E+00-2.0E+00``); NaN as printed by ccx."""
    return [fortran_float(token) for token in _REAL.findall(text)]


@dataclass
class DatFile:
    """Contents of a .dat file, keyed by (what, set name) and then by time (total time: stage s ends at s).

    Attributes
    ----------
    nodal : {(what, set): {time: {node: (3,) values}}}, e.g. what = "displacements (vx,vy,vz)"
    totals : {(what, set): {time: (3,) values}}, e.g. what = "total force (fx,fy,fz)"
    contact : {(slave, master): {time: {"force": (3,), "moment": (3,), "area": a, "normal": n, "shear": s}}}
    """

    nodal: dict = field(default_factory=dict)
    totals: dict = field(default_factory=dict)
    contact: dict = field(default_factory=dict)


def _parse_contact(lines: list[str], start: int) -> tuple[dict, int]:
    """The statistics block of one contact pair starting after its header; returns (entry, next line index)."""
    entry, i = {}, start
    while i < len(lines) and not _HEADER.match(lines[i]) and not _STATISTICS.match(lines[i]):
        text = lines[i].strip()
        if text.startswith("total surface force"):
            values = reals(lines[i + 2])
            entry["force"], entry["moment"] = np.array(values[:3]), np.array(values[3:6])
            i += 2
        elif text.startswith("area,"):
            values = reals(lines[i + 2])
            entry.update(area=values[0], normal=values[1], shear=values[2])
            i += 2
        i += 1
    return entry, i


def _parse_rows(lines: list[str], start: int) -> tuple[dict, int]:
    """Rows 'node v1 v2 ...' after a header (a blank line first); returns ({node: values}, next index)."""
    rows, i = {}, start
    while i < len(lines) and not lines[i].strip():
        i += 1
    while i < len(lines) and lines[i].strip():
        text = lines[i]
        match = re.match(r"\s*(\d+)(?!\.)", text)
        if not match:
            break
        rows[int(match.group(1))] = np.array(reals(text[match.end():]))
        i += 1
    return rows, i


def read_dat(path: str | Path) -> DatFile:
    """Parse a CalculiX .dat file (node prints, totals and contact statistics).

    Raises
    ------
    SolverError
        If the file cannot be read or a block is cut off.
    """
    try:
        lines = Path(path).read_text(errors="replace").splitlines()
    except OSError as exc:
        raise SolverError(f"CalculiX output {path} cannot be read ({exc.strerror})") from None
    out, i = DatFile(), 0
    try:
        while i < len(lines):
            header, stats = _HEADER.match(lines[i]), _STATISTICS.match(lines[i])
            if stats:
                entry, i = _parse_contact(lines, i + 1)
                pair = (stats["slave"], stats["master"])
                out.contact.setdefault(pair, {})[fortran_float(stats["time"])] = entry
                continue
            if header:
                key, time = (header["what"].strip(), header["set"]), fortran_float(header["time"])
                if key[0].startswith("total"):
                    out.totals.setdefault(key, {})[time], i = _total_row(lines, i + 1)
                else:
                    out.nodal.setdefault(key, {})[time], i = _parse_rows(lines, i + 1)
                continue
            i += 1
    except (IndexError, ValueError) as exc:
        raise SolverError(f"CalculiX output {path}: cannot parse line {i + 1} ({exc})") from None
    return out


def _total_row(lines: list[str], i: int) -> tuple[np.ndarray, int]:
    """The values of a 'total ...' block (first non-blank line after the header) and the next index."""
    while not lines[i].strip():
        i += 1
    values = reals(lines[i])
    if not values:
        raise ValueError("a total without values")
    return np.array(values), i + 1


@dataclass(frozen=True)
class FrdBlock:
    """One nodal result block of a .frd file.

    Attributes
    ----------
    name : e.g. "DISP"; step, increment : CalculiX step and increment (1-based); time : total time
    nodes : (n,) CalculiX node numbers; values : (n, n_components)
    """

    name: str
    step: int
    increment: int
    time: float
    nodes: np.ndarray
    values: np.ndarray


@dataclass(frozen=True)
class FrdFile:
    """Node coordinates (CalculiX numbers -> (3,) [mm]) and the result blocks of a .frd file."""

    nodes: np.ndarray
    coordinates: np.ndarray
    blocks: tuple[FrdBlock, ...]

    def last_of_step(self, name: str, step: int) -> FrdBlock:
        """The last block named ``name`` of a step; a :class:`SolverError` if the step wrote none."""
        found = [b for b in self.blocks if b.name == name and b.step == step]
        if not found:
            raise SolverError(f"the .frd file has no {name} result for step {step}")
        return found[-1]


def _fixed_fields(line: str, width: int = 12) -> tuple[int, list[float]]:
    """Node number (columns 4-13) and the fixed-width reals after it of a ' -1' record."""
    body = line.rstrip("\n")[13:]
    values = [fortran_float(body[k:k + width]) for k in range(0, len(body.rstrip()), width)]
    return int(line[3:13]), values


def _records(lines: list[str], i: int) -> tuple[np.ndarray, np.ndarray, int]:
    """' -1' (and continuation ' -2') records up to ' -3': node numbers, values, index after ' -3'."""
    nodes, values = [], []
    while i < len(lines) and not lines[i].startswith(" -3"):
        if lines[i].startswith(" -1"):
            node, row = _fixed_fields(lines[i])
            nodes.append(node)
            values.append(row)
        elif lines[i].startswith(" -2"):
            values[-1] = values[-1] + _fixed_fields(lines[i])[1]
        i += 1
    if i >= len(lines):
        raise SolverError("the .frd file ends inside a block (incomplete output)")
    width = max((len(v) for v in values), default=0)
    if any(len(v) != width for v in values):
        raise SolverError("the .frd file has a block with rows of different lengths")
    return np.array(nodes, dtype=np.int64), np.array(values, dtype=float).reshape(len(values), width), i + 1


def read_frd(path: str | Path) -> FrdFile:
    """Parse an ASCII CalculiX .frd file: node coordinates and nodal result blocks (element blocks skipped).

    Raises
    ------
    SolverError
        If the file cannot be read, has no node block, or ends inside a block.
    """
    try:
        lines = Path(path).read_text(errors="replace").splitlines()
    except OSError as exc:
        raise SolverError(f"CalculiX output {path} cannot be read ({exc.strerror})") from None
    nodes = coordinates = None
    blocks, step, increment, time, i = [], 0, 0, 0.0, 0
    try:
        while i < len(lines):
            line = lines[i]
            if line.startswith("    2C"):
                nodes, coordinates, i = _records(lines, i + 1)
                continue
            if line.startswith("    3C"):
                i = _skip_block(lines, i + 1)
                continue
            if line.startswith("    1PSTEP"):
                increment, step = (int(v) for v in line.split()[2:4])
            elif line.startswith("  100C"):
                time = fortran_float(line[12:24])
            elif line.startswith(" -4"):
                name = line[3:].split()[0]
                block_nodes, values, i = _records(lines, i + 1)
                blocks.append(FrdBlock(name, step, increment, time, block_nodes, values))
                continue
            i += 1
    except ValueError as exc:
        raise SolverError(f"CalculiX output {path}: cannot parse line {i + 1} ({exc})") from None
    if nodes is None:
        raise SolverError(f"CalculiX output {path} has no node block (incomplete output)")
    return FrdFile(nodes, coordinates, tuple(blocks))


def _skip_block(lines: list[str], i: int) -> int:
    while i < len(lines) and not lines[i].startswith(" -3"):
        i += 1
    if i >= len(lines):
        raise SolverError("the .frd file ends inside the element block (incomplete output)")
    return i + 1
