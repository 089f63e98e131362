"""The measurement files of a config's ``[data]`` table: one file or a list (one per stage, or tables with their
stage and force), generic CSV or DIC exports, read into one Measurements table (docs/data.md)."""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from .dic import is_generic, read_export, read_text
from .measurements import read_measurements
from .table import Measurements

#: keys of a table entry of ``[data] file``
ENTRY_KEYS = ("path", "stage", "force", "format", "columns", "transform")


@dataclass(frozen=True)
class Entry:
    """One file of ``[data] file``: its path, the stage of an export's rows (its position in the list unless
    the table says; a generic CSV keeps its own ``stage`` column), its machine force [N] (None: from ``forces``
    or the file), and how to read it."""

    path: Path
    stage: int
    force: float | None
    format: str | None
    columns: dict | None


def entries(data: dict, resolve, where: str = "[data]") -> list[Entry]:
    """The files of ``data["file"]`` in order; ``resolve`` turns a config path into a Path.

    A string is one file (an export in it is stage 1); a list gives one file per stage in stage order, each a
    string or a table ``{ path = "...", stage = 2, force = 1200.0, format = "...", columns = {...} }``.
    """
    _refuse_transform(data.get("transform"), f"{where}: [data] transform")
    files = data["file"]
    items = files if isinstance(files, list) else [files]
    if not items:
        raise InputError(f"{where}: [data] file is an empty list; give at least one file")
    return [_entry(item, position, data, resolve, where) for position, item in enumerate(items, start=1)]


def _entry(item, position: int, data: dict, resolve, where: str) -> Entry:
    if isinstance(item, str):
        item = {"path": item}
    if not isinstance(item, dict) or not isinstance(item.get("path"), str):
        raise InputError(f"{where}: [data] file entry {position} must be a file name or a table "
                         f"{{ path = \"...\", stage = ..., force = ... }}, got {item!r}")
    unknown = [k for k in item if k not in ENTRY_KEYS]
    if unknown:
        raise InputError(f"{where}: [data] file entry {position}: unknown key {', '.join(map(repr, unknown))}; "
                         f"known: {', '.join(ENTRY_KEYS)}")
    _refuse_transform(item.get("transform"), f"{where}: [data] file entry {position} transform")
    stage = item.get("stage", position)
    if isinstance(stage, bool) or not isinstance(stage, int) or stage < 1:
        raise InputError(f"{where}: [data] file entry {position}: stage must be a positive whole number, "
                         f"got {stage!r}")
    force = item.get("force", _listed_force(data.get("forces"), stage, where))
    if force is not None and (isinstance(force, bool) or not isinstance(force, (int, float))
                              or not math.isfinite(force)):
        raise InputError(f"{where}: [data] force of stage {stage} must be a finite number [N], got {force!r}")
    return Entry(resolve(item["path"]), stage,
                 None if force is None else float(force), item.get("format", data.get("format")),
                 item.get("columns", data.get("columns")) or None)


def _listed_force(forces, stage: int, where: str):
    if forces is None:
        return None
    if not all(isinstance(f, (int, float)) and not isinstance(f, bool) for f in forces):
        raise InputError(f"{where}: [data] forces must be a list of numbers [N], one per stage, got {forces!r}")
    return forces[stage - 1] if stage <= len(forces) else None


def _refuse_transform(value, what: str) -> None:
    if value is not None:
        raise InputError(f"{what}: mapping a DIC frame onto the model's frame is not available yet; export the "
                         "points in the model's frame (undeformed coordinates, mm) and leave transform out")


def read_data(data: dict, resolve, where: str = "[data]") -> Measurements:
    """Every file of ``[data] file`` read into one table (see :func:`read_data_reported`)."""
    return read_data_reported(data, resolve, where)[0]


