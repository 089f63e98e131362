"""Measurement files: the generic CSV of docs/data.md, read with file:line:column errors and written to read back equal.

The table itself (:class:`Measurements`) and the axisymmetric mapping live in :mod:`.table` and are re-exported
here, so that ``frictionid.data.measurements`` is the one import for measured data.
"""

from __future__ import annotations

import csv
import difflib
import itertools
import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from .table import CHANNELS, QUANTITIES, REQUIRED, UNITS_COMMENT, Measurements, comment_text, map_to_axisymmetric

SIGMAS = tuple(f"sigma_{q}" for q in QUANTITIES)
#: per-stage columns: the machine force and the channels of a tightening test (wrench torque, clamp force)
STAGE_COLUMNS = ("force",) + tuple(CHANNELS)
KNOWN = REQUIRED + STAGE_COLUMNS + QUANTITIES + SIGMAS
#: rows of one stage must give the same machine force up to this relative difference
FORCE_RTOL = 1e-9
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_INTEGER = re.compile(r"\+?\d+")
_SPACE = re.compile(r"\s")

__all__ = ["CHANNELS", "Measurements", "QUANTITIES", "REQUIRED", "UNITS_COMMENT", "map_to_axisymmetric",
           "read_measurements", "write_measurements"]


def _at(source: str, line: int, column: str | None = None) -> str:
    """Message prefix ``file:line: column 'name': ``."""
    return f"{source}:{line}: " + (f"column {column!r}: " if column else "")


def read_measurements(path) -> Measurements:
    """Read a measurement CSV (docs/data.md, "The generic CSV").

    ``#`` comment lines (kept), a header ``point,x,y,z,stage[,force][,torque][,clamp][,ux,...,exz]
    [,sigma_<quantity>...]``
    in any column order, then one row per (point, stage). Empty cells of optional columns are missing values.

    Raises
    ------
    InputError
        Naming the file, the 1-based line (comment lines counted) and the column: missing file, no header
        or no data rows, missing / unknown / duplicate columns, a sigma column without its value column,
        a row with the wrong number of fields, a cell that is not a finite number (``nan``, ``inf`` written
        out), a stage that is not a positive integer, a sigma <= 0, a (point, stage) given twice, a quantity
        column with no value, and rows of one stage with different forces (torques, clamp forces).

    Examples
    --------
    >>> m = read_measurements("measured.csv")  # doctest: +SKIP
    >>> m.select(quantities=["uy"], stages=[2]).observations()[:1]  # doctest: +SKIP
    [(0, 'uy', 0.0123, nan)]
    """
    source = str(path)
    comments, header, lines, by_column, plain = _split(source, _read_lines(path))
    columns = _check_header(source, *header)
    if not lines:
        raise InputError(f"{_at(source, header[0])}no data rows after the header")
    cells = _numbers(by_column, columns) if plain and isinstance(by_column, _PlainTable) else {}
    cells.update({name: _column(source, lines, name, by_column.few(index) if cells else by_column[index], plain)
                  for name, index in columns.items() if name not in cells})
    _check_rows(source, header[0], lines, cells)
    return Measurements(
        points=tuple(cells["point"]), coordinates=np.column_stack([cells[c] for c in "xyz"]),
        stage=np.array(cells["stage"], dtype=int), force=np.array(cells.get("force", [np.nan] * len(lines))),
        values={q: np.array(cells[q]) for q in QUANTITIES if q in cells},
        sigma={q: np.array(cells[f"sigma_{q}"]) for q in QUANTITIES if f"sigma_{q}" in cells},
        comments=tuple(comments), source=source, channels={c: np.array(cells[c]) for c in CHANNELS if c in cells})


def _read_lines(path) -> list[str]:
    try:
        # utf-8-sig: spreadsheet programs start CSV files with a byte-order mark
        return Path(path).read_text(encoding="utf-8-sig").splitlines()
    except FileNotFoundError:
        raise InputError(f"{path}: no such measurement file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, not a measurement file") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text (byte {exc.start}); save the CSV as UTF-8") from None


