"""Identification (docs/calibration.md §4): exact recovery, groups, couplings, write-model."""

from __future__ import annotations

import numpy as np
import pytest
from _calib_util import MARKERS, data, joints_truth, model, spd, truth_values

import stiffkit
from stiffkit.calib import synth as S
from stiffkit.calib.fit import fit, write_model
from stiffkit.calib.reduce import reduce_model

PROFILE = [0.0, 6e-8, -4e-8, 3e-8, 2e-8]
COMP = dict(S.KR270_COMPENSATOR)

# (name, truth effects, effects to identify): one per effect kind of the contract
CASES = [
    ("joint", joints_truth(), [{"kind": "joint", "target": "all"}]),
    (
        "link",
        [{"kind": "link", "target": "link_2", "value": spd(11).tolist()}],
        [{"kind": "link", "target": "link_2", "template": "full"}],
    ),
    (
        "link-beam",
        [{"kind": "link", "target": "link_3", "value": S.kr270_links()["link_3"].tolist()}],
        [{"kind": "link", "target": "link_3", "template": "beam"}],
    ),
    ("base", [{"kind": "base", "value": spd(12).tolist()}], [{"kind": "base", "template": "full"}]),
    ("tool", [{"kind": "tool", "value": spd(13).tolist()}], [{"kind": "tool", "template": "full"}]),
    (
        "joint_profile",
        [{"kind": "joint_profile", "target": "joint_a2", "value": [2e-7] + PROFILE[1:]}],
        [{"kind": "joint_profile", "target": "joint_a2"}],
    ),
    (
        "gravity_compensator",
        joints_truth() + [{"kind": "gravity_compensator", "target": "joint_a2", **COMP}],
        [
            {"kind": "joint", "target": "all"},
            {"kind": "gravity_compensator", "target": "joint_a2", **{k: COMP[k] for k in ("a", "b", "beta", "s0")}},
        ],
    ),
    (
        "joint_cubic",
        joints_truth() + [{"kind": "joint_cubic", "target": "joint_a2", "value": -2e-15}],
        [{"kind": "joint", "target": "all"}, {"kind": "joint_cubic", "target": "joint_a2"}],
    ),
    (
        "joint_deadzone",
        joints_truth() + [{"kind": "joint_deadzone", "target": "joint_a4", "value": 2e-4, "tau0": 20.0}],
        [{"kind": "joint", "target": "all"}, {"kind": "joint_deadzone", "target": "joint_a4", "tau0": 20.0}],
    ),
    (
        "point_offset",
        joints_truth() + [{"kind": "point_offset", "r": [0.03, -0.02, 0.05]}],
        [{"kind": "joint", "target": "all"}, {"kind": "point_offset"}],
    ),
]


@pytest.mark.parametrize("name,truth,effects", CASES, ids=[c[0] for c in CASES])
def test_exact_recovery_noise_free(name, truth, effects):
    chain, tm, meas = data(truth, sigma=0.0, seed=3)
    res = fit(model(chain, effects), meas)
    true = truth_values(tm)
    scale = max(abs(v) for v in true.values())
    checked = 0
    for n, v, g in zip(res.names, res.values, res.groups):
        assert g == "identifiable", f"{n} is {g}"
        t = true.get(n, 0.0)  # template elements absent from the truth are zero
        tol = 1e-8 * max(abs(t), 1e-3 * scale) if n.split(".")[-1].startswith("c") else 1e-8 * max(abs(t), 1e-12)
        if n.endswith(("k_s", ".cubic", ".backlash")):
            tol = 1e-8 * abs(t)
        assert abs(v - t) <= tol, f"{n}: {v!r} vs {t!r}"
        checked += 1
    assert checked == len(res.names) > 0
    assert res.rms_position < 1e-12 * np.sqrt(np.mean(np.sum(meas.d**2, axis=1)))


