"""A synthetic dual-arm upper body: the robot of ``stiffkit synth dualarm``.

A torso on a fixed base (a vertical joint, two pitch joints and a coupled
pitch that keeps the chest upright: ``q = -(q2 + q3)``, written as two
``<mimic>`` joints on the same axis, one per leader) carrying two 7-joint
arms of a lightweight-arm design (about 1.1 m reach, 14 kg each) with a
hand and a tool-centre frame on each. Link masses and centres of mass are
in the URDF, so the elastic deflection under the robot's own weight is
part of the model. Dimensions are round numbers of that class of robot,
not any product's.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["DUALARM_JOINTS", "DUALARM_LINKS", "dualarm_urdf", "ARM_RANGES", "TORSO_RANGES", "actuated_names"]

#: (name, type, parent, child, xyz, rpy, axis, mimic (leader, multiplier, offset) or None)
DUALARM_JOINTS: list[tuple] = [
    ("torso_1", "revolute", "base_link", "torso_link1", (0, 0, 0.45), (0, 0, 0), (0, 0, 1), None),
    ("torso_2", "revolute", "torso_link1", "torso_link2", (0, 0, 0.10), (0, 0, 0), (0, -1, 0), None),
    ("torso_3", "revolute", "torso_link2", "torso_link3", (0, 0, 0.40), (0, 0, 0), (0, -1, 0), None),
    (
        "torso_4a",
        "revolute",
        "torso_link3",
        "torso_link4a",
        (0, 0, 0.40),
        (0, 0, 0),
        (0, -1, 0),
        ("torso_2", -1.0, 0.0),
    ),
    ("torso_4b", "revolute", "torso_link4a", "chest", (0, 0, 0), (0, 0, 0), (0, -1, 0), ("torso_3", -1.0, 0.0)),
]

#: mass (kg) and centre of mass (link frame, m) of every link that has one
DUALARM_LINKS: dict[str, tuple[float, tuple[float, float, float]]] = {
    "torso_link1": (8.0, (0.0, 0.0, 0.05)),
    "torso_link2": (10.0, (0.0, 0.0, 0.20)),
    "torso_link3": (9.0, (0.0, 0.0, 0.20)),
    "chest": (18.0, (0.0, 0.0, 0.20)),
}


def _arm(side: str) -> tuple[list[tuple], dict]:
    """Seven joints of one arm from the chest; the left arm mirrors the right."""
    s = 1.0 if side == "left" else -1.0
    p = f"{side}_"
    joints = [
        (p + "1", "revolute", "chest", p + "link1", (0.0, s * 0.22, 0.30), (s * -math.pi / 2, 0, 0), (0, 0, 1), None),
        (p + "2", "revolute", p + "link1", p + "link2", (0, 0, 0.11), (math.pi / 2, 0, 0), (0, 0, 1), None),
        (p + "3", "revolute", p + "link2", p + "link3", (0, -0.20, 0), (-math.pi / 2, 0, 0), (0, 0, 1), None),
        (p + "4", "revolute", p + "link3", p + "link4", (0, 0, 0.20), (math.pi / 2, 0, 0), (0, 0, 1), None),
        (p + "5", "revolute", p + "link4", p + "link5", (0, -0.20, 0), (-math.pi / 2, 0, 0), (0, 0, 1), None),
        (p + "6", "revolute", p + "link5", p + "link6", (0, 0, 0.19), (math.pi / 2, 0, 0), (0, 0, 1), None),
        (p + "7", "revolute", p + "link6", p + "link7", (0, 0.08, 0), (-math.pi / 2, 0, 0), (0, 0, 1), None),
        (p + "hand", "fixed", p + "link7", p + "hand", (0, 0, 0.06), (0, 0, 0), (0, 0, 1), None),
        (p + "tcp", "fixed", p + "hand", p + "tcp", (0, 0, 0.12), (0, 0, 0), (0, 0, 1), None),
    ]
    links = {
        p + "link1": (2.7, (0.0, 0.0, 0.05)),
        p + "link2": (2.7, (0.0, -0.10, 0.0)),
        p + "link3": (2.3, (0.0, 0.0, 0.10)),
        p + "link4": (2.3, (0.0, -0.10, 0.0)),
        p + "link5": (1.6, (0.0, 0.0, 0.10)),
        p + "link6": (1.6, (0.0, 0.04, 0.0)),
        p + "link7": (0.4, (0.0, 0.0, 0.02)),
        p + "hand": (1.4, (0.0, 0.0, 0.06)),
    }
    return joints, links


def _all() -> tuple[list[tuple], dict]:
    joints, links = list(DUALARM_JOINTS), dict(DUALARM_LINKS)
    for side in ("left", "right"):
        j, ln = _arm(side)
        joints += j
        links.update(ln)
    return joints, links


def actuated_names() -> list[str]:
    """The joint columns of the measurement CSV, in URDF order."""
    return [j[0] for j in _all()[0] if j[1] != "fixed" and j[7] is None]


#: posture ranges (rad) for calibration configurations
TORSO_RANGES = [(-1.2, 1.2), (-0.3, 0.9), (-0.9, 0.3)]
ARM_RANGES = [(-2.2, 2.2), (-1.7, 1.7), (-2.2, 2.2), (-1.9, 1.9), (-2.2, 2.2), (-1.7, 1.7), (-2.5, 2.5)]


def dualarm_urdf(joints: list[tuple] | None = None, links: dict | None = None, name: str = "dualarm") -> str:
    """The URDF text of the dual-arm robot (or of a variant with other joints/links)."""
    if joints is None or links is None:
        j0, l0 = _all()
        joints = j0 if joints is None else joints
        links = l0 if links is None else links
    names = ["base_link"]
    for j in joints:
        for ln in (j[2], j[3]):
            if ln not in names:
                names.append(ln)

    def f(v: tuple | np.ndarray) -> str:
        return " ".join(f"{float(x):.17g}" for x in v)

    out = ['<?xml version="1.0"?>', f'<robot name="{name}">']
    for ln in names:
        if ln in links:
            m, c = links[ln]
            out.append(
                f'  <link name="{ln}"><inertial><origin xyz="{f(c)}" rpy="0 0 0"/><mass value="{m:.17g}"/>'
                f'<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
            )
        else:
            out.append(f'  <link name="{ln}"/>')
    for name_, kind, parent, child, xyz, rpy, axis, mimic in joints:
        out.append(f'  <joint name="{name_}" type="{kind}">')
        out.append(f'    <parent link="{parent}"/><child link="{child}"/>')
        out.append(f'    <origin xyz="{f(xyz)}" rpy="{f(rpy)}"/>')
        if kind != "fixed":
            out.append(f'    <axis xyz="{f(axis)}"/>')
            out.append('    <limit lower="-3.1" upper="3.1" effort="200" velocity="1"/>')
            if mimic is not None:
                out.append(f'    <mimic joint="{mimic[0]}" multiplier="{mimic[1]:.17g}" offset="{mimic[2]:.17g}"/>')
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out) + "\n"
