"""A synthetic dual-arm upper body and its tracker data: ``stiffkit synth dualarm``.

The robot: a torso on a fixed pedestal (a vertical yaw joint, two pitch
joints and a coupled pitch that keeps the chest upright, ``q = -(q2 + q3)``,
written as two coaxial ``<mimic>`` joints, one per leader) carrying two
anthropomorphic 7-joint arms (shoulder pitch, roll, yaw; elbow; forearm
yaw; wrist pitch, roll; 0.8 m from shoulder to tool centre, 11 kg each)
with a hand and a tool-centre frame on each, and a head. Joint origins have
no rotation and the axes are along the link axes, so frame errors read as
plain directions. Link masses and centres of mass are in the URDF: the
elastic deflection under the robot's own weight is part of the model.
Dimensions and masses are round numbers of that class of robot, not any
product's.

The truth (:func:`dualarm_truth`) is what a laser-tracker calibration of
such a robot finds: the tracker 3 m in front of the robot, one reflector
(SMR) a few centimetres off each tool centre, joint zero offsets of a few
mrad, joint-origin errors of 1-2 mm and mrad, joint compliances that sag
the hands by millimetres under the arms' and torso's weight, and tilting
(lateral) compliances of the joints' bearings. Errors are given only on the
directions the data can identify (the others are zero: they would be taken
up by the identified ones), so the identified values compare one to one
with truth.toml. The truth is the same for every seed and posture count.

:func:`synth_dualarm` writes robot.urdf, truth.toml, model.toml (the user's
starting model: the tracker and one marker per hand, nothing else),
measurements.csv (docs/calibration.md section 6.3: two markers per
posture, Gaussian noise) and targets.csv (a held-out smooth trajectory for
``stiffkit compensate``).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import validate as V
from ..io.files import atomic_write_text
from ..robot.tree import Tree, load_tree
from ..robot.tree_model import FRAME_NAMES, TreeModel, tree_model_from_tables
from .absolute_data import AbsoluteData, write_absolute
from .absolute_write import model_text

__all__ = [
    "DUALARM_JOINTS",
    "DUALARM_LINKS",
    "ARM_RANGES",
    "TORSO_RANGES",
    "TRUTHS",
    "MARKERS",
    "dualarm_urdf",
    "actuated_names",
    "dualarm_truth",
    "dualarm_postures",
    "dualarm_targets",
    "synth_dualarm",
    "add_hidden_effect",
    "HIDDEN_EFFECTS",
]

#: (name, type, parent, child, xyz, rpy, axis, mimic (leader, multiplier, offset) or None)
DUALARM_JOINTS: list[tuple] = [
    ("torso_1", "revolute", "base_link", "torso_link1", (0, 0, 0.45), (0, 0, 0), (0, 0, 1), None),
    ("torso_2", "revolute", "torso_link1", "torso_link2", (0, 0, 0.12), (0, 0, 0), (0, 1, 0), None),
    ("torso_3", "revolute", "torso_link2", "torso_link3", (0, 0, 0.35), (0, 0, 0), (0, 1, 0), None),
    ("torso_4a", "revolute", "torso_link3", "torso_link4a", (0, 0, 0.35), (0, 0, 0), (0, 1, 0), ("torso_2", -1.0, 0.0)),
    ("torso_4b", "revolute", "torso_link4a", "chest", (0, 0, 0), (0, 0, 0), (0, 1, 0), ("torso_3", -1.0, 0.0)),
    ("head", "fixed", "chest", "head", (0.02, 0, 0.42), (0, 0, 0), (0, 0, 1), None),
]

#: mass (kg) and centre of mass (link frame, m) of every link that has one
DUALARM_LINKS: dict[str, tuple[float, tuple[float, float, float]]] = {
    "torso_link1": (7.0, (0.0, 0.0, 0.06)),
    "torso_link2": (9.0, (0.0, 0.0, 0.17)),
    "torso_link3": (8.0, (0.0, 0.0, 0.17)),
    "chest": (16.0, (0.02, 0.0, 0.18)),
    "head": (4.0, (0.03, 0.0, 0.08)),
}


def _arm(side: str) -> tuple[list[tuple], dict]:
    """Seven joints of one arm from the chest. The right arm mirrors the
    left: its shoulder is at -y and its roll and yaw axes are reversed, so
    one set of joint values gives mirrored postures."""
    s = 1.0 if side == "left" else -1.0
    p = f"{side}_"
    joints = [
        (p + "1", "revolute", "chest", p + "link1", (0.0, s * 0.19, 0.30), (0, 0, 0), (0, 1, 0), None),
        (p + "2", "revolute", p + "link1", p + "link2", (0.0, s * 0.07, 0.0), (0, 0, 0), (s, 0, 0), None),
        (p + "3", "revolute", p + "link2", p + "link3", (0.0, 0.0, -0.13), (0, 0, 0), (0, 0, s), None),
        (p + "4", "revolute", p + "link3", p + "link4", (0.015, 0.0, -0.17), (0, 0, 0), (0, 1, 0), None),
        (p + "5", "revolute", p + "link4", p + "link5", (-0.015, 0.0, -0.12), (0, 0, 0), (0, 0, s), None),
        (p + "6", "revolute", p + "link5", p + "link6", (0.0, 0.0, -0.15), (0, 0, 0), (0, 1, 0), None),
        (p + "7", "revolute", p + "link6", p + "link7", (0.0, 0.0, -0.06), (0, 0, 0), (0, 0, s), None),
        (p + "hand", "fixed", p + "link7", p + "hand", (0, 0, -0.04), (0, 0, 0), (0, 0, 1), None),
        (p + "tcp", "fixed", p + "hand", p + "tcp", (0, 0, -0.13), (math.pi, 0, 0), (0, 0, 1), None),
    ]
    links = {
        p + "link1": (1.8, (0.0, s * 0.04, 0.0)),
        p + "link2": (2.0, (0.0, 0.0, -0.05)),
        p + "link3": (2.2, (0.0, 0.0, -0.10)),
        p + "link4": (1.4, (0.0, 0.0, -0.05)),
        p + "link5": (1.3, (0.0, 0.0, -0.09)),
        p + "link6": (0.7, (0.0, 0.0, -0.03)),
        p + "link7": (0.3, (0.0, 0.0, -0.02)),
        p + "hand": (1.1, (0.012, 0.0, -0.06)),  # a gripper: off the wrist axis
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


#: posture ranges (rad) of the calibration configurations: torso yaw and
#: pitches; the arms' (the same values give mirrored postures)
TORSO_RANGES = [(-0.8, 0.8), (-0.15, 0.5), (-0.45, 0.25)]
ARM_RANGES = [(-2.5, 0.3), (-0.2, 1.3), (-1.6, 1.6), (-2.3, -0.1), (-1.8, 1.8), (-1.2, 1.2), (-2.5, 2.5)]
#: joint limits written to the URDF: the ranges plus this margin (rad)
LIMIT_MARGIN = 0.3


def _ranges() -> np.ndarray:
    return np.array(TORSO_RANGES + ARM_RANGES + ARM_RANGES, float)


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
    limits = dict(zip(actuated_names(), _ranges()))

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
            lo, hi = limits.get(name_, (-2.0 - LIMIT_MARGIN, 2.0 + LIMIT_MARGIN))
            out.append(f'    <axis xyz="{f(axis)}"/>')
            lim = f'lower="{lo - LIMIT_MARGIN:.4g}" upper="{hi + LIMIT_MARGIN:.4g}"'
            out.append(f'    <limit {lim} effort="300" velocity="2"/>')
            if mimic is not None:
                out.append(f'    <mimic joint="{mimic[0]}" multiplier="{mimic[1]:.17g}" offset="{mimic[2]:.17g}"/>')
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out) + "\n"


#: the markers (SMR reflectors) of the truth: their point in the tool-centre frame (m)
MARKERS = {"left_tcp": (0.0284, 0.0117, -0.0352), "right_tcp": (0.0261, -0.0139, -0.0368)}
#: the tracker 2.8 m in front of the robot, its head 1.1 m above the base, facing it
TRACKER = {"xyz": (2.815, 0.382, -1.104), "rpy": (0.0041, -0.0063, 3.0572)}
#: the truth's random errors are drawn with this seed (the same truth for every data seed)
TRUTH_SEED = 20240611
#: zero offsets: magnitude uniform in this range (rad), random sign: encoder
#: zeros set at assembly, half a degree to two degrees off
OFFSET_RANGE = (8.0e-3, 34.0e-3)
#: frame errors: standard deviation of the translations (m) and rotations (rad)
FRAME_SIGMA = (1.0e-3, 1.0e-3)
#: joint compliance (rad/(N m)) by joint (arms: by the number after the side):
#: harmonic drives, belts and the links' torsion lumped at the joint
JOINT_C = {
    "torso_1": 2.0e-5,
    "torso_2": 2.5e-5,
    "torso_3": 3.5e-5,
    "torso_4a": 4.0e-5,
    "torso_4b": 0.0,  # coaxial with torso_4a: one physical joint, one compliance
    "1": 1.2e-4,
    "2": 1.5e-4,
    "3": 2.0e-4,
    "4": 2.3e-4,
    "5": 4.0e-4,
    "6": 5.0e-4,
    "7": 6.0e-4,
}
#: lateral (tilt) compliances (rad/(N m)) about x' and y': the bearings' tilt
#: and the links' bending lumped at the joint; the waist's carry the upper body
LATERAL_C = {
    "torso_1": (6.5e-5, 9.0e-5),
    "torso_2": (5.5e-5, 4.5e-5),
    "torso_3": (7.5e-5, 5.5e-5),
    "torso_4a": (6.5e-5, 6.5e-5),
    "torso_4b": (0.0, 0.0),
    "1": (6.0e-5, 5.0e-5),
    "2": (7.0e-5, 6.0e-5),
    "3": (8.0e-5, 9.0e-5),
    "4": (1.0e-4, 8.0e-5),
    "5": (1.6e-4, 1.8e-4),
    "6": (2.0e-4, 1.6e-4),
    "7": (2.4e-4, 2.4e-4),
}
#: the truth variants of ``synth dualarm --truth``
TRUTHS = ("full", "geometric")
#: the kinds of the truth, in the order a user adds them
STORY = ("joint_offset", "frame", "joint", "lateral")
GRAVITY = (0.0, 0.0, -9.81)


def _suffix(joint: str) -> str:
    return joint if joint.startswith("torso") else joint.split("_", 1)[1]


def _structure(tree: Tree) -> list[dict]:
    """The truth's effects without values: tracker, markers, and every kind of STORY on all joints."""
    eff = [{"kind": "tracker", "xyz": list(TRACKER["xyz"]), "rpy": list(TRACKER["rpy"])}]
    eff += [{"kind": "marker", "target": f, "xyz": list(p)} for f, p in MARKERS.items()]
    eff += [{"kind": k, "target": "all"} for k in STORY]
    return eff