def test_gravity_loading_leaves_parameters_non_identifiable():
    truth = joints_truth() + [{"kind": "base", "value": spd(4).tolist()}]
    effects = [{"kind": "joint", "target": "all"}, {"kind": "base", "template": "full"}]
    for loads, expect_g2 in (("gravity", True), ("random", False)):
        chain, tm, meas = data(truth, sigma=1e-5, seed=5, loads=loads)
        res = fit(model(chain, effects, sigma=1e-5), meas)
        groups = dict(zip(res.names, res.groups))
        # forces along -z only: no torque about the vertical axis A1 and no
        # horizontal force on the base spring
        g2 = ["joint_a1.c", "base.c11", "base.c12", "base.c22"]
        if expect_g2:
            assert all(groups[n] == "non-identifiable" for n in g2), {n: groups[n] for n in g2}
            assert sum(g == "identifiable" for g in res.groups) >= 3
        else:
            assert not any(groups[n] == "non-identifiable" for n in g2)


def test_joint_and_link_rotation_about_same_axis_are_coupled():
    truth = joints_truth() + [{"kind": "link", "target": "link_2", "value": S.kr270_links()["link_2"].tolist()}]
    chain, tm, meas = data(truth, sigma=1e-5, seed=6)
    m = model(
        chain,
        [{"kind": "joint", "target": "all"}, {"kind": "link", "target": "link_2", "template": "diagonal"}],
        sigma=1e-5,
    )
    res = fit(m, meas)
    groups = dict(zip(res.names, res.groups))
    # link_2's spring sits at joint_a3's frame; joint_a3 turns about y = c55
    assert groups["joint_a3.c"] == groups["link_2.c55"] == "semi-identifiable"
    assert any({"joint_a3.c", "link_2.c55"} <= set(c) for c in res.couplings)
    assert groups["joint_a1.c"] == "identifiable"
    red = reduce_model(m, meas)
    assert "joint_a3.c" in red.aggregated  # M3
    steps = [r[3] for r in red.rows]
    assert steps[0] == 6 + 36 and steps[1] == 6 + 21 and steps[2] == 6 + 6 and steps[3] == 11
    assert len(red.selected) == res.rank  # M5: rank-many parameters left


def test_write_model_round_trip(tmp_path):
    truth = joints_truth() + [{"kind": "link", "target": "link_3", "value": S.kr270_links()["link_3"].tolist()}]
    S.write_synth(
        tmp_path,
        S.KR270_JOINTS,
        truth,
        [{"kind": "joint", "target": "all"}, {"kind": "link", "target": "link_3", "template": "beam"}],
        sigma=0.0,
        n_configs=20,
        ranges=S.KR270_RANGES,
        markers=MARKERS,
    )
    res = fit(tmp_path / "model.toml", tmp_path / "measurements.csv")
    write_model(res, tmp_path / "identified.toml")
    Q = S.random_postures(20, S.KR270_RANGES, np.random.default_rng(2))
    Ci = stiffkit.load_model(tmp_path / "identified.toml").tool_compliance(Q)
    Ct = stiffkit.load_model(tmp_path / "truth.toml").tool_compliance(Q)
    # joint_a4 and link_3's c44 are coupled: the sum is identified, so compare the tool compliance
    np.testing.assert_allclose(Ci, Ct, rtol=0, atol=1e-8 * np.abs(Ct).max())


def test_marker_on_the_last_axis_leaves_it_non_identifiable():
    """One marker on the A6 axis: A6 turning does not move it (G2, as the paper's partial-pose case)."""
    chain, tm, meas = data(joints_truth(), sigma=1e-5, seed=7, markers=((0.0, 0.0, 0.25),))
    res = fit(model(chain, [{"kind": "joint", "target": "all"}], sigma=1e-5), meas)
    assert dict(zip(res.names, res.groups))["joint_a6.c"] == "non-identifiable"
    assert res.groups.count("identifiable") == 5


def test_fewer_rows_than_parameters(tmp_path):
    chain, tm, meas = data(joints_truth(), n_configs=1, markers=((0, 0, 0.2),))
    m = model(chain, [{"kind": "link", "target": ln, "template": "full"} for ln in ("link_2", "link_3")])
    with pytest.raises(stiffkit.InputError, match="fewer rows than parameters"):
        fit(m, meas)


