"""Small URDFs with the shapes real robot descriptions have (tests/test_urdf_corpus.py).

Each shape is a list of joints written as an exporter would (fixed joints
at the root, between joints and for sensor and tool frames, a ``world``
link above the base, continuous and prismatic joints, mimic chains and a
gripper, axes with exporters' rounding), with its own forward kinematics
(numpy, written here from the URDF convention, not the package's) so that
the data a test fits come from an independent truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MOVING = ("revolute", "continuous", "prismatic")


@dataclass
class J:
    """A URDF joint; ``axis_text`` is written instead of ``axis`` when given
    (an axis as an exporter rounds it); mimic = (leader, multiplier, offset)."""

    name: str
    type: str
    parent: str
    child: str
    xyz: tuple = (0.0, 0.0, 0.0)
    rpy: tuple = (0.0, 0.0, 0.0)
    axis: tuple = (0.0, 0.0, 1.0)
    mimic: tuple | None = None
    axis_text: str | None = None
    limits: tuple = (-2.0, 2.0)


@dataclass
class Shape:
    """A robot: joints, the marker frames with their points, the declared
    base link, link masses (mass, com) and links that belong to no joint."""

    name: str
    joints: list[J]
    markers: dict[str, tuple]
    base: str = "base_link"
    masses: dict[str, tuple] = field(default_factory=dict)
    extra_links: list[str] = field(default_factory=list)

    @property
    def actuated(self) -> list[str]:
        return [j.name for j in self.joints if j.type in MOVING and j.mimic is None]


def _f(v: tuple) -> str:
    return " ".join(f"{float(x):.17g}" for x in v)


def urdf_text(s: Shape) -> str:
    links = list(s.extra_links)
    for j in s.joints:
        for ln in (j.parent, j.child):
            if ln not in links:
                links.append(ln)
    out = ['<?xml version="1.0"?>', f'<robot name="{s.name}">']
    for ln in links:
        if ln in s.masses:
            m, c = s.masses[ln]
            out.append(
                f'  <link name="{ln}"><inertial><origin xyz="{_f(c)}" rpy="0 0 0"/><mass value="{m}"/>'
                '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
                '<visual><origin xyz="0 0 0" rpy="0 0 0"/><geometry><box size="0.1 0.1 0.1"/></geometry></visual>'
                "</link>"
            )
        else:
            out.append(f'  <link name="{ln}"/>')
    for j in s.joints:
        out.append(f'  <joint name="{j.name}" type="{j.type}">')
        out.append(f'    <parent link="{j.parent}"/><child link="{j.child}"/>')
        out.append(f'    <origin xyz="{_f(j.xyz)}" rpy="{_f(j.rpy)}"/>')
        if j.type not in ("fixed", "floating"):
            out.append(f'    <axis xyz="{j.axis_text or _f(j.axis)}"/>')
        if j.type in ("revolute", "prismatic"):
            out.append(f'    <limit lower="{j.limits[0]}" upper="{j.limits[1]}" effort="100" velocity="1"/>')
        if j.mimic is not None:
            out.append(f'    <mimic joint="{j.mimic[0]}" multiplier="{j.mimic[1]!r}" offset="{j.mimic[2]!r}"/>')
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out) + "\n"


def _rot(axis: np.ndarray, a: float) -> np.ndarray:
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K


def rpy(r: float, p: float, y: float) -> np.ndarray:
    return _rot((0, 0, 1), y) @ _rot((0, 1, 0), p) @ _rot((1, 0, 0), r)


def joint_values(s: Shape, q: dict[str, float]) -> dict[str, float]:
    """Every moving joint's value: actuated from q, mimics by their law (chains followed)."""
    by = {j.name: j for j in s.joints}
    out: dict[str, float] = {}

    def value(name: str) -> float:
        if name not in out:
            j = by[name]
            out[name] = q[name] if j.mimic is None else j.mimic[1] * value(j.mimic[0]) + j.mimic[2]
        return out[name]

    for j in s.joints:
        if j.type in MOVING:
            value(j.name)
    return out


