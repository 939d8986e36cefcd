"""Compensation (docs/calibration.md 6.5): `stiffkit compensate` and
robot/compensate.py on synthetic robots with a known truth.

The identified model is the truth, so the compensated commands must bring
the true (simulated) robot onto the nominal targets to the Newton
tolerance, far inside the noise floor of a 0.1 mm tracker."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import tomli_w

import stiffkit as sk
from stiffkit._core import tree as core
from stiffkit.cli import main
from stiffkit.errors import InputError, StiffkitWarning
from stiffkit.field.synthetic import rot_exp
from stiffkit.robot.compensate import load_compensation_model, read_targets
from stiffkit.robot.tree_model import load_tree_model
from stiffkit.robot.urdf import urdf_text

SIGMA = 1e-4  # tracker noise per coordinate (m)
FLOOR = math.sqrt(3) * SIGMA

# ---------------------------------------------------------------- robots

#: a torso (yaw, pitch, and a mimic pitch that keeps the chest level), a
#: 5-joint right arm (7 independent joints to right_tcp: redundant, pose)
#: and a 2-joint left arm (4 to left_tcp: position only); masses on every link
TREE = [
    ("torso_1", "revolute", "base_link", "torso_a", "0 0 0.4", "0 0 0", "0 0 1", None),
    ("torso_2", "revolute", "torso_a", "torso_b", "0 0 0.3", "0 0 0", "0 1 0", None),
    ("torso_3", "revolute", "torso_b", "chest", "0 0 0.35", "0 0 0", "0 1 0", ("torso_2", -1.0, 0.0)),
    ("r1", "revolute", "chest", "r_l1", "0 -0.2 0.3", "0.3 0 0", "0 0 1", None),
    ("r2", "revolute", "r_l1", "r_l2", "0 0 0.1", "0 0 0", "0 1 0", None),
    ("r3", "revolute", "r_l2", "r_l3", "0 0 0.3", "0 0 0", "0 0 1", None),
    ("r4", "revolute", "r_l3", "r_l4", "0 0 0.25", "0 0 0", "0 1 0", None),
    ("r5", "revolute", "r_l4", "r_l5", "0 0 0.2", "0 0 0", "0 0 1", None),
    ("r_tool", "fixed", "r_l5", "right_tcp", "0.02 0 0.1", "0.1 0 0", None, None),
    ("l1", "revolute", "chest", "l_l1", "0 0.2 0.3", "0 0 0", "0 1 0", None),
    ("l2", "revolute", "l_l1", "l_l2", "0 0 0.3", "0 0 0", "0 1 0", None),
    ("l_tool", "fixed", "l_l2", "left_tcp", "0 0 0.25", "0 0 0", None, None),
]
MASS = {
    "torso_a": (10.0, "0 0 0.1"),
    "torso_b": (8.0, "0 0 0.15"),
    "chest": (12.0, "0 0 0.1"),
    "r_l1": (3.0, "0 0 0.05"),
    "r_l2": (3.0, "0 0 0.15"),
    "r_l3": (2.0, "0 0 0.1"),
    "r_l4": (1.5, "0 0 0.1"),
    "r_l5": (1.0, "0 0 0.05"),
    "l_l1": (3.0, "0 0 0.15"),
    "l_l2": (2.0, "0 0 0.1"),
}
ACTUATED = ["torso_1", "torso_2", "r1", "r2", "r3", "r4", "r5", "l1", "l2"]


def tree_urdf() -> str:
    links = ["base_link"] + [j[3] for j in TREE]
    out = ['<?xml version="1.0"?>', '<robot name="upper">']
    for ln in links:
        if ln in MASS:
            m, c = MASS[ln]
            out.append(
                f'<link name="{ln}"><inertial><origin xyz="{c}"/><mass value="{m}"/>'
                f'<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>'
            )
        else:
            out.append(f'<link name="{ln}"/>')
    for name, kind, parent, child, xyz, rpy, axis, mimic in TREE:
        body = f'<parent link="{parent}"/><child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/>'
        if kind != "fixed":
            body += f'<axis xyz="{axis}"/><limit lower="-3" upper="3" effort="100" velocity="1"/>'
        if mimic:
            body += f'<mimic joint="{mimic[0]}" multiplier="{mimic[1]}" offset="{mimic[2]}"/>'
        out.append(f'<joint name="{name}" type="{kind}">{body}</joint>')
    out.append("</robot>")
    return "\n".join(out) + "\n"


def truth_effects(rng, shorten: float = 0.0) -> list[dict]:
    """Offsets, frame errors, joint and lateral compliance, a link spring
    (values: the 'identified' model is the truth). ``shorten``: r4's origin
    moves down by that much (m) on top of its frame error."""
    eff = [
        {"kind": "tracker", "xyz": [1.5, -0.3, 0.2], "rpy": [0.0, 0.0, 0.4]},
        {"kind": "marker", "target": "right_tcp", "xyz": [0.01, 0.0, 0.02]},
        {"kind": "marker", "target": "left_tcp", "xyz": [0.0, 0.01, 0.02]},
    ]
    for name in ACTUATED:
        eff.append({"kind": "joint_offset", "target": name, "value": float(rng.normal(0, 5e-3))})
    for name, *_ in TREE:
        v = np.concatenate([rng.normal(0, 5e-4, 3), rng.normal(0, 5e-4, 3)])
        if name == "r4":
            v[2] -= shorten
        eff.append({"kind": "frame", "target": name, "value": v.tolist()})
    eff.append({"kind": "joint", "target": "all", "value": 4e-6})
    eff.append({"kind": "lateral", "target": "all", "value": [1e-6, 1.5e-6]})
    eff.append({"kind": "link", "target": "r_l2", "value": np.diag([1e-8, 1e-8, 2e-9, 3e-7, 3e-7, 1e-7]).tolist()})
    return eff


def write_model(path, effects, absolute=True, tool_frame=None):
    doc = {"robot": {"urdf": "robot.urdf", "base_link": "base_link"}}
    if tool_frame:
        doc["robot"]["tool_frame"] = tool_frame
    if absolute:
        doc["measurements"] = {"kind": "absolute", "sigma_position": SIGMA}
    doc["effect"] = effects
    path.write_text(tomli_w.dumps(doc))
    return path


def write_targets(path, names, Q, frames=None, W=None, extra=True):
    head = (["config"] if extra else []) + list(names)
    if frames is not None:
        head.append("frame")
    if W is not None:
        head += ["fx", "fy", "fz", "mx", "my", "mz"]
    lines = [",".join(head)]
    for i, q in enumerate(Q):
        cells = ([f"p{i}"] if extra else []) + [repr(float(v)) for v in q]
        if frames is not None:
            cells.append(frames[i])
        if W is not None:
            cells += [repr(float(v)) for v in W[i]]
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n")
    return path


def read_commands(path):
    import csv

    with open(path) as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


@pytest.fixture(scope="module")
def upper(tmp_path_factory):
    d = tmp_path_factory.mktemp("upper")
    (d / "robot.urdf").write_text(tree_urdf())
    rng = np.random.default_rng(7)
    truth = write_model(d / "truth.toml", truth_effects(rng))
    nominal = write_model(d / "nominal.toml", truth_effects(rng)[:3])
    return d, truth, nominal


def trajectory(n, rng, centre, amp):
    t = np.linspace(0, 2 * np.pi, n)
    ph = rng.uniform(0, 2 * np.pi, len(centre))
    return np.asarray(centre) + np.asarray(amp) * np.sin(t[:, None] * (1 + np.arange(len(centre))) / 3 + ph)


def simulate(model_path, frames, Q, W=None):
    """Frame poses (R, p) of the model (with its values) at Q, at equilibrium
    under gravity and the payload W at each row's frame."""
    m = load_tree_model(model_path)
    vj = np.array([m.vj_of_link[f] for f in frames], np.int32)
    loads = None if W is None else (np.arange(len(Q)), vj, W)
    P = core.frame_jacobian(m.packed, m.theta0, vj, Q, loads, m.eqit, 1e-13)
    return P["R"], P["p"], P["J"]


