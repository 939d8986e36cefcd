"""joint_profile and gravity_compensator on tracker data (issue 15: one
law table for both data kinds): the kinds' block is the core's law_joint
(core/sk_laws.f90, the serial chain's joint law), with the profile's five
values in its slots 4..8, k_s in slot 11 and the compensator's geometry
(fixed parameters) in 12..15; the profile's first-order deflection is the
closed form, and tracker fits of synthetic data that have a profile or a
compensator on one joint recover them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stiffkit._core import calib as calib_core
from stiffkit.calib.absolute_data import write_absolute
from stiffkit.calib.absolute_fit import fit_absolute, predict
from stiffkit.calib.absolute_report import load_absolute
from stiffkit.calib.absolute_write import model_effects
from stiffkit.calib.dualarm import GRAVITY, dualarm_truth, synth_dualarm
from stiffkit.robot import catalogue
from stiffkit.robot.tree import load_tree
from stiffkit.robot.tree_model import tree_model_from_tables

#: the profile c0..c4 (1, cos q, sin q, cos 2q, sin 2q) as fractions of the joint's c (c(q) > 0 at every q)
PROFILE = np.array([0.1, 0.6, -0.4, 0.0, 0.2])


@pytest.fixture(scope="module")
def dualarm(tmp_path_factory):
    out = synth_dualarm(tmp_path_factory.mktemp("profile"), configs=150, seed=5)
    urdf = out / "robot.urdf"
    return out, load_tree(urdf), dualarm_truth(urdf)


def _with_profile(tree, truth, joint="left_2", **kw):
    base = tree_model_from_tables(tree, truth, GRAVITY, **kw)
    c = base.theta0[base.index(f"{joint}.c")]
    extra = [{"kind": "joint_profile", "target": joint, "value": [float(v) for v in PROFILE * c]}]
    return tree_model_from_tables(tree, truth + extra, GRAVITY, **kw), extra, c


def test_tracker_block_is_law_joint_with_the_closed_form(dualarm):
    """First order: the profiled joint's deflection is the linear one's
    times c(v) / c, v the joint's value (q + dq0)."""
    out, tree, truth = dualarm
    _model, data = load_absolute(out / "model.toml", out / "measurements.csv")
    lin = tree_model_from_tables(tree, truth, GRAVITY, iterations=1)
    pro, _extra, _c = _with_profile(tree, truth, iterations=1)
    blocks = [b for b in range(len(pro.blocks)) if pro.blocks[b] == ("joint", "left_2")]
    assert len(blocks) == 1 and pro.arrays["ktype"][blocks[0]] == catalogue.LAW_JOINT == 6
    kp = pro.arrays["kpar"][:, blocks[0]]
    names = [pro.names[i - 1] for i in kp[catalogue.JS_PROFILE - 1 : catalogue.JS_PROFILE + 4]]
    assert names == [f"left_2.c{m}" for m in range(5)]
    e = sum(6 if t == 4 else 1 for t in pro.arrays["ktype"][: blocks[0]])
    dl = predict(lin, data, lin.theta0)["delta"][:, e]
    dp = predict(pro, data, pro.theta0)["delta"][:, e]
    v = data.Q[:, data.joints.index("left_2")] + lin.theta0[lin.index("left_2.dq0")]
    basis = np.stack([np.ones_like(v), np.cos(v), np.sin(v), np.cos(2 * v), np.sin(2 * v)], axis=1)
    ratio = 1.0 + basis @ PROFILE
    assert np.max(np.abs(dl)) > 1e-4
    np.testing.assert_allclose(dp, dl * ratio, rtol=1e-12, atol=1e-18)


def test_tracker_fit_recovers_the_profile(dualarm, tmp_path):
    """Synthetic tracker data (0.03 mm noise) of the dual-arm robot whose
    joint left_2 has a profile: the model with a free joint_profile on
    left_2 (its c known, so that c0 is not c's twin) recovers the joint's
    compliance c(v) at the data's angles to 4 % (the five coefficients
    themselves are near-collinear over the joint's range, as the data's
    angles span it) and the RMS falls to the noise; without it the fit
    stays well above."""
    out, tree, truth = dualarm
    th, _extra, c = _with_profile(tree, truth)
    text = (out / "model.toml").read_text().replace('urdf = "robot.urdf"', f'urdf = "{out / "robot.urdf"}"')
    for k in ("joint_offset", "frame", "joint", "lateral"):
        text += f'\n[[effect]]\nkind = "{k}"\ntarget = "all"\n'
    text += f'\n[[effect]]\nkind = "joint"\ntarget = "left_2"\nvalue = {float(c)!r}\n'
    plain = tmp_path / "plain.toml"
    plain.write_text(text)
    profiled = tmp_path / "profiled.toml"
    profiled.write_text(text + '\n[[effect]]\nkind = "joint_profile"\ntarget = "left_2"\n')
    _m, data = load_absolute(plain, out / "measurements.csv")
    rng = np.random.default_rng(8)
    sigma = 3e-5
    data.xyz = predict(th, data, th.theta0)["pred"] + sigma * rng.normal(size=data.xyz.shape)
    write_absolute(tmp_path / "measurements.csv", data)
    before = fit_absolute(*load_absolute(plain, tmp_path / "measurements.csv")).rms_position
    after = fit_absolute(*load_absolute(profiled, tmp_path / "measurements.csv"))
    got = np.array([after.theta[after.model.index(f"left_2.c{m}")] for m in range(5)]) / c
    v = data.Q[:, data.joints.index("left_2")] + after.theta[after.model.index("left_2.dq0")]
    basis = np.stack([np.ones_like(v), np.cos(v), np.sin(v), np.cos(2 * v), np.sin(2 * v)], axis=1)
    err = np.max(np.abs(basis @ (got - PROFILE)) / (1.0 + basis @ PROFILE))
    print(
        f"tracker data: RMS {before * 1e6:.1f} um -> {after.rms_position * 1e6:.1f} um with joint_profile; "
        f"c(v) within {err:.2%} of the truth over v in [{v.min():.2f}, {v.max():.2f}] rad"
    )
    assert after.rms_position < 1.1 * math.sqrt(3) * sigma
    assert before > 2.0 * after.rms_position
    assert err < 0.04


