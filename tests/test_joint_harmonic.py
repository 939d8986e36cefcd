"""The kind joint_harmonic (robot/catalogue.py; core law law_harmonic): a
joint compliance that depends on the joint angle, c(q) = c + c1 cos q +
s1 sin q (cogging, gear eccentricity), on both data kinds: its law against
closed forms, its analytic Jacobians (parameters and joint angles) against
central differences, and the diagnosis finding it on synthetic data that
has it, with the error falling when its proposal is appended."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stiffkit._core import tree as core
from stiffkit.calib.absolute_data import write_absolute
from stiffkit.calib.absolute_diagnose import diagnose_absolute
from stiffkit.calib.absolute_fit import fit_absolute, predict
from stiffkit.calib.absolute_report import load_absolute
from stiffkit.calib.diagnose import diagnose, effect_toml
from stiffkit.calib.dualarm import GRAVITY, dualarm_truth, synth_dualarm
from stiffkit.calib.fit import fit
from stiffkit.calib.problem import Problem
from stiffkit.calib.scenarios import _truth, base_effects
from stiffkit.calib.synth import KR270_JOINTS, KR270_RANGES, synthesize
from stiffkit.errors import InputError
from stiffkit.robot.model import model_from_tables
from stiffkit.robot.tree import load_tree
from stiffkit.robot.tree_model import tree_model_from_tables

C1, S1 = 0.8, -0.5  # the harmonics, as fractions of the joint's c (c(q) > 0 at every q)


@pytest.fixture(scope="module")
def dualarm(tmp_path_factory):
    out = synth_dualarm(tmp_path_factory.mktemp("harmonic"), configs=150, seed=5)
    urdf = out / "robot.urdf"
    return out, load_tree(urdf), dualarm_truth(urdf)


def _with_harmonic(tree, truth, joints=("left_2",)):
    base = tree_model_from_tables(tree, truth, GRAVITY)
    extra = []
    for j in joints:
        c = base.theta0[base.index(f"{j}.c")]
        extra.append({"kind": "joint_harmonic", "target": j, "value": [C1 * c, S1 * c]})
    return tree_model_from_tables(tree, truth + extra, GRAVITY), extra


def test_tree_law_is_the_closed_form(dualarm):
    """First order (iterations = 1): the deflection is c(v) w with w the
    generalised force at zero deflection and v = q + dq0, so the harmonic
    model's deflection is the linear one's times (c + c1 cos v + s1 sin v) / c."""
    out, tree, truth = dualarm
    _model, data = load_absolute(out / "model.toml", out / "measurements.csv")
    lin = tree_model_from_tables(tree, truth, GRAVITY, iterations=1)
    har = tree_model_from_tables(tree, truth + _with_harmonic(tree, truth)[1], GRAVITY, iterations=1)
    blocks = [b for b in range(len(har.blocks)) if har.blocks[b] == ("joint", "left_2")]
    assert len(blocks) == 1 and har.arrays["ktype"][blocks[0]] == 5
    # the block's elastic coordinate: blocks before it have 1 or 6 each
    e = sum(6 if t == 4 else 1 for t in har.arrays["ktype"][: blocks[0]])
    dl = predict(lin, data, lin.theta0)["delta"][:, e]
    dh = predict(har, data, har.theta0)["delta"][:, e]
    q = data.Q[:, data.joints.index("left_2")] + lin.theta0[lin.index("left_2.dq0")]
    ratio = 1.0 + C1 * np.cos(q) + S1 * np.sin(q)
    assert np.max(np.abs(dl)) > 1e-4
    np.testing.assert_allclose(dh, dl * ratio, rtol=1e-12, atol=1e-18)


def test_tree_jacobian_matches_central_differences(dualarm):
    """The parameter Jacobian (c, c1, s1, the joint offsets that move v) and
    the joint-angle Jacobian of a frame at the full equilibrium, against
    central differences; the harmonics large (2x the paper's) so that their
    terms matter."""
    out, tree, truth = dualarm
    _model, data = load_absolute(out / "model.toml", out / "measurements.csv")
    m, _ = _with_harmonic(tree, truth, ("left_2", "right_4"))
    theta = m.theta0.copy()
    for j in ("left_2", "right_4"):
        theta[m.index(f"{j}.c")] *= 30.0  # deflections of cm: the laws' nonlinear terms show
        theta[m.index(f"{j}.cos1")] *= 30.0
        theta[m.index(f"{j}.sin1")] *= 30.0
    names = [f"{j}.{s}" for j in ("left_2", "right_4") for s in ("c", "cos1", "sin1", "dq0")]
    free = np.array([m.index(n) for n in names])
    sub = data.subset(np.arange(12))
    ev = predict(m, sub, theta, free)
    worst = 0.0
    for k, i in enumerate(free):
        h = 1e-6 if names[k].endswith("dq0") else 1e-4 * abs(theta[i])
        tp, tm = theta.copy(), theta.copy()
        tp[i] += h
        tm[i] -= h
        fd = (predict(m, sub, tp)["res"] - predict(m, sub, tm)["res"]) / (2 * h)
        err = np.linalg.norm(fd - ev["jac"][:, k]) / np.linalg.norm(fd)
        worst = max(worst, err)
        assert err < 1e-6, (names[k], err)
    print(f"joint_harmonic parameter Jacobian vs central differences: max relative error {worst:.2e}")
    # joint angles: the frame Jacobian through the equilibrium (the law's d/dv included)
    frame = np.array([m.vj_of_link["left_tcp"]] * 4, np.int32)
    Q = data.Q[:4]
    etol = 1e-14  # the equilibrium far below the differences' step

    def pose(Qx):
        return core.frame_jacobian(m.packed, theta, frame, Qx, None, m.eqit, etol)

    fj = pose(Q)
    big = np.linalg.norm(fj["J"][:, 0:3, :])
    worst = 0.0
    for k in range(Q.shape[1]):
        h = 1e-5
        Qp, Qm = Q.copy(), Q.copy()
        Qp[:, k] += h
        Qm[:, k] -= h
        fd = (pose(Qp)["p"] - pose(Qm)["p"]) / (2 * h)
        an = fj["J"][:, 0:3, k]
        err = np.linalg.norm(fd - an) / big
        assert err < 1e-7, (data.joints[k], err)
        if data.joints[k] == "left_2":  # the harmonic joint's own column, relative to itself
            worst = np.linalg.norm(fd - an) / np.linalg.norm(fd)
            assert worst < 1e-7
    print(f"joint_harmonic joint-angle Jacobian (column of left_2) vs central differences: relative error {worst:.2e}")


def test_deflection_law_and_reader():
    """Serial model: joint + joint_harmonic predicts what joint_profile
    [c, c1, s1, 0, 0] predicts; a harmonic needs a joint effect; the value
    has two numbers."""
    truth = [{"kind": "joint", "target": "all", "value": 2e-7}]
    chain, _tm, meas = synthesize(KR270_JOINTS, truth, n_configs=8, ranges=KR270_RANGES, sigma=0.0, seed=3)
    c, c1, s1 = 2e-7, 8e-8, -5e-8
    others = [{"kind": "joint", "target": j, "value": c} for j in chain.actuated if j != "joint_a3"]
    h = model_from_tables(
        chain,
        others
        + [
            {"kind": "joint", "target": "joint_a3", "value": c},
            {"kind": "joint_harmonic", "target": "joint_a3", "value": [c1, s1]},
        ],
    )
    p = model_from_tables(
        chain, others + [{"kind": "joint_profile", "target": "joint_a3", "value": [c, c1, s1, 0.0, 0.0]}]
    )
    ph = Problem(h, meas).evaluate(np.zeros(0), jac=False)[0]
    pp = Problem(p, meas).evaluate(np.zeros(0), jac=False)[0]
    np.testing.assert_allclose(ph, pp, rtol=1e-13, atol=1e-20)
    q = meas.q[:, chain.actuated.index("joint_a3")]
    jc = h.joint_compliances(meas.q)[chain.joint_index("joint_a3")]
    np.testing.assert_allclose(jc, c + c1 * np.cos(q) + s1 * np.sin(q), rtol=1e-14)
    # the Jacobian of the free harmonic: its columns are the joint's column times cos q, sin q
    free = model_from_tables(chain, others + [{"kind": "joint", "target": "joint_a3", "value": c}])
    free = model_from_tables(chain, free.effects + [{"kind": "joint_harmonic", "target": "joint_a3"}])
    pb = Problem(free, meas)
    _, J = pb.evaluate(np.zeros(2))
    g = Problem(model_from_tables(chain, [{"kind": "joint", "target": "joint_a3", "value": 1e-7}]), meas)
    g = g.evaluate(np.zeros(0), jac=False)[0] / 1e-7
    np.testing.assert_allclose(J[:, :, 0], g * np.cos(q), rtol=1e-13, atol=1e-22)
    np.testing.assert_allclose(J[:, :, 1], g * np.sin(q), rtol=1e-13, atol=1e-22)
    with pytest.raises(InputError, match="joint_harmonic on 'joint_a3' needs a 'joint' effect"):
        model_from_tables(chain, [{"kind": "joint_harmonic", "target": "joint_a3"}])
    with pytest.raises(InputError, match=r"value must be \[cos1, sin1\]"):
        model_from_tables(chain, others + [{"kind": "joint_harmonic", "target": "joint_a3", "value": 1e-8}])


def test_diagnose_finds_it_on_deflection_data():
    """Deflection data (KR-270-like robot) whose joint A3 has a first
    harmonic: diagnose proposes joint_harmonic on A3 (not the wider
    joint_profile), and appending it brings the error down to the noise."""
    sigma = 2e-5
    truth = _truth() + [{"kind": "joint_harmonic", "target": "joint_a3", "value": [6e-8, -4e-8]}]
    chain, _tm, meas = synthesize(
        KR270_JOINTS, truth, n_configs=30, loads_per_config=3, ranges=KR270_RANGES, sigma=sigma, seed=4
    )
    model = model_from_tables(chain, base_effects(), sigma_position=sigma)
    dg = diagnose(model, meas)
    before = fit(model, meas).rms_position
    assert dg.proposal is not None, dg.no_proposal_reasons
    assert (dg.proposal.kind, dg.proposal.target) == ("joint_harmonic", "joint_a3")
    table = dict(dg.proposal.effect)
    assert effect_toml(table) == '[[effect]]\nkind = "joint_harmonic"\ntarget = "joint_a3"'
    after = fit(model_from_tables(chain, model.effects + [table], sigma_position=sigma), meas)
    print(f"deflection data: RMS {before * 1e6:.1f} um -> {after.rms_position * 1e6:.1f} um with joint_harmonic")
    assert after.rms_position < 0.5 * before
    assert after.rms_position < 1.2 * math.sqrt(3) * sigma
    names = after.names
    v = after.theta[[names.index("joint_a3.cos1"), names.index("joint_a3.sin1")]]
    np.testing.assert_allclose(v, [6e-8, -4e-8], rtol=0.1)


def test_diagnose_finds_it_on_absolute_data(dualarm, tmp_path):
    """Tracker data (the synthetic dual-arm robot) whose joint left_2 has a
    first harmonic of its compliance: diagnose proposes joint_harmonic on
    left_2; appending it brings the error to the noise."""
    out, tree, truth = dualarm
    text = (out / "model.toml").read_text()
    for k in ("joint_offset", "frame", "joint", "lateral"):
        text += f'\n[[effect]]\nkind = "{k}"\ntarget = "all"\n'
    model_path = tmp_path / "model.toml"
    model_path.write_text(text.replace('urdf = "robot.urdf"', f'urdf = "{out / "robot.urdf"}"'))
    _m, data = load_absolute(model_path, out / "measurements.csv")
    th, _extra = _with_harmonic(tree, truth)
    rng = np.random.default_rng(6)
    sigma = 3e-5  # a good tracker
    data.xyz = predict(th, data, th.theta0)["pred"] + sigma * rng.normal(size=data.xyz.shape)
    write_absolute(tmp_path / "measurements.csv", data)
    model, data = load_absolute(model_path, tmp_path / "measurements.csv")
    before = fit_absolute(model, data).rms_position
    dg = diagnose_absolute(model, data)
    assert dg.proposal is not None, dg.reasons
    assert (dg.proposal.kind, dg.proposal.target) == ("joint_harmonic", "left_2")
    model_path.write_text(model_path.read_text().rstrip() + "\n\n" + effect_toml(dg.proposal.effect) + "\n")
    model, data = load_absolute(model_path, tmp_path / "measurements.csv")
    after = fit_absolute(model, data)
    print(f"absolute data: RMS {before * 1e6:.1f} um -> {after.rms_position * 1e6:.1f} um with joint_harmonic")
    assert after.rms_position < 0.5 * before
    assert after.rms_position < 1.1 * math.sqrt(3) * sigma
    v = [after.theta[after.model.index(f"left_2.{n}")] for n in ("c", "cos1", "sin1")]
    np.testing.assert_allclose(np.array(v[1:]) / v[0], [C1, S1], atol=0.05)


def test_compensation_takes_the_harmonic_at_the_compensated_angle(tmp_path):
    """Relative-data compensation (robot/compensate.py) of a model with a
    joint_harmonic: the loaded tool of the compensated command sits where the
    unloaded nominal one is (the section-3 model's residual is second order,
    100 x below the uncompensated error); the harmonic's joint is one whose
    compliance the compensation takes per row (at the compensated angle)."""
    from stiffkit.calib.synth import KR270_JOINTS
    from stiffkit.robot.compensate import load_compensation_model
    from stiffkit.robot.model import load_model
    from stiffkit.robot.model_file import model_toml
    from stiffkit.robot.urdf import urdf_text

    (tmp_path / "robot.urdf").write_text(urdf_text("kr", KR270_JOINTS))
    effects = [
        {"kind": "joint", "target": "all", "value": 3e-7},
        {"kind": "joint_harmonic", "target": "joint_a3", "value": [2e-7, -1.5e-7]},
    ]
    path = tmp_path / "model.toml"
    path.write_text(model_toml(effects, urdf=str(tmp_path / "robot.urdf")))
    model = load_model(path)
    rng = np.random.default_rng(3)
    Q = np.array([0.2, -0.6, 0.4, 0.3, 0.8, -0.2]) + 0.3 * rng.normal(size=(12, 6))
    W = np.column_stack([rng.normal(0, 800, (12, 3)), rng.normal(0, 100, (12, 3))])
    cm = load_compensation_model(path)
    assert cm.varying  # the harmonic's joint: its compliance per row
    res = cm.compensate(Q, None, W)
    assert res.converged.all()
    P0 = model.chain.poses(Q)

    def loaded_point(Qx):
        C = model.tool_compliance(Qx, wrench=W)
        return model.chain.poses(Qx)["pt"] + np.einsum("nij,nj->ni", C, W)[:, :3]

    gap = np.linalg.norm(loaded_point(res.q) - P0["pt"], axis=1).max()
    unc = np.median(np.linalg.norm(loaded_point(Q) - P0["pt"], axis=1))
    print(f"compensation with joint_harmonic: max residual {gap * 1e6:.3g} um, uncompensated median {unc * 1e3:.3g} mm")
    assert unc > 100 * gap
