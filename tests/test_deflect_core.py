"""The core's deflection rows (core/sk_deflect.f90): the analytic Jacobian
of every term kind (joint, profile, compensator chain rule, cubic, dead
zone, 6-dof springs of each template, point offset) against central finite
differences, and the joint laws against their closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from _deflection_cases import _data, _joints, _theta_probe

from stiffkit._core import calib as core
from stiffkit.calib import synth as S
from stiffkit.calib.problem import Problem
from stiffkit.robot.model import model_from_tables

EFFECTS = [
    {"kind": "joint", "target": "all"},
    {"kind": "joint_profile", "target": "joint_a1"},
    {
        "kind": "gravity_compensator",
        "target": "joint_a2",
        **{k: S.KR270_COMPENSATOR[k] for k in ("a", "b", "beta", "s0")},
    },
    {"kind": "joint_cubic", "target": "joint_a3"},
    {"kind": "joint_deadzone", "target": "joint_a4", "tau0": 20.0},
    {"kind": "joint_deadzone", "target": "joint_a5"},
    {"kind": "joint_cubic", "target": "joint_a5"},
    {"kind": "link", "target": "link_2", "template": "full"},
    {"kind": "link", "target": "link_3", "template": "beam"},
    {"kind": "tool", "template": "diagonal"},
    {"kind": "base", "template": "beam"},
    {"kind": "point_offset"},
]


@pytest.fixture(scope="module")
def problem():
    chain, _tm, meas = _data(_joints(), seed=21, sigma_rotation=1e-6)
    return Problem(model_from_tables(chain, EFFECTS), meas)


def test_jacobian_of_every_kind_by_finite_differences(problem):
    pb = problem
    th = _theta_probe(pb, 5)
    _, J = pb.evaluate(th)
    for k, name in enumerate(pb.names):
        h = 1e-3 * abs(th[k])
        tp, tm = th.copy(), th.copy()
        tp[k] += h
        tm[k] -= h
        fd = (pb.evaluate(tp, jac=False)[0] - pb.evaluate(tm, jac=False)[0]) / (2 * h)
        scale = np.abs(J[:, :, k]).max()
        assert scale > 0, name
        np.testing.assert_allclose(J[:, :, k], fd, rtol=0, atol=1e-6 * scale, err_msg=name)


def test_joint_laws_closed_forms(problem):
    """One joint at a time: its row is J_s delta(tau) with the tree's laws:
    c_eff tau, c_eff = c / (1 + c k_s h(q)); c3 tau^3; b tanh(tau / tau0)."""
    pb = problem
    ch = pb.model.chain
    tw = pb.joint_twists()  # (6, n, nj) per unit joint rotation
    tau = pb.torques
    names = pb.names
    th = np.zeros(pb.npar)

    def only(vals):
        t = th.copy()
        for n, v in vals.items():
            t[names.index(n)] = v
        return pb.evaluate(t, jac=False)[0]

    k2 = ch.joint_index("joint_a2")
    q2 = pb.meas.q[:, int(ch.qidx[k2]) - 1]
    g = {k: S.KR270_COMPENSATOR[k] for k in ("a", "b", "beta", "s0")}
    h = core.compensator_h(q2, g)
    c, ks = 2e-7, 4e7
    want = tw[:, :, k2] * (tau[:, k2] * c / (1 + c * ks * h))
    np.testing.assert_allclose(only({"joint_a2.c": c, "joint_a2.k_s": ks}), want, rtol=1e-12, atol=1e-20)
    k3 = ch.joint_index("joint_a3")
    np.testing.assert_allclose(
        only({"joint_a3.cubic": -1e-15}), tw[:, :, k3] * (-1e-15 * tau[:, k3] ** 3), rtol=1e-12, atol=1e-20
    )
    k4 = ch.joint_index("joint_a4")
    np.testing.assert_allclose(
        only({"joint_a4.backlash": 1e-4}), tw[:, :, k4] * (1e-4 * np.tanh(tau[:, k4] / 20.0)), rtol=1e-12, atol=1e-20
    )
    # the compensator's h against its definition d2V/dq2 / k_s by differences
    s = lambda q: np.sqrt(g["a"] ** 2 + g["b"] ** 2 - 2 * g["a"] * g["b"] * np.cos(q + g["beta"]))  # noqa: E731
    V = lambda q: 0.5 * (s(q) - g["s0"]) ** 2  # noqa: E731
    e = 1e-4
    np.testing.assert_allclose(h, (V(q2 + e) - 2 * V(q2) + V(q2 - e)) / e**2, rtol=1e-6, atol=1e-9)
