"""A DIC export's layout (which column is which quantity, in which unit and strain measure) and its reading into
:class:`~frictionid.data.table.Measurements`, invalid points dropped and counted."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ...errors import InputError
from ..table import DISPLACEMENTS, QUANTITIES, STRAINS, Measurements
from .text import ExportText
from .units import MEASURES, force_factor, length_factor, small_strain, small_strain_slope, strain_factor

#: standard deviations a ``columns`` mapping may name: ``sigma_<quantity>`` in the quantity's kind of unit
SIGMA_TARGETS = tuple(f"sigma_{q}" for q in QUANTITIES)
#: what a layout may map: a point label, undeformed coordinates [mm], the measured quantities, their standard
#: deviations
TARGETS = ("point", "x", "y", "z") + QUANTITIES + SIGMA_TARGETS + ("force",)
#: rows of one export (one stage) must give the same machine force up to this relative difference
FORCE_RTOL = 1e-9


@dataclass(frozen=True)
class Layout:
    """Which column of an export is which quantity.

    Attributes
    ----------
    flavour : the export's name in messages and ``format``, e.g. "vic3d"
    columns : target (point, x, y, z, ux, ..., exz) -> column name as in :attr:`ExportText.names`
    strain_measure : one of :data:`~.units.MEASURES`, None where the file does not say
    measure_from : why that measure (a header name, the program's default), for the report
    invalid : (column, test on its value, reason): rows whose value passes the test are dropped
    units : target -> unit where the file states none (a program that writes no units but documents them)
    column_units : column -> unit the program documents for a column the layout does not map (pixels), so that
        a ``columns`` mapping of it is refused instead of taken as mm
    deformed : why the coordinate columns hold the deformed (current) position of the points ("" : they hold the
        reference position); the reference position is then the coordinate minus the displacement
    variant : which of the program's layouts this is, for the report (e.g. "MatchID 2023 names")
    """

    flavour: str
    columns: dict[str, str]
    strain_measure: str | None = None
    measure_from: str = ""
    invalid: tuple[tuple[str, Callable[[float], bool], str], ...] = ()
    units: dict[str, str] = field(default_factory=dict)
    column_units: dict[str, str] = field(default_factory=dict)
    deformed: str = ""
    variant: str = ""


#: what a report says of coordinates read as they are
REFERENCE = "reference (undeformed) positions, as written"


@dataclass(frozen=True)
class ExportReport:
    """What was recognised in one file and what became of its rows (printed by ``frictionid check-data``)."""

    source: str
    flavour: str
    columns: dict[str, str]
    units: dict[str, str]
    strain: str
    stage: int
    n_rows: int
    n_valid: int
    dropped: dict[str, int]
    n_missing: int
    text: str
    #: what the export's header says besides the columns (e.g. DICe's subset, step and strain window), one line each
    notes: tuple[str, ...] = ()
    #: the file's line of each valid point, in the order of the measurements' rows
    lines_read: tuple[int, ...] = field(default=(), repr=False, compare=False)
    #: the strain window the export's header gives (:class:`~.window.HeaderWindow`), None where it gives none
    window: object = None
    #: what the coordinate columns hold and what was done with them (:data:`REFERENCE` or the conversion)
    coordinates: str = REFERENCE
    #: what only an identification needs and the file does not give, e.g. "[data] strain (...)"
    needed: tuple[str, ...] = ()

    def lines(self) -> list[str]:
        mapped = ", ".join(f"{t} <- {c!r}" for t, c in self.columns.items())
        units = ", ".join(f"{t} [{u}]" for t, u in self.units.items())
        why = "; ".join(f"{n} {reason}" for reason, n in self.dropped.items()) or "none"
        return [f"{self.source}: {self.flavour} export ({self.text}), stage {self.stage}",
                f"  columns: {mapped}", f"  units: {units}", f"  coordinates: {self.coordinates}",
                f"  strains: {self.strain}",
                f"  points: {self.n_valid} valid of {self.n_rows} rows; dropped: {why}; "
                f"{self.n_missing} empty quantity cells left as missing values"] + [f"  {n}" for n in self.notes]

    def as_dict(self) -> dict:
        """What result.json's ``data.files`` says of this file."""
        return {"file": self.source, "format": self.flavour, "stage": self.stage, "coordinates": self.coordinates,
                "strain": self.strain, "rows": self.n_rows, "valid": self.n_valid, "dropped": dict(self.dropped)}


def read_layout(text: ExportText, layout: Layout, stage: int, strain: str | None = None, check: bool = False
                ) -> tuple[Measurements, ExportReport]:
    """The rows of ``text`` as measurements at ``stage``: coordinates (reference positions) and displacements in
    mm, strains as small tensor strains; invalid rows (the layout's tests, empty or NaN coordinates, no value at
    all, deformed coordinates without a displacement) dropped and counted. ``strain`` (config ``[data] strain``)
    states the measure where the layout does not know it; with ``check`` (``frictionid check-data``) strains of
    unknown measure are kept as written and the report says the key an identification needs.

    Raises
    ------
    InputError
        A missing coordinate column, a unit that cannot be converted, strains of unknown measure, a cell that is
        not a number (file:line: column), a point label given twice.
    """
    src = text.source
    _check_columns(text, layout)
    needed = ()
    try:
        measure, measure_text = _measure(text, layout, strain)
    except InputError as exc:
        if not check or strain is not None:
            raise
        measure, measure_text = "engineering", "measure not stated by the file: shown as written"
        needed = (f"[data] strain ({str(exc).split(': ', 2)[-1]})",)
    factors, units = _factors(text, layout)
    index = {t: text.index(c) for t, c in layout.columns.items()}
    tests = [(text.index(c), test, reason) for c, test, reason in layout.invalid]
    labels, rows, lines, dropped = [], [], [], {}
    for number, (line, fields) in enumerate(text.rows, start=1):
        reason = _invalid(src, line, text, fields, tests, index)
        if reason is None:
            values = {t: _cell(src, line, text.names[i], fields[i] if i < len(fields) else "") * factors[t]
                      for t, i in index.items() if t != "point"}
            reason = "with empty or NaN coordinates" if any(math.isnan(values[c]) for c in "xy" if c in values) \
                else "without any value" if all(math.isnan(v) for t, v in values.items() if t in QUANTITIES) \
                else _to_reference(values) if layout.deformed else None
        if reason is not None:
            dropped[reason] = dropped.get(reason, 0) + 1
            continue
        _check_sigma(src, line, text, values, index)
        labels.append(_label(src, line, fields, index, number))
        rows.append(values)
        lines.append(line)
    if "force" in layout.columns:
        _check_force(text, layout.columns["force"], rows, lines)
    return _measurements(text, layout, stage, labels, rows, measure), ExportReport(
        src, layout.flavour, dict(layout.columns), units, measure_text, stage, len(text.rows), len(rows), dropped,
        sum(math.isnan(r[q]) for r in rows for q in r if q in QUANTITIES), _describe(text, layout),
        lines_read=tuple(lines), coordinates=_coordinates_text(layout), needed=needed)


def _to_reference(values: dict) -> str | None:
    """Deformed coordinates of one row (in ``values``, mm) made reference positions in place: x - ux, y - uy and,
    where the row gives uz, z - uz (a 2-D export's z stays as written); the reason to drop the row where ux or uy
    is missing."""
    if any(math.isnan(values["u" + c]) for c in "xy"):
        return "with deformed coordinates but no in-plane displacement (no reference position)"
    for c in "xyz":
        if c in values and not math.isnan(values.get("u" + c, math.nan)):
            values[c] -= values["u" + c]
    return None


def _coordinates_text(layout: Layout) -> str:
    if not layout.deformed:
        return REFERENCE
    columns = layout.columns
    axes = ", ".join(f"{c} = {columns[c]} - {columns['u' + c]}" for c in "xyz" if c in columns and "u" + c in columns)
    return f"deformed positions ({layout.deformed}), converted to reference positions: {axes}"


def _check_columns(text: ExportText, layout: Layout) -> None:
    absent = {t: c for t, c in layout.columns.items() if c not in text.names}
    if absent:
        raise InputError(f"{text.source}:{text.header_line}: {layout.flavour}: no column "
                         f"{', '.join(repr(c) for c in absent.values())} (for {', '.join(absent)}); the header has "
                         f"{text.header()}")
    alone = [t for t in layout.columns if t in SIGMA_TARGETS and t[6:] not in layout.columns]
    if alone:
        raise InputError(f"{text.source}: [data] columns: {', '.join(alone)} without the column of "
                         f"{', '.join(t[6:] for t in alone)}; map the value's column too")
    missing = [c for c in ("x", "y") if c not in layout.columns]
    if missing:
        raise InputError(f"{text.source}:{text.header_line}: {layout.flavour}: no coordinate column for "
                         f"{' and '.join(missing)} (undeformed coordinates are required); the header has "
                         f"{text.header()}; map them with [data] columns = {{ x = \"...\", y = \"...\" }}")
    if not set(layout.columns) & set(QUANTITIES):
        raise InputError(f"{text.source}:{text.header_line}: {layout.flavour}: no displacement or strain column "
                         f"found in {text.header()}")
    lacking = [c for c in "xy" if layout.deformed and "u" + c not in layout.columns]
    if lacking:
        raise InputError(f"{text.source}:{text.header_line}: {layout.flavour}: the coordinates are deformed "
                         f"positions ({layout.deformed}); the reference position needs the displacement "
                         f"column{'s' * (len(lacking) > 1)} of {' and '.join(lacking)}, which the header "
                         f"({text.header()}) does not have")


def _measure(text: ExportText, layout: Layout, strain: str | None) -> tuple[str | None, str]:
    if not set(layout.columns) & set(STRAINS):
        return None, "none read"
    if strain is not None:
        if strain not in MEASURES:
            raise InputError(f"{text.source}: [data] strain = {strain!r} is not one of {', '.join(MEASURES)}")
        return strain, f"{MEASURES[strain]} (from [data] strain)"
    if layout.strain_measure is None:
        raise InputError(f"{text.source}: {layout.flavour}: the file does not say which strain measure its "
                         f"columns {', '.join(layout.columns[q] for q in STRAINS if q in layout.columns)} hold; "
                         f"state it with [data] strain = \"engineering\", \"green-lagrange\" or \"log\"")
    return layout.strain_measure, f"{MEASURES[layout.strain_measure]} ({layout.measure_from})"


def _factors(text: ExportText, layout: Layout) -> tuple[dict, dict]:
    factors, units = {}, {}
    for target, column in layout.columns.items():
        if target == "point":
            continue
        unit = text.units[text.index(column)] or layout.units.get(target) or layout.column_units.get(column)
        if target == "force":
            factors[target] = force_factor(unit, column, text.source)
            units[target] = unit if unit is not None else "N (no unit in the file)"
            continue
        if target.removeprefix("sigma_") in STRAINS:
            factors[target] = strain_factor(unit, column, text.source)
            units[target] = unit if unit is not None else "-"
            continue
        pixels = layout.column_units.get(column) if text.units[text.index(column)] is None else None
        if pixels is not None and target not in SIGMA_TARGETS:
            raise InputError(f"{text.source}:{text.header_line}: column {column!r} (for {target}) holds image "
                             f"pixels: unit {pixels!r} cannot be converted to mm (a pixel becomes a length only "
                             f"through the DIC calibration); map the export's calibrated coordinates and "
                             f"displacements, or export them from the DIC program")
        try:
            factors[target] = length_factor(unit, column, text.source)
        except InputError as exc:
            if target not in SIGMA_TARGETS:
                raise
            raise InputError(f"{exc}; {target} is a standard deviation of {target[6:]} [mm]: a correlation's "
                             f"confidence in pixels (column {column!r}) has no conversion to mm that the export "
                             f"gives; map a column in mm or give [data] noise") from None
        units[target] = unit if unit is not None else "mm (no unit in the file)"
    return factors, units


def _check_force(text: ExportText, column: str, rows: list, lines: list) -> None:
    """An export is one stage: every valid row that gives the force gives the same (up to FORCE_RTOL)."""
    given = [(line, row["force"]) for line, row in zip(lines, rows) if not math.isnan(row["force"])]
    if not given:
        raise InputError(f"{text.source}: column {column!r} (force): no valid row gives a value")
    first_line, first = given[0]
    for line, value in given:
        if abs(value - first) > FORCE_RTOL * max(abs(value), abs(first)):
            raise InputError(f"{text.source}:{line}: column {column!r}: force {value!r} N differs from {first!r} N "
                             f"on line {first_line}; an export is one stage, which has one machine force")


def _check_sigma(src: str, line: int, text: ExportText, values: dict, index: dict) -> None:
    """A standard deviation given on a valid row must be positive (empty: not given)."""
    for target in SIGMA_TARGETS:
        if target in values and not math.isnan(values[target]) and not values[target] > 0:
            raise InputError(f"{src}:{line}: column {text.names[index[target]]!r}: a standard deviation of "
                             f"{target[6:]} must be positive, got {values[target]!r}")


def _invalid(src, line, text, fields, tests, index) -> str | None:
    for i, test, reason in tests:
        cell = fields[i] if i < len(fields) else ""
        value = _cell(src, line, text.names[i], cell)
        if test(value):
            return reason
    return None


def _cell(src: str, line: int, column: str, cell: str) -> float:
    if not cell.strip():
        return math.nan
    try:
        return float(cell)
    except ValueError:
        raise InputError(f"{src}:{line}: column {column!r}: {cell!r} is not a number") from None


def _label(src, line, fields, index, number) -> str:
    if "point" not in index:
        return str(number)
    label = fields[index["point"]].strip() if index["point"] < len(fields) else ""
    if not label:
        raise InputError(f"{src}:{line}: the point id is empty")
    return label[:-2] if label.endswith(".0") and label[:-2].isdigit() else label


def _measurements(text: ExportText, layout: Layout, stage: int, labels, rows, measure) -> Measurements:
    seen = {}
    for line_label in labels:
        if line_label in seen:
            raise InputError(f"{text.source}: point id {line_label!r} appears twice")
        seen[line_label] = True
    n = len(rows)
    if n == 0:
        raise InputError(f"{text.source}: no valid point ({len(text.rows)} rows, all dropped)")
    column = lambda t: np.array([r.get(t, 0.0 if t == "z" else math.nan) for r in rows])  # noqa: E731
    values, sigma = {}, {}
    for q in QUANTITIES:
        if q in layout.columns:
            values[q] = column(q) if q in DISPLACEMENTS else small_strain(column(q), measure, q[1] == q[2])
        if f"sigma_{q}" in layout.columns:
            slope = 1.0 if q in DISPLACEMENTS else small_strain_slope(column(q), measure, q[1] == q[2])
            sigma[q] = np.where(np.isnan(values[q]), math.nan, column(f"sigma_{q}") * slope)
    force = np.full(n, math.nan)
    if "force" in layout.columns:                                  # one value (_check_force): on every row
        force[:] = next(r["force"] for r in rows if not math.isnan(r["force"]))
    return Measurements(points=tuple(labels), coordinates=np.column_stack([column(c) for c in "xyz"]),
                        stage=np.full(n, stage), force=force, values=values, sigma=sigma,
                        comments=(f"{layout.flavour} export {text.source}, stage {stage}",), source=text.source)


def _describe(text: ExportText, layout: Layout) -> str:
    separator = {"\t": "tab", ";": "';'", ",": "','"}[text.separator]
    return (f"{layout.variant + ', ' if layout.variant else ''}{separator}-separated, "
            f"{'decimal comma, ' if text.decimal_comma else ''}{text.encoding}, "
            f"header on line {text.header_line}{' (a # comment line)' if text.header_commented else ''}")