def rot_angle(Ra, Rb):
    """Angles of Ra Rb^T, accurate when small (from the skew part)."""
    D = np.einsum("nij,nkj->nik", Ra, Rb)
    v = 0.5 * np.stack([D[:, 2, 1] - D[:, 1, 2], D[:, 0, 2] - D[:, 2, 0], D[:, 1, 0] - D[:, 0, 1]], axis=1)
    c = 0.5 * (np.trace(D, axis1=1, axis2=2) - 1)
    return np.arctan2(np.linalg.norm(v, axis=1), c)


CENTRE = [0.1, 0.2, 0.3, 0.6, 0.2, 0.9, 0.3, 0.4, 0.7]
AMP = [0.3, 0.15, 0.4, 0.3, 0.4, 0.3, 0.4, 0.3, 0.3]


# ---------------------------------------------------------------- absolute models


def test_absolute_tree_reaches_nominal_targets(upper, tmp_path):
    """Held-out trajectory on both arms (one row in three with a payload):
    the true robot at q' is where the nominal one is at q, to ~1e-9 m
    (the Newton residual), far inside the noise floor; without
    compensation it is millimetres off."""
    d, truth, nominal = upper
    rng = np.random.default_rng(11)
    n = 60
    Q = trajectory(n, rng, CENTRE, AMP)
    frames = ["right_tcp" if i % 2 == 0 else "left_tcp" for i in range(n)]
    W = np.zeros((n, 6))
    W[::3] = rng.normal(0, [20, 20, 20, 2, 2, 2], (len(W[::3]), 6))
    targets = write_targets(tmp_path / "targets.csv", ACTUATED, Q, frames, W)
    out = tmp_path / "commands.csv"
    with warnings.catch_warnings():
        warnings.simplefilter("error", StiffkitWarning)
        rep = sk.compensate(truth, targets, out)
    res = rep.result
    assert res.converged.all()
    assert res.resp.max() < 1e-9
    head, rows = read_commands(out)
    assert head == ["config", *ACTUATED, "frame", "fx", "fy", "fz", "mx", "my", "mz", *ADDED]
    Qc = np.array([[float(r[1 + k]) for k in range(len(ACTUATED))] for r in rows])
    np.testing.assert_array_equal(Qc, res.q)  # written to the last bit
    assert [r[0] for r in rows] == [f"p{i}" for i in range(n)] and [r[10] for r in rows] == frames
    # the true robot at q' against the nominal at q
    Rn, pn, _ = simulate(nominal, frames, Q)
    Rt, pt, _ = simulate(truth, frames, Qc, W)
    err = np.linalg.norm(pt - pn, axis=1)
    _, p0, _ = simulate(truth, frames, Q, W)
    before = np.linalg.norm(p0 - pn, axis=1)
    assert before.min() > 10 * FLOOR  # the errors compensated are real (mm)
    assert err.max() < 1e-9 < 2 * FLOOR
    right = np.array([f == "right_tcp" for f in frames])
    assert rot_angle(Rt[right], Rn[right]).max() < 1e-8
    # modes: 7 independent joints to right_tcp (the mimic does not count), 4 to left_tcp
    assert all(r[-1] == ("pose" if f == "right_tcp" else "position") for r, f in zip(rows, frames))
    assert rep.cm.independent("right_tcp") == 7 and rep.cm.independent("left_tcp") == 4
    # position only: the orientation is left as it is (not compensated)
    assert res.resr[~right].max() > 1e-4


