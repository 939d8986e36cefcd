"""Absolute measurements (docs/calibration.md section 6.3): where markers on
the robot are, in the tracker's frame, one row per measured point.

Columns: ``config`` (rows with the same label were measured in one posture),
one column per actuated joint named as in the URDF (``q1..qN`` also accepted
for a chain), ``frame`` (the link the point rides on; may be omitted when
the model has one marker), ``x y z`` (m, tracker frame); optional
``fx fy fz mx my mz`` (a payload wrench at the frame's origin, base axes,
N and N m) and ``weight``. Every problem is named with the file, the line
and the field.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..io.tables import parse_number
from ..robot.urdf_checks import limit_warnings
from .checks import copies_message

__all__ = ["AbsoluteData", "read_absolute", "write_absolute", "row_values", "WRENCH"]

WRENCH = ["fx", "fy", "fz", "mx", "my", "mz"]
XYZ = ["x", "y", "z"]
#: how far (rad or m, relative above 1) a mimic joint's column may stray from its <mimic> law
MIMIC_TOL = 1e-6
#: what x, y and z all read in a row whose marker the tracker did not see
UNSEEN = ("", "nan", "na", "n/a", "-")


@dataclass
class AbsoluteData:
    """Rows of absolute measurements grouped into postures.

    Q (np, ndof): the joint values of each posture (configuration), in the
    order of ``joints``; rows: ``posture`` (n,) index into Q, ``frame`` (n,)
    index into ``frames``, ``xyz`` (n, 3) measured points, ``weight`` (n,),
    ``lines`` (n,) line numbers; ``payloads``: (posture, frame index,
    wrench (6,)) per posture and frame that carries one."""

    path: str
    joints: list[str]
    configs: list[str]
    Q: np.ndarray
    posture: np.ndarray
    frame: np.ndarray
    frames: list[str]
    xyz: np.ndarray
    weight: np.ndarray
    lines: np.ndarray
    payloads: list[tuple[int, int, np.ndarray]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def n(self) -> int:
        return int(self.xyz.shape[0])

    @property
    def n_postures(self) -> int:
        return int(self.Q.shape[0])

    def subset(self, rows: np.ndarray) -> AbsoluteData:
        """The rows ``rows`` (bool mask or indices), with the postures they use."""
        rows = np.flatnonzero(rows) if np.asarray(rows).dtype == bool else np.asarray(rows, int)
        used = np.unique(self.posture[rows])
        remap = -np.ones(self.n_postures, int)
        remap[used] = np.arange(used.size)
        return AbsoluteData(
            path=self.path,
            joints=self.joints,
            configs=[self.configs[k] for k in used],
            Q=self.Q[used],
            posture=remap[self.posture[rows]],
            frame=self.frame[rows],
            frames=self.frames,
            xyz=self.xyz[rows],
            weight=self.weight[rows],
            lines=self.lines[rows],
            payloads=[(int(remap[p]), f, w) for p, f, w in self.payloads if remap[p] >= 0],
            warnings=list(self.warnings),
        )


def read_absolute(
    path: str | Path,
    joints: list[str],
    frames: list[str],
    mimic: dict | None = None,
    needed: set[str] | None = None,
    limits: dict | None = None,
) -> AbsoluteData:
    """Read an absolute-measurement CSV for a robot with actuated ``joints``
    (URDF order) and marker ``frames``; ``mimic`` maps the joints whose
    value follows another to their actuated leader, or to (leader,
    multiplier, offset): then a column for one is checked against that law
    on every row (and an error where it strays), else it is an error;
    ``needed``: the joints that move a marker frame (the others may be left
    out of the file: held at 0, with a warning); ``limits``: joint name ->
    (lower, upper) of its URDF <limit> (a posture beyond one is warned
    about). Without a ``config`` column, rows with the same joint values are
    one configuration."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such measurement file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    reader = csv.reader(text.splitlines())
    try:
        header = [h.strip() for h in next(reader)]
    except StopIteration:
        raise InputError(
            f"{path}: empty file; expected a header with config, the joint names, frame, x, y, z"
        ) from None
    dup = sorted({h for h in header if header.count(h) > 1 and h})
    if dup:
        raise InputError(f"{path}: duplicate column(s) {', '.join(map(V.shown, dup))} in the header")
    col = {h: k for k, h in enumerate(header)}
    mimic = mimic or {}
    # a column for a mimic joint (joint_states lists them too): with its law
    # known, read as a check against the law; without, an error
    mimic_cols = {}
    for h in header:
        if h not in mimic:
            continue
        law = mimic[h]
        if isinstance(law, str) or law[0] not in header:
            lead = law if isinstance(law, str) else law[0]
            raise InputError(
                f"{path}: column {h!r} is a mimic joint (it follows {lead!r}); give only the actuated joints"
            )
        mimic_cols[h] = law
    held: list[str] = []
    if all(f"q{k + 1}" in col for k in range(len(joints))) and not any(j in col for j in joints):
        jcols = [col[f"q{k + 1}"] for k in range(len(joints))]
    else:
        missing = [j for j in joints if j not in col]
        # a joint that moves no measured frame (a head, a gripper) may be left out: held at 0
        blocking = [j for j in missing if needed is None or j in needed]
        if blocking:
            raise InputError(
                f"{path}: missing joint column(s) {', '.join(blocking)} (they move a measured frame; the actuated "
                f"joints of the URDF are {', '.join(joints)}; header has {', '.join(header)})"
            )
        held = missing
        jcols = [col.get(j) for j in joints]
    missing = [c for c in XYZ if c not in col]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)} (measured position, m, tracker frame)")
    if "frame" not in col and len(frames) != 1:
        raise InputError(f"{path}: no 'frame' column, but the model has {len(frames)} markers ({', '.join(frames)})")
    has_w = [c for c in WRENCH if c in col]
    if has_w and len(has_w) != 6:
        raise InputError(f"{path}: payload columns must be all of {' '.join(WRENCH)}, found only {' '.join(has_w)}")
    known = {"config", "frame", "weight", *XYZ, *WRENCH, *joints, *mimic_cols}
    known |= {f"q{k + 1}" for k in range(len(joints))}
    unused = [h for h in header if h not in known]
    by_posture: dict[bytes, str] = {}
    cfg_of, configs, Qrows, cfg_line = {}, [], [], {}
    post, frm, xyz, wt, lines, loads = [], [], [], [], [], {}
    unseen: list[int] = []
    for lineno, row in enumerate(reader, start=2):
        if not row or all(not x.strip() for x in row):
            continue
        if len(row) != len(header):
            raise InputError(f"{path}, line {lineno}: {len(row)} fields, the header has {len(header)}")
        q = np.array([0.0 if k is None else parse_number(row[k], path, lineno, header[k]) for k in jcols])
        for h, (lead, mult, off) in mimic_cols.items():
            v = parse_number(row[col[h]], path, lineno, h)
            expect = mult * parse_number(row[col[lead]], path, lineno, lead) + off
            if abs(v - expect) > MIMIC_TOL * max(1.0, abs(expect)):
                raise InputError(
                    f"{path}, line {lineno}: column {h!r} is a mimic joint (it follows {lead!r}): {v:.6g} here, but "
                    f"its <mimic> law gives {mult:g} x {lead} + {off:g} = {expect:.6g}; leave the column out, or "
                    f"remove the <mimic> tag from the URDF if this joint moves on its own"
                )
        if all(row[col[c]].strip().lower() in UNSEEN for c in XYZ):
            unseen.append(lineno)  # the marker was not seen in this posture: no point, not an error
            continue
        if "config" in col:
            label = row[col["config"]].strip()
        else:  # one configuration per distinct posture
            label = by_posture.setdefault(q.tobytes(), f"posture {len(by_posture) + 1}")
        if not label:
            raise InputError(f"{path}, line {lineno}: field 'config' is empty")
        if label in cfg_of:
            k = cfg_of[label]
            if not np.allclose(q, Qrows[k], rtol=0, atol=1e-9):
                raise InputError(
                    f"{path}, line {lineno}: configuration {label!r} has other joint values than on line "
                    f"{cfg_line[label]} (rows of one configuration share one posture)"
                )
        else:
            cfg_of[label] = len(configs)
            cfg_line[label] = lineno
            configs.append(label)
            Qrows.append(q)
        fname = row[col["frame"]].strip() if "frame" in col else frames[0]
        if fname not in frames:
            raise InputError(
                f"{path}, line {lineno}: frame {fname!r} has no marker in the model (markers: {', '.join(frames)})"
            )
        p = np.array([parse_number(row[col[c]], path, lineno, c) for c in XYZ])
        w = parse_number(row[col["weight"]], path, lineno, "weight") if "weight" in col else 1.0
        if w < 0:
            raise InputError(f"{path}, line {lineno}: weight {w} must be >= 0")
        if has_w:
            wr = np.array([parse_number(row[col[c]], path, lineno, c) for c in WRENCH])
            key = (cfg_of[label], frames.index(fname))
            if key in loads and not np.allclose(loads[key][0], wr, rtol=1e-12, atol=0):
                raise InputError(
                    f"{path}, line {lineno}: payload differs from line {loads[key][1]} for configuration "
                    f"{label!r}, frame {fname!r} (one payload per frame and posture)"
                )
            loads.setdefault(key, (wr, lineno))
        post.append(cfg_of[label])
        frm.append(frames.index(fname))
        xyz.append(p)
        wt.append(w)
        lines.append(lineno)
    if not xyz:
        raise InputError(
            f"{path}: no data rows" + (f" with a measured position ({len(unseen)} without)" if unseen else "")
        )
    wt = np.array(wt)
    if not np.any(wt > 0):
        raise InputError(f"{path}: every row has weight 0")
    data = AbsoluteData(
        path=str(path),
        joints=list(joints),
        configs=configs,
        Q=np.array(Qrows),
        posture=np.array(post, int),
        frame=np.array(frm, int),
        frames=list(frames),
        xyz=np.array(xyz),
        weight=wt,
        lines=np.array(lines, int),
        payloads=[(p, f, w) for (p, f), (w, _ln) in loads.items() if np.any(w)],
    )
    data.warnings = plausibility(data)
    if limits:
        data.warnings += limit_warnings(
            data.Q[data.posture], data.joints, [limits.get(j) for j in data.joints], data.lines, path
        )
    copied = copies_message(row_values(data), data.lines, path)
    if copied:
        data.warnings.append(copied)
    if unseen:
        shown = ", ".join(map(str, unseen[:8])) + (", ..." if len(unseen) > 8 else "")
        data.warnings.append(
            f"{path}: {len(unseen)} row(s) without a measured position (x, y, z all empty or NaN: the marker "
            f"was not seen) left out: line(s) {shown}"
        )
    if mimic_cols:
        data.warnings.append(
            f"{path}: column(s) {', '.join(repr(h) for h in mimic_cols)} of mimic joint(s) agree with the URDF's "
            f"<mimic> law on every row: read as a check, the values used are computed from the leaders"
        )
    if unused:
        data.warnings.append(
            f"{path}: column(s) {', '.join(repr(h) for h in unused)} not used (neither an actuated joint of the "
            f"URDF nor config, frame, x, y, z, weight, fx..mz); a misspelt joint name?"
        )
    if held:
        data.warnings.append(
            f"{path}: no column for {', '.join(held)}: these joints move no measured frame and are held at 0 "
            f"(their links' weight acts on the others as at q = 0)"
        )
    return data


