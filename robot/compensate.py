"""Compensation (docs/calibration.md section 6.5): the joint command q' for
which the identified model puts a frame where the nominal model puts it at
the command q.

The nominal model is the URDF alone (no effects, rigid); its frame poses
are the core's forward kinematics (core/sk_tree.f90). The identified model
is the model file with values (section 5), expressed as a tree of virtual
joints (robot/tree_model.py) and solved by the core's compensation
(core/sk_tree_solve.f90 compensate_batch): Newton on q' and the elastic
equilibrium together, the pose (position and orientation) when the path to
the frame has 6 or more independent joints, the position otherwise; a
redundant path gets the least-norm change of q.

Two kinds of model file:

- absolute (``[measurements] kind = "absolute"``, section 6): the tree
  model as it is (joint offsets, frame errors, joint, lateral and 6-dof
  springs under the robot's weight at equilibrium, and the row's payload
  at the row's frame). Tracker and markers play no part (the poses are
  base-frame poses).
- relative (sections 2-5, a serial chain): the chain from base_link to
  tool_frame becomes a tree model with gravity off, first-order
  equilibrium (the springs' forces at the undeflected pose, the frame at
  the deflected one) and the row's wrench as a payload at the tool frame:
  ``joint`` springs are the linear law on the joint's virtual joint,
  ``link``/``base``/``tool`` 6x6 springs are 6-dof spring joints at the
  frames section 2 defines, ``joint_cubic`` and ``joint_deadzone`` are the
  core's cubic and dead-zone laws (``c tau + c3 tau^3``,
  ``c tau + b tanh(tau / tau0)``). ``joint_profile`` and
  ``gravity_compensator`` make a joint's compliance depend on its angle:
  it is evaluated per row at the compensated command (the core takes it as
  a per-row value, and the rows are solved again with the compliance at
  the new q' until q' moves by less than ``PASS_TOL``; the joint's
  compliance is held over one Newton solve, its change with q' is a
  fixed-point iteration whose rate is the relative change of c over the
  correction, ~1e-3). ``point_offset`` concerns measured points, not the
  frame, and is ignored. The relative data's measurement model (section 3:
  twist = sum J C J^T W) is the first-order model linearised in the
  deflection; the core evaluates the deflected frame exactly, so the two
  differ by O(|delta|^2 L) (1e-6 m for 1 mrad on a 1 m arm).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from .._core import tree as core
from ..errors import InputError, StiffkitWarning
from ..io import validate as V
from ..io.files import model_inputs
from ..io.tables import read_toml
from . import catalogue
from .compensate_files import ADDED_COLUMNS, WRENCH, Targets, commands_text, read_targets, write_commands
from .model import Model, load_model
from .tree import Tree, load_tree
from .tree_model import LAW_DEADZONE, TreeModel, load_tree_model, tree_model_from_tables
from .urdf_checks import limit_warnings

__all__ = [
    "CompensationModel",
    "Compensation",
    "Targets",
    "CompensationReport",
    "load_compensation_model",
    "read_targets",
    "write_commands",
    "commands_text",
    "compensate",
    "ADDED_COLUMNS",
    "WRENCH",
]

#: Newton tolerances: position (m), rotation (rad), equilibrium (m of point motion)
PTOL, RTOL, ETOL = 1e-10, 1e-10, 1e-11
#: most Newton steps per row
MAXIT = 50
#: posture-dependent compliances (relative models): solves at most, and the
#: motion of q' (rad) below which the compliance at q' is taken as settled
PASSES, PASS_TOL = 8, 1e-11
#: rows per call of the core: an interrupt waits for one batch at most (~0.05-0.2 s)
BATCH = 128
#: kinds of a relative model whose joint compliance depends on the joint angle
VARYING = catalogue.POSTURE_DEPENDENT


@dataclass
class CompensationModel:
    """An identified model ready for compensation, and its nominal model.

    ``joints``: the actuated joints (the columns of a targets file, q
    order); ``frames``: the links a row may name; ``default_frame``: the
    frame of rows that name none (None: the rows must); ``load_at``: the
    frame of the row's wrench (relative models: the tool frame; None: the
    row's frame); ``varying``: (theta index, chain joint index) of the
    compliances that depend on the posture (relative models)."""

    kind: str
    path: Path | None
    model: TreeModel
    theta: np.ndarray
    nominal: TreeModel
    joints: list[str]
    frames: list[str]
    default_frame: str | None
    mimics: dict[str, str] = field(default_factory=dict)
    load_at: str | None = None
    varying: list[tuple[int, int]] = field(default_factory=list)
    source: Model | None = None

    @property
    def dof(self) -> int:
        return len(self.joints)

    def independent(self, frame: str) -> int:
        """Number of independent joint coordinates that move ``frame``."""
        tree = self.model.tree
        return len({tree.leader(j.name)[0] for j in tree.path(frame) if j.moving})

    def full6(self, frame: str) -> bool:
        """Pose (True) or position only (False) for ``frame``."""
        return self.independent(frame) >= 6

    def check_frame(self, frame: str, where: str) -> str:
        if frame not in self.frames:
            raise InputError(f"{where}: unknown frame {frame!r}; frames of the model: {', '.join(self.frames)}")
        return frame

    def _row_values(self, Q: np.ndarray) -> np.ndarray:
        """(n, k) posture-dependent compliances of the ``varying`` joints at Q."""
        src = self.source
        terms = [t for t in src.terms if t.kind in ("joint",) + VARYING]
        c = src.joint_compliances(Q, terms=terms)
        return np.column_stack([c[j] for _i, j in self.varying])

    def compensate(
        self,
        Q: ArrayLike,
        frames: str | Sequence[str] | None = None,
        wrench: ArrayLike | None = None,
        check_plausible: bool = True,
    ) -> Compensation:
        """Commands q' (n, dof) for the commands Q (n, dof), one frame per row
        (a name, a list of n names, or None: the default frame) and an
        optional wrench per row (n, 6): (f, m) at the frame origin (relative
        models: at the tool frame), base axes, N and N m. ``check_plausible``:
        warn about values implausible for their unit (a reader that warned
        already passes False)."""
        Q = np.atleast_2d(V.array(Q, "commands", None, "angle", check_plausible=check_plausible))
        if Q.ndim != 2 or Q.shape[1] != self.dof or Q.shape[0] < 1:
            raise InputError(f"commands must have shape (n, {self.dof}), got {np.shape(Q)}")
        n = Q.shape[0]
        if frames is None:
            if self.default_frame is None:
                raise InputError(f"the model has several frames ({', '.join(self.frames)}); name the frame of the rows")
            frames = self.default_frame
        if isinstance(frames, str):
            frames = [self.check_frame(frames, "frame")] * n
        else:
            frames = [self.check_frame(f, f"frames[{i}]") for i, f in enumerate(frames)]
            if len(frames) != n:
                raise InputError(f"frames: {len(frames)} names for {n} commands")
        if wrench is not None:
            wrench = np.atleast_2d(V.array(wrench, "wrench", None, "force", check_plausible=check_plausible))
            if wrench.ndim != 2 or wrench.shape[1] != 6:
                raise InputError(f"wrench must have shape (n, 6), got {wrench.shape}")
            if wrench.shape[0] != n:
                raise InputError(f"wrench must have shape ({n}, 6), got {wrench.shape}")
        t0 = time.perf_counter()
        names = sorted(set(frames))
        fidx = np.array([names.index(f) for f in frames])
        nom_vj = np.array([self.nominal.vj_of_link[f] for f in names], np.int32)[fidx]
        vj = np.array([self.model.vj_of_link[f] for f in names], np.int32)[fidx]
        lvj = vj if self.load_at is None else np.full(n, self.model.vj_of_link[self.load_at], np.int32)
        full6 = np.array([self.full6(f) for f in names], bool)[fidx]
        out = Compensation(
            q=Q.copy(),
            resp=np.full(n, np.nan),
            resr=np.full(n, np.nan),
            converged=np.zeros(n, bool),
            nit=np.zeros(n, int),
            full6=full6,
            frames=frames,
        )
        # batches of rows: the time of a row does not grow with their number,
        # and Ctrl-C (SIGTERM) takes effect between two core calls
        R, p = np.empty((n, 3, 3)), np.empty((n, 3))
        nominal = core.pack(0, self.nominal.arrays)
        for lo in range(0, n, BATCH):
            batch = np.arange(lo, min(n, lo + BATCH))
            # targets: the nominal model (rigid URDF) at the commands
            P = core.frame_jacobian(nominal, self.nominal.theta0, nom_vj[batch], Q[batch], None, 0, ETOL)
            R[batch], p[batch] = P["R"], P["p"]
            for mode in (True, False):
                rows = batch[full6[batch] == mode]
                if rows.size:
                    self._solve(rows, Q, R, p, vj, lvj, wrench, mode, out)
        out.seconds = time.perf_counter() - t0
        return out

    def _solve(
        self,
        rows: np.ndarray,
        Q: np.ndarray,
        R: np.ndarray,
        p: np.ndarray,
        vj: np.ndarray,
        lvj: np.ndarray,
        wrench: np.ndarray | None,
        full6: bool,
        out: Compensation,
    ) -> None:
        """Compensate ``rows`` (one mode) into ``out``; posture-dependent
        compliances by passes (module docstring)."""
        loads = None
        if wrench is not None:
            w = wrench[rows]
            hit = np.flatnonzero(np.any(w != 0, axis=1))
            if hit.size:
                loads = (hit, lvj[rows][hit], w[hit])
        qk = Q[rows].copy()
        todo = np.arange(rows.size)
        packed = self.model.packed
        for _pass in range(PASSES if self.varying else 1):
            params = None
            if self.varying:
                params = (np.array([i for i, _j in self.varying]), self._row_values(qk[todo]))
            sub_loads = _subset_loads(loads, todo)
            r = core.compensate(
                packed,
                self.theta,
                vj[rows][todo],
                Q[rows][todo],
                R[rows][todo],
                p[rows][todo],
                sub_loads,
                full6,
                self.model.eqit,
                ETOL,
                MAXIT,
                PTOL,
                RTOL,
                row_params=params,
            )
            moved = np.max(np.abs(r["q"] - qk[todo]), axis=1) if self.dof else np.zeros(todo.size)
            qk[todo] = r["q"]
            at = rows[todo]
            out.q[at] = r["q"]
            out.resp[at] = r["resp"]
            out.resr[at] = r["resr"]
            out.nit[at] += r["nit"]
            ok = r["rinfo"] == 0
            out.converged[at] = ok
            if not self.varying:
                break
            # rows whose compliance at q' is not settled yet
            todo = todo[ok & (moved > PASS_TOL)]
            out.converged[rows[todo]] = False
            if todo.size == 0:
                break


def _subset_loads(loads: tuple | None, todo: np.ndarray) -> tuple | None:
    """The payloads of rows ``todo`` (posture indices renumbered)."""
    if loads is None:
        return None
    pos = -np.ones(int(max(loads[0].max(), todo.max())) + 1, int)
    pos[todo] = np.arange(todo.size)
    keep = pos[loads[0]] >= 0 if loads[0].size else np.zeros(0, bool)
    if not keep.any():
        return None
    return pos[loads[0][keep]], loads[1][keep], loads[2][keep]


@dataclass
class Compensation:
    """Commands ``q`` (n, dof), remaining errors ``resp`` (m) and ``resr``
    (rad; for position-only rows the orientation error left, which is not
    controlled), ``converged``, Newton steps ``nit``, ``full6`` (pose or
    position) and the frame of every row."""

    q: np.ndarray
    resp: np.ndarray
    resr: np.ndarray
    converged: np.ndarray
    nit: np.ndarray
    full6: np.ndarray
    frames: list[str]
    seconds: float = 0.0

    @property
    def n(self) -> int:
        return int(self.q.shape[0])


# ---------------------------------------------------------------------------
# models


def _check_values(m: TreeModel, where: str) -> None:
    """Every parameter but the tracker's and the markers' must carry a value."""
    for p in m.params:
        if p.free and p.kind not in ("tracker", "marker"):
            e = m.effects[p.effect]
            tgt = f", target {e['target']!r}" if "target" in e else ""
            raise InputError(
                f"{where}: [[effect]] #{p.effect + 1} ({p.kind}{tgt}) has no value; compensation evaluates a "
                f"model with values (docs/calibration.md section 5): identify it first (stiffkit fit --write-model)"
            )
    for k, law in enumerate(m.arrays["ktype"]):
        if law == LAW_DEADZONE and not m.arrays["kw0"][k] > 0:
            raise InputError(f"{where}: joint_deadzone on {m.blocks[k][1]!r} has a value but no tau0 (N m)")


def _moving_links(tree: Tree) -> list[str]:
    """Links with at least one moving joint between the root and them."""
    return [ln for ln in tree.links if any(j.moving for j in tree.path(ln))]


def _nominal(tree: Tree, frame: str, where: str) -> TreeModel:
    """The URDF alone: no effect, rigid (tracker and marker are placeholders)."""
    eff = [{"kind": "tracker", "fixed": True}, {"kind": "marker", "target": frame, "fixed": True}]
    return tree_model_from_tables(tree, eff, (0.0, 0.0, 0.0), 1, where)


def _nominal_tree(m: TreeModel, path: Path) -> Tree:
    """The robot the commands refer to: the model's URDF, or ``[robot]
    nominal_urdf`` when the model's URDF already holds the corrections
    (``stiffkit fit --write-urdf`` with ``--write-model``)."""
    nom = m.robot_table.get("nominal_urdf")
    if nom is None:
        return m.tree
    if not isinstance(nom, str):
        raise InputError(f"{path}: [robot] nominal_urdf must be a file name")
    p = Path(nom) if Path(nom).is_absolute() else path.parent / nom
    tree = load_tree(p, m.tree.root)
    if [j.name for j in tree.joints] != [j.name for j in m.tree.joints]:
        raise InputError(f"{path}: [robot] nominal_urdf {p} is not the same robot as {m.tree.urdf} (other joints)")
    return tree


def _absolute(path: Path) -> CompensationModel:
    m = load_tree_model(path)
    _check_values(m, str(path))
    tree = m.tree
    frames = _moving_links(tree)
    if not frames:
        raise InputError(f"{path}: no link of the URDF moves with a joint; nothing to compensate")
    default = m.robot_table.get("tool_frame")
    if default is not None and default not in frames:
        raise InputError(f"{path}: [robot] tool_frame {default!r} is not a moving link (links: {', '.join(frames)})")
    if default is None:
        mk = [f for f in m.frames if f in frames]
        default = mk[0] if len(mk) == 1 else None
    mimics = {j.name: j.mimic[0] for j in tree.joints if j.moving and j.mimic is not None}
    return CompensationModel(
        kind="absolute",
        path=path,
        model=m,
        theta=m.theta0,
        nominal=_nominal(_nominal_tree(m, path), frames[0], str(path)),
        joints=tree.actuated,
        frames=frames,
        default_frame=default,
        mimics=mimics,
    )


def _check_chain_values(model: Model, where: str) -> None:
    """Every effect of a chain model but point_offset must carry a value."""
    for t in model.terms:
        if t.kind != "point_offset" and t.value is None:
            raise InputError(
                f"{where}: [[effect]] #{t.effect + 1} ({t.source or t.kind} on {t.target!r}) has no value; "
                f"compensation evaluates a model with values (section 5): identify it first "
                f"(stiffkit fit --write-model)"
            )


def _relative(path: Path) -> CompensationModel:
    model = load_model(path)
    _check_chain_values(model, str(path))
    ct = model.tree_model(str(path))
    tm, varying, tree = ct.model, ct.varying, ct.tree
    frames = _moving_links(tree)
    return CompensationModel(
        kind="relative",
        path=path,
        model=tm,
        theta=tm.theta0,
        nominal=_nominal(tree, model.chain.tool_frame, str(path)),
        joints=model.chain.actuated,
        frames=frames,
        default_frame=model.chain.tool_frame,
        load_at=model.chain.tool_frame,
        varying=varying,
        source=model,
    )


def load_compensation_model(path: str | Path) -> CompensationModel:
    """Read a model file with values: absolute (section 6) or relative
    (sections 2-5), by its ``[measurements] kind``."""
    if not isinstance(path, (str, Path)):
        raise InputError(f"a model is given by the path of its TOML file, got {type(path).__name__}")
    path = Path(path)
    doc = read_toml(path, "model")
    meas = doc.get("measurements", {})
    kind = meas.get("kind", "deflection") if isinstance(meas, dict) else "deflection"
    return _absolute(path) if kind == "absolute" else _relative(path)


@dataclass
class CompensationReport:
    """What ``stiffkit compensate`` did: the model, the targets, the result."""

    cm: CompensationModel
    targets: Targets
    result: Compensation
    out: Path | None = None

    @property
    def failed_lines(self) -> list[int]:
        return [ln for ln, ok in zip(self.targets.table.lines, self.result.converged) if not ok]

    def text(self) -> str:
        cm, r = self.cm, self.result
        lines = [
            f"compensated {r.n} command(s) of {self.targets.table.path} with the {cm.kind} model {cm.path} "
            f"in {r.seconds:.3g} s ({r.n / max(r.seconds, 1e-9):.3g} rows/s)"
        ]
        dq = np.abs(r.q - self.targets.Q)
        for f in sorted(set(r.frames)):
            rows = np.array([x == f for x in r.frames])
            ok = rows & r.converged
            mode = "position and orientation" if cm.full6(f) else "position only"
            line = (
                f"  frame {f}: {mode} ({cm.independent(f)} independent joints), {rows.sum()} row(s), "
                f"{ok.sum()} converged"
            )
            if ok.any():
                line += f"; residual up to {r.resp[ok].max():.2g} m"
                if cm.full6(f):
                    line += f", {r.resr[ok].max():.2g} rad"
                line += f"; |q' - q| up to {dq[ok].max():.4g}"
            lines.append(line)
        if self.out is not None:
            lines.append(f"wrote {self.out}")
        return "\n".join(lines)

    def warnings(self) -> list[str]:
        bad = self.failed_lines
        if not bad:
            return []
        shown = ", ".join(str(x) for x in bad[:10]) + (", ..." if len(bad) > 10 else "")
        return [
            f"{len(bad)} of {self.result.n} row(s) did not converge (line(s) {shown}): the target is out of "
            f"the identified model's reach or near a singular posture; their commands are the best found, "
            f"flagged converged = 0 with the residual left"
        ]


def _has_values(cm: CompensationModel) -> bool:
    """Whether the model holds a value other than 0 (beyond the tracker and
    markers): else it is the nominal robot and compensates nothing."""
    if cm.source is not None:
        return any(t.value is not None and np.any(np.asarray(t.value) != 0) for t in cm.source.terms)
    m = cm.model
    free = [cm.theta[i] for i, p in enumerate(m.params) if p.kind not in ("tracker", "marker")]
    return bool(np.any(np.asarray(free) != 0)) or "nominal_urdf" in m.robot_table


def compensate(
    model: str | Path, targets: str | Path, out: str | Path | None = None, frame: str | None = None
) -> CompensationReport:
    """``stiffkit compensate MODEL.toml TARGETS.csv --out COMMANDS.csv
    [--frame F]`` (docs/calibration.md 6.5). ``out``: where COMMANDS.csv
    goes (checked before any work, written atomically), or None. Rows
    that do not converge are flagged in the file and given as a warning
    (StiffkitWarning)."""
    if out is not None:
        out = V.output_path(out, "--out", [*model_inputs(model), targets])
    cm = load_compensation_model(model)
    tg = read_targets(targets, cm, frame)
    lim = {j.name: j.limit for j in cm.model.tree.joints}
    for msg in limit_warnings(tg.Q, cm.joints, [lim.get(j) for j in cm.joints], tg.table.lines, tg.table.path):
        V.warn(msg, key=("limits", msg))
    res = cm.compensate(tg.Q, tg.frames, tg.wrench, check_plausible=False)
    if np.array_equal(res.q, tg.Q) and not _has_values(cm):
        raise InputError(
            f"{cm.path}: the model changes no command: its effects have no identified value other than 0 (or it "
            f"has none), so the {res.n} command(s) of {tg.table.path} would be the targets unchanged; compensate "
            "with a fitted model (stiffkit fit --write-model)"
        )
    rep = CompensationReport(cm, tg, res, None)
    if out is not None:
        rep.out = write_commands(out, tg, res)
    for msg in rep.warnings():
        warnings.warn(StiffkitWarning(f"{tg.table.path}: {msg}"), stacklevel=2)
    return rep
