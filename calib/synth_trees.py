"""Random kinematic trees with a known truth, for testing the diagnosis loop
on absolute data (``calib.absolute_diagnose``).

:func:`random_tree_urdf` draws a small robot: a trunk of revolute joints on
the base (optionally below ``n_fixed`` fixed joints, as real URDFs have:
world -> base -> base_link_inertia ...), two arms each ending in a tool
frame that carries a marker, a head on the trunk that carries mass but no
marker, and on the first arm a gripper whose two fingers are a ``<mimic>``
pair (mass, no marker). Axes, lengths, masses and centres of mass are
drawn from ``rng``.

:func:`tree_case` adds the truth (tracker pose, marker points, joint zero
offsets and joint compliances under gravity on every moving joint), and the
data: ``postures`` random postures, both markers measured, Gaussian noise
``sigma``. The start model is the tracker and the markers only. The effects
of the truth are per joint, so a diagnosis proposes them on ``all``.
:func:`twofixed_case` is one such robot with two fixed joints at its base
(drawn from a fixed seed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io.files import atomic_write_text
from ..robot.tree import Tree, load_tree
from ..robot.tree_model import GRAVITY, TreeModel, tree_model_from_tables
from .absolute_data import AbsoluteData

__all__ = ["TreeCase", "random_tree_urdf", "tree_case", "twofixed_case", "TRUTH_KINDS", "NO_MARKER_LINKS"]

#: the effect kinds of every truth drawn here (besides the tracker and the markers)
TRUTH_KINDS = ("joint_offset", "joint")
#: links that carry mass but no marker (and every link below them)
NO_MARKER_LINKS = ("head", "finger_a", "finger_b")
#: the marker points in the tool frames (m)
MARKER_XYZ = {"tool_l": (0.03, 0.01, 0.02), "tool_r": (-0.02, 0.03, 0.025)}
#: joint zero offsets: magnitude uniform in this range (rad), random sign
OFFSET_RANGE = (3.0e-3, 15.0e-3)
#: joint compliances (rad/(N m)): log-uniform in this range
COMPLIANCE_RANGE = (4.0e-5, 2.0e-4)
#: posture range of every actuated joint (rad)
Q_RANGE = 1.4
TRACKER = {"xyz": (2.2, 0.3, -0.9), "rpy": (0.01, -0.02, 3.1)}


@dataclass
class TreeCase:
    """A robot, its truth and data."""

    tree: Tree
    truth: list[dict]  # [[effect]] tables with values
    start: list[dict]  # the user's starting model: tracker and markers
    data: AbsoluteData
    sigma: float

    def model(self, effects: list[dict], sigma_declared: bool = True) -> TreeModel:
        """A tree model of ``effects`` on this robot (sigma declared or not)."""
        sig = self.sigma if sigma_declared else None
        return tree_model_from_tables(self.tree, effects, GRAVITY, where="tree case", sigma_position=sig)


def _axis(rng: np.random.Generator, prev: int) -> int:
    return int(rng.choice([a for a in range(3) if a != prev]))


def random_tree_urdf(rng: np.random.Generator, n_fixed: int = 0, trunk: int = 2, arm: int = 3) -> str:
    """The URDF text of a random robot (module docstring): ``trunk`` joints,
    two arms of ``arm`` joints, ``n_fixed`` fixed joints below the trunk."""
    links: dict[str, tuple[float, tuple]] = {}
    joints: list[tuple] = []
    parent = "base_link"
    for k in range(n_fixed):
        child = f"mount_{k + 1}"
        joints.append((f"fixed_{k + 1}", "fixed", parent, child, (0.0, 0.0, 0.05 * (k + 1)), 0, None))
        parent = child
    prev = -1
    for k in range(trunk):
        ax = 2 if k == 0 else _axis(rng, prev)
        child = f"trunk_{k + 1}"
        joints.append((f"t{k + 1}", "revolute", parent, child, (0.0, 0.0, rng.uniform(0.15, 0.35)), ax, None))
        links[child] = (rng.uniform(3.0, 8.0), (0.0, 0.0, rng.uniform(0.05, 0.15)))
        parent, prev = child, ax
    top = parent
    # the head: mass, no marker
    joints.append(("neck", "revolute", top, "head", (0.02, 0.0, 0.25), 2, None))
    links["head"] = (rng.uniform(2.0, 4.0), (0.03, 0.0, 0.08))
    for side, s in (("l", 1.0), ("r", -1.0)):
        parent, prev = top, -1
        for k in range(arm):
            ax = _axis(rng, prev)
            xyz = (0.0, s * 0.18, 0.2) if k == 0 else (rng.uniform(-0.03, 0.03), 0.0, -rng.uniform(0.15, 0.3))
            child = f"{side}_link{k + 1}"
            joints.append((f"{side}{k + 1}", "revolute", parent, child, xyz, ax, None))
            links[child] = (rng.uniform(0.8, 2.5), (0.0, 0.0, -rng.uniform(0.03, 0.1)))
            parent, prev = child, ax
        joints.append((f"{side}_tool", "fixed", parent, f"tool_{side}", (0.0, 0.0, -0.1), 0, None))
        if side == "l":
            # a gripper: two fingers, the second a mimic of the first (mass, no marker)
            joints.append(("finger_a", "prismatic", parent, "finger_a", (0.0, 0.02, -0.08), 1, None))
            joints.append(("finger_b", "prismatic", parent, "finger_b", (0.0, -0.02, -0.08), 1, ("finger_a", -1.0)))
            links["finger_a"] = (0.3, (0.0, 0.0, -0.02))
            links["finger_b"] = (0.3, (0.0, 0.0, -0.02))
    names = ["base_link"] + [j[3] for j in joints]

    def f(v: tuple) -> str:
        return " ".join(f"{float(x):.17g}" for x in v)

    out = ['<?xml version="1.0"?>', '<robot name="random_tree">']
    for ln in names:
        if ln in links:
            m, c = links[ln]
            out.append(
                f'  <link name="{ln}"><inertial><origin xyz="{f(c)}" rpy="0 0 0"/><mass value="{m:.17g}"/>'
                f'<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
            )
        else:
            out.append(f'  <link name="{ln}"/>')
    for name, kind, par, child, xyz, ax, mimic in joints:
        out.append(f'  <joint name="{name}" type="{kind}"><parent link="{par}"/><child link="{child}"/>')
        out.append(f'    <origin xyz="{f(xyz)}" rpy="0 0 0"/>')
        if kind != "fixed":
            lim = "0.04" if kind == "prismatic" else f"{Q_RANGE + 0.3:.3g}"
            lo = "0" if kind == "prismatic" else f"-{lim}"
            out.append(f'    <axis xyz="{f(np.eye(3)[ax])}"/>')
            out.append(f'    <limit lower="{lo}" upper="{lim}" effort="100" velocity="1"/>')
            if mimic is not None:
                out.append(f'    <mimic joint="{mimic[0]}" multiplier="{mimic[1]:g}" offset="0"/>')
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out) + "\n"


def _truth(tree: Tree, rng: np.random.Generator) -> list[dict]:
    eff = [{"kind": "tracker", "xyz": list(TRACKER["xyz"]), "rpy": list(TRACKER["rpy"])}]
    eff += [{"kind": "marker", "target": ln, "xyz": list(p)} for ln, p in MARKER_XYZ.items()]
    moving = [j for j in tree.joints if j.moving]
    for j in moving:
        v = rng.uniform(*OFFSET_RANGE) * rng.choice([-1.0, 1.0])
        eff.append({"kind": "joint_offset", "target": j.name, "value": float(v if j.type != "prismatic" else 0.0)})
    lo, hi = np.log(COMPLIANCE_RANGE)
    for j in moving:
        c = math.exp(rng.uniform(lo, hi)) if j.type != "prismatic" else 0.0
        eff.append({"kind": "joint", "target": j.name, "value": float(c)})
    return eff


def tree_case(folder: str | Path, seed: int, postures: int = 40, sigma: float = 1e-4, n_fixed: int = 0) -> TreeCase:
    """A random robot drawn with ``seed`` (its URDF written to ``folder``),
    its truth and ``postures`` noisy postures (module docstring)."""
    rng = np.random.default_rng(seed)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / f"tree_{seed}.urdf"
    atomic_write_text(urdf, random_tree_urdf(rng, n_fixed=n_fixed))
    tree = load_tree(urdf)
    truth = _truth(tree, rng)
    joints = tree.actuated
    Q = rng.uniform(-Q_RANGE, Q_RANGE, (postures, len(joints)))
    for k, jn in enumerate(joints):
        if tree.joint(jn).type == "prismatic":
            Q[:, k] = rng.uniform(0.0, 0.04, postures)
    frames = list(MARKER_XYZ)
    nf = len(frames)
    data = AbsoluteData(
        path=f"tree case {seed}",
        joints=joints,
        configs=[f"c{k + 1:03d}" for k in range(postures)],
        Q=Q,
        posture=np.repeat(np.arange(postures), nf),
        frame=np.tile(np.arange(nf), postures),
        frames=frames,
        xyz=np.zeros((postures * nf, 3)),
        weight=np.ones(postures * nf),
        lines=np.arange(postures * nf) + 2,
    )
    from .absolute_fit import predict

    model = tree_model_from_tables(tree, truth, GRAVITY, where="truth")
    data.xyz = predict(model, data, model.theta0)["pred"] + sigma * rng.normal(size=data.xyz.shape)
    start = [{"kind": "tracker"}] + [{"kind": "marker", "target": ln, "xyz": [0.0, 0.0, 0.0]} for ln in frames]
    return TreeCase(tree=tree, truth=truth, start=start, data=data, sigma=sigma)


def twofixed_case(folder: str | Path, seed: int = 0, postures: int = 40, sigma: float = 1e-4) -> TreeCase:
    """The robot of :func:`tree_case` with two fixed joints at its base
    (base_link -> mount_1 -> mount_2 -> the trunk); a head with mass and no
    marker."""
    return tree_case(folder, 9000 + seed, postures=postures, sigma=sigma, n_fixed=2)