def _reference_data(model: TreeModel, Q: np.ndarray, theta: np.ndarray) -> AbsoluteData:
    from .absolute_fit import predict

    n = Q.shape[0]
    frames = list(MARKERS)
    data = AbsoluteData(
        path="dualarm",
        joints=actuated_names(),
        configs=[f"p{k + 1:04d}" for k in range(n)],
        Q=Q,
        posture=np.repeat(np.arange(n), len(frames)),
        frame=np.tile(np.arange(len(frames)), n),
        frames=frames,
        xyz=np.zeros((n * len(frames), 3)),
        weight=np.ones(n * len(frames)),
        lines=np.arange(n * len(frames)) + 2,
    )
    data.xyz = predict(model, data, theta)["pred"]
    return data


def dualarm_truth(urdf: str | Path, variant: str = "full") -> list[dict]:
    """The truth's [[effect]] tables with values (module docstring) for the
    dual-arm URDF at ``urdf``. ``variant``: "full"; "geometric" (no
    compliance: a rigid robot with geometric errors only).

    Each parameter the data identify gets a value drawn with TRUTH_SEED
    (or the compliance tables); a parameter whose column duplicates others
    (a translation along the next parallel axis, the second of two coaxial
    joints) gets 0, and so does a frame error the data do not depend on
    (the head's: it only moves a weight); a compliance the data do not
    depend on (the vertical torso joint's) keeps its physical value."""
    from .absolute_fit import predict, reduce_parameters

    if variant not in TRUTHS:
        raise InputError(f"truth {variant!r}: choose one of {', '.join(TRUTHS)}")
    tree = load_tree(urdf)
    model = tree_model_from_tables(tree, _structure(tree), GRAVITY, where="dualarm truth")
    theta = model.theta0
    data = _reference_data(model, dualarm_postures(200, np.random.default_rng(TRUTH_SEED)), theta)
    free = model.free
    jac = predict(model, data, theta, free)["jac"]
    kept = {model.params[i].name for i in reduce_parameters(model, jac, free).kept}
    norms = np.linalg.norm(jac, axis=0)
    kinds = [model.params[i].kind for i in free]
    top = {k: max(n for n, k2 in zip(norms, kinds) if k2 == k) for k in set(kinds)}
    zero_col = {model.params[i].name for i, n, k in zip(free, norms, kinds) if n <= 1e-9 * top[k]}
    rng = np.random.default_rng(TRUTH_SEED)
    eff = _structure(tree)[:3]
    moving = [j for j in tree.joints if j.moving]

    def value(name: str, draw: float) -> float:
        if name in kept or (name in zero_col and name.rsplit(".", 1)[1] in ("c", "cx", "cy")):
            return float(draw)
        return 0.0

    for j in moving:
        mag = rng.uniform(*OFFSET_RANGE) * rng.choice([-1.0, 1.0])
        eff.append({"kind": "joint_offset", "target": j.name, "value": value(f"{j.name}.dq0", mag)})
    for j in tree.joints:
        d = np.concatenate([rng.normal(0, FRAME_SIGMA[0], 3), rng.normal(0, FRAME_SIGMA[1], 3)])
        v = [value(f"{j.name}.{n}", d[k]) for k, n in enumerate(FRAME_NAMES)]
        eff.append({"kind": "frame", "target": j.name, "value": v})
    if variant == "geometric":
        return eff
    for j in moving:
        eff.append({"kind": "joint", "target": j.name, "value": value(f"{j.name}.c", JOINT_C[_suffix(j.name)])})
    for j in moving:
        cx, cy = LATERAL_C[_suffix(j.name)]
        eff.append(
            {"kind": "lateral", "target": j.name, "value": [value(f"{j.name}.cx", cx), value(f"{j.name}.cy", cy)]}
        )
    return eff


