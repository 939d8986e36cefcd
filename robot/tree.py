"""Kinematic trees read from a URDF: every joint from the base link outwards,
``<mimic>`` couplings, fixed joints and the links' inertials.

The URDF is parsed by yourdfpy (docs/calibration.md §1: a maintained library, not by
hand); this module checks what the library accepts silently (duplicate
names, a link with two parents, loops, broken references, mimic chains that
close on themselves, negative or non-finite masses, a zero axis) and names
the file and the element in every message.

Convention (docs/calibration.md §1): a child frame is ``T_parent * T(origin xyz rpy) *
Motion(axis, q)``; a mimic joint turns by ``multiplier * q_leader + offset``.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..io.tables import read_text

MOVING = ("revolute", "continuous", "prismatic")
SUPPORTED = MOVING + ("fixed",)

__all__ = ["TreeJoint", "Inertial", "Tree", "load_tree", "parse_urdf"]


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

    @property
    def actuated(self) -> list[str]:
        """Moving joints that are not mimics, in the order of the URDF file."""
        return [j.name for j in sorted(self.joints, key=lambda j: j.index) if j.moving and j.mimic is None]

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
        if link not in self.links:
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
        return [j for j in self.joints if j.parent == link]

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


def _origin(j: object, path: Path | str = "URDF") -> np.ndarray:
    T = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise InputError(f"{path}: joint {j.name!r} has a malformed origin")
    return T


#: numeric attributes checked before the library reads them: (element, attribute, count)
_NUMERIC = (("origin", "xyz", 3), ("origin", "rpy", 3), ("axis", "xyz", 3))


def _owner(el: ET.Element, parents: dict[ET.Element, ET.Element]) -> str:
    """'joint NAME' or 'link NAME' of an element, for messages."""
    p = parents.get(el)
    while p is not None and p.tag not in ("joint", "link"):
        p = parents.get(p)
    return f"{p.tag} {p.get('name')!r}" if p is not None else "the robot"


def check_urdf_text(text: str, path: Path | str) -> None:
    """What the URDF library would accept silently or explain badly: XML
    that is not well formed (a truncated file), a root other than <robot>,
    joints or links without a name, numeric attributes that are not finite
    numbers of the right count; and a joint origin implausibly far for
    metres (a URDF in mm) gives a warning."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        line, col = exc.position
        raise InputError(
            f"{path}, line {line}: cannot parse the URDF: not well-formed XML ({str(exc).split(':')[0]}, "
            f"column {col}); is the file complete?"
        ) from None
    if root.tag != "robot":
        raise InputError(f"{path}: the root element is <{root.tag}>, a URDF's is <robot>")
    parents = {c: p for p in root.iter() for c in p}
    for tag in ("joint", "link"):
        for el in root.iter(tag):
            if parents.get(el) is root and not (el.get("name") or "").strip():
                raise InputError(f"{path}: a <{tag}> without a name")
    far = 0.0
    for tag, attr, n in _NUMERIC:
        for el in root.iter(tag):
            if attr not in el.attrib:
                continue
            raw = el.get(attr)
            try:
                vals = [float(x) for x in raw.split()]
            except ValueError:
                vals = None
            if vals is None or len(vals) != n or not all(math.isfinite(v) for v in vals):
                raise InputError(f'{path}: {_owner(el, parents)}: <{tag} {attr}="{raw}"> must be {n} finite number(s)')
            if tag == "origin" and attr == "xyz":
                far = max(far, max(abs(v) for v in vals))
    if far > V.QUANTITIES["position"].plausible[1]:
        V.warn(
            f"{path}: a joint origin {far:g} m from its parent frame is implausible for a robot in metres; "
            "a URDF is in m (is it in mm? multiply by 0.001)",
            key=("urdf", str(path)),
        )


