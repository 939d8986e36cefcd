"""Kinematic trees read from a URDF: every joint from the base link outwards,
``<mimic>`` couplings, fixed joints and the links' inertials.

The URDF is read with expat in one pass (robot/urdf_read.py, :func:`read_urdf`:
linear in the file's size, no element tree built; a URDF library building
its own objects took 2 ms per link, minutes for a 100,000-link file); this module checks what a library
would accept silently (duplicate names, a link with two parents, loops,
broken references, mimic chains that close on themselves, negative or
non-finite masses, a zero or non-unit axis) and names the file and the
element in every message.

Convention (docs/calibration.md §1): a child frame is ``T_parent * T(origin xyz rpy) *
Motion(axis, q)``; a mimic joint turns by ``multiplier * q_leader + offset``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import validate as V
from .capsules import Capsule
from .urdf_read import UrdfDoc, UrdfJoint, check_urdf_text, gc_paused, parse_urdf, read_urdf

MOVING = ("revolute", "continuous", "prismatic")
SUPPORTED = MOVING + ("fixed",)

__all__ = [
    "TreeJoint",
    "Inertial",
    "Tree",
    "UrdfDoc",
    "load_tree",
    "parse_urdf",
    "read_urdf",
    "check_urdf_text",
    "gc_paused",
    "AXIS_TOL",
]


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
    #: link -> bounding capsules of its primitive <collision> shapes (robot/capsules.py)
    collisions: dict[str, list[Capsule]] = field(default_factory=dict)

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

    def subtree(self, link: str) -> list[str]:
        """The link and every link below it."""
        out, todo = [], [link]
        while todo:
            ln = todo.pop()
            out.append(ln)
            todo += [j.child for j in self.children(ln)]
        return out

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
#: an axis norm within this of 1 is normalised without a word (decimal round-off)
AXIS_QUIET = 1e-12


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
    if abs(n - 1.0) > AXIS_QUIET:  # below it: the round-off of a unit axis written in decimals
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
    shapes = {ln: c for ln, c in doc.collisions.items() if ln in below}
    tree = Tree(str(path), root, joints, out_links, inertials, shapes)
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
