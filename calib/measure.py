"""Measured deflections under known wrenches: the CSV of docs/calibration.md §3.

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
import numpy.typing as npt

from ..errors import InputError
from ..io import validate as V
from ..io.files import atomic_open
from ..io.tables import read_table
from .checks import copies_message

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

    def subset(self, idx: npt.ArrayLike) -> Measurements:
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


def read_measurements(path: Path | str, dof: int) -> Measurements:
    """Read and check a measurement CSV for a robot with ``dof`` joints.

    The table rules of stiffkit.io.tables hold (UTF-8, distinct header
    names, as many fields per row as the header). Raises InputError naming
    the file, the line and the field for a missing column, a non-number,
    NaN or Inf, or a value out of its quantity's range; warns when a
    column looks like another unit (mm, degrees) and when a row repeats
    another exactly (a copy: replicated measurements differ by their noise).
    """
    path = Path(path)
    dof = V.count(dof, "dof", 1)
    qcols = [f"q{i}" for i in range(1, dof + 1)]
    table = read_table(path, "measurement")
    table.require(qcols + WRENCH + DEFL, f" (the robot has {dof} joints)")
    extra = [c for c in table.header if c[:1] == "q" and c[1:].isdigit() and int(c[1:]) > dof]
    if extra:
        V.warn(
            f"{path}, line 1: column(s) {', '.join(extra)} ignored: the robot has {dof} joints (q1..q{dof}); "
            "are these measurements of another robot?"
        )
    for group, name in ((POINT, "point"), (ROT, "rotation")):
        present = [c for c in group if table.has(c)]
        if present and len(present) != 3:
            absent = [c for c in group if not table.has(c)]
            raise InputError(f"{path}, line 1: {name} columns incomplete: missing {', '.join(absent)}")
    n = len(table)
    q = table.numbers(qcols, "angle")
    w = np.hstack([table.numbers(WRENCH[:3], "force"), table.numbers(WRENCH[3:], "moment")])
    p = table.numbers(POINT, "position") if table.has("px") else np.zeros((n, 3))
    d = table.numbers(DEFL, "deflection")
    r = table.numbers(ROT, "rotation") if table.has("rx") else None
    configs = table.text("config") if table.has("config") else [f"row{ln}" for ln in table.lines]
    rows = np.hstack([q, w, p, d] + ([r] if r is not None else []))
    _warn_copies(rows, table.lines, path)
    _warn_columns(table.header, qcols, w, path)
    return Measurements(q=q, w=w, p=p, d=d, r=r, config=configs, lines=list(table.lines), path=str(path))


def _warn_copies(rows: np.ndarray, lines: list[int], path: Path | str) -> None:
    """One warning when rows repeat each other exactly (every number equal)."""
    msg = copies_message(rows, lines, path)
    if msg:
        V.warn(msg)


def _warn_columns(header: list[str], qcols: list[str], w: np.ndarray, path: Path | str) -> None:
    """Warnings the tracker reader gives too: a column that is not used (a
    q7 on a 6-joint robot), no measured point (the tool frame's origin is
    taken), every load zero (a deflection then identifies nothing)."""
    known = {"config", *qcols, *WRENCH, *POINT, *DEFL, *ROT}
    unused = [h for h in header if h not in known]
    if unused:
        V.warn(
            f"{path}: column(s) {', '.join(V.shown(h) for h in unused)} not used (the robot has {len(qcols)} "
            f"joints, {', '.join(qcols)}; the other columns are config, fx..mz, px py pz, dx dy dz, rx ry rz)"
        )
    if "px" not in header:
        V.warn(f"{path}: no px, py, pz columns: every deflection is taken at the tool frame's origin (0, 0, 0)")
    if w.size and not np.any(w):
        V.warn(
            f"{path}: every load is zero (fx..mz): a deflection under no load identifies no compliance; "
            "are the load columns filled?"
        )


def write_measurements(path: Path | str, meas: Measurements) -> None:
    """Write rows in the contract format (17 significant digits)."""
    dof = meas.q.shape[1]
    header = ["config"] + [f"q{i}" for i in range(1, dof + 1)] + WRENCH + POINT + DEFL
    if meas.r is not None:
        header += ROT
    with atomic_open(path, "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(header)
        for i in range(meas.n):
            vals = list(meas.q[i]) + list(meas.w[i]) + list(meas.p[i]) + list(meas.d[i])
            if meas.r is not None:
                vals += list(meas.r[i])
            wr.writerow([meas.config[i]] + [f"{v:.17g}" for v in vals])
