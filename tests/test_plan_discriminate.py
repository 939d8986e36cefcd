"""Postures that tell two tied link springs apart (calib/plan_discriminate.py, issue 19).

A small random tree (calib/synth_trees.py: one trunk joint, two arms of two
joints) whose truth is the tracker, the markers and an anisotropic spring on
l_link1. Data seeds whose 9 postures x 2 markers = 18 rows leave the spring
on l_link1 and the one on trunk_1 tied (log10 p within the diagnosis's
TIE_LOG10 of each other) are the cases. 10 postures planned by the T
criterion among 200 uniform candidates (within the joint limits), measured
with fresh noise, make the diagnosis rank the true spring first of the two
in at least 8 of 10 cases; the rate for 10 random postures from the same
candidates is measured and printed.
"""

from __future__ import annotations

import math
import sys
import types

import numpy as np
import pytest

from stiffkit.calib.absolute_data import AbsoluteData
from stiffkit.calib.absolute_diagnose import diagnose_absolute
from stiffkit.calib.absolute_fit import predict
from stiffkit.calib.diagnose_stats import TIE_LOG10
from stiffkit.calib.plan_discriminate import hypothesis_effects, plan_discriminate
from stiffkit.calib.synth_trees import MARKER_XYZ, TRACKER, random_tree_urdf
from stiffkit.errors import InputError
from stiffkit.robot.tree import load_tree
from stiffkit.robot.tree_model import GRAVITY, tree_model_from_tables

SIGMA = 1e-4
TRUE, RIVAL = "link:l_link1", "link:trunk_1"
C_TRUE = np.diag([0.0, 0.0, 0.0, 3e-3, 1.5e-3, 1.5e-3])  # rad/(N m) about the link's x, y, z


# ---- a test-only reference of the T criterion (the core's design.discriminate is plan-core's) ----
def _ncp(f, jh, rows, a, b):
    d = f[rows, a] - f[rows, b]
    J = jh[b][rows]
    if J.shape[1]:
        d = d - J @ np.linalg.lstsq(J, d, rcond=None)[0]
    return float(d @ d)


def ref_pairs(f, jh, n0, nobs, chosen):
    rows = np.concatenate([np.arange(n0)] + [n0 + c * nobs + np.arange(nobs) for c in chosen]).astype(int)
    nh = f.shape[1]
    P = np.zeros((nh, nh))
    for a in range(nh):
        for b in range(nh):
            if a != b:
                P[a, b] = _ncp(f, jh, rows, a, b)
    return P


def _t(P):
    return float(np.min(P[~np.eye(P.shape[0], dtype=bool)]))


def ref_discriminate(f, jh, n0, nobs, k, max_passes=100):
    """Greedy then exchange, maximising T (the smallest noncentrality over ordered pairs)."""
    ncand = (f.shape[0] - n0) // nobs
    chosen: list[int] = []
    for _ in range(k):
        best = max(
            (c for c in range(ncand) if c not in chosen), key=lambda c: _t(ref_pairs(f, jh, n0, nobs, chosen + [c]))
        )
        chosen.append(best)
    val = _t(ref_pairs(f, jh, n0, nobs, chosen))
    for _ in range(max_passes):
        improved = False
        for i in range(k):
            for c in range(ncand):
                if c in chosen:
                    continue
                trial = chosen[:i] + [c] + chosen[i + 1 :]
                v = _t(ref_pairs(f, jh, n0, nobs, trial))
                if v > val * (1 + 1e-12):
                    chosen, val, improved = trial, v, True
        if not improved:
            break
    P = ref_pairs(f, jh, n0, nobs, chosen)
    return types.SimpleNamespace(selected=np.array(chosen), value=_t(P), pairs=P)


try:
    from stiffkit._core import design as _design  # noqa: F401

    HAVE_CORE = hasattr(_design, "discriminate")
except ImportError:
    HAVE_CORE = False


@pytest.fixture(autouse=True)
def _design_core(monkeypatch):
    """Until plan-core's design.discriminate lands, the reference stands in for it."""
    if not HAVE_CORE:
        import stiffkit._core as core

        fake = types.ModuleType("stiffkit._core.design")
        fake.discriminate = ref_discriminate
        monkeypatch.setitem(sys.modules, "stiffkit._core.design", fake)
        monkeypatch.setattr(core, "design", fake, raising=False)


