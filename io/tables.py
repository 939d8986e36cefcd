"""Small readers that name the file, row and field of every problem."""

from __future__ import annotations

import csv
import json
import math
import tomllib
from pathlib import Path

import numpy as np

from ..errors import InputError


def read_columns(path, columns: list[str], what: str = "table") -> np.ndarray:
    """Read the named numeric columns of a CSV with a header row.

    Returns an (nrows, len(columns)) float array. Raises InputError naming
    the file, the 1-based line and the field for a missing column, a
    non-number or a NaN/Inf.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such {what} file")
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise InputError(f"{path}: empty file, expected a header with {', '.join(columns)}") from None
        missing = [c for c in columns if c not in header]
        if missing:
            raise InputError(f"{path}: missing column(s) {', '.join(missing)} (header has: {', '.join(header)})")
        idx = [header.index(c) for c in columns]
        rows = []
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not x.strip() for x in row):
                continue
            vals = []
            for c, i in zip(columns, idx):
                if i >= len(row):
                    raise InputError(f"{path}, line {lineno}: field {c!r} is missing (row has {len(row)} fields)")
                vals.append(parse_number(row[i], path, lineno, c))
            rows.append(vals)
    if not rows:
        raise InputError(f"{path}: no data rows")
    return np.array(rows, dtype=float)


def parse_number(text: str, path, lineno: int, field: str) -> float:
    """A finite float from one CSV field, or InputError naming file, line and field."""
    text = text.strip()
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{path}, line {lineno}: field {field!r} = {text!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"{path}, line {lineno}: field {field!r} is {text} (must be finite)")
    return v


def parse_vector(text: str, n: int, what: str) -> np.ndarray:
    """'1,2,3' -> array of n floats, with a message naming ``what``."""
    try:
        v = np.array([float(x) for x in text.split(",")], dtype=float)
    except ValueError:
        raise InputError(f"{what}: {text!r} is not a comma-separated list of numbers") from None
    if v.shape != (n,):
        raise InputError(f"{what}: expected {n} comma-separated numbers, got {v.size}")
    return v


def matrix6(value, name: str, hint: str = "") -> np.ndarray:
    """A 6x6 matrix of finite floats from ``value`` (nested lists or an
    array), or InputError naming ``name`` (e.g. "file.json: 'compliance'");
    ``hint`` follows the message of a value that is not numbers."""
    try:
        m = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be 6 rows of 6 numbers{hint}") from None
    if m.shape != (6, 6):
        raise InputError(f"{name} must be a 6x6 matrix, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise InputError(f"{name} contains NaN or Inf")
    return m


def _document(path, what: str, where: str, error, kind: str, parse, errors):
    path = Path(path)
    at = f"{where}: {path}" if where else str(path)
    if not path.is_file():
        raise error(f"{at}: no such {what} file")
    try:
        return parse(path.read_text())
    except (UnicodeDecodeError, *errors) as exc:
        raise error(f"{at}: not valid {kind} ({exc})") from None


def read_json(path, what: str, where: str = "", error: type[InputError] = InputError):
    """The JSON document in ``path``; ``error`` (InputError by default)
    naming ``where`` (the caller's context, if any) and the file when it is
    missing or not JSON; ``what`` names the kind of file in the message."""
    return _document(path, what, where, error, "JSON", json.loads, (json.JSONDecodeError,))


def read_toml(path, what: str, where: str = "", error: type[InputError] = InputError) -> dict:
    """The TOML document in ``path``, with the messages of :func:`read_json`."""
    return _document(path, what, where, error, "TOML", tomllib.loads, (tomllib.TOMLDecodeError,))
