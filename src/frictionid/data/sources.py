"""The measurement files of a config's ``[data]`` table: one file or a list (one per stage, or tables with their
stage, force, camera view and frame), generic CSV or DIC exports, read into one Measurements table in the model's
frame (docs/data.md)."""

from __future__ import annotations

import difflib
import hashlib
import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..options import DataSpec
from .dic import is_generic, read_export, read_text
from .dic.window import FileWindow, HeaderWindow, WindowChoice, choose
from .frame_fit import fit_to_points, fit_to_surface, residual_check
from .frames import FrameSpec, frame_spec, in_model_frame
from .measurements import read_measurements
from .plane import onto_plane, plane_tolerance
from .table import Measurements

log = logging.getLogger(__name__)

#: keys of a table entry of ``[data] file``
ENTRY_KEYS = ("path", "stage", "force", "format", "columns", "view", "specimen", "transform", "relative_to",
              "coordinates")
#: what an export's coordinate columns may hold (``coordinates``): reference or deformed positions
COORDINATES = ("reference", "deformed")
#: joins a view's name and a point's label in the file: "front/12"
VIEW_SEPARATOR = "/"


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
    view: str | None = None
    transform: FrameSpec | None = None
    relative_to: str | None = None
    specimen: str | None = None
    #: "reference" or "deformed": what the export's coordinate columns hold (None: as its reader knows)
    coordinates: str | None = None

    def label(self, label: str) -> str:
        """A point's label in the data: the file's, after ``specimen/`` and ``view/`` where the entry names them."""
        return VIEW_SEPARATOR.join(p for p in (self.specimen, self.view, label) if p is not None)


def entries(data: DataSpec, resolve, where: str = "[data]") -> list[Entry]:
    """The files of ``data.file`` in order; ``resolve`` turns a config path into a Path.

    A string is one file (an export in it is stage 1); a list gives one file per stage in stage order, each a
    string or a table ``{ path = "...", stage = 2, force = 1200.0, format = "...", columns = {...},
    view = "front", transform = {...}, relative_to = "12" }``; ``[data] transform`` and ``relative_to`` hold for
    the entries that give none.
    """
    files = data.file
    items = files if isinstance(files, list) else [files]
    if not items:
        raise InputError(f"{where}: [data] file is an empty list; give at least one file")
    return [_entry(item, position, data, resolve, where) for position, item in enumerate(items, start=1)]


