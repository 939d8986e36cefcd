"""Identification on absolute (tracker) data (docs/calibration.md section 6):
exact recovery and the rank of what is dropped on a small tree with a mimic
joint, the calibration story of the synthetic dual-arm robot, the writers'
round trips, and bad inputs named in one line."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import stiffkit
from stiffkit._core import tree as core
from stiffkit.calib import absolute_fit as AF
from stiffkit.calib import dualarm as D
from stiffkit.calib.absolute_data import AbsoluteData, read_absolute
from stiffkit.calib.absolute_fit import fit_absolute, predict, reduce_parameters
from stiffkit.calib.absolute_write import folded_origins, write_model, write_urdf
from stiffkit.robot.tree import load_tree
from stiffkit.robot.tree_model import load_tree_model, tree_model_from_tables

# -- a small tree: torso yaw, a pitch and its mimic (chest kept upright), two 3R arms

SMALL_JOINTS = [
    ("waist", "revolute", "base_link", "torso", (0, 0, 0.5), (0, 0, 0), (0, 0, 1), None),
    ("pitch", "revolute", "torso", "torso2", (0, 0, 0.3), (0, 0, 0), (0, 1, 0), None),
    ("pitch_m", "revolute", "torso2", "chest", (0, 0, 0.3), (0, 0, 0), (0, 1, 0), ("pitch", -1.0, 0.0)),
]
for _s, _y in (("l", 1.0), ("r", -1.0)):
    SMALL_JOINTS += [
        (f"{_s}_1", "revolute", "chest", f"{_s}1", (0, 0.2 * _y, 0.3), (0, 0, 0), (0, 1, 0), None),
        (f"{_s}_2", "revolute", f"{_s}1", f"{_s}2", (0, 0.05 * _y, 0), (0, 0, 0), (_y, 0, 0), None),
        (f"{_s}_3", "revolute", f"{_s}2", f"{_s}3", (0.02, 0, -0.3), (0, 0, 0), (0, 1, 0), None),
        (f"{_s}_tool", "fixed", f"{_s}3", f"{_s}_tcp", (0, 0, -0.25), (0.3, 0, 0), (0, 0, 1), None),
    ]
SMALL_LINKS = {
    "torso": (10.0, (0.0, 0.0, 0.15)),
    "torso2": (8.0, (0.0, 0.0, 0.15)),
    "chest": (12.0, (0.02, 0.0, 0.2)),
    **{f"{s}1": (2.0, (0.0, 0.0, -0.05)) for s in "lr"},
    **{f"{s}2": (2.0, (0.0, 0.0, -0.15)) for s in "lr"},
    **{f"{s}3": (1.5, (0.03, 0.02, -0.12)) for s in "lr"},  # off the axis: every tilt is loaded
}
SMALL_RANGES = [(-1.0, 1.0), (-0.3, 0.6)] + [(-2.5, 0.5), (-0.3, 1.3), (-2.0, 0.0)] * 2
TRACKER = {"xyz": [2.5, -0.3, -0.9], "rpy": [0.01, -0.02, 2.9]}
MARKERS = {"l_tcp": [0.02, 0.01, 0.03], "r_tcp": [0.025, -0.01, 0.03]}
KINDS = ("joint_offset", "frame", "joint", "lateral")


def small_urdf(tmp_path):
    p = tmp_path / "small.urdf"
    p.write_text(D.dualarm_urdf(SMALL_JOINTS, SMALL_LINKS, name="small"))
    return p


def small_effects(values: dict | None = None, start=True) -> list[dict]:
    eff = [{"kind": "tracker", **(TRACKER if start else {})}]
    eff += [{"kind": "marker", "target": f, **({"xyz": p} if start else {})} for f, p in MARKERS.items()]
    return eff + [{"kind": k, "target": "all"} for k in KINDS]


def rows(model, Q, theta, etol=1e-9) -> AbsoluteData:
    """Both markers measured at every posture, exactly (no noise)."""
    n, nm = Q.shape[0], len(model.frames)
    data = AbsoluteData(
        path="small.csv",
        joints=model.actuated,
        configs=[f"c{k}" for k in range(n)],
        Q=Q,
        posture=np.repeat(np.arange(n), nm),
        frame=np.tile(np.arange(nm), n),
        frames=list(model.frames),
        xyz=np.zeros((n * nm, 3)),
        weight=np.ones(n * nm),
        lines=np.arange(n * nm) + 2,
    )
    ev = core.evaluate(
        model.packed,
        theta,
        Q,
        None,
        data.posture,
        data.frame,
        data.xyz,
        data.weight,
        np.zeros(0, int),
        model.eqit,
        etol,
    )
    data.xyz = ev["pred"]
    return data


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """The small tree, its truth (values on the identifiable parameters, 0
    on the others, chosen from the reduction at the nominal start), and
    noise-free data at 60 postures."""
    tmp = tmp_path_factory.mktemp("small")
    tree = load_tree(small_urdf(tmp))
    rng = np.random.default_rng(11)
    lo, hi = np.array(SMALL_RANGES).T
    Q = rng.uniform(lo, hi, (60, lo.size))
    nominal = tree_model_from_tables(tree, small_effects(), where="small")
    free = nominal.free
    jac = predict(nominal, rows(nominal, Q, nominal.theta0), nominal.theta0, free)["jac"]
    kept = set(reduce_parameters(nominal, jac, free).kept)
    truth = nominal.theta0.copy()
    scale = {"joint_offset": 0.01, "frame": 1.5e-3, "joint": 1e-4, "lateral": 5e-5}
    for i, p in enumerate(nominal.params):
        if p.kind in scale and i in kept:
            draw = rng.uniform(0.5, 1.5) if p.kind in ("joint", "lateral") else rng.normal()
            truth[i] = scale[p.kind] * draw
    data = rows(nominal, Q, truth, etol=1e-14)
    # the user's model: no tracker start (Procrustes), markers from the drawing
    user = small_effects(start=False)
    for e in user:
        if e["kind"] == "marker":
            e["xyz"] = [round(v, 2) for v in MARKERS[e["target"]]]
    model = tree_model_from_tables(tree, user, where="small")
    model.path = tmp / "model.toml"
    # the equilibrium to round-off: at the default 1e-9 m its truncation, not
    # the identification, would limit the recovery of the weakest compliances
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(AF, "EQ_TOL", 1e-14)
        fit = fit_absolute(model, data)
    return dict(tmp=tmp, tree=tree, nominal=nominal, truth=truth, data=data, fit=fit, jac=jac, free=free)


def test_noise_free_recovery_of_every_identifiable_parameter(small):
    fit, truth, nominal = small["fit"], small["truth"], small["nominal"]
    assert fit.converged and fit.rms_position < 1e-11
    # the tracker pose (its angles are re-centred by the fit): rotation and translation
    R, t = fit.model.tracker_pose(fit.theta)
    R0, t0 = nominal.tracker_pose(truth)
    assert np.abs(R - R0).max() < 1e-10 and np.abs(t - t0).max() < 1e-10 * np.linalg.norm(t0)
    # every other kept parameter, relative to the larger of its value and its kind's typical value
    kept = [i for i in fit.reduction.kept if fit.model.params[i].kind != "tracker"]
    typical = {}
    for i in kept:
        typical.setdefault(fit.model.params[i].kind, []).append(truth[i])
    typical = {k: np.sqrt(np.mean(np.square(v))) for k, v in typical.items()}
    worst = max(abs(fit.theta[i] - truth[i]) / max(abs(truth[i]), typical[fit.model.params[i].kind]) for i in kept)
    assert worst < 1e-8
    # every kind is represented, the mimic follower's own offset is identified
    kinds = {fit.model.params[i].kind for i in fit.reduction.kept}
    assert kinds == {"tracker", "marker", *KINDS}
    assert fit.model.index("pitch_m.dq0") in fit.reduction.kept


def test_dropped_parameters_are_exactly_the_non_identifiable_ones(small):
    """The kept columns span the full scaled Jacobian: as many as its
    numerical rank (SVD, with a clean gap), and each dropped column lies in
    their span (adding it back does not raise the rank)."""
    fit, jac, free = small["fit"], small["jac"], small["free"]
    assert not fit.reduction.merged
    norms = np.linalg.norm(jac, axis=0)
    live = norms > 1e-9 * norms.max()
    s = np.linalg.svd(jac[:, live] / norms[live], compute_uv=False)
    s = s / s[0]
    rank = int(np.sum(s > 1e-9))
    assert s[rank - 1] > 1e-6 and (rank == s.size or s[rank] < 1e-12)  # the rank does not hang on 1e-9
    col = {int(i): k for k, i in enumerate(free)}
    kept = [col[int(i)] for i in fit.reduction.kept]
    U, sk, _ = np.linalg.svd(jac[:, kept] / norms[kept], full_matrices=False)
    assert len(kept) == rank and sk[-1] / sk[0] > 1e-6
    names = [n for n, _why in fit.reduction.dropped if live[col[fit.model.index(n)]]]
    a = np.column_stack([jac[:, c] / norms[c] for c in (col[fit.model.index(n)] for n in names)])
    off_span = np.linalg.norm(a - U @ (U.T @ a), axis=0)  # what a dropped column would add to the rank
    assert off_span.max() < 1e-9, [n for n, o in zip(names, off_span) if o >= 1e-9]


# -- the dual-arm story


def rows_and_header(path):
    lines = path.read_text().splitlines()
    return len(lines) - 1, lines[0].split(",")


def test_dualarm_story_falls_to_the_noise_floor(tmp_path):
    out = stiffkit.calib.synth_dualarm(tmp_path / "da", seed=5)
    for f in D.OUTPUT_FILES:
        assert (out / f).is_file()
    start = load_tree_model(out / "model.toml")
    assert [e["kind"] for e in start.effects] == ["tracker", "marker", "marker"] and start.sigma_position is None
    mimic = {j.name: j.mimic[0] for j in start.tree.joints if j.mimic}
    data = read_absolute(out / "measurements.csv", start.actuated, start.frames, mimic)
    assert data.n_postures == D.DEFAULT_CONFIGS and data.n == 2 * D.DEFAULT_CONFIGS
    assert rows_and_header(out / "targets.csv") == (2 * D.DEFAULT_TARGETS, ["config", *start.actuated, "frame"])
    effects, rms = list(start.effects), []
    for kind in (None, *D.STORY):
        if kind:
            effects.append({"kind": kind, "target": "all"})
        model = tree_model_from_tables(start.tree, effects, start.gravity)
        fit = fit_absolute(model, data, cv=5 if kind == D.STORY[-1] else 0)
        rms.append(fit.rms_position)
    floor = math.sqrt(3) * D.DEFAULT_SIGMA
    assert all(b < 0.75 * a for a, b in zip(rms, rms[1:])), rms
    assert 15e-3 < rms[0] < 25e-3 and 2e-3 < rms[3] < 4e-3, rms  # the story: ~20 mm ... ~3 mm
    assert abs(rms[-1] / floor - 1) < 0.1
    assert abs(fit.cv["rms_position_m"] / rms[-1] - 1) < 0.1


# -- writers


def _same_points(model, data, theta, ref):
    return np.abs(predict(model, data, theta)["pred"] - ref).max()


def test_written_urdf_and_model_predict_the_fit(small):
    fit, data, tmp = small["fit"], small["data"], small["tmp"]
    ref = predict(fit.model, data, fit.theta)["pred"]
    assert write_model(fit, tmp / "fitted.toml") == []
    m = load_tree_model(tmp / "fitted.toml")
    assert m.free.size == 12  # the tracker and the markers keep theirs as start values
    assert _same_points(m, data, m.theta0, ref) < 1e-9
    write_urdf(fit, tmp / "out" / "fitted.urdf")
    write_model(fit, tmp / "out" / "folded.toml", folded_urdf=tmp / "out" / "fitted.urdf")
    folded = load_tree_model(tmp / "out" / "folded.toml")
    assert not folded.has("joint_offset") and not folded.has("frame") and folded.has("lateral")
    assert _same_points(folded, data, folded.theta0, ref) < 1e-9
    # everything but the folded origins is the original URDF's
    a = ET.parse(small["tree"].urdf).getroot()
    b = ET.parse(tmp / "out" / "fitted.urdf").getroot()
    assert [ET.tostring(x) for x in a.iter("link")] == [ET.tostring(x) for x in b.iter("link")]
    moved = set()
    for ja, jb in zip(a.iter("joint"), b.iter("joint")):
        assert [(c.tag, c.attrib) for c in ja if c.tag != "origin"] == [
            (c.tag, c.attrib) for c in jb if c.tag != "origin"
        ]
        if ja.find("origin").attrib != jb.find("origin").attrib:
            moved.add(ja.get("name"))
    assert moved == set(folded_origins(fit.model, fit.theta))
    assert {"pitch", "pitch_m", "l_1"} <= moved and not {"waist", "l_tool"} & moved  # theirs: the tracker's, l_3's


def test_written_model_with_springs_cubic_and_deadzone(small, tmp_path):
    """Every kind of value the writer knows, read back to the same points."""
    tree, data = small["tree"], small["data"]
    C = np.diag([2e-7, 3e-7, 1e-7, 4e-6, 5e-6, 3e-6])
    C[0, 4] = C[4, 0] = 1e-7
    values = [
        {"kind": "joint_cubic", "target": "l_1", "value": 2e-9},
        {"kind": "joint", "target": "l_1", "value": 1e-4},
        {"kind": "joint", "target": "r_1", "value": 5e-5},
        {"kind": "joint", "target": "l_3", "value": 2e-4},
        {"kind": "joint_deadzone", "target": "r_1", "value": 3e-4, "tau0": 2.0},
        {"kind": "joint_deadzone", "target": "l_3", "value": 1e-4},
        {"kind": "lateral", "target": "pitch", "value": [3e-5, 4e-5]},
        {"kind": "joint_offset", "target": "pitch_m", "value": 0.01},
        {"kind": "frame", "target": "r_2", "value": [1e-3, -2e-3, 0.5e-3, 1e-3, 2e-3, -1e-3]},
        {"kind": "link", "target": "l2", "value": C.tolist()},
        {"kind": "base", "value": (0.1 * C).tolist()},
    ]
    model = tree_model_from_tables(tree, small_effects()[:3] + values, where="t")
    model.path = tmp_path / "m.toml"
    fit = fit_absolute(model, data)
    assert fit.reduction.kept.size == 12  # the tracker and the markers
    ref = predict(fit.model, data, fit.theta)["pred"]
    write_model(fit, tmp_path / "w.toml")
    back = load_tree_model(tmp_path / "w.toml")
    assert back.free.size == 12 and back.names == fit.model.names
    assert _same_points(back, data, back.theta0, ref) < 1e-9


# -- bad inputs: one line naming the file and what is wrong


@pytest.fixture(scope="module")
def da(tmp_path_factory):
    out = stiffkit.calib.synth_dualarm(tmp_path_factory.mktemp("bad") / "da", configs=6, targets=2)
    model = load_tree_model(out / "model.toml")
    mimic = {j.name: j.mimic[0] for j in model.tree.joints if j.mimic}
    return out, model, mimic, (out / "measurements.csv").read_text().splitlines()


def one_line(exc, path) -> str:
    msg = str(exc.value)
    assert "\n" not in msg and str(path) in msg, msg
    return msg


def test_bad_marker_frame(da):
    out, *_ = da
    p = out / "m_marker.toml"
    p.write_text((out / "model.toml").read_text().replace('target = "left_tcp"', 'target = "left_tool"'))
    with pytest.raises(stiffkit.InputError) as exc:
        load_tree_model(p)
    assert "'left_tool'" in one_line(exc, p) and "must be a link" in str(exc.value)


@pytest.mark.parametrize(
    "op, column, fragment",
    [
        ("drop", "left_3", "missing joint column(s) left_3"),
        ("rename", "torso_3", "missing joint column(s) torso_3"),
        ("add", "torso_3", "column 'torso_4a' is a mimic joint (it follows 'torso_2')"),
    ],
)
def test_bad_joint_columns(da, op, column, fragment):
    out, model, mimic, lines = da
    table = [ln.split(",") for ln in lines]
    k = table[0].index(column)
    for n, row in enumerate(table):
        if op == "drop":
            del row[k]
        elif op == "rename" and n == 0:
            row[k] = "torso_9"
        elif op == "add":
            row.insert(k + 1, "torso_4a" if n == 0 else "0")
    p = out / f"cols_{op}.csv"
    p.write_text("\n".join(",".join(row) for row in table) + "\n")
    with pytest.raises(stiffkit.InputError) as exc:
        read_absolute(p, model.actuated, model.frames, mimic)
    assert fragment in one_line(exc, p)


def test_a_mimic_column_is_checked_against_its_law(da):
    """joint_states lists mimic joints too: a column for one that follows
    the URDF's <mimic> law is read as a check (warned), one that strays from
    it is an error naming the line, the values and the law."""
    out, model, _mimic, lines = da
    laws = {j.name: model.tree.leader(j.name) for j in model.tree.joints if j.mimic}
    lead, mult, off = laws["torso_4a"]
    table = [ln.split(",") for ln in lines]
    k = table[0].index(lead)
    for n, row in enumerate(table):
        row.append("torso_4a" if n == 0 else repr(mult * float(row[k]) + off))
    p = out / "mimic_ok.csv"
    p.write_text("\n".join(",".join(row) for row in table) + "\n")
    good = read_absolute(out / "measurements.csv", model.actuated, model.frames, laws)
    data = read_absolute(p, model.actuated, model.frames, laws)
    np.testing.assert_array_equal(data.Q, good.Q)
    assert any("'torso_4a' of mimic joint(s) agree" in w for w in data.warnings)
    table[3][-1] = repr(float(table[3][-1]) + 0.01)
    p.write_text("\n".join(",".join(row) for row in table) + "\n")
    with pytest.raises(stiffkit.InputError) as exc:
        read_absolute(p, model.actuated, model.frames, laws)
    msg = one_line(exc, p)
    assert "line 4: column 'torso_4a' is a mimic joint (it follows 'torso_2')" in msg and "<mimic> law" in msg


def test_bad_negative_mass(da):
    out, *_ = da
    u = out / "neg.urdf"
    u.write_text((out / "robot.urdf").read_text().replace('<mass value="16"', '<mass value="-16"'))
    p = out / "m_neg.toml"
    p.write_text((out / "model.toml").read_text().replace('urdf = "robot.urdf"', 'urdf = "neg.urdf"'))
    with pytest.raises(stiffkit.InputError) as exc:
        load_tree_model(p)
    assert "link 'chest' has mass -16.0" in one_line(exc, u)


def test_bad_points_in_mm(da):
    out, model, mimic, lines = da
    mm = [lines[0]]
    for ln in lines[1:]:
        c = ln.split(",")
        mm.append(",".join(c[:-3] + [repr(1000 * float(x)) for x in c[-3:]]))
    p = out / "mm.csv"
    p.write_text("\n".join(mm) + "\n")
    data = read_absolute(p, model.actuated, model.frames, mimic)
    assert any("millimetres" in w for w in data.warnings)
    with pytest.raises(stiffkit.InputError) as exc:
        fit_absolute(model, data)
    msg = one_line(exc, p)
    assert "tracker start failed" in msg and "in mm?" in msg


def test_bad_fewer_configurations_than_folds(da):
    out, model, mimic, _lines = da
    data = read_absolute(out / "measurements.csv", model.actuated, model.frames, mimic)
    with pytest.raises(stiffkit.InputError) as exc:
        fit_absolute(model, data, cv=7)
    assert "6 configurations for 7 cross-validation folds" in one_line(exc, out / "measurements.csv")


def test_bad_one_configuration_two_postures(da):
    out, model, mimic, lines = da
    row = lines[2].split(",")
    row[5] = "0.123"
    p = out / "two.csv"
    p.write_text("\n".join(lines[:2] + [",".join(row)] + lines[3:]) + "\n")
    with pytest.raises(stiffkit.InputError) as exc:
        read_absolute(p, model.actuated, model.frames, mimic)
    assert "line 3: configuration 'p0001' has other joint values than on line 2" in one_line(exc, p)


def test_fewer_coordinates_than_the_frames_parameters_is_named(tmp_path, capsys):
    """3 tracker points (9 coordinates) cannot fix the tracker and two markers
    (12 parameters): one line naming the file and the minimum, not the core's
    'arrays are inconsistent' (its size check of the LM's rows)."""
    from stiffkit.cli.app import main

    assert main(["synth", "dualarm", "--out", str(tmp_path / "d"), "--configs", "3", "--seed", "1"]) == 0
    lines = (tmp_path / "d" / "measurements.csv").read_text().splitlines()
    meas = tmp_path / "m3.csv"
    meas.write_text("\n".join(lines[:4]) + "\n")
    capsys.readouterr()
    assert main(["fit", str(tmp_path / "d" / "model.toml"), str(meas)]) == 2
    err = capsys.readouterr().err
    assert f"{meas}: 3 point(s) give 9 coordinates, fewer than the 12 parameters of the tracker and markers" in err
    assert "measure at least 4 points" in err
    # 4 points (12 coordinates) are enough for the start
    meas.write_text("\n".join(lines[:5]) + "\n")
    assert main(["fit", str(tmp_path / "d" / "model.toml"), str(meas)]) == 0
