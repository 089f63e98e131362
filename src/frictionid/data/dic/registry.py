"""Which reader a DIC export needs: recognised from its header, forced with ``format``, or mapped with ``columns``;
never guessed (a header no flavour or two flavours claim is an error saying what would work)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...errors import InputError
from . import aramis, davis, dice, gom, matchid, vic3d
from .layout import TARGETS, ExportReport, Layout, read_layout
from .text import ExportText, name_unit, read_text

#: the export flavours by ``format`` name, in the order they are tried
FLAVOURS = {m.NAME: m for m in (dice, vic3d, matchid, gom, aramis, davis)}
#: every ``format`` value: the generic CSV, the flavours
FORMATS = ("generic",) + tuple(FLAVOURS)


def is_generic(text: ExportText) -> bool:
    """The generic CSV of docs/data.md has a ``point`` and a ``stage`` column."""
    return "point" in text.names and "stage" in text.names


def choose_layout(text: ExportText, format: str | None = None, columns: dict | None = None) -> Layout:
    """The layout of ``text``: the flavour ``format`` names, else the one flavour that recognises the header;
    ``columns`` (target -> column name) replaces or adds single columns (and, without ``format``, is the whole
    layout)."""
    where = f"{text.source}:{text.header_line}"
    if format is not None and format not in FLAVOURS:
        raise InputError(f"{text.source}: [data] format = {format!r} is not one of {', '.join(FORMATS)}")
    if columns:
        _check_columns_option(text, columns)
        # "X [mm]" as written in the file names the column X (its unit is read from the header)
        columns = {t: c if c in text.names else name_unit(c)[0] for t, c in columns.items()}
    name = format if format is not None else None if columns else _recognise(text, where)
    try:
        base = FLAVOURS[name].layout(text.names) if name else Layout("columns", {}, None, "",
                                                                     column_units=_pixel_columns(text))
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    from_text = getattr(FLAVOURS.get(name), "from_text", None)
    base = from_text(base, text) if from_text else base
    if not columns:
        return base
    mapped = {**base.columns, **columns}
    return replace(base, flavour=base.flavour + (" + columns" if name else ""),
                   columns={t: mapped[t] for t in TARGETS if t in mapped})


def _pixel_columns(text: ExportText) -> dict[str, str]:
    """The columns in image pixels of the flavours that recognise the header (DICe's COORDINATE_X, VIC's x, ...):
    a ``columns`` mapping without ``format`` must not take them for lengths."""
    found = {}
    for flavour in FLAVOURS.values():
        if flavour.recognise(text.names):
            found.update(getattr(flavour, "PIXEL_COLUMNS", {}))
    return found


def _recognise(text: ExportText, where: str) -> str:
    found = [name for name, flavour in FLAVOURS.items() if flavour.recognise(text.names)]
    if len(found) == 1:
        return found[0]
    if found:
        raise InputError(f"{where}: the header fits several exports ({', '.join(found)}); choose one with "
                         f"[data] format = \"...\"; the header has {text.header()}")
    expected = "\n".join(f"  {name:8s} {f.TITLE}: {f.KEY_COLUMNS}" for name, f in FLAVOURS.items())
    raise InputError(
        f"{where}: no known layout in this header: {text.header()}.\nExpected one of:\n"
        f"  generic  frictionid's CSV: point, x, y, z, stage, ux, ... (docs/data.md)\n{expected}\n"
        f"or name the columns: [data] columns = {{ x = \"...\", y = \"...\", ux = \"...\", ... }} "
        f"(targets: {', '.join(TARGETS)}), with [data] format = \"...\" to force a flavour")


def _check_columns_option(text: ExportText, columns: dict) -> None:
    unknown = [t for t in columns if t not in TARGETS]
    if unknown:
        raise InputError(f"{text.source}: [data] columns: {', '.join(map(repr, unknown))} not among "
                         f"{', '.join(TARGETS)}")
    for target, name in columns.items():
        if not isinstance(name, str):
            raise InputError(f"{text.source}: [data] columns.{target} must be a column name, got {name!r}")


def read_export(path, stage: int, format: str | None = None, columns: dict | None = None,
                strain: str | None = None, check: bool = False, coordinates: str | None = None):
    """Read one DIC export as the measurements of ``stage``; returns (Measurements, ExportReport). ``check``
    (``frictionid check-data``): what only an identification needs (the strain measure) is listed in the
    report's ``needed`` instead of refused. ``coordinates`` (``[data] coordinates``): "reference" or "deformed",
    what the coordinate columns hold where the reader's layout says otherwise (None: the layout's).

    Examples
    --------
    >>> m, report = read_export("stage2.csv", stage=2)  # doctest: +SKIP
    >>> print("\\n".join(report.lines()))  # doctest: +SKIP
    """
    text = read_text(path)
    layout = choose_layout(text, format, columns)
    if coordinates is not None and (coordinates == "deformed") != bool(layout.deformed):
        layout = replace(layout, deformed="[data] coordinates = \"deformed\"" if coordinates == "deformed" else "")
    measurements, report = read_layout(text, layout, stage, strain, check)
    flavour = FLAVOURS.get(layout.flavour.split(" + ")[0])
    force = getattr(flavour, "header_force", None)
    found = force(text) if force and "force" not in layout.columns else None
    if found is not None:
        measurements = replace(measurements, force=np.full(measurements.n_rows, found[0]))
        report = replace(report, notes=report.notes + (found[1],))
    notes = getattr(flavour, "header_notes", None)
    if notes:
        report = replace(report, notes=tuple(notes(text)) + report.notes)
    window = getattr(flavour, "header_window", None)
    found = window(text, layout, report.lines_read, measurements.coordinates) if window else None
    if found is not None:
        report = replace(report, window=found, notes=report.notes + (found.line(),))
    return measurements, report


__all__ = ["FLAVOURS", "FORMATS", "ExportReport", "choose_layout", "is_generic", "read_export"]