def _split(source: str, lines: list[str]):
    """Comment texts, (line, header fields), the 1-based line of each data row, the fields by column, and whether
    the table is plain ASCII without an underscore (so that a column float() reads is one of numbers).

    Comment lines (``#``) and blank lines are skipped anywhere. A table of plain rows (after the header no
    comment, blank line, quote or white space; every row as wide as the header) is split in one pass over the
    whole text: a full field's 1e5 rows in about 0.2 s instead of 0.6 s row by row; anything else row by row,
    where a row of the wrong width is an error naming its line.
    """
    comments = []
    for number, text in enumerate(lines, start=1):
        if text.lstrip().startswith("#"):
            comments.append(comment_text(text))
        elif text.strip():
            header = (number, _fields(text))
            break
    else:
        raise InputError(f"{source}: no header and no data (expected '#' comment lines, a header "
                         f"{','.join(REQUIRED)},... and one row per point and stage)")
    body = lines[header[0]:]
    by_column, plain = _plain_columns(body, len(header[1]))         # a _PlainTable: columns split when asked
    if by_column is not None:
        return comments, header, list(range(header[0] + 1, header[0] + 1 + len(body))), by_column, plain
    rows = []
    for number, text in enumerate(body, start=header[0] + 1):
        if text.lstrip().startswith("#"):
            comments.append(comment_text(text))
        elif text.strip():
            fields = _fields(text)
            _check_width(source, number, fields, header)
            rows.append((number, fields))
    width = len(header[1])
    return (comments, header, [number for number, _ in rows],
            [list(column) for column in zip(*(fields for _, fields in rows))] if rows else [[]] * width, False)


def _fields(text: str) -> list[str]:
    """The fields of a line: a line without quotes splits at its commas, as the csv module would split it (and
    20x faster); without white space there is nothing to strip."""
    if '"' in text:
        return [f.strip() for f in next(csv.reader([text]))]
    return [f.strip() for f in text.split(",")] if _SPACE.search(text) else text.split(",")


#: characters that send a table to the row-by-row path: quotes, comments, ASCII white space and line breaks
_NOT_PLAIN = ('"', "#", " ", "\t", "\r", "\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x1f", "\x85")


class _PlainTable:
    """Plain data lines (see :func:`_split`): ``table[j]`` the texts of column j (the whole table split once, when
    first asked), ``table.few(j)`` those of column j alone (each line split up to it), ``table.body`` the lines."""

    def __init__(self, body: list[str], width: int, block: str):
        self.body, self.width, self._block, self._fields = body, width, block, None

    def __getitem__(self, j: int) -> list[str]:
        if self._fields is None:
            self._fields = self._block.replace("\n", ",").split(",")
        return self._fields[j::self.width]

    def few(self, j: int) -> list[str]:
        return [line.split(",", j + 1)[j] for line in self.body]


def _plain_columns(body: list[str], width: int) -> tuple[_PlainTable | None, bool]:
    """The data lines as a :class:`_PlainTable` if they are all plain (see :func:`_split`), else None; and whether
    they hold no underscore (then a column that float() reads is one of numbers as :func:`_number` reads them)."""
    if not body or not all(body):
        return None, False
    block = "\n".join(body)
    if not block.isascii() or any(c in block for c in _NOT_PLAIN):
        return None, False
    if set(map(str.count, body, itertools.repeat(","))) != {width - 1}:
        return None, False
    return _PlainTable(body, width, block), "_" not in block


def _numbers(table: _PlainTable, columns: dict[str, int]) -> dict[str, np.ndarray]:
    """Every numeric column of a plain table read at once by numpy's text reader, which reads a field as float()
    does (1e5 rows x 15 columns in about 0.4 s instead of 0.7 s through Python strings); {} if a column has an
    empty cell, a cell that is no number, a value that is not finite or a sigma <= 0: the cell-by-cell path then
    reads them and names the cell."""
    numeric = {name: index for name, index in columns.items() if name not in ("point", "stage")}
    if not numeric:
        return {}
    try:
        values = np.loadtxt(table.body, delimiter=",", usecols=list(numeric.values()), comments=None, dtype=float,
                            ndmin=2, encoding=None)
    except ValueError:
        return {}
    cells = {name: np.ascontiguousarray(values[:, k]) for k, name in enumerate(numeric)}
    if not np.isfinite(values).all() or any((cells[name] <= 0).any() for name in cells if name.startswith("sigma_")):
        return {}
    return cells


