"""The full model against a hand calibration (issue 16 item 5,
docs/calibration.md section 6.12): on the synthetic dual-arm robot with a
truth of offsets, frame errors, joint compliances and lateral compliances
about the common normals (simulated by the independent numpy model of
tests/_hand_model.py), `fit` of every kind on all joints is at least as
good as the hand reference in-sample and in 5-fold CV, and keeps no
duplicated parameter. Bench with 500 postures: bench/bench_full_model.py.
"""

from __future__ import annotations

import _hand_model as H
import numpy as np
import pytest

from stiffkit.calib import dualarm as D
from stiffkit.calib.absolute_fit import fit_absolute, predict
from stiffkit.calib.absolute_report import load_absolute
from stiffkit.errors import InputError
from stiffkit.robot.tree_model import duplicated_tilt, lateral_tilts, rpy_matrix, tree_model_from_tables

POSTURES = 150


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    out = D.synth_dualarm(tmp_path_factory.mktemp("dualarm"), configs=POSTURES, seed=3, targets=2)
    start, data = load_absolute(out / "model.toml", out / "measurements.csv")
    truth = D.dualarm_truth(out / "robot.urdf")
    data.xyz = H.normal_truth_points(start.tree, truth, data.Q, seed=5).reshape(-1, 3)
    return start, data, truth


def test_lateral_tilts_are_the_common_normals(case):
    """x' is the common normal with the previous axis, through its foot on
    this axis; y' = z' x x' is held at 0 where it is the previous axis line."""
    tree = case[0].tree
    x, y = lateral_tilts(tree, "left_2")  # y (left_1) then x: perpendicular, meeting: x' = -z, y' = y
    assert np.allclose(x[0], [0, 0, -1]) and np.allclose(x[1], 0) and np.allclose(y[0], [0, 1, 0])
    x, y = lateral_tilts(tree, "left_3")  # x then z, meeting 0.13 m above left_3's origin
    assert np.allclose(x[0], [0, -1, 0]) and np.allclose(x[1], [0, 0, 0.13])
    assert [duplicated_tilt(tree, j) for j in ("left_2", "left_3", "left_5", "torso_2", "torso_3")] == [
        True, True, False, True, False,
    ]  # fmt: skip
    x, y = lateral_tilts(tree, "left_5")  # y then z, 15 mm apart: both tilts
    assert np.allclose(x[0], [1, 0, 0]) and np.allclose(y[0], [0, 1, 0]) and np.allclose(x[1], [0, 0, 0.12])
    x, y = lateral_tilts(tree, "torso_3")  # parallel pitch axes 0.35 m apart: about the perpendicular (z)
    assert np.allclose(x[0], [0, 0, 1]) and np.allclose(y[0], [1, 0, 0])
    x, y = lateral_tilts(tree, "torso_1")  # no moving joint above: the origin frame's x, y
    assert np.allclose(x[0], [1, 0, 0]) and np.allclose(y[0], [0, 1, 0])


def test_core_and_numpy_simulator_agree(case):
    """The core's prediction of a truth with every kind equals the
    independent numpy model's (converged equilibrium) to 1e-9 m."""
    start, data, truth = case
    tree = start.tree
    model = tree_model_from_tables(tree, truth, D.GRAVITY)
    sim = H.HandModel(tree, list(D.MARKERS), lateral="normal", hand=False, second=True)
    th = np.zeros(len(sim.names))
    th[3:6] = truth[0]["xyz"]
    for e in truth[1:]:
        kind, j, v = e["kind"], e["target"], e.get("value")
        if kind == "marker":
            th[[sim.index[("mk", j, k)] for k in range(3)]] = e["xyz"]
        elif kind == "joint_offset":
            th[sim.index[("dq0", j, 0)]] = v
        elif kind == "frame" and tree.joint(j).moving:
            th[[sim.index[("fr", j, k)] for k in range(6)]] = v
        elif kind == "joint":
            th[sim.index[("c", j, 0)]] = v
        elif kind == "lateral":
            for k, (a, p) in enumerate(lateral_tilts(tree, j)):
                assert np.allclose(a, sim.lat_dirs[j][k][0]) and np.allclose(p, sim.lat_dirs[j][k][1])
                th[sim.index[("lat", j, k)]] = v[k]
    pts = sim.predict(th, data.Q, rpy_matrix(np.array(truth[0]["rpy"])))
    assert np.abs(pts.reshape(-1, 3) - predict(model, data, model.theta0)["pred"]).max() < 1e-9


def test_duplicated_tilt_is_held_unless_given(case):
    """left_2's y' is left_1's axis line: its cy is not identified; a value given is used."""
    tree = case[0].tree
    free = tree_model_from_tables(tree, case[0].effects + [{"kind": "lateral", "target": "all"}], D.GRAVITY)
    held = {p.name for p in free.params if p.kind == "lateral" and not p.free}
    assert held == {f"{s}_{k}.cy" for s in ("left", "right") for k in (2, 3, 6, 7)} | {"torso_2.cy"}
    known = case[0].effects + [{"kind": "lateral", "target": "left_2", "value": [1e-5, 2e-5]}]
    model = tree_model_from_tables(tree, known, D.GRAVITY)
    assert model.theta0[model.index("left_2.cy")] == 2e-5
    with pytest.raises(InputError, match="tilts need one target joint"):
        tree_model_from_tables(tree, case[0].effects + [{"kind": "lateral", "tilts": [[1, 0, 0, 0, 0, 0]] * 2}])


def test_full_model_matches_the_hand_reference(case):
    start, data, _truth = case
    eff = [dict(e) for e in start.effects] + [{"kind": k, "target": "all"} for k in D.STORY]
    model = tree_model_from_tables(start.tree, eff, D.GRAVITY, sigma_position=D.DEFAULT_SIGMA)
    fit = fit_absolute(model, data, cv=5)
    full_in = np.linalg.norm(fit.residual, axis=1).mean()
    full_cv = fit.cv["mean_position_m"]
    hm = H.HandModel(start.tree, list(D.MARKERS), lateral="normal", hand=True)
    Q, xyz = data.Q, data.xyz.reshape(-1, len(D.MARKERS), 3)
    # the hand reference holds a compliance identified below 0 at 0, as the full model does
    th, R0, free = H.fit(hm, Q, xyz, H.start(hm, D.NOMINAL_MARKERS), maxit=60)
    hand_in = H.errors(hm, th, R0, Q, xyz).mean()
    hand_cv = H.cross_validate(hm, Q, xyz, th, free).mean()
    assert hand_in < 1.1 * 1.6e-4  # both near the noise floor (mean distance ~1.6 sigma)
    assert full_in <= hand_in, (full_in, hand_in)
    assert full_cv <= 1.02 * hand_cv, (full_cv, hand_cv)
    # no duplicated parameter: none merged, the kept columns pairwise far from parallel
    assert fit.reduction.merged == []
    assert not any(model.params[i].name == f"{j}.cy" for i in fit.reduction.kept for j in ("left_2", "left_3"))
    J = predict(fit.model, data, fit.theta, fit.reduction.kept)["jac"]
    Js = J / np.linalg.norm(J, axis=0)
    cos = np.abs(Js.T @ Js) - np.eye(Js.shape[1])
    assert cos.max() < 0.999, cos.max()