_FK_CACHE: dict = {}


def _tcp_points(Q: np.ndarray) -> np.ndarray:
    """Base-frame positions (np, 2, 3) of the nominal left and right tool centres."""
    from .._core import tree as core

    if "model" not in _FK_CACHE:
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            p = Path(tmp) / "dualarm.urdf"
            p.write_text(dualarm_urdf())
            tree = load_tree(p)
        eff = [{"kind": "tracker"}] + [{"kind": "marker", "target": f} for f in MARKERS]
        _FK_CACHE["model"] = tree_model_from_tables(tree, eff, GRAVITY, where="dualarm")
    m = _FK_CACHE["model"]
    P = core.poses(m.packed, m.theta0, Q, None, 0, 1e-9)
    return P["pa"][:, m.arrays["mvj"] - 1]


#: a posture is kept when both tool centres are this far in front of the
#: torso axis (m, base x) and between these heights (m): the reflectors face
#: the tracker and the arms do not cross the body
FRONT, HEIGHTS = 0.20, (0.75, 2.0)


def dualarm_postures(n: int, rng: np.random.Generator) -> np.ndarray:
    """n calibration postures (n, 17): uniform over the joint ranges, kept
    when both tool centres are in front of the robot (FRONT, HEIGHTS)."""
    lo, hi = _ranges().T
    out = np.zeros((0, lo.size))
    while out.shape[0] < n:
        Q = rng.uniform(lo, hi, (max(4 * (n - out.shape[0]), 64), lo.size))
        P = _tcp_points(Q)
        ok = np.all(P[:, :, 0] > FRONT, axis=1) & np.all((P[:, :, 2] > HEIGHTS[0]) & (P[:, :, 2] < HEIGHTS[1]), axis=1)
        out = np.vstack([out, Q[ok]])
    return out[:n]


