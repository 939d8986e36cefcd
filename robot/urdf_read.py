"""The one-pass URDF reader: what stiffkit reads of a URDF file, as written
(robot/tree.py builds the tree from it and checks its structure).

One expat pass over the text (:func:`read_urdf`): the handlers keep the
attribute dicts of the elements stiffkit reads (``link``: ``inertial/mass``,
``inertial/origin``, the origins of ``visual`` and ``collision``; ``joint``:
``parent``, ``child``, ``origin``, ``axis``, ``mimic``, ``limit``) and build
no element tree; their numbers are converted at once (numpy) and the
element named when one is malformed. Linear in the file's size, with the
cyclic garbage collector held while reading (:func:`gc_paused`).
"""

from __future__ import annotations

import gc
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET
from xml.parsers import expat

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..io.tables import read_text
from .capsules import Capsule, collision_capsules
from .urdf_checks import check_inertials, joint_limit

__all__ = ["UrdfJoint", "UrdfLink", "UrdfDoc", "read_urdf", "check_urdf_text", "parse_urdf", "gc_paused"]


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
    collisions: dict[str, list[Capsule]] = field(default_factory=dict)

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
    #: per <link> of <robot>: [its attributes, has an <inertial>, <mass> and <origin> of the first
    #: <inertial>, its <collision> elements (xml.etree, for robot/capsules.py)]
    links: list[list] = field(default_factory=list)
    #: per <joint> of <robot>: (its attributes, {tag: attributes of its first child of that tag})
    joints: list[tuple[dict, dict]] = field(default_factory=list)
    #: per <origin> of a link's <visual> or <collision>: (visual|collision, the link's attributes, origin's)
    shapes: list[tuple[str, dict, dict]] = field(default_factory=list)


def _et_name(name: str) -> str:
    """A name as xml.etree writes it: {namespace}local (expat: namespace}local)."""
    return "{" + name if "}" in name else name


def _scan(text: str, path: Path | str) -> _Scan:
    """One pass of expat over ``text`` (no element tree is built: the
    handlers keep the attribute dicts that expat gives; the few <collision>
    elements are built as xml.etree elements). Tags as xml.etree names them
    ({namespace}tag)."""
    out = _Scan()
    links, joints, shapes = out.links, out.joints, out.shapes
    depth, kind, sub = 0, 0, ""  # kind: 1 in a <link>, 2 in a <joint>; sub: the link's child being read
    cur: list | dict = []
    tb: ET.TreeBuilder | None = None  # building a <collision> of a link

    def start(tag: str, attrs: dict) -> None:
        nonlocal depth, kind, sub, cur, tb
        d = depth
        depth = d + 1
        if tb is not None:
            tb.start(_et_name(tag), {_et_name(k): v for k, v in attrs.items()})
        if d == 2:
            if kind == 2:
                cur.setdefault(tag, attrs)
            elif kind == 1:
                if tag == "inertial":
                    sub = "" if cur[1] else tag
                    cur[1] = True
                else:
                    sub = tag if tag in ("visual", "collision") else ""
                    if sub == "collision":
                        tb = ET.TreeBuilder()
                        tb.start(tag, {_et_name(k): v for k, v in attrs.items()})
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
                cur = [attrs, False, None, None, []]
                links.append(cur)
                kind = 1
            elif tag == "joint":
                cur = {}
                joints.append((attrs, cur))
                kind = 2
            else:
                kind = 0
        elif d == 0:
            out.root = _et_name(tag)

    def end(tag: str) -> None:
        nonlocal depth, tb
        depth -= 1
        if tb is not None:
            tb.end(_et_name(tag))
            if depth == 2:
                cur[4].append(tb.close())
                tb = None

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
    for attrs, has_inertial, me, oe, _cols in scan.links:
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
    return UrdfDoc(str(path), links, joints, collision_capsules(_collision_links(scan.links), path))


def _collision_links(links: list[list]) -> list[ET.Element]:
    """The links that have a <collision>, as xml.etree elements holding only those."""
    out = []
    for attrs, _has_inertial, _me, _oe, cols in links:
        if cols:
            el = ET.Element("link", attrs)
            el.extend(cols)
            out.append(el)
    return out


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