def link_poses(s: Shape, q: dict[str, float], offsets: dict[str, float] | None = None) -> dict[str, tuple]:
    """(R, p) of every link below the declared base, in the base frame;
    ``offsets``: joint zero offsets added to the joints' values (a mimic
    follower takes its multiplier times its leader's)."""
    qq = dict(q)
    for name, d in (offsets or {}).items():
        qq[name] = qq[name] + d
    vals = joint_values(s, qq)
    poses = {s.base: (np.eye(3), np.zeros(3))}
    todo = list(s.joints)
    while todo:
        rest = []
        for j in todo:
            if j.parent not in poses:
                rest.append(j)
                continue
            R, p = poses[j.parent]
            Rb, pb = R @ rpy(*j.rpy), p + R @ np.asarray(j.xyz, float)
            if j.type in ("revolute", "continuous"):
                Rb = Rb @ _rot(j.axis, vals[j.name])
            elif j.type == "prismatic":
                pb = pb + Rb @ (np.asarray(j.axis, float) / np.linalg.norm(j.axis)) * vals[j.name]
            poses[j.child] = (Rb, pb)
        if len(rest) == len(todo):  # links not below the base (world, other roots)
            break
        todo = rest
    return poses


def postures(s: Shape, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    by = {j.name: j for j in s.joints}
    cols = []
    for name in s.actuated:
        lo, hi = by[name].limits if by[name].type != "continuous" else (-3.0, 3.0)
        cols.append(rng.uniform(lo, hi, n))
    return np.array(cols).T


TRACKER_R = rpy(0.02, -0.03, 2.7)
TRACKER_T = np.array([2.2, -0.4, -0.8])


def measurements(s: Shape, Q: np.ndarray, offsets: dict[str, float] | None = None) -> list[tuple]:
    """(config, q, frame, point in the tracker frame) of every marker at every posture."""
    rows = []
    for k, qv in enumerate(Q):
        poses = link_poses(s, dict(zip(s.actuated, qv)), offsets)
        for f, p in s.markers.items():
            R, t = poses[f]
            rows.append((f"c{k:03d}", qv, f, TRACKER_T + TRACKER_R @ (t + R @ np.asarray(p, float))))
    return rows


def write_csv(path: Path, s: Shape, rows: list[tuple]) -> Path:
    lines = [",".join(["config", *s.actuated, "frame", "x", "y", "z"])]
    for c, qv, f, xyz in rows:
        lines.append(",".join([c, *(f"{v:.17g}" for v in qv), f, *(f"{v:.17g}" for v in xyz)]))
    path.write_text("\n".join(lines) + "\n")
    return path


def write_model(path: Path, urdf: str, base: str, markers: list[str], effects: list[str] = ()) -> Path:
    """A model TOML: tracker, one marker per frame (start at the frame's origin), and ``effects`` (TOML text)."""
    out = [
        "[robot]",
        f'urdf = "{urdf}"',
        f'base_link = "{base}"',
        "",
        "[measurements]",
        'kind = "absolute"',
        "",
        "[[effect]]",
        'kind = "tracker"',
    ]
    for f in markers:
        out += ["", "[[effect]]", 'kind = "marker"', f'target = "{f}"']
    for e in effects:
        out += ["", "[[effect]]", e]
    path.write_text("\n".join(out) + "\n")
    return path


# -- the shapes

#: a UR-like arm as its description writes it: world above base_link; the first
#: joint below the base fixed (base_link -> torso_base), frames base and
#: base_link_inertia on the side; a sensor frame between two joints; a
#: continuous wrist; flange and tool0 fixed at the end
ROOT_FIXED = Shape(
    "root_fixed",
    [
        J("world_joint", "fixed", "world", "base_link", (0.1, 0.2, 0.0)),
        J("base_fixed", "fixed", "base_link", "torso_base", (0, 0, 0.12), (0, 0, math.pi)),
        J("base_link-base", "fixed", "base_link", "base", (0, 0, 0), (0, 0, math.pi)),
        J("base_inertia", "fixed", "base_link", "base_link_inertia", (0, 0, 0), (0, 0, math.pi)),
        J("shoulder", "revolute", "torso_base", "upper", (0, 0, 0.2), axis=(0, 0, 1)),
        J("ft_sensor", "fixed", "upper", "upper_sensor", (0.05, 0, 0.1), (math.pi / 2, 0, 0)),
        J("elbow", "revolute", "upper_sensor", "fore", (0, 0.05, 0), axis=(0, 0, 1)),
        J("wrist", "continuous", "fore", "hand", (0.4, 0, 0), axis=(1, 0, 0)),
        J("flange_fixed", "fixed", "hand", "flange", (0.08, 0, 0), (0, math.pi / 2, 0)),
        J("tool_fixed", "fixed", "flange", "tool0", (0, 0.03, 0.1)),
    ],
    {"tool0": (0.02, 0.01, 0.05)},
    masses={"upper": (3.0, (0, 0, 0.1)), "fore": (2.0, (0.2, 0, 0)), "base_link_inertia": (4.0, (0, 0, 0.05))},
)

#: a rail (prismatic), a continuous turret, a revolute arm, an axis written with
#: an exporter's rounding (norm 1 + 4e-7: normalised with a warning)
PRISMATIC = Shape(
    "prismatic",
    [
        J("rail", "prismatic", "base_link", "carriage", (0, 0, 0.1), axis=(1, 0, 0), limits=(-0.5, 0.5)),
        J("turret", "continuous", "carriage", "turret_link", (0, 0, 0.15), axis=(0, 0, 1)),
        J("arm", "revolute", "turret_link", "arm_link", (0.1, 0, 0.2), axis=(0, 1, 0), axis_text="0 1.0000004 0"),
        J("lift", "prismatic", "arm_link", "lift_link", (0.3, 0, 0), axis=(0, 0, 1), limits=(0.0, 0.2)),
        J("tool_fixed", "fixed", "lift_link", "tool0", (0.05, 0, -0.05), (0.3, 0, 0)),
    ],
    {"tool0": (0.01, 0.02, 0.03), "arm_link": (0.1, 0.03, 0.0)},
)

#: a mimic chain (a coupled torso written as mimic of a mimic) and a
#: parallel gripper (the second finger mimics the first, multiplier -1)
MIMIC = Shape(
    "mimic",
    [
        J("yaw", "revolute", "base_link", "l1", (0, 0, 0.3), axis=(0, 0, 1)),
        J("pitch", "revolute", "l1", "l2", (0, 0, 0.2), axis=(0, 1, 0), limits=(-0.6, 0.6)),
        J("pitch_m", "revolute", "l2", "l3", (0, 0, 0.25), axis=(0, 1, 0), mimic=("pitch", -1.0, 0.05)),
        J("pitch_mm", "revolute", "l3", "l4", (0, 0, 0.2), axis=(0, 1, 0), mimic=("pitch_m", 0.5, 0.0)),
        J("reach", "revolute", "l4", "hand", (0.3, 0, 0.05), axis=(1, 0, 0)),
        J("palm", "fixed", "hand", "palm_link", (0.1, 0, 0), (0, 0, 0.2)),
        J("finger_l", "prismatic", "palm_link", "finger_l_link", (0.05, 0.02, 0), axis=(0, 1, 0), limits=(0, 0.04)),
        J(
            "finger_r",
            "prismatic",
            "palm_link",
            "finger_r_link",
            (0.05, -0.02, 0),
            axis=(0, 1, 0),
            mimic=("finger_l", -1.0, 0.0),
            limits=(-0.04, 0),
        ),
    ],
    {"finger_l_link": (0.03, 0.005, 0.0), "finger_r_link": (0.03, -0.005, 0.01), "hand": (0.02, 0.04, 0.0)},
)

#: the mimic chain alone, with a tool off the last axis (three actuated joints: a square compensation)
MIMIC_ARM = Shape(
    "mimic_arm",
    MIMIC.joints[:5] + [J("tip", "fixed", "hand", "tip_link", (0.1, 0.05, 0.02))],
    {"tip_link": (0.0, 0.0, 0.01)},
)

#: two trees in one file (a robot and a separate camera rig): the declared base
#: picks the robot; a world link above, joined by a floating joint
SEVERAL_ROOTS = Shape(
    "several_roots",
    [
        J("world_float", "floating", "world", "base_link", (0, 0, 0.5)),
        J("j1", "revolute", "base_link", "a1", (0, 0, 0.2), axis=(0, 0, 1)),
        J("j2", "revolute", "a1", "a2", (0.3, 0, 0), axis=(0, 1, 0)),
        J("tip", "fixed", "a2", "tool0", (0.25, 0, 0)),
        J("rig_mount", "fixed", "camera_rig", "camera", (1, 1, 1)),
    ],
    {"tool0": (0.0, 0.02, 0.01)},
)

SHAPES = {s.name: s for s in (ROOT_FIXED, PRISMATIC, MIMIC, MIMIC_ARM, SEVERAL_ROOTS)}