def parse_urdf(path: str | Path) -> object:
    """The yourdfpy model of ``path`` (no meshes, no scene graph), after the
    checks of :func:`check_urdf_text`."""
    import yourdfpy  # heavy (trimesh): imported when a URDF is read

    if not isinstance(path, (str, Path)):
        raise InputError(f"a URDF is given by its file name, got {type(path).__name__}")
    path = Path(path)
    check_urdf_text(read_text(path, "URDF"), path)
    try:
        return yourdfpy.URDF.load(
            str(path),
            build_scene_graph=False,
            load_meshes=False,
            build_collision_scene_graph=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # the library raises many kinds on malformed XML
        raise InputError(f"{path}: cannot parse the URDF ({type(exc).__name__}: {exc})") from None


def load_tree(urdf_path: str | Path, root: str = "base_link", urdf: object | None = None) -> Tree:
    """Read the URDF at ``urdf_path`` and return the tree below ``root``.

    Raises InputError naming the file for: unreadable XML, duplicate link or
    joint names, a link that is the child of two joints, joints that form a
    loop, a joint naming a missing link, an unsupported joint type (floating,
    planar) below the root, a zero or non-finite axis, a mimic joint whose
    leader is missing, fixed, or part of a mimic loop, and an inertial with a
    missing, negative or non-finite mass or centre of mass.
    """
    path = Path(urdf_path)
    model = urdf if urdf is not None else parse_urdf(path)
    robot = model.robot
    names = [ln.name for ln in robot.links]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"{path}: duplicate link name(s) {', '.join(dup)}")
    jnames = [j.name for j in robot.joints]
    dup = sorted({n for n in jnames if jnames.count(n) > 1})
    if dup:
        raise InputError(f"{path}: duplicate joint name(s) {', '.join(dup)}")
    links = set(names)
    if root not in links:
        raise InputError(f"{path}: base_link {root!r} is not a link of the URDF (links: {', '.join(sorted(links))})")
    by_child: dict[str, object] = {}
    for j in robot.joints:
        for end in (j.parent, j.child):
            if end not in links:
                raise InputError(f"{path}: joint {j.name!r} names the link {end!r}, which the URDF does not define")
        if j.child in by_child:
            raise InputError(
                f"{path}: link {j.child!r} is the child of two joints ({by_child[j.child].name}, {j.name}): not a tree"
            )
        by_child[j.child] = j
    # loops: walking up from any link must end at a link without a parent
    for start in links:
        seen, link = set(), start
        while link in by_child:
            if link in seen:
                raise InputError(f"{path}: the joints form a loop at link {link!r}")
            seen.add(link)
            link = by_child[link].parent
    # breadth-first from the root: parents before children
    position = {id(j): k for k, j in enumerate(robot.joints)}
    order, out_links, frontier = [], [root], [root]
    kids: dict[str, list] = {}
    for j in robot.joints:
        kids.setdefault(j.parent, []).append(j)
    while frontier:
        nxt = []
        for link in frontier:
            for j in kids.get(link, []):
                order.append(j)
                out_links.append(j.child)
                nxt.append(j.child)
        frontier = nxt
    joints = []
    for j in order:
        if j.type not in SUPPORTED:
            raise InputError(
                f"{path}: joint {j.name!r} is {j.type!r}; supported joint types are {', '.join(SUPPORTED)}"
            )
        T = _origin(j, path)
        if j.type in MOVING:
            ax = np.asarray(j.axis if j.axis is not None else [1.0, 0.0, 0.0], dtype=float)
            n = float(np.linalg.norm(ax))
            if not math.isfinite(n) or n == 0:
                raise InputError(f"{path}: joint {j.name!r} has a zero or non-finite axis")
            ax = ax / n
        else:
            ax = np.zeros(3)
        mimic = None
        if j.mimic is not None and j.type in MOVING:
            m = 1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)
            o = 0.0 if j.mimic.offset is None else float(j.mimic.offset)
            if not (math.isfinite(m) and math.isfinite(o)):
                raise InputError(f"{path}: mimic of joint {j.name!r} has a non-finite multiplier or offset")
            mimic = (j.mimic.joint, m, o)
        joints.append(TreeJoint(j.name, j.type, j.parent, j.child, T, ax, mimic, position[id(j)]))
    inertials = {}
    for ln in robot.links:
        if ln.name not in out_links or ln.inertial is None:
            continue
        mass = ln.inertial.mass
        if mass is None:
            raise InputError(f"{path}: link {ln.name!r} has an <inertial> without a <mass>")
        mass = float(mass)
        if not math.isfinite(mass) or mass < 0:
            raise InputError(f"{path}: link {ln.name!r} has mass {mass}; a mass must be finite and >= 0 kg")
        T = np.eye(4) if ln.inertial.origin is None else np.asarray(ln.inertial.origin, dtype=float)
        if not np.all(np.isfinite(T)):
            raise InputError(f"{path}: link {ln.name!r} has a non-finite centre of mass")
        if mass > 0:
            inertials[ln.name] = Inertial(mass, T[:3, 3].copy())
    tree = Tree(str(path), root, joints, out_links, inertials)
    for j in joints:
        if j.mimic is None:
            continue
        lead = j.mimic[0]
        if lead not in tree._by_name:
            raise InputError(f"{path}: joint {j.name!r} mimics {lead!r}, which is not a joint below {root!r}")
        if not tree._by_name[lead].moving:
            raise InputError(f"{path}: joint {j.name!r} mimics the fixed joint {lead!r}")
        tree.leader(j.name)  # raises on a mimic loop
        if tree._by_name[lead].type != j.type and "prismatic" in (j.type, tree._by_name[lead].type):
            raise InputError(f"{path}: joint {j.name!r} ({j.type}) mimics {lead!r} ({tree._by_name[lead].type})")
    return tree