def _check_header(source: str, line: int, names: list[str]) -> dict[str, int]:
    """Column name -> field index, after checking the header's names."""
    at = _at(source, line)
    seen = {}
    for index, name in enumerate(names):
        if name in seen:
            raise InputError(f"{_at(source, line, name)}appears twice in the header "
                             f"(fields {seen[name] + 1} and {index + 1})")
        seen[name] = index
    unknown = [_unknown(name, index) for index, name in enumerate(names) if name not in KNOWN]
    if unknown:
        raise InputError(f"{at}unknown column{'s' if len(unknown) > 1 else ''} {'; '.join(unknown)}. Known: "
                         f"{', '.join(REQUIRED + STAGE_COLUMNS + QUANTITIES)} and sigma_<quantity>")
    missing = [name for name in REQUIRED if name not in seen]
    if missing:
        raise InputError(f"{at}missing required column{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(map(repr, missing))} (required: {', '.join(REQUIRED)})")
    for q in QUANTITIES:
        if f"sigma_{q}" in seen and q not in seen:
            raise InputError(f"{_at(source, line, 'sigma_' + q)}standard deviations without the column {q!r}")
    return seen


def _unknown(name: str, index: int) -> str:
    if not name:
        return f"'' (field {index + 1} of the header is empty)"
    close = difflib.get_close_matches(name.lower(), KNOWN, n=2, cutoff=0.6)
    hint = f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""
    return f"{name!r}{hint}"


def _check_width(source: str, line: int, fields: list[str], header) -> None:
    if len(fields) != len(header[1]):
        raise InputError(f"{_at(source, line)}{len(fields)} fields, but the header (line {header[0]}) "
                         f"has {len(header[1])}: {','.join(header[1])}")


def _column(source: str, lines: list[int], name: str, texts: list[str], plain: bool = False):
    """The values of one column, checked as :func:`_cell` checks each cell; a column of finite numbers only (no
    empty cell) is converted at once (1e5 rows in a few ms), anything else cell by cell. ``plain``: the whole
    table is ASCII without underscores (checked once by :func:`_split`)."""
    if name == "point" and all(texts):
        return list(texts)
    digits = "".join(texts) if name == "stage" else ""
    if digits.isascii() and digits.isdigit() and all(texts):
        numbers = list(map(int, texts))
        if all(numbers):
            return numbers                                    # digits only, none of them 0: positive integers
    numeric = name not in ("point", "stage") and bool(texts)
    # float() reads every cell _NUMBER matches the same way; it also reads nan, inf (not finite), 1_000 and
    # non-ASCII digits, which the checks here leave to the cell-by-cell path and its messages
    if numeric and (plain or ("\n".join(texts).isascii() and not any("_" in text for text in texts))):
        try:
            values = np.array(texts, dtype=float)
        except ValueError:
            values = None
        if values is not None and np.isfinite(values).all() and (not name.startswith("sigma_") or (values > 0).all()):
            return values
    return [_cell(source, line, name, text) for line, text in zip(lines, texts)]


def _cell(source: str, line: int, name: str, text: str):
    """The value of one cell: label (point), int (stage), float, or nan for an empty optional cell."""
    if name == "point":
        if not text:
            raise InputError(f"{_at(source, line, name)}a point label is required")
        return text
    if name == "stage":
        if not _INTEGER.fullmatch(text) or int(text) < 1:
            raise InputError(f"{_at(source, line, name)}the stage must be a positive integer (1-based stage of "
                             f"the model's load path), got {text!r}")
        return int(text)
    if not text:
        if name in REQUIRED:
            raise InputError(f"{_at(source, line, name)}a value is required (undeformed coordinate, mm)")
        return np.nan
    value = _number(source, line, name, text)
    if name.startswith("sigma_") and not value > 0:
        raise InputError(f"{_at(source, line, name)}a standard deviation must be positive, got {text}")
    return value


def _number(source: str, line: int, name: str, text: str) -> float:
    if text.lower() in ("nan", "-nan", "+nan"):
        raise InputError(f"{_at(source, line, name)}{text!r} is not allowed: leave the cell empty for a "
                         f"missing value")
    if not _NUMBER.fullmatch(text):
        finite = "a finite number" if text.lower().lstrip("+-") in ("inf", "infinity") else "a number"
        raise InputError(f"{_at(source, line, name)}{text!r} is not {finite}")
    value = float(text)
    if not np.isfinite(value):
        raise InputError(f"{_at(source, line, name)}{text!r} is not a finite number")
    return value


