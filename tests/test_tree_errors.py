"""Every argument error of the kinematic-tree core names the argument and
the index (issue 17.9): the core returns errloc = [argument, index]
(core/sk_tree_check.f90) and the bindings say which virtual joint (with the
URDF joint or effect it comes from), entry, block, parameter, posture,
payload, observation or row, and what is wrong with its value. One row per
mapped code; the Fortran and Python tables agree."""

from __future__ import annotations

import re
from pathlib import Path

import _urdf_corpus as C
import numpy as np
import pytest

import stiffkit
from stiffkit._core import tree as core
from stiffkit._core.errors import TREE_ARGUMENTS
from stiffkit.robot.tree import load_tree
from stiffkit.robot.tree_model import tree_model_from_tables

ROOT = Path(__file__).resolve().parents[1]
NAN = float("nan")


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    p = tmp_path_factory.mktemp("err") / "robot.urdf"
    p.write_text(C.urdf_text(C.ROOT_FIXED))
    effects = [
        {"kind": "tracker"},
        {"kind": "marker", "target": "tool0"},
        {"kind": "joint", "target": "all"},
        {"kind": "joint_deadzone", "target": "elbow", "tau0": 1.0},
        {"kind": "frame", "target": "elbow"},
        {"kind": "joint_offset", "target": "all"},
        {"kind": "link", "target": "fore", "template": "diagonal"},
    ]
    return tree_model_from_tables(load_tree(p), effects)


def _vj(m, label: str) -> int:
    """1-based index of the virtual joint labelled ``label``."""
    return m.arrays.labels["vj"].index(label) + 1


def _call(m, routine, arrays=None, ne=None, theta=None, **over):
    a = m.copy().arrays if arrays is None else arrays
    th = m.theta0 if theta is None else theta
    ne = m.ne if ne is None else ne
    Q = over.pop("Q", np.zeros((2, 3)))
    loads = over.pop("loads", None)
    etol = over.pop("etol", 1e-9)
    if routine == "evaluate":
        obs = dict(posture=np.array([0, 1]), marker=np.array([0, 0]), xyz=np.zeros((2, 3)), weight=np.ones(2))
        obs.update(over)
        free = obs.pop("free", np.array([0]))
        return core.evaluate(
            core.pack(ne, a), th, Q, loads, obs["posture"], obs["marker"], obs["xyz"], obs["weight"], free, 0, etol
        )
    if routine == "lm":
        return core.lm(
            core.pack(ne, a),
            th,
            Q,
            loads,
            np.array([0, 1]),
            np.array([0, 0]),
            np.zeros((2, 3)),
            np.ones(2),
            [0],
            0,
            etol,
        )
    if routine == "frame_jacobian":
        return core.frame_jacobian(core.pack(ne, a), th, over.get("frame", np.array([4, 4])), Q, loads, 0, etol)
    rt = over.get("rtarget", np.array([np.eye(3)] * 2))
    pt = over.get("ptarget", np.zeros((2, 3)))
    return core.compensate(
        core.pack(ne, a), th, np.array([4, 4]), Q, rt, pt, loads, False, 0, etol, row_params=over.get("rows")
    )


def _set(name, index, value):
    def f(a):
        a[name][index] = value
        return a

    return f


def _scale(name, index, factor):
    def f(a):
        a[name][index] = a[name][index] * factor
        return a

    return f