def test_redundant_chain_least_norm(upper):
    """7 independent joints for a 6-dof task: q' - q has no component in
    the null space of the task Jacobian at q' (total, through the
    equilibrium: the left arm's weight bends the torso, so its joints have
    small columns too)."""
    d, truth, _ = upper
    cm = load_compensation_model(truth)
    rng = np.random.default_rng(3)
    Q = trajectory(12, rng, CENTRE, AMP)
    res = cm.compensate(Q, "right_tcp")
    assert res.converged.all() and res.full6.all()
    _, _, J = simulate(truth, ["right_tcp"] * len(Q), res.q)
    for Jk, qk, q0 in zip(J, res.q, Q):
        dq = qk - q0
        _, s, vt = np.linalg.svd(Jk)
        null = vt[int(np.sum(s > 1e-10 * s[0])) :]
        assert null.shape[0] == 3  # 9 columns, rank 6
        assert np.linalg.norm(null @ dq) < 1e-6 * np.linalg.norm(dq)
        assert np.linalg.norm(dq) > 1e-3
        # the left arm moves right_tcp through the torso's deflection only
        assert np.abs(dq[7:]).max() < 1e-3 * np.abs(dq).max()


def test_position_only_four_joint_chain(upper):
    d, truth, nominal = upper
    cm = load_compensation_model(truth)
    assert not cm.full6("left_tcp")
    rng = np.random.default_rng(4)
    Q = trajectory(10, rng, CENTRE, AMP)
    res = cm.compensate(Q, "left_tcp")
    assert res.converged.all() and not res.full6.any()
    _, pn, _ = simulate(nominal, ["left_tcp"] * 10, Q)
    _, pt, _ = simulate(truth, ["left_tcp"] * 10, res.q)
    assert np.linalg.norm(pt - pn, axis=1).max() < 1e-9


