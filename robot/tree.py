"""Kinematic trees read from a URDF: every joint from the base link outwards,
``<mimic>`` couplings, fixed joints and the links' inertials.

The URDF is read with expat in one pass (:func:`read_urdf`: linear in the
file's size, no element tree built; a URDF library building its own objects
took 2 ms per link, minutes for a 100,000-link file); this module checks what a library
would accept silently (duplicate names, a link with two parents, loops,
broken references, mimic chains that close on themselves, negative or
non-finite masses, a zero or non-unit axis) and names the file and the
element in every message.

Convention (docs/calibration.md §1): a child frame is ``T_parent * T(origin xyz rpy) *
Motion(axis, q)``; a mimic joint turns by ``multiplier * q_leader + offset``.
"""

from __future__ import annotations

import gc
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..io.tables import read_text
from .urdf_checks import check_inertials, joint_limit

MOVING = ("revolute", "continuous", "prismatic")
SUPPORTED = MOVING + ("fixed",)

__all__ = ["TreeJoint", "Inertial", "Tree", "UrdfDoc", "load_tree", "parse_urdf", "read_urdf", "AXIS_TOL"]


@dataclass
class TreeJoint:
    """One URDF joint: origin (4, 4) in the parent link's frame, unit axis in
    the joint frame (zero for fixed joints), and its mimic coupling."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    mimic: tuple[str, float, float] | None = None  # (leader, multiplier, offset)
    index: int = 0  # position in the URDF file
    limit: tuple[float, float] | None = None  # <limit lower upper> of a revolute or prismatic joint

    @property
    def moving(self) -> bool:
        return self.type in MOVING


@dataclass
class Inertial:
    """Mass (kg) and centre of mass (m, link frame) of a link."""

    mass: float
    com: np.ndarray


@dataclass
class Tree:
    """The joints reachable from ``root``, parents before children.

    ``actuated`` are the moving joints that are not mimics: the joint
    coordinates a measurement row gives (in URDF order)."""

    urdf: str
    root: str
    joints: list[TreeJoint]
    links: list[str]
    inertials: dict[str, Inertial] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._by_name = {j.name: j for j in self.joints}
        self._by_child = {j.child: j for j in self.joints}
        self._kids: dict[str, list[TreeJoint]] = {}
        for j in self.joints:
            self._kids.setdefault(j.parent, []).append(j)
        self._link_set = set(self.links)
        self._actuated = [j.name for j in sorted(self.joints, key=lambda j: j.index) if j.moving and j.mimic is None]

    @property
    def actuated(self) -> list[str]:
        """Moving joints that are not mimics, in the order of the URDF file."""
        return list(self._actuated)

    @property
    def total_mass(self) -> float:
        return float(sum(i.mass for i in self.inertials.values()))

    def joint(self, name: str) -> TreeJoint:
        try:
            return self._by_name[name]
        except KeyError:
            raise InputError(
                f"{self.urdf}: no joint {name!r} below {self.root!r} (joints: {', '.join(self._by_name)})"
            ) from None

    def parent_joint(self, link: str) -> TreeJoint | None:
        """The joint whose child is ``link`` (None for the root)."""
        if link not in self._link_set:
            raise InputError(f"{self.urdf}: {link!r} is not a link below {self.root!r}")
        return self._by_child.get(link)

    def path(self, link: str) -> list[TreeJoint]:
        """Joints from the root to ``link``, root side first."""
        out = []
        j = self.parent_joint(link)
        while j is not None:
            out.append(j)
            j = self._by_child.get(j.parent)
        return out[::-1]

    def children(self, link: str) -> list[TreeJoint]:
        """The joints whose parent is ``link`` (breadth-first order)."""
        return list(self._kids.get(link, ()))

    def leader(self, name: str) -> tuple[str, float, float]:
        """(actuated joint, multiplier, offset) that drives joint ``name``:
        itself with (1, 0) when it is actuated; mimic chains are followed."""
        j = self.joint(name)
        mult, off = 1.0, 0.0
        seen = {name}
        while j.mimic is not None:
            lead, m, o = j.mimic
            mult, off = mult * m, mult * o + off  # q_j = m q_lead + o
            if lead in seen:
                raise InputError(f"{self.urdf}: mimic joints form a loop through {lead!r}")
            seen.add(lead)
            j = self.joint(lead)
        return j.name, mult, off


#: how far from 1 the norm of a joint axis may be to be normalised (with a warning); beyond, an error
AXIS_TOL = 1e-6


@dataclass
class UrdfJoint:
    """A <joint> as written: origin (4, 4), axis as written (not normalised;
    None when absent), mimic (leader, multiplier, offset) or None."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray | None
    mimic: tuple[str, float, float] | None
    limit: tuple[float, float] | None = None  # (lower, upper) of a revolute or prismatic joint


