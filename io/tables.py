"""Readers of CSV tables, numbers, JSON and TOML documents that name the
file, line and field of every problem.

CSV rules (every table stiffkit reads): UTF-8 text (a spreadsheet's BOM is
allowed), a header row of distinct, non-empty column names, then one row per
record with exactly as many fields as the header (blank lines are skipped);
extra columns are ignored; every number is finite and within the range of
its quantity (stiffkit.io.validate), and a column whose values are
implausible for their unit (a length in mm, an angle in degrees) gives one
warning naming the largest value and the fix.
"""

from __future__ import annotations

import csv
import io
import json
import math
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np

from ..errors import InputError
from . import validate as V

_T = TypeVar("_T")

__all__ = [
    "Table",
    "read_table",
    "read_columns",
    "parse_number",
    "parse_vector",
    "matrix6",
    "read_json",
    "read_toml",
    "read_text",
]


def read_text(path: Path | str, what: str = "file", where: str = "", error: type[InputError] = InputError) -> str:
    """The UTF-8 text of ``path`` (a BOM is dropped); ``error`` naming the
    file (and the line of the first byte that is not UTF-8) otherwise."""
    path = Path(path)
    at = f"{where}: {path}" if where else str(path)
    if not path.exists():
        raise error(f"{at}: no such {what} file")
    if not path.is_file():
        raise error(f"{at}: not a file (a {what} file is expected)")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise error(f"{at}: cannot read it ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise error(
            f"{at}, line {line}: not UTF-8 text (byte 0x{data[exc.start]:02x}); save the {what} file as UTF-8"
        ) from None
    if "\x00" in text:
        line = text.count("\n", 0, text.index("\x00")) + 1
        raise error(f"{at}, line {line}: a NUL byte: not a text file")
    return text


@dataclass
class Table:
    """A CSV table: header, rows of text fields and their 1-based line numbers."""

    path: Path
    header: list[str]
    rows: list[list[str]]
    lines: list[int]
    what: str = "table"

    def __len__(self) -> int:
        return len(self.rows)

    def has(self, column: str) -> bool:
        return column in self.header

    def require(self, columns: Sequence[str], note: str = "") -> None:
        missing = [c for c in columns if c not in self.header]
        if missing and len(self.header) == 1 and any(sep in self.header[0] for sep in ";\t"):
            raise InputError(
                f"{self.path}, line 1: one column {self.header[0]!r}: the fields are separated by "
                f"{'a semicolon' if ';' in self.header[0] else 'tabs'}; stiffkit's CSV files use commas"
            )
        if missing:
            raise InputError(
                f"{self.path}, line 1: missing column(s) {', '.join(missing)}{note} "
                f"(header has: {', '.join(self.header)})"
            )

    def text(self, column: str) -> list[str]:
        i = self.header.index(column)
        return [r[i].strip() for r in self.rows]

    def numbers(self, columns: Sequence[str], q: str | None = None) -> np.ndarray:
        """(rows, len(columns)) floats; InputError naming line and field for
        a non-number, NaN/Inf or a magnitude beyond the quantity's limit."""
        self.require(columns)
        idx = [self.header.index(c) for c in columns]
        out = np.empty((len(self.rows), len(columns)))
        for r, (row, line) in enumerate(zip(self.rows, self.lines)):
            for k, (c, i) in enumerate(zip(columns, idx)):
                out[r, k] = parse_number(row[i], self.path, line, c, q)
        if q is not None and out.size:
            V.plausible_array(out, f"{self.path}: column(s) {', '.join(columns)}", q, self._where(out))
        return out

    def _where(self, a: np.ndarray) -> str:
        k = np.unravel_index(int(np.argmax(np.abs(a))), a.shape)
        return f" (line {self.lines[k[0]]})"


def read_table(path: Path | str, what: str = "table") -> Table:
    """Read a CSV table under the rules of the module docstring."""
    path = Path(path)
    text = read_text(path, what)
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader, None)
        if header is None or all(not h.strip() for h in header):
            raise InputError(f"{path}: empty file, expected a header row of column names")
        header = [h.strip() for h in header]
        for k, h in enumerate(header):
            if not h:
                raise InputError(f"{path}, line 1: column {k + 1} of the header has no name (a trailing comma?)")
        dup = sorted({h for h in header if header.count(h) > 1})
        if dup:
            raise InputError(f"{path}, line 1: duplicate column name(s) {', '.join(map(V.shown, dup))}")
        rows, lines = [], []
        for row in reader:
            line = reader.line_num
            if not row or all(not x.strip() for x in row):
                continue
            if len(row) < len(header):
                raise InputError(
                    f"{path}, line {line}: field {header[len(row)]!r} is missing "
                    f"(row has {len(row)} fields, the header {len(header)})"
                )
            if len(row) > len(header):
                raise InputError(
                    f"{path}, line {line}: {len(row)} fields, but the header has {len(header)} columns "
                    "(an extra field: a decimal comma, or a comma inside a value?)"
                )
            rows.append(row)
            lines.append(line)
    except csv.Error as exc:
        raise InputError(f"{path}, line {reader.line_num}: not a CSV row ({exc})") from None
    if not rows:
        raise InputError(f"{path}: no data rows")
    return Table(path, header, rows, lines, what)