def row_values(data: AbsoluteData) -> np.ndarray:
    """Every number of each row (n, ndof + 11): joint values, marker frame,
    x y z, weight, payload wrench; rows equal here are exact copies."""
    loads = {(p, f): w for p, f, w in data.payloads}
    wr = np.array([loads.get((int(p), int(f)), np.zeros(6)) for p, f in zip(data.posture, data.frame)])
    return np.column_stack([data.Q[data.posture], data.frame, data.xyz, data.weight, wr.reshape(-1, 6)])


def plausibility(data: AbsoluteData) -> list[str]:
    """Warnings about values implausible for their unit (degrees for
    radians, millimetres for metres), naming the column and the fix."""
    out = []
    big = np.abs(data.Q).max(axis=0) if data.Q.size else np.zeros(0)
    for j, v in zip(data.joints, big):
        if v > 2 * math.pi + 1e-6:
            out.append(
                f"{data.path}: joint {j!r} reaches {v:.4g}, beyond one turn: are the joint values in degrees? "
                f"(files are in rad: multiply by pi/180)"
            )
    out += scale_slips(data)
    use = data.weight > 0
    span = np.ptp(data.xyz[use], axis=0).max() if use.sum() > 1 else 0.0
    if span > 50.0:
        out.append(
            f"{data.path}: the measured points span {span:.4g} (x, y, z), implausible in metres for a robot: "
            f"millimetres? (files are in m: divide by 1000)"
        )
    return out