# ---- the case ----
@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    path = tmp_path_factory.mktemp("disc") / "tree.urdf"
    path.write_text(random_tree_urdf(np.random.default_rng(1), trunk=1, arm=2))
    tree = load_tree(path)
    frames = [{"kind": "tracker", "xyz": list(TRACKER["xyz"]), "rpy": list(TRACKER["rpy"])}]
    frames += [{"kind": "marker", "target": ln, "xyz": list(v)} for ln, v in MARKER_XYZ.items()]
    truth = tree_model_from_tables(
        tree, frames + [{"kind": "link", "target": "l_link1", "value": C_TRUE.tolist()}], GRAVITY, where="truth"
    )
    start = [{"kind": "tracker"}] + [{"kind": "marker", "target": ln, "xyz": [0.0, 0.0, 0.0]} for ln in MARKER_XYZ]
    model = tree_model_from_tables(tree, start, GRAVITY, where="model", sigma_position=SIGMA)
    lo = np.array([0.0 if tree.joint(j).type == "prismatic" else -1.4 for j in tree.actuated])
    hi = np.array([0.04 if tree.joint(j).type == "prismatic" else 1.4 for j in tree.actuated])
    return types.SimpleNamespace(tree=tree, truth=truth, model=model, lo=lo, hi=hi)


def measure(robot, Q, rng, configs=None):
    """Both markers at postures Q, predicted by the truth plus fresh noise."""
    n, nf = Q.shape[0], len(MARKER_XYZ)
    data = AbsoluteData(
        path="synthetic",
        joints=robot.tree.actuated,
        configs=configs or [f"c{i}" for i in range(n)],
        Q=Q,
        posture=np.repeat(np.arange(n), nf),
        frame=np.tile(np.arange(nf), n),
        frames=list(MARKER_XYZ),
        xyz=np.zeros((n * nf, 3)),
        weight=np.ones(n * nf),
        lines=np.arange(n * nf) + 2,
    )
    data.xyz = predict(robot.truth, data, robot.truth.theta0)["pred"] + SIGMA * rng.normal(size=data.xyz.shape)
    return data


def postures(robot, n, rng):
    return robot.lo + (robot.hi - robot.lo) * rng.random((n, robot.lo.size))


def joined(robot, data, Qnew, rng):
    extra = measure(robot, Qnew, rng, [f"n{i}" for i in range(Qnew.shape[0])])
    Q = np.vstack([data.Q, Qnew])
    return measure_rows(robot, data, extra, Q)


def measure_rows(robot, a, b, Q):
    return AbsoluteData(
        path="synthetic",
        joints=a.joints,
        configs=a.configs + b.configs,
        Q=Q,
        posture=np.concatenate([a.posture, a.n_postures + b.posture]),
        frame=np.concatenate([a.frame, b.frame]),
        frames=a.frames,
        xyz=np.vstack([a.xyz, b.xyz]),
        weight=np.concatenate([a.weight, b.weight]),
        lines=np.arange(a.n + b.n) + 2,
    )


def ranks(dg):
    labels = [c.label.rsplit(":", 1)[0] if c.kind == "link" else c.label for c in dg.candidates]
    return labels


def true_first(dg) -> tuple[bool, bool]:
    """(the true spring ranks ahead of its rival, the true spring ranks first of all)."""
    lab = ranks(dg)
    t = lab.index(TRUE) if TRUE in lab else len(lab)
    r = lab.index(RIVAL) if RIVAL in lab else len(lab)
    return t < r, t == 0


def tied(dg) -> bool:
    """The two springs within the diagnosis's tie margin: log10 p within TIE_LOG10 of each other."""
    lp = {lab: c.log_p / math.log(10) for lab, c in zip(ranks(dg), dg.candidates)}
    return TRUE in lp and RIVAL in lp and abs(lp[TRUE] - lp[RIVAL]) <= TIE_LOG10


