"""Models of a robot measured by a tracker (docs/calibration.md section 6):
a URDF tree with geometric and gravity-elastic effects, expanded into the
virtual joints of the core (core/sk_tree.f90).

Every effect becomes virtual joints or parameters of the core's model:

- ``tracker``: the tracker-from-base transform, 6 parameters
  ``tracker.x y z`` (m) and ``tracker.a1 a2 a3`` (rad), with
  ``T = Trans(x, y, z) * R_ref * Rx(a1) Ry(a2) Rz(a3)``; R_ref is the start
  (re-centred by the fit), so the angles stay small.
- ``marker`` (target: a link): the point's coordinates in that link's
  frame, ``marker.<link>.x y z`` (m).
- ``joint_offset`` (target: a moving joint or ``all``): ``<joint>.dq0``
  (rad, m for prismatic); a mimic follower turns by its multiplier times
  its leader's offset too.
- ``frame`` (target: a joint or ``all``): the joint's origin becomes
  ``T(origin) * Trans(dx, dy, dz) * Rx(drx) Ry(dry) Rz(drz)`` (origin
  axes): ``<joint>.dx dy dz drx dry drz``. Each rotation is an exact screw,
  so the analytic derivatives hold at any value.
- ``joint`` (target: a moving joint or ``all``): ``<joint>.c``, the
  deflection about (along) the axis is ``c * tau``, tau the generalised
  gravity force (moment about the axis of the weight beyond the joint and
  the row's payloads).
- ``lateral`` (target: a revolute joint or ``all``): ``<joint>.cx cy``,
  tilts of the joint's axis before its motion (fixed in the parent link),
  driven by the moment components about the tilt axes (section 6.12):
  x' is the common normal of the previous moving joint's axis and this one
  (through its foot on this axis; for parallel axes the perpendicular
  between them, through the origin), y' = z' x x'. Where y' is the previous
  joint's axis line itself (perpendicular axes that meet) its tilt is that
  joint's compliance: ``cy`` is held at 0 (not identified) unless the table
  gives a value. A joint with no moving joint
  above it, or coaxial with it, tilts about the origin frame's axis least
  aligned with z' (made orthogonal) and y' = z' x x'.
- ``joint_cubic`` / ``joint_deadzone`` (target: a joint with a ``joint``
  effect): the law becomes ``c tau + c3 tau^3`` (``<joint>.cubic``) or
  ``c tau + b tanh(tau / tau0)`` (``<joint>.backlash``, ``tau0`` a key in N m;
  default 5 % of the RMS gravity torque about the joint in the data).
- ``link`` (target: a link) and ``base``: 6-dof springs (21, 8 or 6
  parameters ``<link>.cIJ``, templates full / beam / diagonal) driven by
  the transmitted gravity wrench. A link with one child joint carries its
  spring at that joint's origin frame (before the joint's motion, as in
  section 2); a link with several children, or none, at its own frame.

Elastic deflections of a mimic leader do not move its followers (each
virtual joint has its own spring). Values in an effect table are known
values (not identified), except the ``xyz``/``rpy`` of ``tracker`` and
``marker``, which are start values (``fixed = true`` holds them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from .._core.tree import CoreArrays, PackedTree, pack
from ..errors import InputError
from ..io import validate as V
from ..io.tables import read_toml
from . import catalogue
from .catalogue import DEADZONE_TAU0_FRACTION, LAW_CUBIC, LAW_DEADZONE, LAW_LINEAR, LAW_SPRING6  # noqa: F401
from .model import SYM, TEMPLATES, rpy_matrix, template_elements
from .model_bodies import body_entries
from .plan_settings import plan_table
from .tree import Tree, load_tree
from .tree_lateral import duplicated_tilt, joint_tilts, lateral_tilts
from .urdf_read import gc_paused

__all__ = [
    "ABS_KINDS",
    "Param",
    "TreeModel",
    "load_tree_model",
    "tree_model_from_tables",
    "rpy_from_matrix",
    "GRAVITY",
    "model_kind",
    "MEASUREMENT_KINDS",
    "lateral_tilts",
    "duplicated_tilt",
    "joint_tilts",
]

#: [measurements] kind: relative deflections under known loads (section 3) or absolute positions (section 6)
MEASUREMENT_KINDS = ("deflection", "absolute")

ABS_KINDS = catalogue.kinds(catalogue.ABSOLUTE)  # the gravity parameters last: the reduction keeps compliances first
GRAVITY = (0.0, 0.0, -9.81)
#: equilibrium: at most this many fixed-point iterations, to this tolerance (m)
EQ_ITERATIONS, EQ_TOL = 100, 1e-9

KEYS = catalogue.keys(catalogue.ABSOLUTE)
FRAME_NAMES = ("dx", "dy", "dz", "drx", "dry", "drz")


@dataclass
class Param:
    """One model parameter: name, effect kind, target, the index of its
    [[effect]] table, start (or known) value, and whether it is identified."""

    name: str
    kind: str
    target: str
    effect: int
    start: float = 0.0
    free: bool = True


def rpy_from_matrix(R: np.ndarray) -> np.ndarray:
    """URDF rpy (R = Rz(y) Ry(p) Rx(r)) of a rotation matrix."""
    R = np.asarray(R, float)
    p = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    if abs(R[2, 0]) < 1.0 - 1e-12:
        r = math.atan2(R[2, 1], R[2, 2])
        y = math.atan2(R[1, 0], R[0, 0])
    else:  # gimbal lock: put the whole turn on yaw
        r = 0.0
        y = math.atan2(-R[0, 1], R[1, 1])
    return np.array([r, p, y])


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _vec(table: dict, key: str, n: int, where: str) -> np.ndarray:
    try:
        v = np.asarray(table[key], dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {key} must be a list of {n} numbers, got {table[key]!r}") from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise InputError(f"{where}: {key} must be {n} finite numbers, got {table[key]!r}")
    return v


def _number(v: object, where: str, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise InputError(f"{where}: {what} must be a finite number, got {v!r}")
    return float(v)


@dataclass
class TreeModel:
    """A tree model ready for the core: ``arrays`` (the virtual joints,
    elastic blocks, bodies, markers and tracker indices in the core's layout,
    1-based), ``params`` and their start values ``theta0``."""

    tree: Tree
    effects: list[dict]
    params: list[Param]
    arrays: dict[str, np.ndarray]
    ne: int
    frames: list[str]
    vj_of_link: dict[str, int]
    gravity: np.ndarray
    iterations: int
    path: Path | None = None
    sigma_position: float | None = None
    robot_table: dict = field(default_factory=dict)
    #: joint name -> index of its own virtual joint (the joint's motion)
    vj_of_joint: dict[str, int] = field(default_factory=dict)
    #: (block index 0-based) -> (kind, target) for reports
    blocks: list[tuple[str, str]] = field(default_factory=list)
    #: parameter name -> sigma of its prior toward the URDF (model_bodies)
    priors: dict[str, float] = field(default_factory=dict)
    #: the file's optional [plan] table as written (robot/plan_settings.py reads it; the writers keep it)
    plan: dict = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.params]

    @property
    def theta0(self) -> np.ndarray:
        return np.array([p.start for p in self.params], dtype=float)

    @property
    def free(self) -> np.ndarray:
        """0-based indices of the parameters to identify."""
        return np.array([i for i, p in enumerate(self.params) if p.free], dtype=int)

    @property
    def actuated(self) -> list[str]:
        return self.tree.actuated

    @property
    def elastic(self) -> bool:
        return self.ne > 0

    @property
    def eqit(self) -> int:
        """The core's equilibrium mode: 0 rigid, 1 first order, >= 2 iterated."""
        return 0 if not self.elastic else self.iterations

    @property
    def packed(self) -> PackedTree:
        """The model as every routine of the tree core takes it (bindings/tree.py
        ``pack``), packed from the current arrays: take it once per batch of
        calls; a change of the arrays (tracker rotation, tau0) needs a new one."""
        return pack(self.ne, self.arrays)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise InputError(f"the model has no parameter {name!r}") from None

    def has(self, kind: str, target: str | None = None) -> bool:
        return any(p.kind == kind and (target is None or p.target == target) for p in self.params)

    def tracker_pose(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(R, t) of the tracker-from-base transform at theta."""
        tp = self.arrays["tpar"] - 1
        t = theta[tp[:3]]
        a = theta[tp[3:]]
        R = self.arrays["rref"] @ _rx(a[0]) @ _ry(a[1]) @ _rz(a[2])
        return R, t

    def copy(self) -> TreeModel:
        """A copy whose arrays can be changed (tracker rotation, tau0) without touching this one."""
        m = TreeModel(**{k: getattr(self, k) for k in self.__dataclass_fields__})
        m.arrays = CoreArrays(
            {k: np.array(v, order="F") for k, v in self.arrays.items()}, labels=getattr(self.arrays, "labels", {})
        )
        return m

    def recentred(self, theta: np.ndarray) -> tuple[TreeModel, np.ndarray]:
        """The same model with the tracker's reference rotation moved to the
        pose at theta (angles back to zero)."""
        R, _t = self.tracker_pose(theta)
        m = self.copy()
        m.arrays["rref"] = np.asfortranarray(R)
        th = np.array(theta, dtype=float)
        th[self.arrays["tpar"][3:] - 1] = 0.0
        return m, th

    def with_tracker(self, R: np.ndarray, t: np.ndarray, theta: np.ndarray | None = None) -> np.ndarray:
        """Set the tracker pose (reference rotation R, translation t);
        returns theta with the tracker's parameters set."""
        self.arrays["rref"] = np.asfortranarray(np.asarray(R, float))
        th = self.theta0 if theta is None else np.array(theta, dtype=float)
        tp = self.arrays["tpar"] - 1
        th[tp[:3]] = t
        th[tp[3:]] = 0.0
        return th

    def set_deadzone_tau0(self, block: int, tau0: float) -> None:
        if not (math.isfinite(tau0) and tau0 > 0):
            raise InputError(f"joint_deadzone on {self.blocks[block][1]!r}: tau0 must be > 0 N m, got {tau0}")
        self.arrays["kw0"] = np.array(self.arrays["kw0"], dtype=float)
        self.arrays["kw0"][block] = tau0


class _Builder:
    """Expands a tree and effect tables into the core's arrays."""

    def __init__(self, tree: Tree, where: str) -> None:
        self.tree = tree
        self.where = where
        self.v = []  # virtual joints: (parent, type, axis, rot or None (identity), pos)
        self.q: dict[int, tuple[int, float, float]] = {}  # virtual joint -> (qcol, qcoef, qconst) of a motion
        self.g = []  # geometric entries: (vj, param, coef)
        self.k = []  # blocks: (type, [vj..], [param..] (21), w0)
        self.params: list[Param] = []
        self.names: set[str] = set()
        self.blocks: list[tuple[str, str]] = []
        self.labels: list[str] = []  # what each virtual joint is, for the core's messages

    def add_vj(
        self,
        parent: int,
        vtype: int = 0,
        axis: ArrayLike = (0, 0, 0),
        rot: np.ndarray | None = None,
        pos: ArrayLike = (0, 0, 0),
        label: str = "",
    ) -> int:
        self.labels.append(label)
        self.v.append((parent, vtype, axis, rot, pos))  # to arrays once, in _vj_arrays
        return len(self.v)

    def add_param(self, name: str, kind: str, target: str, effect: int, start: float = 0.0, free: bool = True) -> int:
        if name in self.names:
            raise InputError(f"{self.where}: the parameter {name} is defined by two effects (a duplicated effect?)")
        self.names.add(name)
        self.params.append(Param(name, kind, target, effect, float(start), free))
        return len(self.params)

    def spring6(self, parent: int, kind: str, target: str, effect: int, table: dict, where: str, axis0: int) -> int:
        """Six virtual joints (3 prismatic, 3 revolute) carrying a 6-dof spring."""
        first = None
        vjs = []
        for i in range(6):
            ax = np.eye(3)[i % 3]
            what = f"{kind} spring of {target!r}" if kind != "base" else "base spring"
            label = f"{what}, {('translation', 'rotation')[i // 3]} {'xyz'[i % 3]}"
            vj = self.add_vj(parent if first is None else vjs[-1], 2 if i < 3 else 1, ax, label=label)
            first = first or vj
            vjs.append(vj)
        template = table.get("template", "full")
        if template not in TEMPLATES:
            raise InputError(f"{where}: unknown template {template!r}; choose one of {', '.join(TEMPLATES)}")
        if "axis" in table:
            if table["axis"] not in ("x", "y", "z"):
                raise InputError(f"{where}: axis must be 'x', 'y' or 'z'")
            axis0 = "xyz".index(table["axis"])
        kpar = [0] * 21
        if "value" in table:
            C = np.asarray(table["value"], dtype=float) if not isinstance(table["value"], str) else None
            if C is None or C.shape != (6, 6) or not np.all(np.isfinite(C)):
                raise InputError(f"{where}: value must be a 6x6 matrix of finite numbers (SI)")
            if "rpy" in table:
                R = rpy_matrix(_vec(table, "rpy", 3, where))
                B = np.zeros((6, 6))
                B[:3, :3] = B[3:, 3:] = R
                C = B @ C @ B.T
            C = 0.5 * (C + C.T)
            for e, (a, b) in enumerate(SYM):
                kpar[e] = self.add_param(f"{target}.c{a + 1}{b + 1}", kind, target, effect, C[a, b], free=False)
        else:
            for e in template_elements(template, axis0):
                a, b = SYM[e]
                kpar[e] = self.add_param(f"{target}.c{a + 1}{b + 1}", kind, target, effect)
        self.k.append((LAW_SPRING6, vjs, kpar, 1.0))
        self.blocks.append((kind, target))
        return vjs[-1]


class _Cursor:
    """Appends the virtual joints of one URDF joint: the first carries the
    joint's origin transform, the others follow it with no offset."""

    def __init__(self, b: _Builder, parent: int, origin: np.ndarray, joint: str = "") -> None:
        self.b, self.vj, self.origin, self.first, self.joint = b, parent, origin, True, joint
        self.back = np.zeros(3)

    def add(self, vtype: int = 0, axis: ArrayLike = (0, 0, 0), what: str = "", at: ArrayLike | None = None) -> int:
        """The next virtual joint; ``at``: its point in the current frame (the
        next one comes back from it)."""
        label = f"URDF joint {self.joint!r}" + (f", {what}" if what else "")
        shift = np.zeros(3) if at is None else np.asarray(at, float)
        pos, self.back = self.back + shift, -shift
        if self.first:
            o = self.origin
            self.vj = self.b.add_vj(self.vj, vtype, axis, o[:3, :3], o[:3, 3] + o[:3, :3] @ pos, label)
            self.first = False
        else:
            self.vj = self.b.add_vj(self.vj, vtype, axis, pos=pos, label=label)
        return self.vj


def _vj_arrays(b: _Builder) -> dict[str, np.ndarray]:
    """The core's arrays of the virtual joints, built at once from the builder's lists."""
    nv = len(b.v)
    parent, vtype, axis, rot, pos = zip(*b.v)
    vrot = np.tile(np.eye(3), (nv, 1, 1))
    turned = [k for k, r in enumerate(rot) if r is not None]
    if turned:
        vrot[turned] = np.array([rot[k] for k in turned], float)
    q = np.zeros((nv, 3))
    if b.q:
        q[np.array(list(b.q), int) - 1] = np.array(list(b.q.values()), float)
    return {
        "vparent": np.array(parent, np.int32),
        "vtype": np.array(vtype, np.int32),
        "vaxis": np.asfortranarray(np.array(axis, float).reshape(nv, 3).T),
        "vrot": np.asfortranarray(np.transpose(vrot, (1, 2, 0))),
        "vpos": np.asfortranarray(np.array(pos, float).reshape(nv, 3).T),
        "qcol": q[:, 0].astype(np.int32),
        "qcoef": q[:, 1].copy(),
        "qconst": q[:, 2].copy(),
    }


def _joint_law(b: _Builder, jn: str, slot: dict, vj: int) -> tuple:
    """The elastic block of a joint: linear, cubic or dead zone."""
    i, table, w = slot["joint"]
    val = table.get("value")
    if val is not None:
        val = _number(val, w, "value")
        if val < 0:
            raise InputError(f"{w}: a joint compliance must be >= 0 (rad/(N m) or m/N), got {val}")
    kp = [b.add_param(f"{jn}.c", "joint", jn, i, 0.0 if val is None else val, val is None)] + [0] * 20
    law, w0 = LAW_LINEAR, 1.0
    for kind in catalogue.LAW_KINDS:  # a law in place of the linear one (robot/catalogue.py)
        if kind not in slot:
            continue
        e = catalogue.KIND[kind]
        i2, t2, w2 = slot[kind]
        v2 = t2.get("value")
        if v2 is not None:
            v2 = [_number(v2, w2, "value")] if e.scalar else list(_vec(t2, "value", len(e.params), w2))
        for s, p in enumerate(e.params):
            start = p.default if v2 is None else v2[s]
            kp[1 + s] = b.add_param(f"{jn}.{p.suffix}", kind, jn, i2, start, v2 is None)
        law = catalogue.law_code(kind)
        if e.w0_key:
            w0 = 0.0  # 0: set from the data's torque scale before the first evaluation
            if e.w0_key in t2:
                w0 = _number(t2[e.w0_key], w2, e.w0_key)
                if w0 <= 0:
                    raise InputError(f"{w2}: {e.w0_key} must be > 0 N m, got {w0}")
    return law, [vj], kp, w0


def _targets(tree: Tree, table: dict, where: str, kind: str, moving_only: bool) -> list[str]:
    target = table.get("target", "all")
    if not isinstance(target, str) or not target:
        raise InputError(f"{where}: target must be a joint name or 'all'")
    if target == "all":
        return [j.name for j in tree.joints if (j.moving or not moving_only)]
    j = tree.joint(target)
    if moving_only and not j.moving:
        raise InputError(f"{where}: joint {target!r} is fixed; {kind} needs a moving joint")
    return [target]


@gc_paused()
def tree_model_from_tables(
    tree: Tree,
    effects: list[dict],
    gravity: ArrayLike = GRAVITY,
    iterations: int = EQ_ITERATIONS,
    where: str = "model",
    sigma_position: float | None = None,
    base_dir: Path = Path("."),
) -> TreeModel:
    """Expand ``effects`` on ``tree`` (see the module docstring); raises
    InputError naming the effect table and the problem."""
    b = _Builder(tree, where)
    by_kind: dict[str, list[tuple[int, dict, str]]] = {k: [] for k in ABS_KINDS}
    for i, table in enumerate(effects):
        if not isinstance(table, dict):
            raise InputError(f"{where}: [[effect]] #{i + 1} is not a table")
        kind = table.get("kind")
        w = f"{where}: [[effect]] #{i + 1} ({kind}" + (f", target {table['target']!r})" if "target" in table else ")")
        if kind not in ABS_KINDS:
            raise InputError(f"{w}: unknown kind {kind!r} for absolute data; choose one of {', '.join(ABS_KINDS)}")
        unknown = sorted(set(table) - KEYS[kind] - {"kind", "note"})
        if unknown:
            raise InputError(
                f"{w}: unknown key(s) {', '.join(map(V.shown, unknown))} for kind {kind!r} "
                f"(allowed: kind, {', '.join(sorted(KEYS[kind]))}, note)"
            )
        by_kind[kind].append((i, table, w))
    if len(by_kind["tracker"]) > 1:
        raise InputError(f"{where}: more than one tracker effect")
    if len(by_kind["base"]) > 1:
        raise InputError(f"{where}: more than one base effect")

    # which joint gets which per-joint effect (one of each kind per joint)
    per_joint: dict[str, dict[str, tuple[int, dict, str]]] = {}
    for kind, moving in ((e.name, e.moving) for e in catalogue.ENTRIES if e.per_joint and catalogue.ABSOLUTE in e.data):
        # a table naming one joint takes precedence over target = "all" (which
        # then means every other joint); two tables naming one joint, or two
        # "all", are an error
        tables = sorted(by_kind[kind], key=lambda e: e[1].get("target", "all") == "all")
        alls = [e for e in tables if e[1].get("target", "all") == "all"]
        if len(alls) > 1:
            raise InputError(f"{alls[1][2]}: a second {kind} effect with target 'all' ({alls[0][2]})")
        for i, table, w in tables:
            every = table.get("target", "all") == "all"
            for jn in _targets(tree, table, w, kind, moving):
                if kind == "lateral" and tree.joint(jn).type == "prismatic":
                    if every:
                        continue
                    raise InputError(f"{w}: lateral compliance needs a revolute joint; {jn!r} is prismatic")
                slot = per_joint.setdefault(jn, {})
                if kind in slot:
                    if every:
                        continue
                    raise InputError(f"{w}: joint {jn!r} already has a {kind} effect ({slot[kind][2]})")
                slot[kind] = (i, table, w)
    for jn, slot in per_joint.items():
        for nl in catalogue.LAW_KINDS:
            if nl in slot and "joint" not in slot:
                raise InputError(f"{slot[nl][2]}: {nl} on {jn!r} needs a 'joint' effect on the same joint (its c)")
        laws = [k for k in catalogue.LAW_KINDS if k in slot]
        if len(laws) > 1:  # one law per joint's block
            raise InputError(f"{slot[laws[1]][2]}: joint {jn!r} has both {laws[0]} and {laws[1]}")
    links = {}
    for i, table, w in by_kind["link"]:
        target = table.get("target")
        if not isinstance(target, str) or target not in tree.links:
            raise InputError(f"{w}: target must be a link below {tree.root!r}; got {target!r}")
        if target in links:
            raise InputError(f"{w}: link {target!r} already has a spring ({links[target][2]})")
        links[target] = (i, table, w)

    # tracker and markers first (they lead the parameter vector)
    tr = by_kind["tracker"][0] if by_kind["tracker"] else None
    if tr is None:
        raise InputError(f"{where}: absolute data need a 'tracker' effect (the tracker-from-base transform)")
    i, table, w = tr
    fixed = bool(table.get("fixed", False))
    xyz = _vec(table, "xyz", 3, w) if "xyz" in table else np.zeros(3)
    rref = rpy_matrix(_vec(table, "rpy", 3, w)) if "rpy" in table else np.eye(3)
    tpar = [b.add_param(f"tracker.{c}", "tracker", "tracker", i, xyz[k], not fixed) for k, c in enumerate("xyz")]
    tpar += [b.add_param(f"tracker.a{k + 1}", "tracker", "tracker", i, 0.0, not fixed) for k in range(3)]
    frames, mpar_list = [], []
    for i, table, w in by_kind["marker"]:
        target = table.get("target")
        if not isinstance(target, str) or target not in tree.links:
            raise InputError(
                f"{w}: target must be a link (frame) of the URDF below {tree.root!r}; got {target!r} "
                f"(links: {', '.join(tree.links)})"
            )
        if target in frames:
            raise InputError(f"{w}: a second marker on {target!r}; one marker effect per frame")
        fixed = bool(table.get("fixed", False))
        xyz = _vec(table, "xyz", 3, w) if "xyz" in table else np.zeros(3)
        frames.append(target)
        mpar_list.append(
            [b.add_param(f"marker.{target}.{c}", "marker", target, i, xyz[k], not fixed) for k, c in enumerate("xyz")]
        )
    if not frames:
        raise InputError(f"{where}: absolute data need at least one 'marker' effect (the measured point's frame)")

    # the base spring sits before everything
    root_vj = 0
    if by_kind["base"]:
        i, table, w = by_kind["base"][0]
        root_vj = b.spring6(0, "base", "base", i, table, w, 2)
    vj_of_link = {tree.root: root_vj}
    vj_of_joint: dict[str, int] = {}
    # a link with one child joint carries its spring at that joint's origin,
    # any other link at its own frame
    at_child = {ln: kids[0].name for ln in links if len(kids := tree.children(ln)) == 1}
    at_frame = set(links) - set(at_child)
    if tree.root in at_frame:
        i, table, w = links[tree.root]
        vj_of_link[tree.root] = b.spring6(root_vj, "link", tree.root, i, table, w, 0)
    offset_param: dict[str, int] = {}
    for jn, slot in per_joint.items():
        if "joint_offset" in slot:
            i, table, w = slot["joint_offset"]
            val = table.get("value")
            if val is not None and table.get("target", "all") == "all":
                raise InputError(f"{w}: a joint_offset value needs one target joint, not 'all'")
            start = 0.0 if val is None else _number(val, w, "value")
            offset_param[jn] = b.add_param(f"{jn}.dq0", "joint_offset", jn, i, start, val is None)
    qcols = {name: k + 1 for k, name in enumerate(tree.actuated)}
    for j in tree.joints:
        slot = per_joint.get(j.name, {})
        cur = _Cursor(b, vj_of_link[j.parent], j.origin, j.name)
        if at_child.get(j.parent) == j.name:
            i, table, w = links[j.parent]
            seg = j.origin[:3, 3]
            axis0 = int(np.argmax(np.abs(seg))) if np.linalg.norm(seg) > 0 else 0
            cur.vj = b.spring6(cur.add(what="origin"), "link", j.parent, i, table, w, axis0)
        if "frame" in slot:
            i, table, w = slot["frame"]
            val = table.get("value")
            if val is not None:
                if table.get("target", "all") == "all":
                    raise InputError(f"{w}: a frame value needs one target joint, not 'all'")
                val = _vec(table, "value", 6, w)
            for k in range(6):
                vj = cur.add(2 if k < 3 else 1, np.eye(3)[k % 3], f"frame error {FRAME_NAMES[k]}")
                start = 0.0 if val is None else val[k]
                pi = b.add_param(f"{j.name}.{FRAME_NAMES[k]}", "frame", j.name, i, start, val is None)
                b.g.append((vj, pi, 1.0))
        if j.moving:
            # the bearing's tilt: before the motion, fixed in the parent link (section 6.12)
            if "lateral" in slot and j.type != "prismatic":
                i, table, w = slot["lateral"]
                val = table.get("value")
                if val is not None:
                    if isinstance(val, (int, float)) and not isinstance(val, bool):
                        val = np.array([float(val)] * 2)
                    else:
                        val = _vec(table, "value", 2, w)
                    if np.any(val < 0):
                        raise InputError(f"{w}: lateral compliances must be >= 0 rad/(N m), got {list(val)}")
                tilts = joint_tilts(tree, j.name, table, w)
                # y' on the previous axis line duplicates that joint's compliance: held at 0 unless given
                dup = "tilts" not in table and duplicated_tilt(tree, j.name)
                for k, (ax, at) in enumerate(tilts):
                    vj = cur.add(1, ax, f"lateral tilt c{'xy'[k]}", at=at)
                    start = 0.0 if val is None else val[k]
                    free = val is None and not (k == 1 and dup)
                    pi = b.add_param(f"{j.name}.c{'xy'[k]}", "lateral", j.name, i, start, free)
                    b.k.append((LAW_LINEAR, [vj], [pi] + [0] * 20, 1.0))
                    b.blocks.append(("lateral", j.name))
            vj = cur.add(1 if j.type != "prismatic" else 2, j.axis)
            lead, mult, off = tree.leader(j.name)
            b.q[vj] = (qcols[lead], mult, off)
            # the offsets of this joint and of every joint up its mimic chain
            name, coef = j.name, 1.0
            while True:
                if name in offset_param:
                    b.g.append((vj, offset_param[name], coef))
                mimic = tree.joint(name).mimic
                if mimic is None:
                    break
                coef *= mimic[1]
                name = mimic[0]
            if "joint" in slot:
                b.k.append(_joint_law(b, j.name, slot, vj))
                b.blocks.append(("joint", j.name))
            vj_of_joint[j.name] = vj
        else:
            vj_of_joint[j.name] = cur.add() if cur.first else cur.vj
        vj_of_link[j.child] = cur.vj
        if j.child in at_frame:
            i, table, w = links[j.child]
            vj_of_link[j.child] = b.spring6(cur.vj, "link", j.child, i, table, w, 0)

    # arrays for the core (1-based indices); a list with no entry is an
    # array of size 0 (the core's interface takes empty lists: no placeholder)
    nv = len(b.v)
    if nv == 0:
        raise InputError(f"{where}: the tree below {tree.root!r} has no joint")
    arrays = CoreArrays(
        labels={
            "vj": b.labels,
            "param": [p.name for p in b.params],
            "block": [f"{kind} on {target!r}" for kind, target in b.blocks],
            "marker": [f"marker on {f!r}" for f in frames],
        }
    )
    arrays.update(_vj_arrays(b))
    arrays["gvj"] = np.array([e[0] for e in b.g], np.int32)
    arrays["gpar"] = np.array([e[1] for e in b.g], np.int32)
    arrays["gcoef"] = np.array([e[2] for e in b.g], float)
    nk = len(b.k)
    kvj = np.zeros((6, nk), np.int32, order="F")
    kpar = np.zeros((21, nk), np.int32, order="F")
    ktype = np.zeros(nk, np.int32)
    kw0 = np.ones(nk)
    ne = 0
    for k, (law, vjs, kp, w0) in enumerate(b.k):
        ktype[k] = law
        kvj[: len(vjs), k] = vjs
        kpar[:, k] = kp
        kw0[k] = w0
        ne += len(vjs)
    arrays.update(ktype=ktype, kvj=kvj, kpar=kpar, kw0=kw0)
    bodies = [(vj_of_link[ln], ine.mass, ine.com, ln) for ln, ine in tree.inertials.items() if ln in vj_of_link]
    arrays.labels["body"] = [f"link {ln!r}" for ln, _ine in tree.inertials.items() if ln in vj_of_link]
    arrays["bvj"] = np.array([x[0] for x in bodies], np.int32)
    arrays["bmass"] = np.array([x[1] for x in bodies], float)
    arrays["bcom"] = np.asfortranarray(np.array([x[2] for x in bodies], float).reshape(-1, 3).T)
    grav = np.asarray(gravity, dtype=float)
    if grav.shape != (3,) or not np.all(np.isfinite(grav)):
        raise InputError(f"{where}: [gravity] vector must be 3 finite numbers (m/s^2)")
    arrays["grav"] = grav
    arrays["tpar"] = np.array(tpar, np.int32)
    arrays["rref"] = np.asfortranarray(rref)
    arrays["mvj"] = np.array([vj_of_link[f] for f in frames], np.int32)
    arrays["mpar"] = np.asfortranarray(np.array(mpar_list, np.int32).T)
    arrays["bpar"], priors = body_entries(b, tree, by_kind, [x[3] for x in bodies], where)
    return TreeModel(
        tree=tree,
        effects=list(effects),
        params=b.params,
        arrays=arrays,
        ne=ne,
        frames=frames,
        vj_of_link=vj_of_link,
        gravity=grav,
        iterations=int(iterations),
        sigma_position=sigma_position,
        vj_of_joint=vj_of_joint,
        blocks=b.blocks,
        priors=priors,
    )


def load_tree_model(path: str | Path) -> TreeModel:
    """Read a model TOML whose ``[measurements] kind = "absolute"`` (section 6)."""
    path = Path(path)
    doc = read_toml(path, "model")
    robot = doc.get("robot")
    if not isinstance(robot, dict) or not isinstance(robot.get("urdf"), str):
        raise InputError(f'{path}: missing [robot] table with urdf = "robot.urdf"')
    urdf = Path(robot["urdf"])
    urdf = urdf if urdf.is_absolute() else path.parent / urdf
    base = robot.get("base_link", "base_link")
    if not isinstance(base, str):
        raise InputError(f"{path}: [robot] base_link must be a link name")
    tree = load_tree(urdf, base)
    meas = doc.get("measurements", {})
    sigma = meas.get("sigma_position")
    if sigma is not None:
        sigma = _number(sigma, f"{path}: [measurements]", "sigma_position")
        if sigma <= 0:
            raise InputError(f"{path}: [measurements] sigma_position = {sigma} must be > 0 (m)")
        if sigma > 0.05:
            raise InputError(
                f"{path}: [measurements] sigma_position = {sigma} m is implausible for a tracker "
                f"(a value in mm? write {sigma / 1000:g} for {sigma:g} mm)"
            )
    grav = doc.get("gravity", {})
    if not isinstance(grav, dict):
        raise InputError(f"{path}: [gravity] must be a table")
    unknown = sorted(set(grav) - {"vector", "iterations"})
    if unknown:
        names = ", ".join(map(V.shown, unknown))
        raise InputError(f"{path}: [gravity] has unknown key(s) {names} (allowed: vector, iterations)")
    vector = grav.get("vector", list(GRAVITY))
    g = np.asarray(vector, dtype=float) if isinstance(vector, list) else None
    if g is None or g.shape != (3,) or not np.all(np.isfinite(g)):
        raise InputError(f"{path}: [gravity] vector must be [gx, gy, gz] in m/s^2, got {vector!r}")
    if g.any() and not 0.5 < np.linalg.norm(g) < 30:
        raise InputError(
            f"{path}: [gravity] vector has magnitude {np.linalg.norm(g):g} m/s^2; expected about 9.81 "
            f"(or [0, 0, 0] to switch gravity off)"
        )
    its = grav.get("iterations", EQ_ITERATIONS)
    if isinstance(its, bool) or not isinstance(its, int) or its < 1:
        raise InputError(f"{path}: [gravity] iterations must be an integer >= 1 (1 = first order), got {its!r}")
    effects = doc.get("effect", [])
    if not isinstance(effects, list):
        raise InputError(f"{path}: 'effect' must be an array of tables [[effect]]")
    m = tree_model_from_tables(tree, effects, g, its, str(path), sigma, path.parent)
    m.path = path
    m.robot_table = robot
    m.plan = plan_table(doc, path)
    return m


def model_kind(path: str | Path) -> str:
    """The ``[measurements] kind`` of a model file: "deflection" (section 3,
    the default) or "absolute" (section 6)."""
    path = Path(path)
    doc = read_toml(path, "model")
    meas = doc.get("measurements", {})
    kind = meas.get("kind", "deflection") if isinstance(meas, dict) else "deflection"
    if kind not in MEASUREMENT_KINDS:
        raise InputError(
            f"{path}: [measurements] kind = {kind!r}; choose one of {', '.join(repr(k) for k in MEASUREMENT_KINDS)}"
        )
    return kind
