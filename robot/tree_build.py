"""The expansion of a tree model's effects into the core's arrays
(robot/tree_model.py's docstring says what each effect becomes): the
builder that collects virtual joints, parameters, geometric entries and
elastic blocks, the steps that add the tracker and markers, the joints
with their frame errors, tilts, motions and laws, the link springs, and
the arrays in the core's 1-based layout (core/sk_api_tree.f90)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .._core.tree import CoreArrays
from ..errors import InputError
from . import catalogue
from .catalogue import LAW_LINEAR, LAW_SPRING6
from .effect_values import COMPENSATOR_KEYS, compensator_geometry, effect_values, effect_w0
from .model_bodies import body_entries
from .spring6 import SYM, TEMPLATES, rpy_matrix, template_elements
from .tree import Tree, TreeJoint
from .tree_effects import Effect, table_vector
from .tree_lateral import duplicated_tilt, joint_tilts

__all__ = ["FRAME_NAMES", "Builder", "Observed", "Param", "add_joints", "core_arrays", "tracker_and_markers"]

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


class Builder:
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
                R = rpy_matrix(table_vector(table, "rpy", 3, where))
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


class Cursor:
    """Appends the virtual joints of one URDF joint: the first carries the
    joint's origin transform, the others follow it with no offset."""

    def __init__(self, b: Builder, parent: int, origin: np.ndarray, joint: str = "") -> None:
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


@dataclass
class Observed:
    """What the tracker measures: its parameters tpar (6, 1-based) and
    start rotation rref, the markers' frames and their parameters (3 each)."""

    tpar: list[int]
    rref: np.ndarray
    frames: list[str]
    mpar: list[list[int]]


def tracker_and_markers(b: Builder, tree: Tree, by_kind: dict[str, list[Effect]], where: str) -> Observed:
    """The tracker's and the markers' parameters (they lead the parameter vector)."""
    tr = by_kind["tracker"][0] if by_kind["tracker"] else None
    if tr is None:
        raise InputError(f"{where}: absolute data need a 'tracker' effect (the tracker-from-base transform)")
    i, table, w = tr
    fixed = bool(table.get("fixed", False))
    xyz = table_vector(table, "xyz", 3, w) if "xyz" in table else np.zeros(3)
    rref = rpy_matrix(table_vector(table, "rpy", 3, w)) if "rpy" in table else np.eye(3)
    tpar = [b.add_param(f"tracker.{c}", "tracker", "tracker", i, xyz[k], not fixed) for k, c in enumerate("xyz")]
    tpar += [b.add_param(f"tracker.a{k + 1}", "tracker", "tracker", i, 0.0, not fixed) for k in range(3)]
    frames, mpar = [], []
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
        xyz = table_vector(table, "xyz", 3, w) if "xyz" in table else np.zeros(3)
        frames.append(target)
        mpar.append(
            [b.add_param(f"marker.{target}.{c}", "marker", target, i, xyz[k], not fixed) for k, c in enumerate("xyz")]
        )
    if not frames:
        raise InputError(f"{where}: absolute data need at least one 'marker' effect (the measured point's frame)")
    return Observed(tpar=tpar, rref=rref, frames=frames, mpar=mpar)


def _joint_law(b: Builder, jn: str, slot: dict, vj: int) -> tuple:
    """The elastic block of a joint: linear, or the law of its law kind (robot/catalogue.py)."""
    i, table, w = slot["joint"]
    val = effect_values(table, "joint", w)
    kp = [b.add_param(f"{jn}.c", "joint", jn, i, 0.0 if val is None else val[0], val is None)] + [0] * 20
    law, w0 = LAW_LINEAR, 1.0
    for kind in catalogue.LAW_KINDS:  # a law in place of the linear one (robot/catalogue.py)
        if kind not in slot:
            continue
        e = catalogue.KIND[kind]
        i2, t2, w2 = slot[kind]
        v2 = effect_values(t2, kind, w2)
        for s, p in enumerate(e.params):
            start = p.default if v2 is None else v2[s]
            kp[e.slots[s] - 1 if e.slots else 1 + s] = b.add_param(f"{jn}.{p.suffix}", kind, jn, i2, start, v2 is None)
        law = catalogue.law_code(kind)
        if kind == "gravity_compensator":  # its geometry: fixed parameters of the block
            g = compensator_geometry(t2, w2)
            for k, key in enumerate(COMPENSATOR_KEYS):
                kp[catalogue.JS_GEOM - 1 + k] = b.add_param(f"{jn}.{key}", kind, jn, i2, g[key], False)
        if e.w0_key:
            w0 = effect_w0(t2, kind, w2) or 0.0  # 0: set from the data's torque scale before the first evaluation
    return law, [vj], kp, w0