def dualarm_targets(n: int = 50) -> np.ndarray:
    """A smooth held-out trajectory (n, 17) through four postures of the
    calibration ranges (drawn with a seed of their own), cosine-blended."""
    keys = dualarm_postures(4, np.random.default_rng(TRUTH_SEED + 1))
    s = np.linspace(0.0, 3.0, n)
    k = np.minimum(s.astype(int), 2)
    u = 0.5 - 0.5 * np.cos(math.pi * (s - k))
    return keys[k] + (keys[k + 1] - keys[k]) * u[:, None]


#: the starting model's marker points: the reflector nests' drawing values (m)
NOMINAL_MARKERS = {f: tuple(round(v, 2) for v in p) for f, p in MARKERS.items()}
#: the files synth_dualarm writes
OUTPUT_FILES = ("robot.urdf", "truth.toml", "model.toml", "measurements.csv", "targets.csv")
#: the defaults of synth_dualarm (and of ``stiffkit synth dualarm``)
DEFAULT_CONFIGS, DEFAULT_SIGMA, DEFAULT_TARGETS = 400, 1.0e-4, 50


def _csv_rows(Q: np.ndarray, frames: list[str], prefix: str) -> list[str]:
    rows = [",".join(["config"] + actuated_names() + ["frame"])]
    for k, q in enumerate(Q):
        for f in frames:
            rows.append(",".join([f"{prefix}{k + 1:03d}"] + [f"{v:.17g}" for v in q] + [f]))
    return rows