def tied_cases(robot, n):
    """The first n data seeds whose 18 rows leave the two springs tied."""
    out, seed = [], 0
    while len(out) < n:
        rng = np.random.default_rng(100 + seed)
        data = measure(robot, postures(robot, 9, rng), rng)
        if tied(diagnose_absolute(robot.model, data)):
            out.append((seed, data, rng))
        seed += 1
        assert seed < 20 * n, "too few tied cases"
    return out


def planned_vs_random(robot, n, ncand=200, k=10):
    """Over n tied cases: is the true spring ranked ahead of its rival after
    k planned postures, after k random ones (of the same candidates)?"""
    out = {"planned": [], "random": [], "planned_first": [], "random_first": [], "seeds": []}
    for seed, data, rng in tied_cases(robot, n):
        cand = postures(robot, ncand, rng)
        plan = plan_discriminate(robot.model, data, [TRUE, RIVAL], cand, k)
        assert plan["hypotheses"] == [TRUE + ":beam", RIVAL + ":beam"]
        rand = rng.choice(ncand, k, replace=False)
        for what, sel in (("planned", plan["selected"]), ("random", rand)):
            ahead, first = true_first(diagnose_absolute(robot.model, joined(robot, data, cand[sel], rng)))
            out[what].append(ahead)
            out[what + "_first"].append(first)
        out["seeds"].append(seed)
    print({key: f"{sum(v)}/{len(v)}" for key, v in out.items() if key != "seeds"}, "seeds", out["seeds"])
    return out


def test_hypotheses_are_the_fits_to_the_data_so_far(robot):
    """Each hypothesis at the existing rows is the least-squares fit of the model plus its
    effect (its residual orthogonal to its Jacobian); the pair matrix is the T criterion's."""
    from stiffkit.calib.absolute_fit import fit_absolute
    from stiffkit.calib.plan_discriminate import _hypotheses, _postures

    rng = np.random.default_rng(7)
    data = measure(robot, postures(robot, 9, rng), rng)
    cand = postures(robot, 30, rng)
    fit = fit_absolute(robot.model, data)
    effects = hypothesis_effects(robot.model, [TRUE, RIVAL])
    f, jh = _hypotheses(fit, data, _postures(data, cand), effects, SIGMA)
    n0 = 3 * data.n
    assert f.shape == (n0 + 30 * 6, 2)
    measured = data.xyz.ravel() / SIGMA  # weights 1: whitened measured points
    for h in range(2):
        e = f[:n0, h] - measured
        assert np.abs(jh[h][:n0].T @ e).max() < 1e-6 * np.linalg.norm(e)
        assert np.allclose(jh[h].T @ jh[h], np.eye(jh[h].shape[1]), atol=1e-10)
    plan = plan_discriminate(robot.model, data, {"candidates": [TRUE + ":beam", RIVAL]}, cand, 3)
    P = ref_pairs(f, jh, n0, 6, plan["selected"])
    assert np.allclose(plan["pairs"], P, rtol=1e-6, atol=1e-8)
    assert plan["value"] == pytest.approx(_t(P), rel=1e-6)
    # the core's choice is at least as good as the reference's greedy + exchange
    assert plan["value"] >= ref_discriminate(f, jh, n0, 6, 3).value * (1 - 1e-9)
    assert plan["sigma_position_m"] == SIGMA


def test_bad_inputs(robot):
    rng = np.random.default_rng(3)
    data = measure(robot, postures(robot, 9, rng), rng)
    cand = postures(robot, 5, rng)
    with pytest.raises(InputError, match="at least 2"):
        plan_discriminate(robot.model, data, [TRUE], cand, 2)
    with pytest.raises(InputError, match=r"tied\[1\]: 'link:nowhere'"):
        plan_discriminate(robot.model, data, [TRUE, "link:nowhere"], cand, 2)
    with pytest.raises(InputError, match="given twice"):
        plan_discriminate(robot.model, data, [TRUE, TRUE + ":beam"], cand, 2)
    with pytest.raises(InputError, match="k = 6 exceeds the 5 candidate"):
        plan_discriminate(robot.model, data, [TRUE, RIVAL], cand, 6)
    with pytest.raises(InputError, match="positive integer"):
        plan_discriminate(robot.model, data, [TRUE, RIVAL], cand, 0)
    bad = cand.copy()
    bad[2, 1] = np.nan
    with pytest.raises(InputError, match="posture 2, joint neck: not finite"):
        plan_discriminate(robot.model, data, [TRUE, RIVAL], bad, 2)
    with pytest.raises(InputError, match=r"\(m, 7\) array"):
        plan_discriminate(robot.model, data, [TRUE, RIVAL], cand[:, :3], 2)


