"""One serial-chain implementation: the URDF chain (its tree model,
sk_chain_tree, Model.tool_compliance) and the generalised-spring serial array (sk_springs,
serial_vjm / model_vjm) agree on the same 6R robot.

Numbers checked: on the KR-270-like robot with 6 joint + 7 link springs
(random symmetric positive definite link compliances, all 21 entries
non-zero) the two core paths give the same tool compliance to 1e-12
relative and the same stiffness to 1e-9; both equal an independent numpy
evaluation of klimchik eq. 2 (URDF forward kinematics written out here,
J from cross products); the core's forward kinematics (Chain.poses) equals
the Python one; at a wrist singularity both report rank 5 and the springs
path's rigid wrench is the null vector of the compliance; base and tool
springs (tilted tool frame) agree too.
"""

from __future__ import annotations

import numpy as np
import pytest
from _calib_util import spd

from stiffkit.calib import synth as S
from stiffkit.errors import InputError
from stiffkit.robot.model import model_from_tables
from stiffkit.robot.urdf import load_chain
from stiffkit.springs import Joint, Spring, evaluate, model_tree, model_vjm, serial_vjm, series

URDF = "examples/kr270/robot.urdf"


def relerr(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


@pytest.fixture(scope="module")
def robot():
    from pathlib import Path

    chain = load_chain(Path(__file__).resolve().parent.parent / URDF)
    eff = [{"kind": "joint", "target": j["name"], "value": c} for j, c in zip(S.KR270_JOINTS, S.KR270_JOINT_C)]
    for i, link in enumerate(chain.links[:-1]):  # base_link, link_1 .. link_6: 7 link springs
        eff.append({"kind": "link", "target": link, "value": spd(100 + i).tolist()})
    return chain, model_from_tables(chain, eff)


def rot(axis, a):
    axis = np.asarray(axis, float)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def numpy_frames(chain, q):
    """URDF forward kinematics written out: frames F_k and the tool frame."""
    R, p, F = np.eye(3), np.zeros(3), []
    for k in range(len(chain.joint_names)):
        p = p + R @ chain.jpos[k]
        R = R @ chain.jrot[k]
        F.append((R.copy(), p.copy()))
        if chain.qidx[k] > 0:
            R = R @ rot(chain.jaxis[k], q[chain.qidx[k] - 1])
    return F, (R @ chain.trot, p + R @ chain.tpos)


def numpy_eq2(chain, model, q):
    F, (Rt, pt) = numpy_frames(chain, q)
    C = np.zeros((6, 6))
    for k, c in model.joint_compliances(q[None]).items():
        u = F[k][0] @ chain.jaxis[k]
        xi = np.r_[np.cross(u, pt - F[k][1]), u]
        C += c[0] * np.outer(xi, xi)
    for (_stype, k), Cs in model.six_values().items():
        R, p = F[k - 1]
        T = np.eye(6)
        r = pt - p
        T[:3, 3:] = -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        B = np.zeros((6, 6))
        B[:3, :3] = B[3:, 3:] = R
        J = T @ B
        C += J @ Cs @ J.T
    return C


def test_core_poses_equal_python_forward_kinematics(robot):
    chain, _ = robot
    Q = S.random_postures(20, S.KR270_RANGES, np.random.default_rng(1))
    P = chain.poses(Q)
    for i, q in enumerate(Q):
        F, (Rt, pt) = numpy_frames(chain, q)
        assert np.abs(P["rt"][i] - Rt).max() < 1e-14 and np.abs(P["pt"][i] - pt).max() < 1e-14
        for k, (R, p) in enumerate(F):
            assert np.abs(P["rf"][i, k] - R).max() < 1e-14 and np.abs(P["pf"][i, k] - p).max() < 1e-14


def test_chain_and_spring_tree_agree_on_the_6r(robot):
    chain, model = robot
    assert len(model.springs()) == 13  # 6 joint + 7 link springs
    Q = S.random_postures(200, S.KR270_RANGES, np.random.default_rng(2))
    C, K, rank, ok = model.stiffness(Q)
    res = model_vjm(model, Q)
    assert ok.all() and np.all(res.rank == 6) and np.all(res.stiffness_exists)
    for i in range(len(Q)):
        assert relerr(res.compliance[i], C[i]) < 1e-12
        assert relerr(res.stiffness[i], K[i]) < 1e-9
    for i in range(0, len(Q), 20):
        assert relerr(C[i], numpy_eq2(chain, model, Q[i])) < 1e-12
    # serial_vjm with explicit poses (the same robot, poses from Chain.poses)
    P = chain.poses(Q)
    k6 = [k for k in range(len(chain.joint_names)) if chain.qidx[k] > 0]
    axes = np.einsum("nkab,kb->nka", P["rf"][:, k6], chain.jaxis[k6])
    six = model.six_values()
    idx = [k - 1 for (_, k) in six]
    res2 = serial_vjm(
        axes,
        P["pf"][:, k6],
        S.KR270_JOINT_C,
        np.array(list(six.values())),
        P["pf"][:, idx],
        P["rf"][:, idx],
        P["pt"],
        lscale=chain.characteristic_length,
    )
    assert relerr(res2.compliance, C) < 1e-12


def test_wrist_singularity_rank_and_rigid_wrench(robot):
    chain, _ = robot
    joints = model_from_tables(
        chain, [{"kind": "joint", "target": j["name"], "value": c} for j, c in zip(S.KR270_JOINTS, S.KR270_JOINT_C)]
    )
    Q = np.array([[0.3, -0.6, 0.4, 0.5, 0.0, 0.2], [0.3, -0.6, 0.4, 0.5, 0.8, 0.2]])
    C, K, rank, ok = joints.stiffness(Q)
    res = model_vjm(joints, Q)
    assert list(rank) == [5, 6] and list(ok) == [False, True]
    assert list(res.nrigid) == [1, 0] and list(res.nfree) == [0, 0]
    w = res.rigid_wrenches(0)[:, 0]
    assert np.linalg.norm(C[0] @ w) < 1e-12 * np.linalg.norm(C[0])
    assert relerr(res.compliance[0], C[0]) < 1e-12
    assert relerr(res.stiffness[1], K[1]) < 1e-9


def test_posture_dependent_joint_compliance_is_refused(robot):
    chain, _ = robot
    m = model_from_tables(
        chain, [{"kind": "joint_profile", "target": "joint_a2", "value": [2e-7, 5e-8, 0.0, 0.0, 0.0]}]
    )
    with pytest.raises(InputError, match="depends on the posture"):
        model_tree(m, [[0, -0.5, 0.3, 0, 1.2, 0], [0, 0.1, 0.3, 0, 1.2, 0]])


def test_spring_tree_leaves_reuse_the_chain_terms():
    """A joint leaf and a 6x6 leaf through sk_springs equal the sk_spatial
    terms (revolute twist, rotated and transferred spring)."""
    rng = np.random.default_rng(4)
    c6 = spd(7)
    R = rot([0.3, -0.2, 0.9] / np.linalg.norm([0.3, -0.2, 0.9]), 0.8)
    p, tool, u = rng.normal(size=3), rng.normal(size=3), np.array([0.0, 0.6, 0.8])
    res = evaluate(series(Joint("revolute", u, p, compliance=3e-6), Spring(c6, pos=p, rot=R)), tool=tool)
    xi = np.r_[np.cross(u, tool - p), u]
    T = np.eye(6)
    r = tool - p
    T[:3, 3:] = -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    B = np.zeros((6, 6))
    B[:3, :3] = B[3:, 3:] = R
    assert relerr(res.compliance[0], 3e-6 * np.outer(xi, xi) + T @ B @ c6 @ B.T @ T.T) < 1e-13


def test_base_and_tool_springs_agree(robot):
    """The base spring (base origin, base axes) and the tool spring (tool
    frame) through both paths, with a tilted tool frame (rpy in the URDF)."""
    chain, model = robot
    eff = list(model.effects) + [
        {"kind": "base", "value": spd(201).tolist()},
        {"kind": "tool", "value": spd(202).tolist()},
    ]
    m = model_from_tables(chain, eff)
    Q = S.random_postures(50, S.KR270_RANGES, np.random.default_rng(6))
    C = m.tool_compliance(Q)
    res = model_vjm(m, Q)
    assert relerr(res.compliance, C) < 1e-12
    for i in range(0, 50, 10):
        ref = numpy_eq2(chain, model, Q[i])
        F, (Rt, pt) = numpy_frames(chain, Q[i])
        T = np.eye(6)
        T[:3, 3:] = -np.array([[0, -pt[2], pt[1]], [pt[2], 0, -pt[0]], [-pt[1], pt[0], 0]])
        B = np.zeros((6, 6))
        B[:3, :3] = B[3:, 3:] = Rt
        ref = ref + T @ spd(201) @ T.T + B @ spd(202) @ B.T
        assert relerr(C[i], ref) < 1e-12
