"""The files of compensation (docs/calibration.md section 6.5): TARGETS.csv
read for a compensation model, COMMANDS.csv written (robot/compensate.py
solves)."""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..io.files import atomic_write_text
from ..io.tables import Table, read_table

if TYPE_CHECKING:
    from .compensate import Compensation, CompensationModel

__all__ = ["Targets", "read_targets", "commands_text", "write_commands", "ADDED_COLUMNS", "WRENCH"]

WRENCH = ["fx", "fy", "fz", "mx", "my", "mz"]
#: columns COMMANDS.csv adds to the input's
ADDED_COLUMNS = ["residual_position_m", "residual_rotation_rad", "converged", "mode"]


@dataclass
class Targets:
    """A targets file: its table, the joint columns (q order), the commands
    Q (n, dof), each row's frame and wrench (n, 6) or None."""

    table: Table
    jcols: list[str]
    Q: np.ndarray
    frames: list[str]
    wrench: np.ndarray | None


def read_targets(path: str | Path, cm: CompensationModel, frame: str | None = None) -> Targets:
    """Read TARGETS.csv (docs/calibration.md 6.5) for the model ``cm``:
    joint columns named as the actuated joints (or q1..qN), optional
    ``frame`` and ``fx fy fz mx my mz`` (all or none). ``frame`` (the
    --frame option) names the frame of every row of a file without a frame
    column."""
    path = Path(path)
    t = read_table(path, "targets")
    head = t.header
    for h in head:
        if h in cm.mimics:
            raise InputError(
                f"{path}, line 1: column {h!r} is a mimic joint (it follows {cm.mimics[h]!r}); "
                f"give only the actuated joints ({', '.join(cm.joints)})"
            )
    qnames = [f"q{k + 1}" for k in range(cm.dof)]
    if all(j in head for j in cm.joints):
        jcols = list(cm.joints)
    elif all(q in head for q in qnames) and not any(j in head for j in cm.joints):
        jcols = qnames
    else:
        missing = [j for j in cm.joints if j not in head]
        raise InputError(
            f"{path}, line 1: missing joint column(s) {', '.join(missing)} (a column per actuated joint, "
            f"{', '.join(cm.joints)}, or q1..q{cm.dof}; header has: {', '.join(head)})"
        )
    Q = t.numbers(jcols, "angle")
    if "frame" in head:
        if frame is not None:
            raise InputError(f"--frame {frame}: {path} has a frame column, which names each row's frame; give one")
        frames = []
        for name, line in zip(t.text("frame"), t.lines):
            if not name:
                raise InputError(f"{path}, line {line}: field 'frame' is empty")
            frames.append(cm.check_frame(name, f"{path}, line {line}"))
    else:
        if frame is None:
            frame = cm.default_frame
        if frame is None:
            raise InputError(
                f"{path}: no 'frame' column and the model has no single tool frame; add a frame column or give "
                f"--frame (frames: {', '.join(cm.frames)})"
            )
        frames = [cm.check_frame(frame, "--frame")] * len(t)
    have = [c for c in WRENCH if c in head]
    wrench = None
    if have and len(have) != 6:
        missing = [c for c in WRENCH if c not in head]
        raise InputError(
            f"{path}, line 1: payload columns must be all of {' '.join(WRENCH)} or none; missing {', '.join(missing)}"
        )
    if have:
        wrench = np.hstack([t.numbers(WRENCH[:3], "force"), t.numbers(WRENCH[3:], "moment")])
    return Targets(t, jcols, Q, frames, wrench)


def _num(v: float) -> str:
    return repr(float(v)) if math.isfinite(v) else ""


def commands_text(targets: Targets, res: Compensation) -> str:
    """COMMANDS.csv: the input's columns, joint columns replaced by q', and
    ADDED_COLUMNS (replaced in place when the input has them already)."""
    t = targets.table
    head = list(t.header) + [c for c in ADDED_COLUMNS if c not in t.header]
    jpos = [head.index(c) for c in targets.jcols]
    apos = [head.index(c) for c in ADDED_COLUMNS]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(head)
    for i, row in enumerate(t.rows):
        cells = list(row) + [""] * (len(head) - len(row))
        for k, c in enumerate(jpos):
            cells[c] = _num(res.q[i, k])
        added = [
            _num(res.resp[i]),
            _num(res.resr[i]),
            "1" if res.converged[i] else "0",
            "pose" if res.full6[i] else "position",
        ]
        for c, v in zip(apos, added):
            cells[c] = v
        w.writerow(cells)
    return buf.getvalue()


def write_commands(path: str | Path, targets: Targets, res: Compensation) -> Path:
    """Write COMMANDS.csv atomically (commands_text)."""
    return atomic_write_text(path, commands_text(targets, res))