def synth_dualarm(
    out: str | Path,
    configs: int = DEFAULT_CONFIGS,
    seed: int = 1,
    sigma: float = DEFAULT_SIGMA,
    truth: str = "full",
    targets: int = DEFAULT_TARGETS,
) -> Path:
    """Write the dual-arm data set into the folder ``out`` (module
    docstring): ``configs`` postures with both hand markers measured,
    Gaussian noise ``sigma`` (m per coordinate; 0: noise-free) drawn with
    ``seed``, the truth variant ``truth`` (TRUTHS), and a held-out
    trajectory of ``targets`` postures. Returns the folder."""
    configs = V.count(configs, "configs", 1, 10**5)
    seed = V.count(seed, "seed", 0)
    targets = V.count(targets, "targets", 1, 10**5)
    sigma = V.number(sigma, "sigma", "sigma_position", lo=0.0, check_plausible=sigma != 0)
    if truth not in TRUTHS:
        raise InputError(f"truth = {truth!r}: choose one of {', '.join(TRUTHS)}")
    if not isinstance(out, (str, Path)) or not str(out).strip():
        raise InputError(f"out = {out!r}: give the name of a folder")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: a file, not a folder")
    out.mkdir(parents=True, exist_ok=True)
    urdf = out / "robot.urdf"
    atomic_write_text(urdf, dualarm_urdf())
    effects = dualarm_truth(urdf, truth)
    tree = load_tree(urdf)
    model = tree_model_from_tables(tree, effects, GRAVITY, where=str(out / "truth.toml"))
    rng = np.random.default_rng(seed)
    Q = dualarm_postures(configs, rng)
    data = _reference_data(model, Q, model.theta0)
    data.path = str(out / "measurements.csv")
    data.xyz = data.xyz + sigma * rng.normal(size=data.xyz.shape)
    head = (
        "# the truth of `stiffkit synth dualarm`: every effect with its value; zeros on the\n"
        "# directions the data cannot identify (stiffkit.calib.dualarm)"
    )
    atomic_write_text(
        out / "truth.toml",
        model_text(effects, sigma_position=sigma if sigma > 0 else None, gravity=GRAVITY, header=head),
    )
    start = [{"kind": "tracker"}]
    start += [{"kind": "marker", "target": f, "xyz": list(p)} for f, p in NOMINAL_MARKERS.items()]
    head = (
        "# the starting model: the tracker (its pose from the data) and one reflector per hand;\n"
        '# add effects one kind at a time: joint_offset, frame, joint, lateral (target "all")'
    )
    atomic_write_text(out / "model.toml", model_text(start, gravity=GRAVITY, header=head))
    write_absolute(out / "measurements.csv", data)
    atomic_write_text(out / "targets.csv", "\n".join(_csv_rows(dualarm_targets(targets), list(MARKERS), "t")) + "\n")
    return out