def test_planned_postures_tell_the_springs_apart_10_seeds(robot):
    """The rates are printed (pytest -s); measured: planned 9/10, random 8/10. The true spring
    ranked first of ALL candidates (the issue's number, 8 of 10): planned 0/10, random 1/10, not
    met; no choice of these candidates can meet it (the next test: the true effect is, to 4 %,
    the joint compliances of the tree)."""
    out = planned_vs_random(robot, 10)
    assert sum(out["planned"]) >= 8
    assert sum(out["planned_first"]) <= 2 and sum(out["random_first"]) <= 2  # measured 0/10 and 1/10


def test_the_true_spring_is_nearly_the_joint_compliances(robot):
    """Why the true spring is not ranked first of all candidates however 10 of the 200 are
    chosen: the truth, rotations at the origin of l2 (the link spring of l_link1 carries its
    child there), is exactly a compliance of joint l2 plus a lateral one (both nested in the
    spring), and nearly the compliances of the tree's joints. Noise-free rows at the 9 data
    postures and ALL 200 candidates: joint:all (3 parameters) ranks first, the true spring (7)
    second, its 4 more parameters explaining under 5 % more (measured 9.3 sigma^2 of 254). The
    spring explains the truth exactly, so that difference is the noncentrality of joint:all
    against the truth, which only grows with rows: at any subset of these postures it is at
    most 9.3 sigma^2 (plus 4 expected from the noise in the 4 more parameters), short of what
    4 parameters cost in the log p ranking (8 to 10 sigma^2 for log10 p from -3 to -5; with the
    truth known, 10 postures chosen greedily reach 1.5 sigma^2). A plan cannot change that; a
    truth the joint compliances cannot mimic would be a different case."""
    seed, data, rng = tied_cases(robot, 1)[0]
    full = joined(robot, data, postures(robot, 200, rng), rng)
    full.xyz = predict(robot.truth, full, robot.truth.theta0)["pred"]  # noise-free
    dg = diagnose_absolute(robot.model, full)
    lab = ranks(dg)
    assert lab[:2] == ["joint:all", TRUE], lab[:4]
    top, spring = dg.candidates[0], dg.candidates[1]
    assert (top.dof, spring.dof) == (3, 7)
    assert 0 < spring.statistic - top.statistic < 0.05 * spring.statistic
    assert spring.statistic - top.statistic < 10.0


def test_diagnose_names_the_plan_command_on_a_tie(robot):
    """A tie of the absolute diagnosis (text and JSON) names `stiffkit plan --discriminate`
    with K = the postures measured (within 5..30); the tie as reported goes to plan_discriminate."""
    from stiffkit.calib.absolute_diagnose_report import format_absolute_diagnosis
    from stiffkit.calib.plan_hint import plan_command

    # the first data seed (from 130) whose 18 rows tie two candidates
    for seed in range(130, 190):
        rng = np.random.default_rng(seed)
        data = measure(robot, postures(robot, 9, rng), rng)
        dg = diagnose_absolute(robot.model, data)
        if len(dg.ties) == 1:
            break
    assert len(dg.ties) == 1, "no seed in 130..189 gives one tie"
    want = "stiffkit plan MODEL.toml --discriminate --measured synthetic --select 9"
    tie = dg.to_json()["ties"][0]
    assert tie["plan_command"] == want and tie["plan_select"] == 9
    assert f"  postures that would tell them apart: {want}" in format_absolute_diagnosis(dg).splitlines()
    plan = plan_discriminate(robot.model, data, dg.ties[0], postures(robot, 20, rng), 4)
    assert plan["hypotheses"] == tie["candidates"] and len(set(plan["selected"].tolist())) == 4
    assert plan["value"] > 0
    assert plan_command("my cell/m.toml", "runs/a.csv", 2) == (
        "stiffkit plan 'my cell/m.toml' --discriminate --measured runs/a.csv --select 5",
        5,
    )
    assert plan_command(None, None, 80)[1] == 30
