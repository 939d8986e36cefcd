"""Robot model: URDF chain, TOML effects, tool compliance (docs/calibration.md §1, §2, §5)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from _calib_util import data, joints_truth, model, spd

import stiffkit
from stiffkit.calib import synth as S
from stiffkit.robot.model import model_from_tables
from stiffkit.robot.urdf import urdf_text


def planar_files(tmp_path, c1=2e-6, c2=5e-6, l1=0.7, l2=0.4):
    joints = [
        dict(name="j1", type="revolute", parent="base_link", child="l1", axis=(0, 0, 1)),
        dict(name="j2", type="revolute", parent="l1", child="l2", xyz=(l1, 0, 0), axis=(0, 0, 1)),
        dict(name="jt", type="fixed", parent="l2", child="tool0", xyz=(l2, 0, 0)),
    ]
    (tmp_path / "arm.urdf").write_text(urdf_text("arm", joints))
    (tmp_path / "arm.toml").write_text(f"""
[robot]
urdf = "arm.urdf"
base_link = "base_link"
tool_frame = "tool0"

[[effect]]
kind = "joint"
target = "j1"
value = {c1!r}

[[effect]]
kind = "joint"
target = "j2"
value = {c2!r}
""")
    return tmp_path / "arm.toml"


def test_planar_two_link_equals_hand_derived(tmp_path):
    c1, c2, l1, l2 = 2e-6, 5e-6, 0.7, 0.4
    m = stiffkit.load_model(planar_files(tmp_path, c1, c2, l1, l2))
    Q = np.array([[0.3, 0.9], [-1.0, 2.0], [2.5, -0.4], [0.0, 0.0]])
    C = m.tool_compliance(Q)
    assert C.shape == (4, 6, 6)
    for q, Ci in zip(Q, C):
        x = l1 * math.cos(q[0]) + l2 * math.cos(q[0] + q[1])
        y = l1 * math.sin(q[0]) + l2 * math.sin(q[0] + q[1])
        x2, y2 = x - l1 * math.cos(q[0]), y - l1 * math.sin(q[0])
        # twist of joint i per unit rotation: (z x (p - p_i), z)
        j1 = np.array([-y, x, 0, 0, 0, 1.0])
        j2 = np.array([-y2, x2, 0, 0, 0, 1.0])
        Ch = c1 * np.outer(j1, j1) + c2 * np.outer(j2, j2)
        np.testing.assert_allclose(Ci, Ch, rtol=0, atol=1e-15)
    C, K, rank, ok = m.stiffness(Q)
    assert list(rank) == [2, 2, 2, 2] and not ok.any()  # two springs: no 6x6 stiffness


def test_kr270_stiffness_positive_definite_and_inverse():
    chain, truth, _ = data(
        joints_truth() + [{"kind": "base", "value": spd(1).tolist()}, {"kind": "tool", "value": spd(2).tolist()}],
        n_configs=2,
    )
    Q = S.random_postures(50, S.KR270_RANGES, np.random.default_rng(0))
    C, K, rank, ok = truth.stiffness(Q)
    assert ok.all() and (rank == 6).all()
    np.testing.assert_allclose(np.einsum("nij,njk->nik", C, K), np.broadcast_to(np.eye(6), C.shape), atol=1e-8)


def test_basis_prediction_matches_tool_compliance():
    """Two code paths of the core: observation basis vs C W moved to the point."""
    truth = S.kr270_truth(compensator=True) + [
        {"kind": "joint_profile", "target": "joint_a3", "value": [0, 1e-7, -5e-8, 3e-8, 2e-8]}
    ]
    chain, tm, meas = data(truth, n_configs=10)
    C = tm.tool_compliance(meas.q)
    tw = np.einsum("nij,nj->ni", C, meas.w)
    R = np.array([chain.forward(q)[0] for q in meas.q])
    v = np.einsum("nij,nj->ni", R, meas.p)
    d = tw[:, :3] + np.cross(tw[:, 3:], v)
    np.testing.assert_allclose(meas.d, d, rtol=1e-10, atol=1e-15)


def test_link_value_from_json_with_rpy(tmp_path):
    Ccad = spd(3)
    (tmp_path / "links").mkdir()
    (tmp_path / "links" / "arm.json").write_text(json.dumps({"compliance": Ccad.tolist()}))
    S.write_synth(tmp_path, S.KR270_JOINTS, joints_truth(), [], n_configs=2)
    base = (tmp_path / "truth.toml").read_text()
    rpy = [0.1, -0.2, 0.3]
    (tmp_path / "a.toml").write_text(
        base + f'\n[[effect]]\nkind = "link"\ntarget = "link_2"\nvalue = "links/arm.json"\nrpy = {rpy}\n'
    )
    from stiffkit.robot.model import rpy_matrix

    R = rpy_matrix(rpy)
    B = np.kron(np.eye(2), R)
    (tmp_path / "b.toml").write_text(
        base + f'\n[[effect]]\nkind = "link"\ntarget = "link_2"\nvalue = {(B @ Ccad @ B.T).tolist()}\n'
    )
    Q = S.random_postures(5, S.KR270_RANGES, np.random.default_rng(1))
    Ca = stiffkit.load_model(tmp_path / "a.toml").tool_compliance(Q)
    Cb = stiffkit.load_model(tmp_path / "b.toml").tool_compliance(Q)
    np.testing.assert_allclose(Ca, Cb, rtol=1e-12, atol=1e-20)
    C0 = stiffkit.load_model(tmp_path / "truth.toml").tool_compliance(Q)
    assert np.abs(Ca - C0).max() > 1e-3 * np.abs(C0).max()  # the link counts


def test_model_without_values_cannot_be_evaluated(tmp_path):
    S.write_synth(tmp_path, S.KR270_JOINTS, joints_truth(), [{"kind": "joint", "target": "all"}], n_configs=2)
    m = stiffkit.load_model(tmp_path / "model.toml")
    with pytest.raises(stiffkit.InputError, match="no value"):
        m.tool_compliance(np.zeros((1, 6)))


def test_spring_jacobians_by_finite_differences():
    """The link spring's Jacobian against a finite deflection of its frame:
    F_k -> F_k T(dt) Rot(dphi), both in the spring frame's own axes."""
    import copy

    from stiffkit.robot.urdf import _rot_axis

    chain, tm, _ = data(joints_truth() + [{"kind": "link", "target": "link_3", "value": spd(5).tolist()}], n_configs=1)
    q = np.array([0.3, -0.7, 0.4, 1.1, 0.9, -0.5])
    k = chain.joint_index("joint_a4")  # link_3's spring: frame of joint_a4
    Jl = tm.jacobians(q)[(2, k + 1)]
    R0, p0 = chain.forward(q)
    h = 1e-7
    for i in range(6):
        e = np.zeros(6)
        e[i] = h
        ch2 = copy.deepcopy(chain)
        Rk = chain.jrot[k]
        ch2.jpos[k] = chain.jpos[k] + Rk @ e[:3]
        if i >= 3:
            ch2.jrot[k] = Rk @ _rot_axis(e[3:] / h, h)
        R1, p1 = ch2.forward(q)
        dR = R1 @ R0.T
        dphi = np.array([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]]) / 2
        fd = np.concatenate([p1 - p0, dphi]) / h
        np.testing.assert_allclose(Jl[:, i], fd, rtol=0, atol=1e-6 * max(1.0, np.abs(Jl).max()))