def test_unreachable_target_is_flagged(upper, tmp_path, capsys):
    """r4's link 3 mm shorter: the stretched arm cannot reach the nominal
    target. The row is flagged (converged 0, the residual left, a warning
    line naming it), the reachable rows are compensated."""
    d, _, _ = upper
    short = write_model(d / "short.toml", truth_effects(np.random.default_rng(7), shorten=3e-3))
    Q = np.array([CENTRE, [0.1, 0.0, 0.3, 0.0, 0.2, 0.0, 0.3, 0.4, 0.7]])  # row 2: right arm straight up
    targets = write_targets(tmp_path / "t.csv", ACTUATED, Q, ["right_tcp", "right_tcp"])
    out = tmp_path / "c.csv"
    assert main(["compensate", str(short), str(targets), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    warn = [ln for ln in err.splitlines() if ": warning: " in ln]
    assert len(warn) == 1 and "1 of 2 row(s) did not converge (line(s) 3)" in warn[0], err
    head, rows = read_commands(out)
    conv = [r[head.index("converged")] for r in rows]
    resid = [float(r[head.index("residual_position_m")]) for r in rows]
    assert conv == ["1", "0"]
    assert resid[0] < 1e-9 and resid[1] > 1e-4


# ---------------------------------------------------------------- relative models

#: a 6R arm (KR-like) with a tool frame; the relative model's effects
CHAIN = [
    dict(name="a1", type="revolute", parent="base_link", child="link_1", xyz=(0, 0, 0.675), axis=(0, 0, 1)),
    dict(name="a2", type="revolute", parent="link_1", child="link_2", xyz=(0.35, 0, 0), axis=(0, 1, 0)),
    dict(name="a3", type="revolute", parent="link_2", child="link_3", xyz=(1.15, 0, 0), axis=(0, 1, 0)),
    dict(name="a4", type="revolute", parent="link_3", child="link_4", xyz=(1.0, 0, -0.041), axis=(1, 0, 0)),
    dict(name="a5", type="revolute", parent="link_4", child="link_5", xyz=(0.2, 0, 0), axis=(0, 1, 0)),
    dict(name="a6", type="revolute", parent="link_5", child="link_6", xyz=(0.1, 0, 0), axis=(1, 0, 0)),
    dict(name="t", type="fixed", parent="link_6", child="tool0", xyz=(0.1, 0.02, 0.05), rpy=(0, 0.3, 0)),
]


def spd(rng, scale):
    a = rng.normal(size=(6, 6))
    return (scale * (a @ a.T / 6 + np.eye(6))).tolist()


def relative_effects(rng):
    return [
        {"kind": "joint", "target": "all", "value": 3e-7},
        {"kind": "joint_profile", "target": "a3", "value": [2e-7, 5e-8, -3e-8, 2e-8, 1e-8]},
        {"kind": "gravity_compensator", "target": "a2", "a": 0.3, "b": 0.5, "beta": 0.2, "s0": 0.4, "k_s": 2e5},
        {"kind": "joint_cubic", "target": "a5", "value": 2e-11},
        {"kind": "joint_deadzone", "target": "a4", "value": 1e-4, "tau0": 5.0},
        {"kind": "link", "target": "link_2", "value": spd(rng, 1e-8)},
        {"kind": "base", "value": spd(rng, 2e-9)},
        {"kind": "tool", "value": spd(rng, 5e-9)},
        {"kind": "point_offset", "r": [0.0, 0.0, 0.1]},
    ]


@pytest.fixture(scope="module")
def arm6(tmp_path_factory):
    d = tmp_path_factory.mktemp("arm6")
    (d / "robot.urdf").write_text(urdf_text("arm6", CHAIN))
    rng = np.random.default_rng(2)
    path = write_model(d / "model.toml", relative_effects(rng), absolute=False, tool_frame="tool0")
    return d, path


def linear_pose(model, Q, W):
    """Section 3's model: the tool frame moved by its twist sum J C J^T W
    (the secant compliance under W, so load-nonlinear joints count)."""
    P = model.chain.poses(Q)
    C = model.tool_compliance(Q, wrench=W)
    tw = np.einsum("nij,nj->ni", C, W)
    R = np.array([rot_exp(t[3:]) @ r for t, r in zip(tw, P["rt"])])
    return R, P["pt"] + tw[:, :3], tw


def test_relative_model_compensated_against_its_wrench(arm6, tmp_path):
    """Every relative effect at once (joint, joint_profile, compensator,
    cubic, dead zone, link, base and tool springs): q' puts the loaded
    tool where the unloaded nominal one is at q, checked against section
    3's own (linear) model: the difference is second order in the
    deflection (x 100 smaller for a load 10 x smaller), the compensated
    error itself was first order."""
    d, path = arm6
    model = sk.load_model(path)
    rng = np.random.default_rng(5)
    n = 30
    Q = trajectory(n, rng, [0.2, -0.6, 0.4, 0.3, 0.8, -0.2], [0.5, 0.3, 0.3, 0.5, 0.4, 0.5])
    W0 = np.column_stack([rng.normal(0, 800, (n, 3)), rng.normal(0, 100, (n, 3))])
    cm = load_compensation_model(path)
    assert cm.kind == "relative" and cm.varying and cm.full6("tool0")
    P0 = model.chain.poses(Q)
    gaps = []
    for scale in (1.0, 0.1):
        W = scale * W0
        targets = write_targets(tmp_path / f"t{scale}.csv", [f"q{k}" for k in range(1, 7)], Q, W=W)
        rep = sk.compensate(path, targets, tmp_path / f"c{scale}.csv")
        res = rep.result
        assert res.converged.all() and res.resp.max() < 1e-9 and res.resr.max() < 1e-9
        R, p, tw = linear_pose(model, res.q, W)
        _, p_unc, _ = linear_pose(model, Q, W)
        gap = np.linalg.norm(p - P0["pt"], axis=1).max()
        assert np.median(np.linalg.norm(p_unc - P0["pt"], axis=1)) > 100 * gap
        assert rot_angle(R, P0["rt"]).max() < 1e-6 * scale
        gaps.append((gap, np.abs(tw).max()))
    (g1, d1), (g2, d2) = gaps
    assert g1 < 10 * d1**2 and g2 < g1 / 50  # second order in the deflection
    # posture-dependent compliances were evaluated at q', not at q
    assert np.abs(res.q - Q).max() > 1e-4


def test_relative_rigid_and_unloaded_rows_stay(arm6):
    d, path = arm6
    cm = load_compensation_model(path)
    Q = np.array([[0.2, -0.6, 0.4, 0.3, 0.8, -0.2]])
    res = cm.compensate(Q, None, np.zeros((1, 6)))
    assert res.converged.all() and np.abs(res.q - Q).max() < 1e-12


# ---------------------------------------------------------------- inputs


def test_inputs_are_checked(upper, arm6, tmp_path):
    d, truth, _ = upper
    cm = load_compensation_model(truth)
    Q = np.array([CENTRE])
    bad = tmp_path / "b.csv"
    write_targets(bad, ACTUATED[:-1], Q[:, :-1], ["right_tcp"])
    with pytest.raises(InputError, match="missing joint column"):
        read_targets(bad, cm)
    write_targets(bad, ACTUATED, Q, ["nowhere"])
    with pytest.raises(InputError, match=r"line 2: unknown frame 'nowhere'"):
        read_targets(bad, cm)
    bad.write_text(",".join(ACTUATED) + ",frame\n" + ",".join(["0.1"] * 8 + ["nan"]) + ",right_tcp\n")
    with pytest.raises(InputError, match="l2.*must be finite"):
        read_targets(bad, cm)
    bad.write_text(",".join(ACTUATED) + ",frame,fx\n" + ",".join(["0.1"] * 9) + ",right_tcp,5\n")
    with pytest.raises(InputError, match="payload columns must be all of"):
        read_targets(bad, cm)
    # the mimic joint is not a column; the tree has two frames: rows must name theirs
    bad.write_text(",".join(ACTUATED) + ",torso_3\n" + ",".join(["0.1"] * 10) + "\n")
    with pytest.raises(InputError, match="mimic joint"):
        read_targets(bad, cm)
    write_targets(bad, ACTUATED, Q)
    with pytest.raises(InputError, match="no 'frame' column"):
        read_targets(bad, cm)
    assert read_targets(bad, cm, frame="left_tcp").frames == ["left_tcp"]
    # degrees: accepted with a warning naming the fix
    write_targets(bad, ACTUATED, np.degrees(Q), ["right_tcp"])
    with pytest.warns(sk.PlausibilityWarning, match="deg"):
        read_targets(bad, cm)
    # a model without values
    eff = truth_effects(np.random.default_rng(1))
    eff[-2] = {"kind": "lateral", "target": "all"}
    with pytest.raises(InputError, match=r"\(lateral, target 'all'\) has no value"):
        load_compensation_model(write_model(d / "novalue.toml", eff))
    d6, path6 = arm6
    text = path6.read_text().replace("value = 2e-11\n", "")
    (d6 / "novalue.toml").write_text(text)
    with pytest.raises(InputError, match="joint_cubic on 'a5'.*has no value"):
        load_compensation_model(d6 / "novalue.toml")


ADDED = ["residual_position_m", "residual_rotation_rad", "converged", "mode"]


def test_row_parameters_must_be_law_parameters(upper):
    """The core takes per-row values of law parameters only: a geometric
    one (folded into the model at theta) is refused, a law one is used."""
    d, truth, _ = upper
    cm = load_compensation_model(truth)
    m = cm.model
    Q = np.array([CENTRE])
    P = core.frame_jacobian(
        core.pack(0, cm.nominal.arrays), cm.nominal.theta0, [cm.nominal.vj_of_link["left_tcp"]], Q, None, 0, 1e-11
    )
    args = (m.packed, cm.theta, [m.vj_of_link["left_tcp"]], Q, P["R"], P["p"], None, False, m.eqit, 1e-11)
    with pytest.raises(InputError, match="out of range"):
        core.compensate(*args, row_params=([m.index("r4.dz")], [[0.0]]))
    c = m.index("l2.c")
    same = core.compensate(*args, row_params=([c], [[cm.theta[c]]]))
    base = core.compensate(*args)
    np.testing.assert_array_equal(same["q"], base["q"])
    stiff = core.compensate(*args, row_params=([c], [[10 * cm.theta[c]]]))
    assert np.abs(stiff["q"] - base["q"]).max() > 1e-6