@dataclass
class UrdfLink:
    """A <link>: its inertial as (mass or None, centre of mass (3,)), or None."""

    name: str
    inertial: tuple[float | None, np.ndarray] | None


@dataclass
class UrdfDoc:
    """What stiffkit reads of a URDF: links and joints in file order."""

    path: str
    links: list[UrdfLink]
    joints: list[UrdfJoint]

    @property
    def link_map(self) -> dict[str, UrdfLink]:
        return {ln.name: ln for ln in self.links}

    @property
    def roots(self) -> list[str]:
        """Links that are no joint's child, in file order."""
        children = {j.child for j in self.joints}
        return [ln.name for ln in self.links if ln.name not in children]


def _bad_numbers(path: Path | str, owner: str, tag: str, attr: str, raw: str, n: int) -> InputError:
    return InputError(f'{path}: {owner}: <{tag} {attr}="{raw}"> must be {n} finite number(s)')


def _parse(raw: str, n: int) -> list[float] | None:
    try:
        vals = [float(x) for x in raw.split()]
    except ValueError:
        return None
    return vals if len(vals) == n and all(math.isfinite(v) for v in vals) else None


class _Vectors:
    """Numeric attributes of n numbers gathered while reading and converted
    all at once (numpy), the element named when one is malformed; absent
    attributes (``attrs`` None or without ``attr``) take ``default``."""

    def __init__(
        self, n: int, tag: str, attr: str, default: tuple[float, ...], kind: str, attrs: list, names: list[str]
    ) -> None:
        self.n, self.tag, self.attr, self.default, self.kind = n, tag, attr, default, kind
        self.raw: list[str | None] = [None if a is None else a.get(attr) for a in attrs]
        self.names = names

    def values(self, path: Path | str) -> np.ndarray:
        m = len(self.raw)
        out = np.empty((m, self.n))
        given = [k for k, r in enumerate(self.raw) if r is not None]
        absent = np.ones(m, bool)
        absent[given] = False
        out[absent] = self.default
        if given:
            tokens = [self.raw[k].split() for k in given]
            try:
                if any(len(t) != self.n for t in tokens):
                    raise ValueError
                vals = np.array(tokens, dtype=float).reshape(len(given), self.n)
                if not np.all(np.isfinite(vals)):
                    raise ValueError
            except ValueError:  # name the first malformed one
                for k in given:
                    if _parse(self.raw[k], self.n) is None:
                        owner = f"{self.kind} {self.names[k]!r}"
                        raise _bad_numbers(path, owner, self.tag, self.attr, self.raw[k], self.n) from None
                vals = np.array([_parse(self.raw[k], self.n) for k in given], float)  # numpy and Python differ
            out[given] = vals
        return out