def _entry(item, position: int, data: DataSpec, resolve, where: str) -> Entry:
    if isinstance(item, str):
        item = {"path": item}
    if not isinstance(item, dict) or not isinstance(item.get("path"), str):
        raise InputError(f"{where}: [data] file entry {position} must be a file name or a table "
                         f"{{ path = \"...\", stage = ..., force = ... }}, got {item!r}")
    unknown = [k for k in item if k not in ENTRY_KEYS]
    if unknown:
        close = difflib.get_close_matches(unknown[0], ENTRY_KEYS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise InputError(f"{where}: [data] file entry {position}: unknown key {', '.join(map(repr, unknown))}"
                         f"{hint}; known: {', '.join(ENTRY_KEYS)}")
    stage = item.get("stage", position)
    if isinstance(stage, bool) or not isinstance(stage, int) or stage < 1:
        raise InputError(f"{where}: [data] file entry {position}: stage must be a positive whole number, "
                         f"got {stage!r}")
    force = item.get("force", _listed_force(data.forces, stage, where))
    if force is not None and (isinstance(force, bool) or not isinstance(force, (int, float))
                              or not math.isfinite(force)):
        raise InputError(f"{where}: [data] force of stage {stage} must be a finite number [N], got {force!r}")
    transform, key = (item["transform"], f"{where}: [data] file entry {position} transform") \
        if "transform" in item else (data.transform, f"{where}: [data] transform")
    return Entry(resolve(item["path"]), stage,
                 None if force is None else float(force), item.get("format", data.format),
                 item.get("columns", data.columns) or None, _name(item, "view", position, where),
                 None if transform is None else frame_spec(transform, key),
                 _relative_to(item.get("relative_to", data.relative_to), position, where),
                 _name(item, "specimen", position, where), _coordinates(item, data, position, where))


def _coordinates(item: dict, data: DataSpec, position: int, where: str) -> str | None:
    value = item.get("coordinates", data.coordinates)
    if value is not None and value not in COORDINATES:
        raise InputError(f"{where}: [data] file entry {position}: coordinates must be \"reference\" or "
                         f"\"deformed\" (what the export's coordinate columns hold), got {value!r}")
    return value


def _name(item: dict, key: str, position: int, where: str) -> str | None:
    name = item.get(key)
    if name is not None and (not isinstance(name, str) or not name or VIEW_SEPARATOR in name
                             or any(c in name for c in "*?[:@")):
        raise InputError(f"{where}: [data] file entry {position}: {key} must be a name without "
                         f"{VIEW_SEPARATOR!r}, ':', '@' or pattern characters, e.g. {key} = \"front\", got {name!r}")
    return name


def _relative_to(label, position: int, where: str) -> str | None:
    if label is not None and not isinstance(label, str):
        raise InputError(f"{where}: [data] file entry {position}: relative_to must be a point label of the file "
                         f"(a string, e.g. \"12\"), got {label!r}")
    return label


def _listed_force(forces, stage: int, where: str):
    if forces is None:
        return None
    if not all(isinstance(f, (int, float)) and not isinstance(f, bool) for f in forces):
        raise InputError(f"{where}: [data] forces must be a list of numbers [N], one per stage, got {forces!r}")
    return forces[stage - 1] if stage <= len(forces) else None


@dataclass(frozen=True)
class Sources:
    """What ``[data] file`` gave: the measurements (model frame, labels with their views), what was recognised in
    each file (report lines), the frame of each file that has one (result.json's ``data.frames``), per point
    label the label of the point whose displacement its displacements are taken relative to, and per point label
    its specimen (where files name specimens)."""

    measurements: Measurements
    lines: list[str]
    frames: list[dict] = field(default_factory=list)
    relative: dict[str, str] = field(default_factory=dict)
    specimens: dict[str, str] = field(default_factory=dict)
    #: the fit's strain window (config or the exports' headers), :class:`~.dic.window.WindowChoice`
    window: WindowChoice | None = None
    #: how each export was read (result.json's ``data.files``: format, coordinates, strain measure, points)
    files: list[dict] = field(default_factory=list)
    #: what an identification needs that the files do not give (read with ``check``), one line each
    needed: list[str] = field(default_factory=list)
    #: points of a plane model's data projected onto its plane (how many, the largest |z|), None: none moved
    plane: str | None = None


def read_data(data: DataSpec, resolve, where: str = "[data]", model=None) -> Measurements:
    """Every file of ``[data] file`` read into one table (see :func:`read_sources`)."""
    return read_sources(data, resolve, where, model).measurements


def read_data_reported(data: DataSpec, resolve, where: str = "[data]",
                       model=None) -> tuple[Measurements, list[str]]:
    """Every file of ``[data] file`` read into one table, and what was recognised in each (report lines)."""
    sources = read_sources(data, resolve, where, model)
    return sources.measurements, sources.lines


def read_sources(data: DataSpec, resolve, where: str = "[data]", model=None, check: bool = False) -> Sources:
    """Every file of ``[data] file`` read into one table in the model's frame, with what was recognised.

    ``model`` gives the surface a frame is fitted to (``fit = "surface"``); it is not needed otherwise. With
    ``check`` (``frictionid check-data``) what only an identification needs (a strain measure the file does not
    state, a machine force) is listed in ``needed`` instead of refused.

    Raises
    ------
    InputError
        A bad entry or transform, a file no reader recognises, a (point, stage) given by two files, a force that
        contradicts the file's, a reference point the file does not have.
    """
    parts, lines, frames, relative, fitted, specimens, windows, files, needed = [], [], [], {}, {}, {}, [], [], []
    listed = entries(data, resolve, where)
    if any(e.specimen is not None for e in listed) and any(e.specimen is None for e in listed):
        raise InputError(f"{where}: [data] file: some entries name a specimen and some do not; give every file its "
                         "specimen")
    for entry in listed:
        measurements, report, generic, flavour, header, read = _read(entry, data.strain, check, where)
        if read is not None:
            files.append(read.as_dict())
            needed += [f"{n}: {entry.path}" for n in read.needed]
        forces = {s: _listed_force(data.forces, s, where) for s in measurements.stages} if generic \
            else {entry.stage: entry.force}
        measurements = _with_forces(measurements, {s: f for s, f in forces.items() if f is not None})
        strains = any(q[0] == "e" for q in measurements.quantities)
        frame = None
        if entry.transform is not None:
            measurements, frame = _framed(entry, measurements, model, fitted, data.noise)
            frames.append(frame)
            report = report + [f"  {frame['line']}"]
            log.info("%s: %s", entry.path, frame["line"])
        elif flavour == "matchid":
            report = report + [f"  note: {MATCHID_NOTE}"]
            log.warning("%s: %s", entry.path, MATCHID_NOTE)
            needed.append(f"[data] transform (unless the model's y points down as MatchID's does): {entry.path}")
        windows.append(FileWindow(str(entry.path), header, 1.0 if frame is None else float(frame["scale"]), strains))
        relative.update(_relative_labels(entry, measurements, relative))
        if entry.specimen is not None:
            specimens.update({entry.label(p): entry.specimen for p in measurements.points})
        parts.append(_with_view(entry, measurements))
        lines += report + ([f"  points labelled '{entry.label('<point>')}'"] if entry.view or entry.specimen
                           else [])
    window = choose(data.strain_window, data.strain_window_shape, windows)
    joined, plane = _joined(parts), None
    if model is not None and model.kind == "plane_strain":
        joined, plane = onto_plane(joined, plane_tolerance(data.plane_tolerance, where), model.kind)
        lines += [plane] if plane else []
    observed = data.observables if data.observables is not None else ("force",)
    if check and "force" in observed and np.any(np.isnan(joined.force)):
        stages = sorted({int(s) for s in joined.stage[np.isnan(joined.force)]})
        needed.append(f"[data] forces (or a file's force), where force is observed: no machine force for stage(s) "
                      f"{', '.join(map(str, stages))}")
    return Sources(joined, lines, frames, relative, specimens, window, files, needed, plane)


#: MatchID's frame (docs/data.md): read as written, turned by a transform
MATCHID_NOTE = ("MatchID writes Y (and V) downwards, as in the image; read as written (no transform): a model "
                "with y up needs transform = { rotation_deg = [180, 0, 0] } (y and z turned)")


def _read(entry: Entry, strain: str | None, check: bool = False, where: str = "[data]"):
    """(measurements, report lines, generic?, flavour, header window, ExportReport or None for a generic CSV)."""
    text = read_text(entry.path, n_rows=50)         # the header tells the generic CSV from an export
    if entry.format == "generic" or entry.format is None and not entry.columns and is_generic(text):
        if entry.coordinates == "deformed":
            raise InputError(f"{where}: [data] coordinates = \"deformed\" is for DIC exports; {entry.path} is a "
                             "generic CSV, whose x, y, z are reference positions (docs/data.md)")
        m = read_measurements(entry.path)
        return (m, [f"{entry.path}: generic CSV, stages {', '.join(map(str, m.stages))} from its stage column"],
                True, "generic", None, None)
    m, report = read_export(entry.path, entry.stage, entry.format, entry.columns, strain, check, entry.coordinates)
    return m, report.lines(), False, report.flavour, report.window, report


def _framed(entry: Entry, m: Measurements, model, fitted: dict, noise=None) -> tuple[Measurements, dict]:
    """``m`` in the model's frame by the entry's transform (fitted once per transform and set of points); a fitted
    frame whose residual is far above the displacement ``noise`` (``[data] noise``) carries a warning."""
    spec = entry.transform
    labels = list(dict.fromkeys(m.points))
    first = {p: i for i, p in reversed(list(enumerate(m.points)))}
    xyz = m.coordinates[[first[p] for p in labels]]
    if spec.fit is None:
        frame, report = spec.frame, {"fit": None, **spec.frame.as_dict()}
        line = (f"frame given: rotation_deg = [{', '.join(f'{a + 0.0:.6g}' for a in frame.rotation_deg())}], "
                f"translation = [{', '.join(f'{t + 0.0:.6g}' for t in frame.translation)}] mm, scale {frame.scale:g}")
    else:
        key = (spec.key, xyz.tobytes(), tuple(labels))
        if key not in fitted:
            fitted[key] = fit_to_points(spec, labels, xyz, str(entry.path)) if spec.fit == "points" else \
                fit_to_surface(spec, labels, xyz, _surface(spec, model), str(entry.path))
        fit = fitted[key]
        frame, report, line = fit.frame, fit.as_dict(), fit.line()
        warning = residual_check(fit, _displacement_noise(noise), xyz, 3 if model is None else model.mesh.dim,
                                 spec.key)
        if warning:
            log.warning("%s: %s", entry.path, warning)
            report, line = {**report, "warning": warning}, f"{line}; {warning}"
    note = f"frame: {line}"
    return (in_model_frame(m, frame, note),
            {"file": str(entry.path), "stage": entry.stage, "view": entry.view, **report, "line": line})


def _displacement_noise(noise) -> float | None:
    """The in-plane displacement noise [mm] of a ``[data] noise`` table (ux's, else u's), None where not given."""
    if not isinstance(noise, dict):
        return None
    value = noise.get("ux", noise.get("u"))
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0 else None


def _surface(spec: FrameSpec, model):
    from ..fem.surface import mesh_surface
    if model is None:
        raise InputError(f"{spec.key}: fit = \"surface\" needs the model's surface; it is fitted by identify, "
                         "simulate and check-data CONFIG.toml, not check-data FILE")
    if model.kind == "axisymmetric":
        raise InputError(f"{spec.key}: fit = \"surface\" is not available for an axisymmetric model (its surface "
                         "turns about the axis, which leaves that turn free); use fit = \"points\"")
    try:
        return mesh_surface(model.mesh, spec.regions)
    except InputError as exc:
        raise InputError(f"{spec.key}.{exc}") from None


def _relative_labels(entry: Entry, m: Measurements, known: dict) -> dict:
    """label -> reference label for the entry's points (with their views), checked against the file."""
    if entry.relative_to is None:
        return {}
    if entry.relative_to not in m.points:
        shown = ", ".join(list(dict.fromkeys(m.points))[:8])
        raise InputError(f"{entry.path}: relative_to = {entry.relative_to!r} is not a point of this file "
                         f"(its points: {shown}, ...)")
    out = {entry.label(p): entry.label(entry.relative_to) for p in dict.fromkeys(m.points)}
    clash = [p for p, r in out.items() if known.get(p, r) != r]
    if clash:
        raise InputError(f"{entry.path}: point {clash[0]!r} is relative to {out[clash[0]]!r} here and to "
                         f"{known[clash[0]]!r} in another file; give one relative_to per point")
    return out


def _with_view(entry: Entry, m: Measurements) -> Measurements:
    if entry.view is None and entry.specimen is None:
        return m
    return Measurements(tuple(entry.label(p) for p in m.points), m.coordinates, m.stage, m.force, m.values,
                        m.sigma, m.comments + (f"labelled {entry.label('<point>')!r}",), m.source, m.channels)


def _with_forces(m: Measurements, forces: dict[int, float]) -> Measurements:
    """``m`` with the machine force of each stage in ``forces`` (stage -> N) where its rows give none."""
    force = m.force.copy()
    for stage, value in forces.items():
        rows = m.stage == stage
        given = rows & ~np.isnan(m.force)
        if np.any(m.force[given] != value):
            raise InputError(f"{m.source}: stage {stage}: the file gives the force {float(m.force[given][0])!r} N, the "
                             f"config {value!r} N; give one of them")
        force[rows] = value
    return Measurements(m.points, m.coordinates, m.stage, force, m.values, m.sigma, m.comments, m.source, m.channels)


def _joined(parts: list[Measurements]) -> Measurements:
    if len(parts) == 1:
        return parts[0]
    first = {}
    for m in parts:
        for key in zip(m.points, m.stage.tolist()):
            if key in first:
                raise InputError(f"{m.source}: point {key[0]!r} at stage {key[1]} is also in {first[key]}; one "
                                 "file per stage, or several views of one stage, each with view = \"name\" "
                                 "(its points are then labelled name/point) and its own transform")
            first[key] = m.source
    names = [q for q in dict.fromkeys(q for m in parts for q in m.quantities)]
    nan = lambda m: np.full(m.n_rows, np.nan)  # noqa: E731
    return Measurements(
        points=sum((m.points for m in parts), ()), coordinates=np.vstack([m.coordinates for m in parts]),
        stage=np.concatenate([m.stage for m in parts]), force=np.concatenate([m.force for m in parts]),
        values={q: np.concatenate([m.values.get(q, nan(m)) for m in parts]) for q in names},
        sigma={q: np.concatenate([m.sigma.get(q, nan(m)) for m in parts])
               for q in names if any(q in m.sigma for m in parts)},
        comments=sum((m.comments for m in parts), ()), source=", ".join(m.source for m in parts),
        channels={c: np.concatenate([m.channels.get(c, nan(m)) for m in parts])
                  for c in dict.fromkeys(c for m in parts for c in m.channels)})


def data_paths(data: DataSpec, resolve) -> list[Path]:
    """The files ``[data] file`` names, in order."""
    files = data.file
    items = files if isinstance(files, list) else [files]
    return [resolve(i["path"] if isinstance(i, dict) else i) for i in items]


def data_digest(data: DataSpec, resolve) -> str:
    """SHA-256 of the bytes of every file of ``[data] file`` and of what its table says besides the path (stage,
    force, view, transform, ...), so that a run is not resumed with another frame; one file named by a string:
    the hash of its bytes, as before."""
    files = data.file
    items = files if isinstance(files, list) else [files]
    paths = data_paths(data, resolve)
    if len(paths) == 1 and isinstance(items[0], str):
        return hashlib.sha256(paths[0].read_bytes()).hexdigest()
    h = hashlib.sha256()
    for item, path in zip(items, paths):
        h.update(hashlib.sha256(path.read_bytes()).digest())
        if isinstance(item, dict):
            h.update(json.dumps({k: v for k, v in item.items() if k != "path"}, sort_keys=True,
                                default=str).encode())
    return h.hexdigest()


def check_data(path, format: str | None = None, strain: str | None = None) -> str:
    """What ``frictionid check-data FILE`` prints: what was recognised (flavour, columns, units, strain measure,
    valid and dropped points) and the summary of the measurements. An export is shown as stage 1."""
    sources = read_sources(DataSpec(file=str(path), format=format, strain=strain), Path, check=True)
    return "\n".join(sources.lines + [sources.measurements.summary()] + needed_lines(sources.needed))


def needed_lines(needed: list[str]) -> list[str]:
    """check-data's last lines: what an identification will need besides the files (none: no line)."""
    if not needed:
        return []
    keys = ", ".join(dict.fromkeys(n.split(" (")[0].split(":")[0] for n in needed))
    return [f"needed to identify: {keys}"] + [f"  {n}" for n in needed]


def fits_surface(data: DataSpec) -> bool:
    """Whether a transform of ``[data]`` is fitted to the model's surface (so reading it needs the model)."""
    files = data.file
    tables = [data.transform] + [i.get("transform") for i in (files if isinstance(files, list) else [])
                                        if isinstance(i, dict)]
    return any(isinstance(t, dict) and t.get("fit") == "surface" for t in tables)


def check_config_data(data: DataSpec, resolve, where: str = "[data]", model=None) -> str:
    """What ``frictionid check-data CONFIG.toml`` prints: every file of a config's ``[data]`` as identify reads
    it (frames given or fitted with their residuals, views, relative points) and the summary of the whole;
    ``resolve`` turns the config's paths into Paths, ``where`` names the config in messages."""
    sources = read_sources(data, resolve, where, model, check=True)
    relative = sorted(set(sources.relative.values()))
    return "\n".join(sources.lines + ([f"displacements relative to point(s) {', '.join(relative)}"] if relative
                                       else []) + list(sources.window.lines) + [sources.measurements.summary()]
                      + needed_lines(sources.needed))
