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
    metadata : the key/value lines of the preamble, (key, (values...)) in file order: ``Unit;mm;%`` (a line of
        fewer fields than the header before it) and ``# force : value_element : 597.6`` (a comment line with ':')
    header_commented : the header is the last '#' comment line (its fields match the data rows')
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
    metadata: tuple[tuple[str, tuple[str, ...]], ...] = ()
    header_commented: bool = False

    def header(self) -> str:
        """The header as it reads in the file (names with their units), for messages."""
        return ", ".join(repr(n if u is None else f"{n} [{u}]") for n, u in zip(self.names, self.units))

    def index(self, name: str) -> int:
        return self.names.index(name)

    def meta(self, key: str) -> tuple[str, ...] | None:
        """The values of the first metadata line whose key is ``key`` (case and surrounding space ignored)."""
        return next((values for k, values in self.metadata if k.strip().lower() == key.lower()), None)


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
    preamble, comments, number = [], [], 0
    for number, line in enumerate(lines, start=1):
        if line.strip() and not line.lstrip().startswith(_PREAMBLE):
            break
        if line.strip():
            preamble.append(line.lstrip("#*/ \t").rstrip())
            comments.append((number, line))
    else:
        raise InputError(f"{source}: no header and no data rows")
    separator = _separator(lines, number)
    number, keyed = _key_values(lines, number, separator)
    commented = _commented_header(lines[number - 1], comments, separator)
    metadata = tuple(_comment_meta(line) for _, line in comments if ":" in line) + tuple(keyed)
    preamble += [separator.join((key,) + values) for key, values in keyed]
    end = None if n_rows is None else number + n_rows
    fields = [_split(line, separator) for line in lines[number - 1:end]]
    if commented is not None:
        preamble.pop(len(comments) - 1)
        fields.insert(0, _split(commented[1].lstrip().lstrip("#"), separator))
    names, units = zip(*(name_unit(f) for f in fields[0]))
    first = number if commented is None else number - 1     # rows are numbered from the line after the header
    header_line = number if commented is None else commented[0]
    data = [(first + k, f) for k, f in enumerate(fields[1:], start=1) if any(fields[k])]
    if data and _is_unit_row(data[0][1]):
        units = tuple(u if u is not None else _bare(r) for u, r in zip(units, data[0][1] + ("",) * len(names)))
        data = data[1:]
    if not data:
        raise InputError(f"{source}:{header_line}: a header ({', '.join(names)}) but no data rows")
    comma = separator != "," and any("," in cell for _, row in data[:50] for cell in row)
    if comma:
        data = [(line, tuple(cell.replace(",", ".") for cell in row)) for line, row in data]
    return ExportText(source, tuple(names), tuple(units), tuple(data), header_line, tuple(preamble), separator,
                      comma, encoding, metadata, commented is not None)


#: a key/value line of a preamble has at most this many fields (``Unit;mm;%``: the key and two units)
KEY_VALUE_FIELDS = 3
#: lines of a file's beginning looked at for its separator and its rows' width
_SAMPLE = 60


def _separator(lines: list[str], number: int) -> str:
    """The first of SEPARATORS in the last non-empty line of the sample from ``number``: a data row where the
    file has one (a key/value preamble line such as ``Project name`` may have no separator)."""
    sample = [line for line in lines[number - 1:number - 1 + _SAMPLE] if line.strip()]
    return next((s for s in SEPARATORS if s in sample[-1]), next((s for s in SEPARATORS if s in sample[0]), ","))


def _key_values(lines: list[str], number: int, separator: str) -> tuple[int, list]:
    """Skip the key/value lines before the header (``Project;...``, ``Unit;mm;%``): lines of at most
    KEY_VALUE_FIELDS filled fields (a spreadsheet pads them with empty ones), fewer than the widest row after them.
    Returns the header's line and the pairs."""
    sample = [(k, _filled(_split(line, separator))) for k, line in
              enumerate(lines[number - 1:number - 1 + _SAMPLE], start=number) if line.strip()]
    width = max(len(fields) for _, fields in sample)
    keyed = []
    for k, fields in sample[:-1]:
        if len(fields) > KEY_VALUE_FIELDS or len(fields) >= width or _NUMBER.fullmatch(fields[0].replace(",", ".")):
            return k, keyed
        keyed.append((fields[0], tuple(f for f in fields[1:] if f)))
    return number, []


def _filled(fields: tuple[str, ...]) -> tuple[str, ...]:
    """``fields`` without the empty ones at the end."""
    n = len(fields)
    while n > 1 and not fields[n - 1]:
        n -= 1
    return fields[:n]


def _commented_header(line: str, comments: list, separator: str) -> tuple[int, str] | None:
    """The last comment line, where it is the header: the first non-comment line is a row of numbers (or NaN,
    empty cells) and the comment, split alike, has as many fields, none of them a number."""
    if not comments:
        return None
    row = _split(line, separator)
    if not all(not c or _NUMBER.fullmatch(c.replace(",", ".")) for c in row):
        return None
    number, comment = comments[-1]
    fields = _split(comment.lstrip().lstrip("#"), separator)
    if len(fields) != len(row) or any(not f or _NUMBER.fullmatch(f) for f in fields):
        return None
    return number, comment


def _comment_meta(line: str) -> tuple[str, tuple[str, ...]]:
    """``# force : value_element : 597.6`` -> ("force", ("value_element", "597.6"))."""
    key, *values = (part.strip() for part in line.lstrip("#*/ \t").split(":"))
    return key, tuple(values)


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