def _joint_offsets(b: Builder, per_joint: dict[str, dict[str, Effect]]) -> dict[str, int]:
    """The ``<joint>.dq0`` parameter of every joint with a joint_offset."""
    offset_param: dict[str, int] = {}
    for jn, slot in per_joint.items():
        if "joint_offset" in slot:
            i, table, w = slot["joint_offset"]
            if "value" in table and table.get("target", "all") == "all":
                raise InputError(f"{w}: a joint_offset value needs one target joint, not 'all'")
            val = effect_values(table, "joint_offset", w)
            start = 0.0 if val is None else val[0]
            offset_param[jn] = b.add_param(f"{jn}.dq0", "joint_offset", jn, i, start, val is None)
    return offset_param


def _frame_error(b: Builder, cur: Cursor, j: TreeJoint, effect: Effect) -> None:
    """Six screws after the joint's origin, each moved by one parameter."""
    i, table, w = effect
    if "value" in table and table.get("target", "all") == "all":
        raise InputError(f"{w}: a frame value needs one target joint, not 'all'")
    val = effect_values(table, "frame", w)
    for k in range(6):
        vj = cur.add(2 if k < 3 else 1, np.eye(3)[k % 3], f"frame error {FRAME_NAMES[k]}")
        start = 0.0 if val is None else val[k]
        pi = b.add_param(f"{j.name}.{FRAME_NAMES[k]}", "frame", j.name, i, start, val is None)
        b.g.append((vj, pi, 1.0))


def _lateral(b: Builder, cur: Cursor, tree: Tree, j: TreeJoint, effect: Effect) -> None:
    """The bearing's tilts: before the motion, fixed in the parent link (section 6.12)."""
    i, table, w = effect
    val = effect_values(table, "lateral", w)
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


def _motion(b: Builder, cur: Cursor, tree: Tree, j: TreeJoint, slot: dict, qcols: dict, offsets: dict) -> int:
    """A moving joint's tilts, its motion (a coordinate of q, or its mimic
    leader's) with the offsets up its mimic chain, and its law."""
    if "lateral" in slot and j.type != "prismatic":
        _lateral(b, cur, tree, j, slot["lateral"])
    vj = cur.add(1 if j.type != "prismatic" else 2, j.axis)
    lead, mult, off = tree.leader(j.name)
    b.q[vj] = (qcols[lead], mult, off)
    # the offsets of this joint and of every joint up its mimic chain
    name, coef = j.name, 1.0
    while True:
        if name in offsets:
            b.g.append((vj, offsets[name], coef))
        mimic = tree.joint(name).mimic
        if mimic is None:
            break
        coef *= mimic[1]
        name = mimic[0]
    if "joint" in slot:
        b.k.append(_joint_law(b, j.name, slot, vj))
        b.blocks.append(("joint", j.name))
    return vj