def read_data_reported(data: dict, resolve, where: str = "[data]") -> tuple[Measurements, list[str]]:
    """Every file of ``[data] file`` read into one table, and what was recognised in each (report lines).

    Raises
    ------
    InputError
        A bad entry, a file no reader recognises, a (point, stage) given by two files, a force that
        contradicts the file's.
    """
    parts, lines = [], []
    for entry in entries(data, resolve, where):
        measurements, report, generic = _read(entry, data.get("strain"))
        forces = {s: _listed_force(data.get("forces"), s, where) for s in measurements.stages} if generic \
            else {entry.stage: entry.force}
        parts.append(_with_forces(measurements, {s: f for s, f in forces.items() if f is not None}))
        lines += report
    return _joined(parts), lines


def _read(entry: Entry, strain: str | None) -> tuple[Measurements, list[str], bool]:
    text = read_text(entry.path)
    if entry.format == "generic" or entry.format is None and not entry.columns and is_generic(text):
        m = read_measurements(entry.path)
        return m, [f"{entry.path}: generic CSV, stages {', '.join(map(str, m.stages))} from its stage column"], True
    m, report = read_export(entry.path, entry.stage, entry.format, entry.columns, strain)
    return m, report.lines(), False


def _with_forces(m: Measurements, forces: dict[int, float]) -> Measurements:
    """``m`` with the machine force of each stage in ``forces`` (stage -> N) where its rows give none."""
    force = m.force.copy()
    for stage, value in forces.items():
        rows = m.stage == stage
        given = rows & ~np.isnan(m.force)
        if np.any(m.force[given] != value):
            raise InputError(f"{m.source}: stage {stage}: the file gives the force {m.force[given][0]!r} N, the "
                             f"config {value!r} N; give one of them")
        force[rows] = value
    return Measurements(m.points, m.coordinates, m.stage, force, m.values, m.sigma, m.comments, m.source)


def _joined(parts: list[Measurements]) -> Measurements:
    if len(parts) == 1:
        return parts[0]
    first = {}
    for m in parts:
        for key in zip(m.points, m.stage.tolist()):
            if key in first:
                raise InputError(f"{m.source}: point {key[0]!r} at stage {key[1]} is also in {first[key]}; one "
                                 "file per stage (several views of one stage need transforms, not yet available)")
            first[key] = m.source
    names = [q for q in dict.fromkeys(q for m in parts for q in m.quantities)]
    nan = lambda m: np.full(m.n_rows, np.nan)  # noqa: E731
    return Measurements(
        points=sum((m.points for m in parts), ()), coordinates=np.vstack([m.coordinates for m in parts]),
        stage=np.concatenate([m.stage for m in parts]), force=np.concatenate([m.force for m in parts]),
        values={q: np.concatenate([m.values.get(q, nan(m)) for m in parts]) for q in names},
        sigma={q: np.concatenate([m.sigma.get(q, nan(m)) for m in parts])
               for q in names if any(q in m.sigma for m in parts)},
        comments=sum((m.comments for m in parts), ()), source=", ".join(m.source for m in parts))


def data_paths(data: dict, resolve) -> list[Path]:
    """The files ``[data] file`` names, in order."""
    files = data["file"]
    items = files if isinstance(files, list) else [files]
    return [resolve(i["path"] if isinstance(i, dict) else i) for i in items]


def data_digest(data: dict, resolve) -> str:
    """SHA-256 of the bytes of every file of ``[data] file`` (one file: the hash of its bytes, as before)."""
    paths = data_paths(data, resolve)
    if len(paths) == 1:
        return hashlib.sha256(paths[0].read_bytes()).hexdigest()
    h = hashlib.sha256()
    for path in paths:
        h.update(hashlib.sha256(path.read_bytes()).digest())
    return h.hexdigest()


def check_data(path, format: str | None = None, strain: str | None = None) -> str:
    """What ``frictionid check-data FILE`` prints: what was recognised (flavour, columns, units, strain measure,
    valid and dropped points) and the summary of the measurements. An export is shown as stage 1."""
    m, lines = read_data_reported({"file": str(path), "format": format, "strain": strain}, Path)
    return "\n".join(lines + [m.summary()])