#: effects outside the catalogue that add_hidden_effect can put into the data
HIDDEN_EFFECTS = ("cyclic", "drift")
#: joints of the cyclic transmission error
CYCLIC_JOINTS = ("left_2", "right_2", "left_4", "right_4")


def add_hidden_effect(out: str | Path, kind: str, amount: float, seed: int, sigma: float = DEFAULT_SIGMA) -> None:
    """Regenerate the measurements of a ``synth_dualarm`` folder from its
    truth with an effect no catalogued kind describes (for testing the
    diagnosis): ``cyclic``, an eccentric gear or encoder in four joints
    (q_true = q + amount sin 2q, amount in rad), or ``drift``, the tracker
    drifting linearly over the measurement (amount in m at the end, along
    a fixed direction); fresh noise ``sigma`` drawn with ``seed``. The
    commanded joint values in the file stay as they were."""
    from .absolute_fit import predict
    from .absolute_report import load_absolute

    if kind not in HIDDEN_EFFECTS:
        raise InputError(f"hidden effect {kind!r}: choose one of {', '.join(HIDDEN_EFFECTS)}")
    out = Path(out)
    truth = tree_model_from_tables(
        load_tree(out / "robot.urdf"), dualarm_truth(out / "robot.urdf"), GRAVITY, where=str(out / "truth.toml")
    )
    _model, data = load_absolute(out / "model.toml", out / "measurements.csv")
    rng = np.random.default_rng(seed)
    moved = replace(data, Q=data.Q.copy())
    if kind == "cyclic":
        for j in CYCLIC_JOINTS:
            k = data.joints.index(j)
            moved.Q[:, k] += amount * np.sin(2 * data.Q[:, k])
    pts = predict(truth, moved, truth.theta0)["pred"] + sigma * rng.normal(size=data.xyz.shape)
    if kind == "drift":
        pts += amount * np.outer(data.posture / max(data.posture.max(), 1), [1.0, 0.5, -0.3]) / math.sqrt(1.34)
    data.xyz = pts
    write_absolute(out / "measurements.csv", data)


def summary(out: str | Path, configs: int, targets: int) -> str:
    """What ``stiffkit synth dualarm`` wrote, and the next step."""
    out = Path(out)
    nm = len(MARKERS)
    return (
        f"wrote {out}/robot.urdf, truth.toml, model.toml (the tracker and {nm} markers), measurements.csv "
        f"({configs * nm} rows, {configs} postures), targets.csv ({targets * nm} rows, {targets} postures)\n"
        f"next: stiffkit fit {out}/model.toml {out}/measurements.csv, then add [[effect]] tables of kind "
        + ", ".join(STORY)
        + ' (target = "all") one at a time'
    )