def test_rotation_columns_make_the_last_axis_identifiable(tmp_path):
    """rx, ry, rz measured: one marker on the A6 axis suffices (docs/calibration.md §3, optional rotations)."""
    S.write_synth(
        tmp_path,
        S.KR270_JOINTS,
        joints_truth(),
        [{"kind": "joint", "target": "all"}],
        sigma=1e-5,
        sigma_rotation=1e-5,
        n_configs=20,
        ranges=S.KR270_RANGES,
        markers=((0.0, 0.0, 0.25),),
    )
    assert "rx" in (tmp_path / "measurements.csv").read_text().splitlines()[0]
    res = fit(tmp_path / "model.toml", tmp_path / "measurements.csv")
    assert res.nobs == 6 * 60 and all(g == "identifiable" for g in res.groups)
    z = (res.values - np.array(S.KR270_JOINT_C)) / res.std
    assert np.abs(z).max() < 5  # estimates within their standard errors


def test_cli_reduce_prints_table_1(tmp_path, capsys):
    from stiffkit.cli import main

    truth = joints_truth() + [{"kind": "link", "target": "link_2", "value": S.kr270_links()["link_2"].tolist()}]
    S.write_synth(
        tmp_path,
        S.KR270_JOINTS,
        truth,
        [{"kind": "joint", "target": "all"}]
        + [{"kind": "link", "target": f"link_{i}", "template": "beam"} for i in range(1, 6)],
        sigma=1e-5,
        n_configs=20,
        ranges=S.KR270_RANGES,
        markers=MARKERS,
    )
    assert (
        main(
            [
                "fit",
                str(tmp_path / "model.toml"),
                str(tmp_path / "measurements.csv"),
                "--reduce",
                "--quiet",
                "--json",
                str(tmp_path / "r.json"),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    import json

    js = json.loads((tmp_path / "r.json").read_text())
    # the reduced model: exactly the selected parameters, all identifiable
    assert [p["name"] for p in js["parameters"]] == js["reduction"]["selected"]
    assert all(p["group"] == "identifiable" for p in js["parameters"])
    assert "M1 symmetrisation" in out and "M5a splitting" in out
    assert "6 joints + 5 6-dof springs" in out and " 186 " in out  # 6 + 5 x 36


def test_reduction_of_the_complete_kr270_model_follows_table_1():
    """6 joints + 7 links: 258 -> 153 (M1) -> 62 (M2 beam) -> 56 (M3), as in
    klimchik Table 1; with gravity loading M4 finds non-identifiable
    parameters and M5 leaves exactly rank-many."""
    chain, tm, meas = data(S.kr270_truth(), sigma=2e-5, seed=1, loads="gravity")
    links = ["base_link"] + [f"link_{i}" for i in range(1, 7)]
    m = model(
        chain,
        [{"kind": "joint", "target": "all"}] + [{"kind": "link", "target": ln, "template": "beam"} for ln in links],
        sigma=2e-5,
    )
    red = reduce_model(m, meas)
    counts = [r[3] for r in red.rows]
    assert counts[:4] == [258, 153, 62, 56]
    assert len(red.aggregated) == 6 and len(red.g2) > 0
    assert "base_link.c66" in red.g2  # no moment about the vertical axis under gravity
    assert counts[4] == 56 - len(red.g2)
    res = fit(m, meas)
    assert counts[5] == len(red.selected) == res.rank


def test_core_levenberg_marquardt_by_reverse_communication():
    """The core's LM (core/sk_lm.f90) driven from Python as fit drives it:
    Rosenbrock's valley to (1, 1); a call out of order is refused."""
    from stiffkit._core import calib as core

    def model(x):
        return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]]), np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])

    x = np.array([-1.2, 1.0])
    st = core.lm_start(model(x)[1], model(x)[0], 100, 1e-15, 1e-15, 0.0)
    while st.running:
        dx = core.lm_step(st, x)
        r, J = model(x + dx)
        if core.lm_accept(st, J, r):
            x = x + dx
    assert st.converged and core.LM_REASONS[st.reason] and 0 < st.niter < 60
    np.testing.assert_allclose(x, [1.0, 1.0], atol=1e-10)
    with pytest.raises(stiffkit.InputError, match="sk_lm_step"):
        core.lm_step(st, x)  # the iteration has stopped
    st = core.lm_start(model(x + 0.1)[1], model(x + 0.1)[0], 100, 0.0, 0.0, 0.0)
    with pytest.raises(stiffkit.InputError, match="sk_lm_accept"):
        core.lm_accept(st, *model(x)[::-1])  # a verdict before a step
