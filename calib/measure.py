"""Measured deflections under known wrenches: the CSV of contract s3.

One row per measured point and load: ``config`` (label; optional, rows are
then labelled by line), ``q1..qN`` (rad),
``fx fy fz mx my mz`` (N, N m; at the tool-frame origin, base axes),
optional ``px py pz`` (m, tool frame; 0 if absent), ``dx dy dz`` (m, base
axes) and optional ``rx ry rz`` (rad). Extra columns are ignored.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.tables import parse_number

WRENCH = ["fx", "fy", "fz", "mx", "my", "mz"]
POINT = ["px", "py", "pz"]
DEFL = ["dx", "dy", "dz"]
ROT = ["rx", "ry", "rz"]


@dataclass
class Measurements:
    """Rows of a measurement file (arrays row-aligned)."""

    q: np.ndarray  # (n, dof)
    w: np.ndarray  # (n, 6)
    p: np.ndarray  # (n, 3)
    d: np.ndarray  # (n, 3)
    r: np.ndarray | None  # (n, 3) or None
    config: list[str]
    lines: list[int]  # 1-based line numbers in the file
    path: str = "measurements"

    @property
    def n(self) -> int:
        return self.q.shape[0]

    def subset(self, idx) -> Measurements:
        idx = np.asarray(idx)
        return Measurements(
            self.q[idx],
            self.w[idx],
            self.p[idx],
            self.d[idx],
            None if self.r is None else self.r[idx],
            [self.config[i] for i in idx],
            [self.lines[i] for i in idx],
            self.path,
        )


def read_measurements(path, dof: int) -> Measurements:
    """Read and check a measurement CSV for a robot with ``dof`` joints.

    Raises InputError naming the file, the line and the field for a missing
    column, a non-number, NaN or Inf, or a row with too few fields.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such measurement file")
    qcols = [f"q{i}" for i in range(1, dof + 1)]
    with path.open(newline="", encoding="utf-8-sig") as fh:  # a spreadsheet's BOM is not a column name
        reader = csv.reader(fh)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise InputError(
                f"{path}: empty file; expected a header with config, "
                f"{', '.join(qcols)}, {', '.join(WRENCH)}, {', '.join(DEFL)}"
            ) from None
        required = qcols + WRENCH + DEFL
        missing = [c for c in required if c not in header]
        if missing:
            raise InputError(
                f"{path}, line 1: missing column(s) {', '.join(missing)} "
                f"(the robot has {dof} joints; header has: {', '.join(header)})"
            )
        has_p = any(c in header for c in POINT)
        has_r = any(c in header for c in ROT)
        for group, name in ((POINT, "point"), (ROT, "rotation")):
            present = [c for c in group if c in header]
            if present and len(present) != 3:
                absent = [c for c in group if c not in header]
                raise InputError(f"{path}, line 1: {name} columns incomplete: missing {', '.join(absent)}")
        numeric = qcols + WRENCH + DEFL + (POINT if has_p else []) + (ROT if has_r else [])
        has_config = "config" in header
        labels = numeric + (["config"] if has_config else [])
        idx = {c: header.index(c) for c in labels}
        rows, configs, lines = [], [], []
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not x.strip() for x in row):
                continue
            vals = {}
            for c in labels:
                i = idx[c]
                if i >= len(row):
                    raise InputError(
                        f"{path}, line {lineno}: field {c!r} is missing "
                        f"(row has {len(row)} fields, header {len(header)})"
                    )
                if c == "config":
                    continue
                vals[c] = parse_number(row[i], path, lineno, c)
            rows.append(vals)
            configs.append(row[idx["config"]].strip() if has_config else f"row{lineno}")
            lines.append(lineno)
    if not rows:
        raise InputError(f"{path}: no data rows")

    def cols(names):
        return np.array([[r[c] for c in names] for r in rows], dtype=float)

    n = len(rows)
    return Measurements(
        q=cols(qcols),
        w=cols(WRENCH),
        p=cols(POINT) if has_p else np.zeros((n, 3)),
        d=cols(DEFL),
        r=cols(ROT) if has_r else None,
        config=configs,
        lines=lines,
        path=str(path),
    )


def write_measurements(path, meas: Measurements) -> None:
    """Write rows in the contract format (17 significant digits)."""
    dof = meas.q.shape[1]
    header = ["config"] + [f"q{i}" for i in range(1, dof + 1)] + WRENCH + POINT + DEFL
    if meas.r is not None:
        header += ROT
    with open(path, "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(header)
        for i in range(meas.n):
            vals = list(meas.q[i]) + list(meas.w[i]) + list(meas.p[i]) + list(meas.d[i])
            if meas.r is not None:
                vals += list(meas.r[i])
            wr.writerow([meas.config[i]] + [f"{v:.17g}" for v in vals])