@contextmanager
def gc_paused() -> Iterator[None]:
    """The cyclic garbage collector held (a context or a decorator: ``@gc_paused()``)
    while a URDF is read or a model built from it: the objects made hold no
    cycles (reference counts free them), and with 100,000 links the
    collector's passes over them cost more than the reading itself."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


@dataclass
class _Scan:
    """What one expat pass gathers of a URDF: the root's tag, and the
    attributes (dicts) of the elements stiffkit reads, in file order."""

    root: str = ""
    #: per <link> of <robot>: [its attributes, has an <inertial>, <mass> and <origin> of the first <inertial>]
    links: list[list] = field(default_factory=list)
    #: per <joint> of <robot>: (its attributes, {tag: attributes of its first child of that tag})
    joints: list[tuple[dict, dict]] = field(default_factory=list)
    #: per <origin> of a link's <visual> or <collision>: (visual|collision, the link's attributes, origin's)
    shapes: list[tuple[str, dict, dict]] = field(default_factory=list)


def _scan(text: str, path: Path | str) -> _Scan:
    """One pass of expat over ``text`` (no element tree is built: the
    handlers keep the attribute dicts that expat gives). Tags as xml.etree
    names them ({namespace}tag)."""
    out = _Scan()
    links, joints, shapes = out.links, out.joints, out.shapes
    depth, kind, sub = 0, 0, ""  # kind: 1 in a <link>, 2 in a <joint>; sub: the link's child being read
    cur: list | dict = []

    def start(tag: str, attrs: dict) -> None:
        nonlocal depth, kind, sub, cur
        d = depth
        depth = d + 1
        if d == 2:
            if kind == 2:
                cur.setdefault(tag, attrs)
            elif kind == 1:
                if tag == "inertial":
                    sub = "" if cur[1] else tag
                    cur[1] = True
                else:
                    sub = tag if tag in ("visual", "collision") else ""
        elif d == 3:
            if sub == "inertial":
                if tag == "mass":
                    if cur[2] is None:
                        cur[2] = attrs
                elif tag == "origin" and cur[3] is None:
                    cur[3] = attrs
            elif sub and tag == "origin":
                shapes.append((sub, cur[0], attrs))
        elif d == 1:
            sub = ""
            if tag == "link":
                cur = [attrs, False, None, None]
                links.append(cur)
                kind = 1
            elif tag == "joint":
                cur = {}
                joints.append((attrs, cur))
                kind = 2
            else:
                kind = 0
        elif d == 0:
            out.root = "{" + tag if "}" in tag else tag

    def end(tag: str) -> None:
        nonlocal depth
        depth -= 1

    parser = expat.ParserCreate(namespace_separator="}")  # as xml.etree's parser: namespaces resolved
    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        raise InputError(
            f"{path}, line {exc.lineno}: cannot parse the URDF: not well-formed XML ({str(exc).split(':')[0]}, "
            f"column {exc.offset}); is the file complete?"
        ) from None
    return out


def _check_numbers(shapes: list[tuple[str, dict, dict]], path: Path | str) -> None:
    """The origins of visuals and collisions hold finite numbers of the
    right count (those of joints and inertials are read); the link is named."""
    for part in ("visual", "collision"):
        for p, link, el in shapes:
            if p != part:
                continue
            for attr in ("xyz", "rpy"):
                raw = el.get(attr)
                if raw is not None and _parse(raw, 3) is None:
                    raise _bad_numbers(path, f"link {link.get('name')!r}", "origin", attr, raw, 3)


def _scalar(attrs: dict, tag: str, attr: str, owner: str, path: Path | str, default: float | None) -> float | None:
    raw = attrs.get(attr)
    if raw is None:
        return default
    try:
        v = float(raw)
    except ValueError:
        raise InputError(f'{path}: {owner}: <{tag} {attr}="{raw}"> must be a number') from None
    return v


def _rpy_matrices(rpy: np.ndarray) -> np.ndarray:
    """URDF rotations R = Rz(y) Ry(p) Rx(r) of rpy (n, 3), all at once (n, 3, 3)."""
    cr, cp, cy = np.cos(rpy).T
    sr, sp, sy = np.sin(rpy).T
    R = np.empty((rpy.shape[0], 3, 3))
    R[:, 0, 0] = cy * cp
    R[:, 0, 1] = cy * sp * sr - sy * cr
    R[:, 0, 2] = cy * sp * cr + sy * sr
    R[:, 1, 0] = sy * cp
    R[:, 1, 1] = sy * sp * sr + cy * cr
    R[:, 1, 2] = sy * sp * cr - cy * sr
    R[:, 2, 0] = -sp
    R[:, 2, 1] = cp * sr
    R[:, 2, 2] = cp * cr
    return R


def _transforms(xyz: np.ndarray, rpy: np.ndarray) -> np.ndarray:
    n = len(xyz)
    T = np.zeros((n, 4, 4))
    T[:, 3, 3] = 1.0
    if n:
        T[:, :3, :3] = _rpy_matrices(rpy)
        T[:, :3, 3] = xyz
    return T


@gc_paused()
def read_urdf(text: str, path: Path | str) -> UrdfDoc:
    """The links and joints of a URDF document (expat, one pass: linear in
    the size of the file). Raises InputError naming the file and the element
    for XML that is not well formed (a truncated file: and the line), a root
    other than <robot>, joints or links without a name, a joint without a
    type, parent or child, numbers that are not finite numbers of the right
    count; a joint origin implausibly far for metres (a URDF in mm), a link
    mass in grams or a centre of mass in mm give a warning."""
    scan = _scan(text, path)
    if scan.root != "robot":
        raise InputError(f"{path}: the root element is <{scan.root}>, a URDF's is <robot>")
    _check_numbers(scan.shapes, path)
    names, masses, origins, inertial_of = [], [], [], []  # inertial_of: link -> index among inertials, or -1
    for attrs, has_inertial, me, oe in scan.links:
        name = (attrs.get("name") or "").strip()
        if not name:
            raise InputError(f"{path}: a <link> without a name")
        names.append(name)
        if not has_inertial:
            inertial_of.append(-1)
            continue
        raw = None if me is None else me.get("value")
        try:
            mass = None if raw is None else float(raw)
        except ValueError:
            mass = _scalar(me, "mass", "value", f"link {name!r}", path, None)  # raises, naming the link
        inertial_of.append(len(masses))
        masses.append(mass)
        origins.append(oe)
    inertial_names = [n for n, k in zip(names, inertial_of) if k >= 0]
    coms = _Vectors(3, "origin", "xyz", (0.0, 0.0, 0.0), "link", origins, inertial_names).values(path)
    _Vectors(3, "origin", "rpy", (0.0, 0.0, 0.0), "link", origins, inertial_names).values(path)
    com_rows = list(coms)  # iterating an array yields its rows' views in C
    links = [UrdfLink(n, None if k < 0 else (masses[k], com_rows[k])) for n, k in zip(names, inertial_of)]
    raw_joints, jnames, jparts = [], [], []
    for attrs, parts in scan.joints:
        name = (attrs.get("name") or "").strip()
        if not name:
            raise InputError(f"{path}: a <joint> without a name")
        jtype = attrs.get("type")
        if not jtype:
            raise InputError(f"{path}: joint {name!r} has no type")
        pe, ce = parts.get("parent"), parts.get("child")
        parent = (pe.get("link") or "").strip() if pe is not None else ""
        child = (ce.get("link") or "").strip() if ce is not None else ""
        if not parent or not child:
            raise InputError(f'{path}: joint {name!r} has no <{"parent" if not parent else "child"} link="..."/>')
        jnames.append(name)
        jparts.append(parts)
        mimic = None
        me = parts.get("mimic")
        if me is not None:
            owner = f"joint {name!r}"
            lead = (me.get("joint") or "").strip()
            if not lead:
                raise InputError(f'{path}: {owner}: <mimic> without joint="..."')
            mimic = (
                lead,
                _scalar(me, "mimic", "multiplier", owner, path, 1.0),
                _scalar(me, "mimic", "offset", owner, path, 0.0),
            )
        le = parts.get("limit")
        lim = None
        if le is not None:
            who = f"joint {name!r}"
            lo, hi = _scalar(le, "limit", "lower", who, path, None), _scalar(le, "limit", "upper", who, path, None)
            lim = joint_limit(jtype, lo, hi)
        raw_joints.append((name, jtype, parent, child, mimic, lim))
    oes = [p.get("origin") for p in jparts]
    X = _Vectors(3, "origin", "xyz", (0.0, 0.0, 0.0), "joint", oes, jnames).values(path)
    A = _Vectors(3, "axis", "xyz", (math.nan, math.nan, math.nan), "joint", [p.get("axis") for p in jparts], jnames)
    A = A.values(path)
    R = _Vectors(3, "origin", "rpy", (0.0, 0.0, 0.0), "joint", oes, jnames).values(path)
    T = _transforms(X, R)
    # iterating the arrays yields the rows' views in C (indexing one by one costs more than the rest)
    joints = [
        UrdfJoint(n, t, p, c, Tk, None if a[0] != a[0] else a, m, lim)
        for (n, t, p, c, m, lim), Tk, a in zip(raw_joints, T, A)
    ]
    far = float(np.abs(X).max()) if len(X) else 0.0
    if far > V.QUANTITIES["position"].plausible[1]:
        V.warn(
            f"{path}: a joint origin {far:g} m from its parent frame is implausible for a robot in metres; "
            "a URDF is in m (is it in mm? multiply by 0.001)",
            key=("urdf", str(path)),
        )
    check_inertials(inertial_names, masses, coms, path)
    return UrdfDoc(str(path), links, joints)


def check_urdf_text(text: str, path: Path | str) -> None:
    """The checks of :func:`read_urdf` alone (what a URDF library would
    accept silently or explain badly)."""
    read_urdf(text, path)


def parse_urdf(path: str | Path) -> UrdfDoc:
    """The links and joints of the URDF file ``path`` (:func:`read_urdf`)."""
    if not isinstance(path, (str, Path)):
        raise InputError(f"a URDF is given by its file name, got {type(path).__name__}")
    path = Path(path)
    return read_urdf(read_text(path, "URDF"), path)


def _axis(j: UrdfJoint, path: Path) -> np.ndarray:
    """The unit axis of a moving joint: (1, 0, 0) when not written (the URDF
    default); normalised with a warning when its norm is within AXIS_TOL of
    1 (exporters round), an error beyond."""
    if j.axis is None:
        return np.array([1.0, 0.0, 0.0])
    n = float(np.linalg.norm(j.axis))
    if n == 0:
        raise InputError(f"{path}: joint {j.name!r} has a zero or non-finite axis")
    if abs(n - 1.0) > AXIS_TOL:
        raise InputError(
            f"{path}: joint {j.name!r}: axis {' '.join(f'{v:.12g}' for v in j.axis)} has norm {n:.9g}; "
            f"a URDF axis is a unit vector (normalised only within {AXIS_TOL:g} of 1)"
        )
    if n != 1.0:
        V.warn(
            f"{path}: joint {j.name!r}: axis norm {n:.12g} is not 1; normalised",
            key=("urdf-axis", str(path), j.name),
        )
    return j.axis / n


def _duplicates(names: list[str]) -> list[str]:
    seen, dup = set(), set()
    for n in names:
        (dup if n in seen else seen).add(n)
    return sorted(dup)


def _name_list(names: list[str], most: int = 12) -> str:
    """Names for a message: all of them, or the first ``most`` and how many more."""
    if len(names) <= most:
        return ", ".join(names)
    return f"{', '.join(names[:most])}, ... ({len(names) - most} more)"


#: what to say of a joint type the models do not take
_UNSUPPORTED = {
    "floating": "a free (6-dof) joint, as between a world frame and a mobile or humanoid base",
    "planar": "a 3-dof planar joint",
}


#: the axis of every fixed joint (shared, read-only)
_NO_AXIS = np.zeros(3)
_NO_AXIS.flags.writeable = False


@gc_paused()
def load_tree(urdf_path: str | Path, root: str = "base_link", urdf: UrdfDoc | None = None) -> Tree:
    """Read the URDF at ``urdf_path`` and return the tree below ``root``.

    Raises InputError naming the file for: unreadable XML, duplicate link or
    joint names, a link that is the child of two joints, joints that form a
    loop, a joint naming a missing link, an unsupported joint type (floating,
    planar) below the root, a zero axis or one whose norm is not 1 (within
    AXIS_TOL: normalised with a warning), a mimic joint whose leader is
    missing, fixed, or part of a mimic loop, and an inertial with a missing,
    negative or non-finite mass. Links above ``root`` (a ``world`` link and
    its fixed joint) and trees with other roots are left out. Linear in the
    number of links.
    """
    path = Path(urdf_path)
    doc = urdf if urdf is not None else parse_urdf(path)
    names = [ln.name for ln in doc.links]
    dup = _duplicates(names)
    if dup:
        raise InputError(f"{path}: duplicate link name(s) {', '.join(dup)}")
    dup = _duplicates([j.name for j in doc.joints])
    if dup:
        raise InputError(f"{path}: duplicate joint name(s) {', '.join(dup)}")
    if not names:
        raise InputError(f"{path}: the URDF has no <link> (is it an unexpanded xacro wrapper?)")
    links = set(names)
    if root not in links:
        roots = doc.roots
        hint = f"the URDF's root link(s): {_name_list(roots)}" if roots else f"links: {_name_list(names)}"
        raise InputError(f"{path}: base_link {root!r} is not a link of the URDF ({hint}); set [robot] base_link")
    by_child: dict[str, UrdfJoint] = {}
    kids: dict[str, list[UrdfJoint]] = {}
    for j in doc.joints:
        for end in (j.parent, j.child):
            if end not in links:
                raise InputError(f"{path}: joint {j.name!r} names the link {end!r}, which the URDF does not define")
        if j.child in by_child:
            raise InputError(
                f"{path}: link {j.child!r} is the child of two joints ({by_child[j.child].name}, {j.name}): not a tree"
            )
        by_child[j.child] = j
        kids.setdefault(j.parent, []).append(j)
    # loops: every link has at most one parent, so walking up either ends at a
    # link without a parent or closes a loop; each link is walked once
    state: dict[str, int] = {}  # 1: on the current walk, 2: known to reach a root
    for start in names:
        walk, link = [], start
        while state.get(link, 0) == 0 and link in by_child:
            state[link] = 1
            walk.append(link)
            link = by_child[link].parent
        if state.get(link, 0) == 1:
            raise InputError(f"{path}: the joints form a loop at link {link!r}")
        for ln in walk:
            state[ln] = 2
    # breadth-first from the root: parents before children
    position = {j.name: k for k, j in enumerate(doc.joints)}
    order, out_links, frontier = [], [root], [root]
    while frontier:
        nxt = []
        for link in frontier:
            for j in kids.get(link, ()):
                order.append(j)
                out_links.append(j.child)
                nxt.append(j.child)
        frontier = nxt
    joints = []
    for j in order:
        if j.type not in SUPPORTED:
            what = _UNSUPPORTED.get(j.type)
            hint = (
                f" (when it joins the world to the robot, declare [robot] base_link = {j.child!r}: "
                "the base is then fixed and the tracker measures from it)"
                if what
                else ""
            )
            raise InputError(
                f"{path}: joint {j.name!r} ({j.parent} -> {j.child}) is {j.type!r}"
                f"{f', {what}' if what else ''}; supported joint types are {', '.join(SUPPORTED)} "
                f"below the base link {root!r}{hint}"
            )
        ax = _axis(j, path) if j.type in MOVING else _NO_AXIS
        mimic = None
        if j.mimic is not None and j.type in MOVING:
            lead, m, o = j.mimic
            if not (math.isfinite(m) and math.isfinite(o)):
                raise InputError(f"{path}: mimic of joint {j.name!r} has a non-finite multiplier or offset")
            mimic = (lead, m, o)
        joints.append(TreeJoint(j.name, j.type, j.parent, j.child, j.origin, ax, mimic, position[j.name], j.limit))
    below = set(out_links)
    inertials = {}
    for ln in doc.links:
        if ln.name not in below or ln.inertial is None:
            continue
        mass, com = ln.inertial
        if mass is None:
            raise InputError(f"{path}: link {ln.name!r} has an <inertial> without a <mass>")
        if not math.isfinite(mass) or mass < 0:
            raise InputError(f"{path}: link {ln.name!r} has mass {mass}; a mass must be finite and >= 0 kg")
        if mass > 0:
            inertials[ln.name] = Inertial(mass, com)
    tree = Tree(str(path), root, joints, out_links, inertials)
    for j in joints:
        if j.mimic is None:
            continue
        lead = j.mimic[0]
        if lead not in tree._by_name:
            where = (
                "which is not a joint of the URDF" if lead not in position else f"which is not a joint below {root!r}"
            )
            raise InputError(f"{path}: joint {j.name!r} mimics {lead!r}, {where}")
        if not tree._by_name[lead].moving:
            raise InputError(f"{path}: joint {j.name!r} mimics the fixed joint {lead!r}")
        tree.leader(j.name)  # raises on a mimic loop
        if tree._by_name[lead].type != j.type and "prismatic" in (j.type, tree._by_name[lead].type):
            raise InputError(f"{path}: joint {j.name!r} ({j.type}) mimics {lead!r} ({tree._by_name[lead].type})")
    return tree