def _check_rows(source: str, header_line: int, lines: list[int], cells: dict) -> None:
    """Checks across rows: unique (point, stage), one force per stage, no empty quantity column."""
    points = cells["point"]
    if len(set(points)) != len(points) and len(set(zip(points, cells["stage"]))) != len(points):
        first = {}                                                  # (distinct labels: distinct pairs)
        for line, key in zip(lines, zip(points, cells["stage"])):
            if key in first:
                raise InputError(f"{_at(source, line, 'point')}point {key[0]!r} at stage {key[1]} is already on "
                                 f"line {first[key]}")
            first[key] = line
    stage = np.asarray(cells["stage"])
    for name in STAGE_COLUMNS:
        if name in cells:
            _check_stage_values(source, lines, stage, np.asarray(cells[name], dtype=float), name)
    for q in QUANTITIES:
        if q in cells and np.all(np.isnan(cells[q])):
            raise InputError(f"{_at(source, header_line, q)}no row has a value; leave the column out")


def _check_stage_values(source: str, lines: list[int], stage: np.ndarray, value: np.ndarray, name: str) -> None:
    """Every value of a per-stage column (force, torque, clamp) given at a stage equals the first one given at
    that stage (up to FORCE_RTOL)."""
    given = ~np.isnan(value)
    unit, what = ("N", "machine force") if name == "force" else (CHANNELS[name][1], CHANNELS[name][0])
    for s in np.unique(stage[given]):
        rows = np.flatnonzero(given & (stage == s))
        reference = value[rows[0]]
        bad = rows[np.abs(value[rows] - reference) > FORCE_RTOL * np.maximum(np.abs(value[rows]), abs(reference))]
        if bad.size:
            raise InputError(f"{_at(source, lines[bad[0]], name)}{float(value[bad[0]])!r} {unit} differs from "
                             f"{float(reference)!r} {unit} of stage {int(s)} on line {lines[rows[0]]}; a stage has "
                             f"one {what}")


def write_measurements(path, measurements: Measurements) -> None:
    """Write ``measurements`` as a measurement CSV that :func:`read_measurements` reads back equal.

    Comment lines first (``# `` + text), then the header (required columns, ``force`` if any row has one, the
    channels ``torque``, ``clamp`` of the table, each quantity followed by its sigma column), then one row per
    point and stage; missing values are empty cells and floats are written with ``repr`` (shortest text that
    reads back to the same float).

    Raises
    ------
    InputError
        A value that is not finite, a point label the reader would not read back (empty, starting with
        ``#``, surrounding spaces), or a comment with a line break.
    """
    m = measurements
    _check_writable(m)
    columns = list(REQUIRED) + (["force"] if np.any(~np.isnan(m.force)) else []) + list(m.channels)
    for q in m.quantities:
        columns += [q] + ([f"sigma_{q}"] if q in m.sigma else [])
    with open(path, "w", newline="", encoding="utf-8") as stream:
        stream.writelines(f"# {text}\n" if text else "#\n" for text in m.comments)
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(columns)
        writer.writerows([_text(m, i, name) for name in columns] for i in range(m.n_rows))


def _text(m: Measurements, i: int, name: str) -> str:
    if name == "point":
        return m.points[i]
    if name == "stage":
        return str(int(m.stage[i]))
    if name in ("x", "y", "z"):
        value = m.coordinates[i, "xyz".index(name)]
    elif name == "force":
        value = m.force[i]
    elif name in m.channels:
        value = m.channels[name][i]
    else:
        value = m.sigma[name[6:]][i] if name.startswith("sigma_") else m.values[name][i]
    return "" if np.isnan(value) else repr(float(value))


def _check_writable(m: Measurements) -> None:
    where = m.source or "measurements"
    for p in m.points:
        if not p or p != p.strip() or p.startswith("#") or "\n" in p:
            raise InputError(f"{where}: point label {p!r} would not read back (empty, leading '#', surrounding "
                             f"spaces or a line break)")
    if any("\n" in c or "\r" in c for c in m.comments):
        raise InputError(f"{where}: a comment must be a single line")
    if np.any(m.stage < 1):
        raise InputError(f"{where}: stages must be positive integers")
    for name, column in [("coordinates", m.coordinates), ("force", m.force), *m.channels.items(), *m.values.items()]:
        if np.any(np.isinf(column)) or (name == "coordinates" and np.any(np.isnan(column))):
            raise InputError(f"{where}: {name} must be finite numbers (nan only for missing optional values)")
    for q, column in m.sigma.items():
        if np.any(~(column[~np.isnan(column)] > 0)) or np.any(np.isinf(column)):
            raise InputError(f"{where}: sigma of {q} must be positive finite numbers (nan where not given)")