def add_joints(
    b: Builder, tree: Tree, per_joint: dict[str, dict[str, Effect]], links: dict[str, Effect], root_vj: int
) -> tuple[dict[str, int], dict[str, int]]:
    """The virtual joints of every URDF joint in the tree's order, below
    ``root_vj`` (the base spring's, or 0): (vj_of_link, vj_of_joint). A
    link with one child joint carries its spring at that joint's origin,
    any other link at its own frame."""
    vj_of_link = {tree.root: root_vj}
    vj_of_joint: dict[str, int] = {}
    at_child = {ln: kids[0].name for ln in links if len(kids := tree.children(ln)) == 1}
    at_frame = set(links) - set(at_child)
    if tree.root in at_frame:
        i, table, w = links[tree.root]
        vj_of_link[tree.root] = b.spring6(root_vj, "link", tree.root, i, table, w, 0)
    offsets = _joint_offsets(b, per_joint)
    qcols = {name: k + 1 for k, name in enumerate(tree.actuated)}
    for j in tree.joints:
        slot = per_joint.get(j.name, {})
        cur = Cursor(b, vj_of_link[j.parent], j.origin, j.name)
        if at_child.get(j.parent) == j.name:
            i, table, w = links[j.parent]
            seg = j.origin[:3, 3]
            axis0 = int(np.argmax(np.abs(seg))) if np.linalg.norm(seg) > 0 else 0
            cur.vj = b.spring6(cur.add(what="origin"), "link", j.parent, i, table, w, axis0)
        if "frame" in slot:
            _frame_error(b, cur, j, slot["frame"])
        if j.moving:
            vj_of_joint[j.name] = _motion(b, cur, tree, j, slot, qcols, offsets)
        else:
            vj_of_joint[j.name] = cur.add() if cur.first else cur.vj
        vj_of_link[j.child] = cur.vj
        if j.child in at_frame:
            i, table, w = links[j.child]
            vj_of_link[j.child] = b.spring6(cur.vj, "link", j.child, i, table, w, 0)
    return vj_of_link, vj_of_joint


def _vj_arrays(b: Builder) -> dict[str, np.ndarray]:
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


def _block_arrays(b: Builder) -> tuple[dict[str, np.ndarray], int]:
    """The core's arrays of the elastic blocks and their number of elastic coordinates ne."""
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
    return {"ktype": ktype, "kvj": kvj, "kpar": kpar, "kw0": kw0}, ne


def core_arrays(
    b: Builder,
    tree: Tree,
    by_kind: dict[str, list[Effect]],
    obs: Observed,
    vj_of_link: dict[str, int],
    gravity: ArrayLike,
    where: str,
) -> tuple[CoreArrays, int, np.ndarray, dict[str, float]]:
    """The core's arrays (1-based indices; a list with no entry is an array
    of size 0: the core's interface takes empty lists, no placeholder)
    with their labels, ne, the gravity vector and the gravity parameters'
    priors (model_bodies)."""
    if len(b.v) == 0:
        raise InputError(f"{where}: the tree below {tree.root!r} has no joint")
    arrays = CoreArrays(
        labels={
            "vj": b.labels,
            "param": [p.name for p in b.params],
            "block": [f"{kind} on {target!r}" for kind, target in b.blocks],
            "marker": [f"marker on {f!r}" for f in obs.frames],
        }
    )
    arrays.update(_vj_arrays(b))
    arrays["gvj"] = np.array([e[0] for e in b.g], np.int32)
    arrays["gpar"] = np.array([e[1] for e in b.g], np.int32)
    arrays["gcoef"] = np.array([e[2] for e in b.g], float)
    blocks, ne = _block_arrays(b)
    arrays.update(blocks)
    bodies = [(vj_of_link[ln], ine.mass, ine.com, ln) for ln, ine in tree.inertials.items() if ln in vj_of_link]
    arrays.labels["body"] = [f"link {ln!r}" for ln, _ine in tree.inertials.items() if ln in vj_of_link]
    arrays["bvj"] = np.array([x[0] for x in bodies], np.int32)
    arrays["bmass"] = np.array([x[1] for x in bodies], float)
    arrays["bcom"] = np.asfortranarray(np.array([x[2] for x in bodies], float).reshape(-1, 3).T)
    grav = np.asarray(gravity, dtype=float)
    if grav.shape != (3,) or not np.all(np.isfinite(grav)):
        raise InputError(f"{where}: [gravity] vector must be 3 finite numbers (m/s^2)")
    arrays["grav"] = grav
    arrays["tpar"] = np.array(obs.tpar, np.int32)
    arrays["rref"] = np.asfortranarray(obs.rref)
    arrays["mvj"] = np.array([vj_of_link[f] for f in obs.frames], np.int32)
    arrays["mpar"] = np.asfortranarray(np.array(obs.mpar, np.int32).T)
    arrays["bpar"], priors = body_entries(b, tree, by_kind, [x[3] for x in bodies], where)
    return arrays, ne, grav, priors