#: a configuration whose points lie this many times farther from the data's centre than the
#: others' median is a unit slip (1e3: mm, 1e2: cm), set aside before any fit
SLIP_RATIO = 30.0


def scale_slips(data: AbsoluteData) -> list[str]:
    """Configurations recorded in another unit of length (a few postures in
    mm among postures in m): their points lie ~1000 times farther from the
    data's centre. They get weight 0 (set aside: a tracker start or a fit
    through them would be meaningless) and a warning naming them and the
    fix; when most of the data is in such a unit the whole file is, which
    the tracker start reports."""
    if data.n < 4:
        return []
    centre = np.median(data.xyz, axis=0)
    dist = np.linalg.norm(data.xyz - centre, axis=1)
    typical = float(np.median(dist))
    if not typical > 0:
        return []
    out = []
    for p, label in enumerate(data.configs):
        rows = np.flatnonzero(data.posture == p)
        ratio = float(np.median(dist[rows])) / typical
        if ratio < SLIP_RATIO:
            continue
        unit, fix = ("mm", "divide by 1000") if ratio > 300 else ("cm", "divide by 100")
        data.weight[rows] = 0.0
        lines = ", ".join(str(int(x)) for x in data.lines[rows][:6])
        out.append(
            f"{data.path}: configuration {label!r} (line {lines}): its points lie {ratio:.0f}x farther from the "
            f"others' centre: recorded in {unit}? ({fix}); set aside"
        )
    return out


def write_absolute(path: str | Path, data: AbsoluteData) -> None:
    """Write ``data`` as an absolute-measurement CSV (joint-name columns)."""
    from ..io.files import atomic_write_text

    head = ["config"] + data.joints + ["frame", "x", "y", "z"]
    loads = {(p, f): w for p, f, w in data.payloads}
    if loads:
        head += WRENCH
    if np.any(data.weight != 1):
        head.append("weight")
    rows = [",".join(head)]
    for i in range(data.n):
        p = data.posture[i]
        cells = [data.configs[p]] + [f"{v:.17g}" for v in data.Q[p]]
        cells += [data.frames[data.frame[i]]] + [f"{v:.17g}" for v in data.xyz[i]]
        if loads:
            cells += [f"{v:.17g}" for v in loads.get((p, data.frame[i]), np.zeros(6))]
        if "weight" in head:
            cells.append(f"{data.weight[i]:.17g}")
        rows.append(",".join(cells))
    atomic_write_text(path, "\n".join(rows) + "\n")
