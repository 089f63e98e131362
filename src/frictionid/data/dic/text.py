"""The text of a DIC export: encoding, separator, preamble, header, unit row and decimal commas, before any meaning."""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

from ...errors import InputError

#: separators tried on the header line, in this order of preference (a ';' file may still use ',' as decimal)
SEPARATORS = (";", "\t", ",")
#: preamble lines: '#' comments, DICe's '***' block, '//' remarks
_PREAMBLE = ("#", "*", "//")
_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]?nan|[+-]?inf", re.I)


@dataclass(frozen=True)
class ExportText:
    """The cells of a delimited export, as text.

    Attributes
    ----------
    source : the file, for messages
    names : column names as written, without quotes and without a trailing ``[unit]``
    units : the unit of each column (from ``name [unit]`` or a unit row), None where the file states none
    rows : (line, fields) of each data row; line is 1-based in the file
    header_line : line of the header
    preamble : the lines before the header, without their comment marks
    separator, decimal_comma, encoding : how the text was written
    """

    source: str
    names: tuple[str, ...]
    units: tuple[str | None, ...]
    rows: tuple[tuple[int, tuple[str, ...]], ...]
    header_line: int
    preamble: tuple[str, ...]
    separator: str
    decimal_comma: bool
    encoding: str

    def header(self) -> str:
        """The header as it reads in the file (names with their units), for messages."""
        return ", ".join(repr(n if u is None else f"{n} [{u}]") for n, u in zip(self.names, self.units))

    def index(self, name: str) -> int:
        return self.names.index(name)


def read_text(path, n_rows: int | None = None) -> ExportText:
    """Split an export into preamble, header, optional unit row and data rows.

    ``n_rows``: split only the first that many lines after the header (enough to recognise the format without
    splitting a full field of 1e5 rows), read from the file's first HEAD_BYTES where they are there (the
    encoding is then that of those bytes); all by default.

    UTF-8 (with or without byte-order mark) is tried first, then Latin-1, the encoding of exports written by
    Windows programs (``µm``, ``°`` in headers). The separator is the first of ``;``, tab, ``,`` found in the
    header; with ``;`` or tab, a ``,`` inside a number is a decimal comma.

    Raises
    ------
    InputError
        A missing file or a file without header and data rows.
    """
    source = str(path)
    if n_rows is not None:
        try:                                       # the head only: recognising a 1e5-row file reads 64 kB of it
            return _read(source, *_decode(path, HEAD_BYTES), n_rows)
        except InputError:
            pass                                   # a longer preamble, or no data row in the head: all of it
    return _read(source, *_decode(path), n_rows)


#: bytes read to recognise a file's format (read_text with n_rows): whole lines of its beginning
HEAD_BYTES = 1 << 16


def _read(source: str, text: str, encoding: str, n_rows: int | None) -> ExportText:
    lines = text.splitlines()
    preamble, number = [], 0
    for number, line in enumerate(lines, start=1):
        if line.strip() and not line.lstrip().startswith(_PREAMBLE):
            break
        if line.strip():
            preamble.append(line.lstrip("#*/ \t").rstrip())
    else:
        raise InputError(f"{source}: no header and no data rows")
    separator = next((s for s in SEPARATORS if s in lines[number - 1]), ",")
    end = None if n_rows is None else number + n_rows
    fields = [_split(line, separator) for line in lines[number - 1:end]]
    names, units = zip(*(name_unit(f) for f in fields[0]))
    data = [(number + k, f) for k, f in enumerate(fields[1:], start=1) if any(fields[k])]
    if data and _is_unit_row(data[0][1]):
        units = tuple(u if u is not None else _bare(r) for u, r in zip(units, data[0][1] + ("",) * len(names)))
        data = data[1:]
    if not data:
        raise InputError(f"{source}:{number}: a header ({', '.join(names)}) but no data rows")
    comma = separator != "," and any("," in cell for _, row in data[:50] for cell in row)
    if comma:
        data = [(line, tuple(cell.replace(",", ".") for cell in row)) for line, row in data]
    return ExportText(source, tuple(names), tuple(units), tuple(data), number, tuple(preamble), separator, comma,
                      encoding)


def _decode(path, head: int | None = None) -> tuple[str, str]:
    """The text and its encoding; ``head``: only the whole lines within the first that many bytes."""
    try:
        if head is None:
            raw = Path(path).read_bytes()
        else:
            with open(path, "rb") as stream:
                raw = stream.read(head + 1)
            raw = raw if len(raw) <= head else raw[:raw.rfind(b"\n", 0, head) + 1]
    except FileNotFoundError:
        raise InputError(f"{path}: no such measurement file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, not a measurement file") from None
    try:
        return raw.decode("utf-8-sig"), "utf-8"
    except UnicodeDecodeError:
        return raw.decode("latin-1"), "latin-1"


def _split(line: str, separator: str) -> tuple[str, ...]:
    if '"' not in line:                 # what the csv module gives for a line without quotes, 10x faster
        return tuple(f.strip() for f in line.split(separator))
    return tuple(f.strip().strip('"').strip() for f in next(csv.reader([line], delimiter=separator)))


def name_unit(field: str) -> tuple[str, str | None]:
    """``"X [mm]"`` -> ("X", "mm"); a name without unit -> (name, None)."""
    match = _UNIT.match(field)
    return (match["name"].strip(), match["unit"].strip()) if match else (field, None)


def _bare(cell: str) -> str | None:
    cell = cell.strip().strip("[]()").strip()
    return cell or None


def _is_unit_row(fields: tuple[str, ...]) -> bool:
    """A row right after the header whose cells are all units (``[mm]``, ``mm``, ``%``, ``-``), not numbers."""
    cells = [c for c in fields if c]
    return bool(cells) and not any(_NUMBER.fullmatch(c.replace(",", ".")) for c in cells) and \
        all(len(c) <= 8 and " " not in c.strip("[]()") for c in cells)