def test_random_chain_against_finite_difference_reference(tmp_path):
    """A chain with random origins (xyz, rpy), random axes and a tilted tool:
    the core's tool compliance equals sum J C J^T with every Jacobian taken
    by finite differences of the forward kinematics (joints, a link spring,
    base and tool springs)."""
    import copy

    from stiffkit.robot.model import model_from_tables
    from stiffkit.robot.urdf import _rot_axis, load_chain

    rng = np.random.default_rng(42)
    joints, parent = [], "base_link"
    for i in range(5):
        ax = rng.normal(size=3)
        joints.append(
            dict(
                name=f"j{i}",
                type="revolute",
                parent=parent,
                child=f"l{i}",
                xyz=rng.uniform(-0.5, 0.5, 3),
                rpy=rng.uniform(-1, 1, 3),
                axis=ax / np.linalg.norm(ax),
            )
        )
        parent = f"l{i}"
    joints.append(
        dict(name="jt", type="fixed", parent=parent, child="tool0", xyz=(0.1, 0.05, 0.2), rpy=(0.3, -0.4, 0.5))
    )
    (tmp_path / "r.urdf").write_text(urdf_text("r", joints))
    chain = load_chain(tmp_path / "r.urdf")
    cj = rng.uniform(1e-7, 1e-6, 5)
    Cl, Cb, Ct = spd(21), spd(22), spd(23)
    effects = [{"kind": "joint", "target": f"j{i}", "value": float(cj[i])} for i in range(5)]
    effects += [
        {"kind": "link", "target": "l1", "value": Cl.tolist()},
        {"kind": "base", "value": Cb.tolist()},
        {"kind": "tool", "value": Ct.tolist()},
    ]
    m = model_from_tables(chain, effects)
    Q = rng.uniform(-2, 2, (4, 5))
    C = m.tool_compliance(Q)

    def twist(R0, p0, R1, p1, h):
        dR = R1 @ R0.T
        vee = np.array([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]]) / 2
        return np.concatenate([p1 - p0, vee]) / h

    def skew(v):
        return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])

    h = 1e-7
    k = chain.joint_index("j2")  # l1's spring: frame of j2 (its parent is l1)
    for q, Cq in zip(Q, C):
        R0, p0 = chain.forward(q)
        ref = np.zeros((6, 6))
        for j in range(5):  # joint springs: d(pose)/dq_j
            dq = np.zeros(5)
            dq[j] = h
            Rp, pp = chain.forward(q + dq)
            Jj = twist(R0, p0, Rp, pp, h)
            ref += cj[j] * np.outer(Jj, Jj)
        Jl = np.zeros((6, 6))
        for i in range(6):  # link spring: deflect F_k in its own axes
            ch2 = copy.deepcopy(chain)
            e = np.zeros(6)
            e[i] = h
            ch2.jpos[k] = chain.jpos[k] + chain.jrot[k] @ e[:3]
            if i >= 3:
                ch2.jrot[k] = chain.jrot[k] @ _rot_axis(e[3:] / h, h)
            R1, p1 = ch2.forward(q)
            Jl[:, i] = twist(R0, p0, R1, p1, h)
        ref += Jl @ Cl @ Jl.T
        Jb = np.eye(6)
        Jb[:3, 3:] = -skew(p0)  # base: t = dt + dphi x p
        ref += Jb @ Cb @ Jb.T
        Jt = np.kron(np.eye(2), R0)  # tool: deflection in tool axes
        ref += Jt @ Ct @ Jt.T
        np.testing.assert_allclose(Cq, ref, rtol=0, atol=1e-6 * np.abs(ref).max())