SHOULDER = "URDF joint 'shoulder'"
# (mutation of the model's arrays, or call options; the routine; the message)
CASES = {
    "vparent": (lambda m: _set("vparent", 2, 5), {}, "virtual joint 3 (URDF joint 'base_inertia'): parent 5 is not"),
    "vtype": (lambda m: _set("vtype", _vj(m, SHOULDER) - 1, 7), {}, f"({SHOULDER}): type 7 is not 0 (fixed)"),
    "vaxis": (
        lambda m: _scale("vaxis", (slice(None), _vj(m, SHOULDER) - 1), 1.2),
        {},
        f"virtual joint 4 ({SHOULDER}): axis not unit (norm 1.2)",
    ),
    "vaxis-nan": (
        lambda m: _set("vaxis", (0, _vj(m, SHOULDER) - 1), NAN),
        {},
        f"virtual joint 4 ({SHOULDER}): not a finite number",
    ),
    "vrot": (
        lambda m: _scale("vrot", (slice(None), slice(None), 1), 2.0),
        {},
        "virtual joint 2 (URDF joint 'base_link-base'): origin rotation is not a rotation matrix",
    ),
    "vpos": (lambda m: _set("vpos", (1, 1), np.inf), {}, "virtual joint 2 (URDF joint 'base_link-base'): not a finite"),
    "qcol": (lambda m: _set("qcol", _vj(m, SHOULDER) - 1, 9), {}, f"({SHOULDER}): joint coordinate 9 is not in 0..3"),
    "qcoef": (lambda m: _set("qcoef", 0, NAN), {}, "virtual joint 1 (URDF joint 'base_fixed'): not a finite"),
    "qconst": (lambda m: _set("qconst", 0, np.inf), {}, "virtual joint 1 (URDF joint 'base_fixed'): not a finite"),
    "gvj": (
        lambda m: _set("gvj", 0, 1),
        {},
        "geometric entry 1 (gvj): parameter 10 (shoulder.dq0) moves virtual joint 1 (URDF joint 'base_fixed'), "
        "which is fixed",
    ),
    "gpar": (lambda m: _set("gpar", 0, 999), {}, "geometric entry 1 (gpar): parameter index 999 is not in 1.."),
    "gcoef": (lambda m: _set("gcoef", 0, NAN), {}, "geometric entry 1 (gcoef): not a finite number"),
    "ktype": (lambda m: _set("ktype", 0, 9), {}, "elastic block 1 (joint on 'shoulder'): law type 9 is not"),
    "kvj": (
        lambda m: _set("kvj", (0, 1), _vj(m, SHOULDER)),
        {},
        "elastic block 2 (joint on 'elbow'): its coordinates ride on virtual joint(s) 4:",
    ),
    "kpar": (
        lambda m: _set("kpar", (0, 0), 999),
        {},
        "elastic block 1 (joint on 'shoulder'): a parameter index is not",
    ),
    "kw0": (
        lambda m: _set("kw0", 1, -1.0),
        {},
        "elastic block 2 (joint on 'elbow'): dead-zone width tau0 = -1 must be > 0",
    ),
    "bvj": (lambda m: _set("bvj", 0, 999), {}, "body 1 (link 'base_link_inertia'): its frame 999 is not in 0.."),
    "bmass": (lambda m: _set("bmass", 0, -2.0), {}, "body 1 (link 'base_link_inertia'): mass -2 kg is negative"),
    "bcom": (lambda m: _set("bcom", (2, 1), NAN), {}, "body 2 (link 'upper'): not a finite number"),
    "grav": (lambda m: _set("grav", 2, NAN), {}, "argument grav: not a finite number"),
    "tpar": (lambda m: _set("tpar", 3, 0), {}, "tracker parameter 4 (tpar): parameter index 0 is not in 1.."),
    "rref": (lambda m: _scale("rref", slice(None), 2.0), {}, "argument rref: the tracker's reference rotation is not"),
    "mvj": (lambda m: _set("mvj", 0, 999), {}, "marker 1 (marker on 'tool0'): its frame 999 is not in 0.."),
    "mpar": (lambda m: _set("mpar", (1, 0), 0), {}, "marker 1 (marker on 'tool0'): a parameter index is not in 1.."),
    "ne": (None, {"ne": +1}, "argument ne: ne = "),
    "theta": (None, {"theta": (4, NAN)}, "parameter 5 (tracker.a2): not a finite number"),
    "q": (None, {"Q": np.array([[0, 0, 0], [0, NAN, 0]])}, "posture 2 (q): not a finite number"),
    "lpost": (None, {"loads": ([4], [1], np.zeros((1, 6)))}, "payload 1 (lpost): posture 5 is not in 1..2"),
    "lvj": (None, {"loads": ([0], [999], np.zeros((1, 6)))}, "payload 1 (lvj): frame 999 is not in 0.."),
    "lw": (None, {"loads": ([0], [1], np.full((1, 6), NAN))}, "payload 1 (lw): not a finite number"),
    "opost": (None, {"posture": np.array([0, 5])}, "observation 2 (opost): posture 6 is not in 1..2"),
    "omark": (None, {"marker": np.array([0, 3])}, "observation 2 (omark): marker 4 is not in 1..1"),
    "oxyz": (None, {"xyz": np.array([[NAN, 0, 0], [0, 0, 0]])}, "observation 1 (oxyz): not a finite number"),
    "owt": (None, {"weight": np.array([1.0, -1.0])}, "observation 2 (owt): weight -1 is negative"),
    "free": (None, {"free": np.array([0, 0])}, "free parameter 2 (free): parameter 1 (tracker.x) is listed twice"),
    "free-range": (None, {"free": np.array([999])}, "free parameter 1 (free): parameter index 1000 is not in 1.."),
    "etol": (None, {"etol": NAN}, "argument etol: not a finite number"),
}
# routines other than evaluate: (the routine, call options, message)
ROW_CASES = {
    "lm-vaxis": ("lm", "vaxis", "Levenberg-Marquardt (sk_tree_lm): virtual joint 4 (URDF joint 'shoulder'): axis"),
    "frame": ("frame_jacobian", {"frame": np.array([4, 999])}, "(sk_tree_frame_jacobian): row 2 (frame): frame 999"),
    "rtarget": (
        "compensate",
        {"rtarget": np.array([np.eye(3), 2 * np.eye(3)])},
        "(sk_tree_compensate): row 2 (rtarget): the target orientation is not a rotation matrix",
    ),
    "ptarget": ("compensate", {"ptarget": np.array([[0, 0, NAN], [0, 0, 0]])}, "row 1 (ptarget): not a finite number"),
    "prow": ("compensate", {"rows": ([998], np.zeros((2, 1)))}, "per-row parameter 1 (prow): parameter index 999 is"),
    "trow": ("compensate", {"rows": ([2], np.array([[0.0], [NAN]]))}, "row 2 (trow): not a finite number"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_evaluate_names_argument_and_index(model, case):
    mutate, opts, needle = CASES[case]
    opts = dict(opts)
    arrays = mutate(model)(model.copy().arrays) if mutate else None
    if "ne" in opts:
        opts["ne"] = model.ne + opts["ne"]
    if "theta" in opts:
        k, v = opts.pop("theta")
        opts["theta"] = model.theta0.copy()
        opts["theta"][k] = v
    with pytest.raises(stiffkit.InputError) as exc:
        _call(model, "evaluate", arrays, **opts)
    msg = str(exc.value)
    assert msg.startswith("tree evaluation (sk_tree_evaluate): ")
    assert needle in msg, msg


@pytest.mark.parametrize("case", list(ROW_CASES))
def test_other_routines_name_argument_and_index(model, case):
    routine, opts, needle = ROW_CASES[case]
    arrays = None
    if isinstance(opts, str):  # a model mutation of CASES
        arrays = CASES[opts][0](model)(model.copy().arrays)
        opts = {}
    with pytest.raises(stiffkit.InputError) as exc:
        _call(model, routine, arrays, **opts)
    assert needle in str(exc.value), str(exc.value)


def test_every_code_is_mapped_and_tested():
    """The Fortran table (arg_<name> = code) is the Python one, and every code has a test row."""
    text = (ROOT / "core" / "sk_tree_check.f90").read_text()
    fortran = {int(c): n for n, c in re.findall(r"arg_(\w+) = (\d+)", text)}
    assert fortran == {c: n for c, (n, _w) in TREE_ARGUMENTS.items()}
    tested = {k.split("-")[0] for k in CASES} | {k.split("-")[-1] for k in ROW_CASES}
    assert set(fortran.values()) <= tested


def test_the_root_fixed_robot_reaches_the_core_without_error(model):
    """The model itself is valid (no placeholder entry): evaluate runs."""
    out = _call(model, "evaluate", free=np.arange(len(model.params)))
    assert out["jac"].shape == (6, len(model.params))