def test_law_joint_slots_are_the_cores():
    """The catalogue's law_joint slots are core/sk_laws.f90's js_* codes."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "core" / "sk_laws.f90").read_text()
    codes = {m[0]: int(m[1]) for m in re.findall(r"\b(js_[a-z]+)\s*=\s*(\d+)\b", text)}
    assert codes["js_profile"] == catalogue.JS_PROFILE and codes["js_ks"] == catalogue.JS_KS
    assert catalogue.KIND["joint_profile"].slots == tuple(range(codes["js_profile"], codes["js_profile"] + 5))


#: the compensator's geometry (m, m, rad, m)
GEOMETRY = {"a": 0.3, "b": 0.5, "beta": 0.2, "s0": 0.25}


def test_tracker_fit_recovers_a_compensator(dualarm, tmp_path):
    """Synthetic tracker data (0.03 mm noise) of the dual-arm robot whose
    joint left_2 carries a gravity compensator (stiffness 1/c + k_s h(q),
    k_s c h up to 0.6): the model with the compensator's k_s free (c known)
    recovers k_s to 2 %, the RMS falls to the noise, and the written model
    reads back with its geometry."""
    out, tree, truth = dualarm
    base = tree_model_from_tables(tree, truth, GRAVITY)
    c = base.theta0[base.index("left_2.c")]
    _m, data = load_absolute(out / "model.toml", out / "measurements.csv")
    v = data.Q[:, data.joints.index("left_2")] + base.theta0[base.index("left_2.dq0")]
    ks = 0.6 / (c * np.max(np.abs(calib_core.compensator_h(v, GEOMETRY))))
    th = tree_model_from_tables(
        tree, truth + [{"kind": "gravity_compensator", "target": "left_2", "k_s": ks, **GEOMETRY}], GRAVITY
    )
    text = (out / "model.toml").read_text().replace('urdf = "robot.urdf"', f'urdf = "{out / "robot.urdf"}"')
    for k in ("joint_offset", "frame", "joint", "lateral"):
        text += f'\n[[effect]]\nkind = "{k}"\ntarget = "all"\n'
    text += f'\n[[effect]]\nkind = "joint"\ntarget = "left_2"\nvalue = {float(c)!r}\n'
    plain = tmp_path / "plain.toml"
    plain.write_text(text)
    comp = tmp_path / "compensated.toml"
    geo = "".join(f"{k} = {v!r}\n" for k, v in GEOMETRY.items())
    comp.write_text(text + f'\n[[effect]]\nkind = "gravity_compensator"\ntarget = "left_2"\n{geo}')
    rng = np.random.default_rng(9)
    sigma = 3e-5
    data.xyz = predict(th, data, th.theta0)["pred"] + sigma * rng.normal(size=data.xyz.shape)
    write_absolute(tmp_path / "measurements.csv", data)
    before = fit_absolute(*load_absolute(plain, tmp_path / "measurements.csv")).rms_position
    after = fit_absolute(*load_absolute(comp, tmp_path / "measurements.csv"))
    got = after.theta[after.model.index("left_2.k_s")]
    print(
        f"tracker data: RMS {before * 1e6:.1f} um -> {after.rms_position * 1e6:.1f} um with gravity_compensator; "
        f"k_s {got:.4g} N/m (truth {ks:.4g})"
    )
    assert after.rms_position < 1.1 * math.sqrt(3) * sigma
    assert before > 1.5 * after.rms_position
    assert got == pytest.approx(ks, rel=0.02)
    tables, _notes = model_effects(after.model, after.theta)
    (tab,) = [t for t in tables if t["kind"] == "gravity_compensator"]
    assert {k: tab[k] for k in GEOMETRY} == GEOMETRY and tab["k_s"] == got
