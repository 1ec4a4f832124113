"""Small delimited text tables as people save them: GCP files and batch job lists.

Spreadsheets save "CSV UTF-8" with a byte-order mark (Excel, LibreOffice) and, in locales whose
decimal separator is a comma, separate the columns with ``;``; older tools write tabs. One
reader, :func:`read_table`, is used by every table of the package (GCP CSVs, QGIS ``.points``,
the ``batch`` jobs CSV), so that each accepts all of them:

* the text is decoded as UTF-8 with an optional byte-order mark (``utf-8-sig``), else as
  Windows-1252 (what Excel writes for plain "CSV" on Windows);
* the delimiter is the one of ``,`` ``;`` tab that splits the header line into the most fields
  (a deterministic equivalent of :class:`csv.Sniffer` restricted to those three: the Sniffer
  guesses from the data lines too, where decimal commas confuse it);
* lines starting with ``#`` are comments, returned apart (a GCP file's ``# CRS: ...`` line);
  blank lines are skipped; cells are stripped of surrounding blanks.
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass

from ..errors import InputError

#: The delimiters recognised, in order of preference when the header splits equally.
DELIMITERS = (",", ";", "\t")


@dataclass(frozen=True)
class Table:
    """``header`` (the first non-comment line's cells), ``rows`` (each a list of cells, with
    its 1-based ``line_numbers`` in the file), ``comments`` (``#`` lines, without the ``#``)
    and the ``delimiter`` found."""

    header: list[str]
    rows: list[list[str]]
    line_numbers: list[int]
    comments: list[str]
    delimiter: str


def read_text(path: str, label: str) -> str:
    """The text of a small file: UTF-8 (with or without a byte-order mark), else Windows-1252."""
    if not os.path.isfile(path):
        raise InputError(f"{label} {path} does not exist: check the path")
    with open(path, "rb") as f:
        data = f.read()
    for encoding in ("utf-8-sig", "cp1252"):
        try:
            return data.decode(encoding)
        except UnicodeDecodeError:
            continue
    raise InputError(f"{label} {path} is not text (neither UTF-8 nor Windows-1252): save it as CSV")


def sniff_delimiter(header_line: str) -> str:
    """The delimiter among ``,`` ``;`` tab that splits ``header_line`` into the most fields
    (``,`` when none splits it: a one-column table)."""
    best, fields = ",", 1
    for d in DELIMITERS:
        n = len(next(csv.reader([header_line], delimiter=d), []))
        if n > fields:
            best, fields = d, n
    return best


def read_table(path, label: str = "table") -> Table:
    """Read a delimited table (see the module's description); ``label`` names it in errors."""
    path = os.fspath(path)
    text = read_text(path, label)
    comments, lines, numbers = [], [], []
    for n, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            comments.append(stripped[1:].strip())
            continue
        lines.append(line)
        numbers.append(n)
    if not lines:
        raise InputError(f"{label} {path} holds no table (no line besides comments)")
    delimiter = sniff_delimiter(lines[0])
    rows = [
        [cell.strip() for cell in row]
        for row in csv.reader(io.StringIO("\n".join(lines)), delimiter=delimiter)
    ]
    return Table(rows[0], rows[1:], numbers[1:], comments, delimiter)


def parse_number(cell: str, delimiter: str) -> float:
    """A number from a table cell; with ``;`` or tab delimiters a decimal comma is accepted
    (``660000,5``), as spreadsheets in those locales write it."""
    if delimiter != "," and "," in cell and "." not in cell:
        cell = cell.replace(",", ".")
    return float(cell)
