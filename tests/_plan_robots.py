"""The two robots of the plan tests and bench: the synthetic dual-arm
(tracker data, every kind of effect on all joints) and a KR-270-like chain
(deflection data: joint compliances and beam springs on links 2-4, the
[plan] loads), each with task postures in a workcell (every joint within
+-0.35 rad of a working posture)."""

from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import numpy as np

import stiffkit.calib.plan  # noqa: F401 - the module (stiffkit.calib.plan is the function)
from stiffkit.calib import dualarm as D
from stiffkit.calib.absolute_write import model_text
from stiffkit.robot.plan_candidates import feasible

P = sys.modules["stiffkit.calib.plan"]
ROOT = Path(__file__).resolve().parents[1]

#: the half-width of the workcell around the working posture (rad)
WORKCELL = 0.35
#: the points measured on the KR-270's tool in each posture (tool frame, m; the demo's markers)
KR_POINTS = ((0.0, 0.0, 0.25), (0.12, 0.0, 0.2), (0.0, 0.12, 0.2))
KR_MODEL = """\
[robot]
urdf = "robot.urdf"
base_link = "base_link"
tool_frame = "tool0"

[measurements]
sigma_position = 2e-05

[plan]
loads = [[0, 0, -2500, 0, 0, 0], [2500, 0, 0, 0, 0, 0], [0, 2500, 0, 0, 0, 0], [0, 0, 0, 300, 0, 0]]
{extra}
[[effect]]
kind = "joint"
target = "all"
""" + "".join(f'\n[[effect]]\nkind = "link"\ntarget = "link_{k}"\ntemplate = "beam"\n' for k in (2, 3, 4))


def dualarm_files(folder: Path) -> Path:
    """robot.urdf and model.toml (tracker, the two markers, joint_offset,
    frame, joint and lateral on all joints, sigma 0.1 mm) in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "robot.urdf").write_text(D.dualarm_urdf())
    eff = [{"kind": "tracker", "xyz": list(D.TRACKER["xyz"]), "rpy": list(D.TRACKER["rpy"])}]
    eff += [{"kind": "marker", "target": f, "xyz": list(p)} for f, p in D.MARKERS.items()]
    eff += [{"kind": k, "target": "all"} for k in D.STORY]
    path = folder / "model.toml"
    path.write_text(model_text(eff, sigma_position=1e-4, gravity=D.GRAVITY))
    return path


def kr_files(folder: Path, extra: str = "") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(ROOT / "examples" / "kr270" / "robot.urdf", folder / "robot.urdf")
    path = folder / "model.toml"
    path.write_text(KR_MODEL.format(extra=extra))
    return path


def workcell_task(model: object, q_work: np.ndarray, n: int, seed: int, path: Path, names: list[str]) -> np.ndarray:
    """n feasible task postures within WORKCELL of q_work, written to ``path`` (joint-name columns)."""
    rng = np.random.default_rng(seed)
    T = q_work + rng.uniform(-WORKCELL, WORKCELL, (4 * n, q_work.size))
    T = feasible(model, T).q[:n]
    assert T.shape[0] == n
    rows = [",".join(names)] + [",".join(f"{v:.17g}" for v in q) for q in T]
    path.write_text("\n".join(rows) + "\n")
    return T


def k_rule(npar: int) -> int:
    """K = ceil(1.3 x identifiable parameters / 3) (issue 19)."""
    return math.ceil(1.3 * npar / 3)


def tied_tree_files(tmp_path: Path) -> tuple[Path, Path]:
    """model.toml and m.csv in ``tmp_path``: a small tree whose truth has a
    spring on l_link1, measured at 9 postures (the fingers closed), where
    the link springs of l_link1 and trunk_1 tie. Returns (model, measurements)."""
    from stiffkit.calib.absolute_data import write_absolute
    from stiffkit.calib.absolute_fit import predict
    from stiffkit.calib.absolute_write import model_text
    from stiffkit.calib.synth_trees import MARKER_XYZ, TRACKER, random_tree_urdf
    from stiffkit.robot.tree import load_tree
    from stiffkit.robot.tree_model import GRAVITY, tree_model_from_tables

    (tmp_path / "robot.urdf").write_text(random_tree_urdf(np.random.default_rng(1), trunk=1, arm=2))
    tree = load_tree(tmp_path / "robot.urdf")
    frames = [{"kind": "tracker", "xyz": list(TRACKER["xyz"]), "rpy": list(TRACKER["rpy"])}]
    frames += [{"kind": "marker", "target": ln, "xyz": list(v)} for ln, v in MARKER_XYZ.items()]
    spring = np.diag([0.0, 0.0, 0.0, 3e-3, 1.5e-3, 1.5e-3]).tolist()
    truth = tree_model_from_tables(tree, [*frames, {"kind": "link", "target": "l_link1", "value": spring}], GRAVITY)
    # the fingers (finger_b = -finger_a, both limited to [0, 0.04]) stay closed
    plan = "\n[plan]\nlimits = { finger_a = [0.0, 1e-9] }\n"
    (tmp_path / "model.toml").write_text(model_text(frames, sigma_position=1e-4, gravity=GRAVITY) + plan)
    rng = np.random.default_rng(100)
    Q = rng.uniform(-1.4, 1.4, (9, len(tree.actuated)))
    Q[:, tree.actuated.index("finger_a")] = 0.0
    data = P._abs_data(truth, Q, path=str(tmp_path / "m.csv"))
    data.xyz = predict(truth, data, truth.theta0)["pred"] + 1e-4 * rng.normal(size=data.xyz.shape)
    write_absolute(tmp_path / "m.csv", data)
    return tmp_path / "model.toml", tmp_path / "m.csv"