def test_tool_compliance_symmetric_psd_and_batched_like_single_calls():
    from _profiles import examples
    from hypothesis import given, settings
    from hypothesis import strategies as st

    chain, tm, _ = data(
        joints_truth()
        + [{"kind": "link", "target": "link_2", "value": spd(7).tolist()}, {"kind": "tool", "value": spd(8).tolist()}],
        n_configs=1,
    )
    angles = st.lists(st.floats(-3.1, 3.1, allow_nan=False), min_size=6, max_size=6)

    @settings(max_examples=examples(30), deadline=None)
    @given(st.lists(angles, min_size=1, max_size=5))
    def check(qs):
        Q = np.array(qs)
        C = tm.tool_compliance(Q)
        for i, q in enumerate(Q):
            Ci = tm.tool_compliance(q[None])[0]
            np.testing.assert_array_equal(C[i], Ci)  # one batched call = N single calls
            np.testing.assert_allclose(Ci, Ci.T, rtol=0, atol=1e-20)
            assert np.linalg.eigvalsh(Ci).min() > -1e-12 * np.abs(Ci).max()

    check()


def test_load_nonlinear_joints_secant_compliance_and_round_trip(tmp_path):
    """joint_cubic / joint_deadzone (contract extensions): the secant tool
    compliance under a row's wrench times that wrench is the row's predicted
    rotation; without a load the dead zone has no compliance (a clear
    error) and the cubic is its tangent at zero load; write-model keeps tau0."""
    from stiffkit.calib.fit import fit, write_model
    from stiffkit.calib.problem import Problem

    nl = [
        {"kind": "joint_cubic", "target": "joint_a2", "value": -2e-15},
        {"kind": "joint_deadzone", "target": "joint_a4", "value": 2e-4, "tau0": 15.0},
    ]
    chain, tm, meas = data(joints_truth() + nl, sigma=0.0, seed=3, n_configs=8)
    pred, _ = Problem(tm, meas).evaluate(np.zeros(0), jac=False)
    C = tm.tool_compliance(meas.q, wrench=meas.w)
    twist = np.einsum("nij,nj->ni", C, meas.w)
    np.testing.assert_allclose(twist[:, 3:], pred[3:].T, rtol=0, atol=1e-12 * np.abs(pred[3:]).max())
    with pytest.raises(stiffkit.InputError, match="dead zone"):
        tm.tool_compliance(meas.q)
    lin = model_from_tables(chain, joints_truth())
    cub = model_from_tables(chain, joints_truth() + nl[:1])
    np.testing.assert_allclose(cub.tool_compliance(meas.q), lin.tool_compliance(meas.q), rtol=1e-14)
    # tau0 chosen from the data (5 % of the RMS torque) and written back
    res = fit(
        model(chain, [{"kind": "joint", "target": "all"}, {"kind": "joint_deadzone", "target": "joint_a4"}]), meas
    )
    tau = chain.joint_torques(meas.q, meas.w)[:, chain.joint_index("joint_a4")]
    tau0 = res.problem.tau0(res.problem.terms[-1])
    assert tau0 == pytest.approx(0.05 * np.sqrt(np.mean(tau**2)), rel=0.05)
    write_model(res, tmp_path / "m.toml")
    text = (tmp_path / "m.toml").read_text()
    assert 'kind = "joint_deadzone"' in text and f"tau0 = {tau0!r}" in text