def read_columns(path: Path | str, columns: list[str], what: str = "table", q: str | None = None) -> np.ndarray:
    """Read the named numeric columns of a CSV with a header row.

    Returns an (nrows, len(columns)) float array. Raises InputError naming
    the file, the 1-based line and the field for a missing column, a
    non-number or a NaN/Inf (and every rule of the module docstring);
    ``q`` names the quantity of the columns (range and plausibility).
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such {what} file")
    return read_table(path, what).numbers(columns, q)


def parse_number(text: str, path: Path | str, lineno: int, field: str, q: str | None = None) -> float:
    """A finite float from one CSV field, or InputError naming file, line and
    field; with ``q`` (a quantity of stiffkit.io.validate) also its range."""
    text = text.strip()
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{path}, line {lineno}: field {field!r} = {text!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"{path}, line {lineno}: field {field!r} is {text} (must be finite)")
    if q is not None:
        qq = V.quantity(q)
        if abs(v) > qq.limit:
            raise InputError(
                f"{path}, line {lineno}: field {field!r} = {text} is out of range for {V._an(qq.label)} "
                f"(|value| <= {qq.limit:g} {qq.unit}); check the unit"
            )
    return v


def parse_vector(text: str, n: int, what: str, q: str | None = None) -> np.ndarray:
    """'1,2,3' -> array of n checked floats, with a message naming ``what``."""
    try:
        v = [float(x) for x in str(text).split(",")]
    except ValueError:
        raise InputError(f"{what}: {text!r} is not a comma-separated list of numbers") from None
    if len(v) != n:
        raise InputError(f"{what}: expected {n} comma-separated numbers, got {len(v)}")
    return V.array(v, what, (n,), q)


def matrix6(value: object, name: str, hint: str = "") -> np.ndarray:
    """A 6x6 matrix of finite floats from ``value`` (nested lists or an
    array), or InputError naming ``name`` (e.g. "file.json: 'compliance'");
    ``hint`` follows the message of a value that is not numbers."""
    if isinstance(value, (str, bytes, dict)) or value is None:
        raise InputError(f"{name} must be 6 rows of 6 numbers{hint}")
    try:
        m = V.array(value, name, None, "matrix6")
    except InputError as exc:
        msg = str(exc)
        if "finite" in msg:
            raise InputError(f"{name} contains NaN or Inf") from None
        if "out of range" in msg:
            raise
        raise InputError(f"{name} must be 6 rows of 6 numbers{hint}") from None
    if m.shape != (6, 6):
        raise InputError(f"{name} must be a 6x6 matrix, got shape {m.shape}")
    return m


def _no_constant(name: str) -> None:
    raise ValueError(f"{name} is not a JSON number (JSON has no NaN or Infinity)")


def _no_duplicates(pairs: list) -> dict:
    keys = [k for k, _ in pairs]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise ValueError(f"the key {dup[0]!r} appears twice in one object (which one is meant?)")
    return dict(pairs)


def _document(
    path: Path | str,
    what: str,
    where: str,
    error: type[InputError],
    kind: str,
    parse: Callable[[str], _T],
    errors: tuple[type[Exception], ...],
) -> _T:
    path = Path(path)
    at = f"{where}: {path}" if where else str(path)
    text = read_text(path, what, where, error)
    try:
        return parse(text)
    except (*errors, ValueError, RecursionError) as exc:
        raise error(f"{at}: not valid {kind} ({' '.join(str(exc).split())})") from None


def read_json(path: Path | str, what: str, where: str = "", error: type[InputError] = InputError) -> object:
    """The JSON document in ``path``; ``error`` (InputError by default)
    naming ``where`` (the caller's context, if any) and the file when it is
    missing, not UTF-8 or not JSON (NaN and Infinity are not JSON, and an
    object that names a key twice is refused);
    ``what`` names the kind of file in the message."""
    return _document(
        path,
        what,
        where,
        error,
        "JSON",
        lambda t: json.loads(t, parse_constant=_no_constant, object_pairs_hook=_no_duplicates),
        (json.JSONDecodeError,),
    )


def read_toml(path: Path | str, what: str, where: str = "", error: type[InputError] = InputError) -> dict:
    """The TOML document in ``path``, with the messages of :func:`read_json`."""
    return _document(path, what, where, error, "TOML", tomllib.loads, (tomllib.TOMLDecodeError,))
