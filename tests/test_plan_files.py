"""What stiffkit plan writes, read back by stiffkit with the same numbers
(issue 19): the Python result's table is POSTURES.csv; the CSV filled in
with measurements is read by ``stiffkit fit``, whose standard errors are the
plan's expected standard deviations (deflection data: the same linear
least squares, to round-off; tracker data: the nonlinear fit's Jacobian at
its solution, to 1e-3)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from _plan_robots import P, kr_files

import stiffkit
from stiffkit.calib.absolute_fit import predict
from stiffkit.calib.plan_report import plan_json, plan_text, postures_text
from stiffkit.cli.app import main


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    root = tmp_path_factory.mktemp("plan_files")
    kr_files(root / "kr")
    assert main(["synth", "dualarm", "--out", str(root / "da")]) == 0
    return root


def _filled(path, values) -> list[str]:
    """POSTURES.csv with its last three (empty) columns filled by ``values`` (n, 3)."""
    lines = path.read_text().splitlines()
    assert all(ln.endswith(",,,") for ln in lines[1:])
    return [lines[0]] + [ln[:-3] + "," + ",".join(f"{v:.17g}" for v in x) for ln, x in zip(lines[1:], values)]


def _cells(table: list[dict]) -> list[list[str]]:
    return [["" if isinstance(v, float) and math.isnan(v) else (v if isinstance(v, str) else f"{v:.17g}")
             for v in row.values()] for row in table]  # fmt: skip


@pytest.mark.parametrize("robot", ["kr", "da"])
def test_python_result_is_the_command_s_table_and_report(ws, robot, tmp_path, capsys):
    model = ws / robot / "model.toml"
    argv = ["plan", str(model), "--select", "6", "--candidates", "80", "--seed", "5"]
    argv += ["--out", str(tmp_path / "p.csv"), "--json", str(tmp_path / "p.json")]
    assert main(argv) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    res = stiffkit.plan(model, 6, candidates=80, seed=5)
    table = res.table()
    if not isinstance(table, list):  # pandas installed: the DataFrame's records
        table = table.to_dict("records")
    lines = (tmp_path / "p.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert all(list(r) == header for r in table) and len(table) == len(lines) - 1
    assert _cells(table) == [ln.split(",") for ln in lines[1:]]  # every number to the last digit
    assert res.text() == plan_text(res) and res.text() in printed
    assert res.to_json() == plan_json(res)
    assert json.loads((tmp_path / "p.json").read_text()) == json.loads(json.dumps(plan_json(res)))
    assert res.write(tmp_path / "again.csv").read_text() == postures_text(res) == "\n".join(lines) + "\n"
    # the report's chosen joint values are the table's
    joints = res.setup.joint_names
    first = {r["config"]: r for r in reversed(table)}
    cols = joints if robot == "da" else [f"q{i + 1}" for i in range(len(joints))]
    for sel in res.to_json()["selected"]:
        assert [sel["q"][j] for j in joints] == [first[sel["config"]][c] for c in cols]


def test_fit_of_the_planned_deflections_has_the_planned_std(ws, tmp_path, capsys):
    """KR-270-like, deflection data: POSTURES.csv filled with noise (the
    model's values are zero: the data are noise alone), fitted by ``stiffkit
    fit --reduce`` (the reduction the plan plans for): each identified
    parameter's standard error is the plan's expected standard deviation
    (both sqrt diag (J^T W J)^-1 at the declared sigma)."""
    model = ws / "kr" / "model.toml"
    out, rep = tmp_path / "p.csv", tmp_path / "p.json"
    # 10 postures x 3 coordinates: as many observations as the model's 30 free parameters, what fit needs
    assert (
        main(["plan", str(model), "--select", "10", "--candidates", "120", "--out", str(out), "--json", str(rep)]) == 0
    )
    plan = json.loads(rep.read_text())
    n = len(out.read_text().splitlines()) - 1
    noise = plan["sigma_position_m"] * np.random.default_rng(3).normal(size=(n, 3))
    (tmp_path / "m.csv").write_text("\n".join(_filled(out, noise)) + "\n")
    capsys.readouterr()
    assert main(["fit", str(model), str(tmp_path / "m.csv"), "--reduce", "--json", str(tmp_path / "f.json")]) == 0
    fit = {p["name"]: p for p in json.loads((tmp_path / "f.json").read_text())["parameters"]}
    assert len(plan["parameters"]) == plan["identifiable"] > 10
    for p in plan["parameters"]:
        assert fit[p["name"]]["group"] == "identifiable"
        assert fit[p["name"]]["std"] == pytest.approx(p["expected_std"], rel=1e-9), p["name"]
    # the fit's own reduction of these rows keeps what the plan planned for
    assert set(fit) == {p["name"] for p in plan["parameters"]}


def test_fit_of_the_planned_tracker_data_has_the_planned_std(ws, tmp_path, capsys):
    """Dual-arm, tracker data (tracker pose and two markers): POSTURES.csv
    filled with the model's own prediction plus noise, fitted by ``stiffkit
    fit``: the standard errors are the plan's expected standard deviations
    to 1e-3 (the fit's Jacobian is taken at its solution, sigma away from
    the start values the plan's is taken at)."""
    model = ws / "da" / "model.toml"
    out, rep = tmp_path / "p.csv", tmp_path / "p.json"
    argv = ["plan", str(model), "--select", "8", "--candidates", "150", "--sigma", "1e-4"]
    assert main([*argv, "--out", str(out), "--json", str(rep)]) == 0
    plan = json.loads(rep.read_text())
    m = P.load_plan_model(model)
    Q, t = P.read_postures(out, m.actuated, "postures", P._mimics(m))
    data = P._abs_data(m, Q, np.array([m.frames.index(f) for f in t.text("frame")]))
    xyz = predict(m, data, m.theta0)["pred"] + 1e-4 * np.random.default_rng(4).normal(size=(Q.shape[0], 3))
    (tmp_path / "m.csv").write_text("\n".join(_filled(out, xyz)) + "\n")
    capsys.readouterr()
    assert (
        main(["fit", str(model), str(tmp_path / "m.csv"), "--sigma", "1e-4", "--json", str(tmp_path / "f.json")]) == 0
    )
    fit = {p["name"]: p for p in json.loads((tmp_path / "f.json").read_text())["parameters"]}
    assert plan["identifiable"] == 12
    for p in plan["parameters"]:
        assert fit[p["name"]]["std"] == pytest.approx(p["expected_std"], rel=1e-3), p["name"]


def test_deflection_plan_says_how_fit_takes_it(ws):
    """The KR-270-like model has 30 free parameters; the plan is for the
    reduced ones (fit --reduce), and 8 postures x 3 coordinates = 24 are
    fewer observations than fit takes: the report says so, with the minimum."""
    model = ws / "kr" / "model.toml"
    setup = P.build_setup(model, candidates=120)
    assert setup.free_parameters == 30 and setup.npar < 30 and setup.nobs == 3
    notes = P.plan(None, 8, "D", setup=setup).notes
    assert len(notes) == 2
    assert f"the {setup.npar} parameters the fit's reduction keeps" in notes[0] and "--reduce" in notes[0]
    assert "the model's 30 free parameters, and 8 x 3 = 24 are fewer: measure at least --select 10" in notes[1]
    assert len(P.plan(None, 10, "D", setup=setup).notes) == 1
    assert P.plan(None, 10, "D", setup=setup).to_json()["notes"] == notes[:1]


def test_from_list_names_the_postures_left_out(ws, tmp_path):
    """--from: a posture outside the [plan] limits is left out, named in one
    warning by the file's row and line; rows of one posture count once; K
    beyond the feasible ones says to add postures (not --candidates)."""
    folder = tmp_path / "kr"
    kr_files(folder, extra="limits = { joint_a2 = [-1.5, -0.2] }\n")
    head = "config,q1,q2,q3,q4,q5,q6,fx,fy,fz,mx,my,mz"
    rows = [
        "a,0.1,-0.6,0.4,0.0,1.1,0.0,0,0,-100,0,0,0",
        "a,0.1,-0.6,0.4,0.0,1.1,0.0,100,0,0,0,0,0",  # the same posture under another load
        "b,0.3,0.1,0.2,0.5,1.0,0.3,0,0,-100,0,0,0",  # q2 above -0.2
        "c,-0.4,-0.8,0.6,-0.5,0.9,-0.3,0,0,-100,0,0,0",
        "d,0.2,-1.7,0.1,0.2,0.3,0.4,0,0,-100,0,0,0",  # q2 below -1.5
        "e,0.5,-1.1,0.9,0.7,-0.6,0.2,0,0,-100,0,0,0",
    ]
    (tmp_path / "mine.csv").write_text("\n".join([head, *rows]) + "\n")
    with pytest.warns(stiffkit.StiffkitWarning) as rec:
        setup = P.build_setup(folder / "model.toml", postures=tmp_path / "mine.csv")
    msgs = [str(w.message) for w in rec]
    assert len(msgs) == 1, msgs
    assert (
        "mine.csv: 2 of 5 postures left out (not feasible): row 3 (line 4): joint limit (joint joint_a2 = 0.1"
        in msgs[0]
    )
    assert "row 5 (line 6): joint limit (joint joint_a2 = -1.7" in msgs[0]
    kept = [[0.1, -0.6, 0.4, 0.0, 1.1, 0.0], [-0.4, -0.8, 0.6, -0.5, 0.9, -0.3], [0.5, -1.1, 0.9, 0.7, -0.6, 0.2]]
    np.testing.assert_array_equal(setup.candidates.q, kept)
    assert setup.jc.shape[0] == 3 * 4  # each posture under the 4 [plan] loads
    with pytest.raises(stiffkit.InputError, match=r"--select 13: only 12 \(posture, load\) candidates .*; add "
                       r"postures to the --from list or loosen \[plan\]$"):  # fmt: skip
        P.plan(None, 13, "D", setup=setup)
    # two postures x 4 loads x 3 coordinates = 24 < the 30 free parameters: no reduction can tell
    with pytest.warns(stiffkit.StiffkitWarning), pytest.raises(
        stiffkit.InputError, match=r"2 candidate postures x 4 \[plan\] loads x 1 point\(s\) give 24 observations for "
        r"the model's 30 free parameters: too few to tell which are identifiable; give more postures \(the --from"
    ):  # fmt: skip
        P.build_setup(folder / "model.toml", postures=np.array(kept[:2] + [[0.2, -1.7, 0.1, 0.2, 0.3, 0.4]]))


PTS = [[0.0, 0.0, 0.25], [0.12, 0.0, 0.2]]


def test_points_from_the_plan_table_or_the_measured_rows(ws, tmp_path):
    """Deflection data: the points measured on the tool come from [plan]
    points, else from the rows already measured (--measured), else the tool
    origin; each candidate then has 3 rows per point, and POSTURES.csv a row
    per (posture, load) and point that fit reads back with those points."""
    from stiffkit.calib.measure import read_measurements

    folder = tmp_path / "kr"
    kr_files(folder, extra=f"points = {PTS}\n")
    res = stiffkit.plan(folder / "model.toml", 5, "D", candidates=60, seed=1)
    s = res.setup
    assert s.nobs == 6 and s.points.tolist() == PTS and s.points_source.endswith("[plan] points")
    assert "2 point(s) measured on the tool in each" in res.text() and res.to_json()["points"] == PTS
    res.write(tmp_path / "p.csv")
    lines = (tmp_path / "p.csv").read_text().splitlines()
    (tmp_path / "m.csv").write_text("\n".join([lines[0]] + [ln[:-3] + ",0,0,0" for ln in lines[1:]]) + "\n")
    meas = read_measurements(tmp_path / "m.csv", 6)
    assert meas.n == 5 * 2 and meas.p.tolist() == PTS * 5
    np.testing.assert_array_equal(meas.q, np.repeat(s.candidates.q[s.posture[res.selected]], 2, axis=0))
    # no [plan] points: those of the measured rows (here the plan's own file), in their order
    s2 = P.build_setup(ws / "kr" / "model.toml", candidates=60, seed=1, measured=tmp_path / "m.csv")
    assert s2.points.tolist() == PTS and s2.nobs == 6 and s2.points_source == f"the points of {tmp_path / 'm.csv'}"
    s3 = P.build_setup(ws / "kr" / "model.toml", candidates=60, seed=1)
    assert s3.points.tolist() == [[0.0, 0.0, 0.0]] and s3.nobs == 3


@pytest.mark.parametrize(
    ("kind", "line", "match"),
    [
        ("kr", "points = [[0, 0, 0.25], [0, 0, 0.25]]", r"\[plan\] points\[1\] = \[0, 0, 0.25\] repeats points\[0\]"),
        ("kr", "points = [0, 0, 0.25]", r"\[plan\] points must be a list of \[x, y, z\]"),
        ("kr", "points = [[0, 0]]", r"\[plan\] points\[0\] must have shape \(3,\)"),
        ("kr", "points = [[0, nan, 0]]", r"\[plan\] points\[0\]\[1\] is nan"),
        ("da", "points = [[0, 0, 0.25]]", r"\[plan\] points: points are for deflection data"),
    ],
)
def test_bad_points_are_named(ws, tmp_path, kind, line, match):
    folder = tmp_path / kind
    if kind == "kr":
        kr_files(folder, extra=line + "\n")
    else:
        folder.mkdir()
        for f in ("robot.urdf", "model.toml"):
            (folder / f).write_text((ws / "da" / f).read_text())
        with open(folder / "model.toml", "a") as fh:
            fh.write(f"\n[plan]\n{line}\n")
    with pytest.raises(stiffkit.InputError, match=match):
        P.build_setup(folder / "model.toml", candidates=20)


def test_a_load_given_twice_is_named(tmp_path):
    from _plan_robots import KR_MODEL

    text = KR_MODEL.format(extra="").replace("[0, 0, 0, 300, 0, 0]]", "[0, 0, 0, 300, 0, 0], [2500, 0, 0, 0, 0, 0]]")
    kr_files(tmp_path)
    (tmp_path / "model.toml").write_text(text)
    with pytest.raises(stiffkit.InputError, match=r"\[plan\] loads\[4\] = \[2500, 0, 0, 0, 0, 0\] repeats "
                       r"\S+ \[plan\] loads\[1\]: give each load once"):  # fmt: skip
        P.build_setup(tmp_path / "model.toml", candidates=20)


def test_measured_alone_is_reported(ws, tmp_path):
    """--measured: the report gives the expected task error of the rows
    already measured alone, sqrt(trace(Jt M0^-1 Jt^T) / points) (numpy
    here), above the plan's that adds to them."""
    model = ws / "kr" / "model.toml"
    first = stiffkit.plan(model, 12, "D", candidates=80, seed=2)
    lines = postures_text(first).splitlines()
    (tmp_path / "m.csv").write_text("\n".join([lines[0]] + [ln[:-3] + ",0,0,0" for ln in lines[1:]]) + "\n")
    res = stiffkit.plan(model, 3, "D", candidates=80, seed=2, measured=tmp_path / "m.csv")
    s = res.setup
    assert s.measured_rows == 12 and first.measured_task_rms is None
    want = math.sqrt(np.trace(s.jt @ np.linalg.solve(s.m0, s.jt.T)) / (s.jt.shape[0] / 3))
    assert res.measured_task_rms == pytest.approx(want, rel=1e-9)
    assert res.task_rms < res.measured_task_rms
    assert f"the 12 rows already measured alone: {want * 1e3:.4g} mm" in res.text()
    assert res.to_json()["task"]["measured_alone_rms_position_m"] == pytest.approx(want, rel=1e-9)


def test_k_too_small_gives_the_minimum(ws):
    """observations per candidate x K < identifiable parameters: the message
    gives the minimum K = ceil(identifiable / observations), which plans."""
    setup = P.build_setup(ws / "kr" / "model.toml", candidates=60, seed=3)
    kmin = math.ceil(setup.npar / setup.nobs)
    assert setup.nobs == 3 and kmin >= 5
    with pytest.raises(stiffkit.InputError) as exc:
        P.plan(None, kmin - 1, "D", setup=setup)
    assert str(exc.value) == (
        f"--select {kmin - 1}: {kmin - 1} x 3 observations per candidate = {3 * (kmin - 1)} < {setup.npar} "
        f"identifiable parameters: the minimum is --select {kmin}"
    )
    assert P.plan(None, kmin, "D", setup=setup).k == kmin


def test_task_rows_of_one_posture_are_one_task_posture(ws, tmp_path):
    """A task file with a row per posture and marker (targets.csv of the
    dual-arm: 50 postures x 2 markers) or per posture and load (deflection):
    the expected error per task posture (report, --png) is over the distinct
    postures, sqrt of the mean of their points' variances (numpy here)."""
    res = stiffkit.plan(ws / "da" / "model.toml", 6, candidates=80, seed=5, task=ws / "da" / "targets.csv")
    s = res.setup
    assert s.task_q.shape[0] == 50 and s.jt.shape[0] == 3 * 100 and res.task_posture_rms.size == 50
    A = s.jc[res.selected].reshape(-1, s.npar)
    var = np.einsum("ij,ji->i", s.jt, np.linalg.solve(A.T @ A, s.jt.T)).reshape(100, 3).sum(axis=1)
    per = np.sqrt(var.reshape(50, 2).mean(axis=1))  # the file's rows: posture-major, both markers
    np.testing.assert_allclose(res.task_posture_rms, per, rtol=1e-8)
    assert res.to_json()["task"]["postures"] == 50 and res.to_json()["task"]["points"] == 100
    # deflection: two postures, each under two task loads
    head = "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,fx,fy,fz,mx,my,mz"
    q1, q2 = "0.1,-0.6,0.4,0.0,1.1,0.0", "-0.4,-0.8,0.6,-0.5,0.9,-0.3"
    rows = [f"{q1},0,0,-2000,0,0,0", f"{q1},1000,0,0,0,0,0", f"{q2},0,0,-2000,0,0,0", f"{q2},1000,0,0,0,0,0"]
    (tmp_path / "task.csv").write_text("\n".join([head, *rows]) + "\n")
    r2 = stiffkit.plan(ws / "kr" / "model.toml", 10, candidates=60, seed=1, task=tmp_path / "task.csv")
    assert r2.setup.task_q.shape == (2, 6) and r2.task_posture_rms.size == 2
    pts = np.bincount(r2.setup.task_of) / 3
    assert pts.tolist() == [2.0, 2.0]
    assert np.sum(r2.task_posture_rms**2 * pts) == pytest.approx(r2.task_trace, rel=1e-9)


@pytest.mark.parametrize("criterion", ["D", "A", "task"])
def test_reported_values_are_the_direct_ones_on_an_ill_conditioned_problem(ws, tmp_path, criterion):
    """KR-270-like, 60 postures x 4 loads, no prior: M is ill-conditioned
    when it just becomes regular and the low-rank updates lose digits (the
    task plan from the D start drifted 34 % before the core checked its
    value); the values the core returns and the plan reports are a direct
    evaluation's to 1e-9."""
    from stiffkit._core import design

    head = "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,fx,fy,fz,mx,my,mz"
    q1, q2 = "0.1,-0.6,0.4,0.0,1.1,0.0", "-0.4,-0.8,0.6,-0.5,0.9,-0.3"
    rows = [f"{q1},0,0,-2000,0,0,0", f"{q1},1000,0,0,0,0,0", f"{q2},0,0,-2000,0,0,0", f"{q2},1000,0,0,0,0,0"]
    (tmp_path / "task.csv").write_text("\n".join([head, *rows]) + "\n")
    setup = P.build_setup(ws / "kr" / "model.toml", candidates=60, seed=1, task=tmp_path / "task.csv")
    jt = setup.jt if criterion == "task" else None
    d = design.select(setup.jc, 10, "D")
    for start in (None, d.selected):
        res = design.select(setup.jc, 10, criterion, jt=jt, start=start)
        direct = design.criterion(setup.jc, res.selected, criterion, jt=jt)
        assert res.value == pytest.approx(direct, rel=1e-9)
        if start is not None:
            assert res.greedy_value == pytest.approx(design.criterion(setup.jc, start, criterion, jt=jt), rel=1e-9)
    plan = P.plan(None, 10, criterion, setup=setup)
    assert plan.value == pytest.approx(design.criterion(setup.jc, plan.selected, criterion, jt=jt), rel=1e-9)
    A = setup.jc[plan.selected].reshape(-1, setup.npar)
    assert plan.task_trace == pytest.approx(np.trace(setup.jt @ np.linalg.solve(A.T @ A, setup.jt.T)), rel=1e-8)


def test_too_few_sampled_candidates_are_warned(ws, tmp_path):
    """--candidates N when the tries run out first (a narrow view cone): a
    warning with how many were found of how many tried, and why."""
    folder = tmp_path / "da"
    folder.mkdir()
    for f in ("robot.urdf", "model.toml"):
        (folder / f).write_text((ws / "da" / f).read_text())
    with open(folder / "model.toml", "a") as fh:
        fh.write("\n[plan]\ntracker = { position = [3.0, 0.0, 1.0], direction = [-1.0, 0.0, -0.3], cone_deg = 20 }\n")
    with pytest.warns(stiffkit.StiffkitWarning) as rec:
        setup = P.build_setup(folder / "model.toml", candidates=100, seed=0)
    c = setup.candidates
    assert 0 < len(c) < 100 and c.tried == 10_000  # GIVE_UP tries (more than 20 per candidate)
    (msg,) = [str(w.message) for w in rec]
    assert msg.startswith(f"--candidates 100: only {len(c)} feasible of 10,000 tried (")
    assert f"{c.rejected['out of view']:,} out of view" in msg and msg.endswith("the plan chooses among these; "
                                                                             "loosen [plan] for more")  # fmt: skip


def test_diagnose_names_each_tie_in_its_plan_command():
    """Several ties: the first is what bare --discriminate plans for; the
    command of every other tie names its candidates, and the command line
    reads them back as the labels."""
    import shlex

    from stiffkit.calib.plan_hint import plan_command
    from stiffkit.cli.app import build_parser

    tied = ["link:l_link1", "joint:left_2"]
    cmd, k = plan_command("my cell/m.toml", "a.csv", 12, tied)
    assert k == 12
    assert cmd == "stiffkit plan 'my cell/m.toml' --discriminate link:l_link1,joint:left_2 --measured a.csv --select 12"
    args = build_parser().parse_args(shlex.split(cmd)[1:])
    assert args.model == "my cell/m.toml" and args.measured == "a.csv" and args.select == 12
    assert [s.strip() for s in args.discriminate.split(",")] == tied
    assert plan_command("m.toml", "a.csv", 12)[0] == "stiffkit plan m.toml --discriminate --measured a.csv --select 12"


def test_radius_of_a_link_with_urdf_shapes_is_warned(tmp_path):
    """[plan] radius of a link whose URDF has primitive collision shapes:
    the shapes are its capsules (unchanged), the radius is said to be unused."""
    from stiffkit.robot.plan_candidates import _Checks, plan_settings
    from stiffkit.robot.tree import load_tree
    from stiffkit.robot.tree_model import tree_model_from_tables

    (tmp_path / "r.urdf").write_text(
        '<robot name="r"><link name="base_link"/><link name="a">'
        '<collision><geometry><cylinder radius="0.05" length="0.4"/></geometry></collision></link><link name="b"/>'
        '<joint name="j" type="revolute"><parent link="base_link"/><child link="a"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        '<joint name="k" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.5 0 0"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    tm = tree_model_from_tables(
        load_tree(tmp_path / "r.urdf"), [{"kind": "tracker"}, {"kind": "marker", "target": "b"}]
    )
    tm.plan = {"radius": {"a": 0.2, "base_link": 0.1}}
    tm.path = tmp_path / "model.toml"
    with pytest.warns(stiffkit.StiffkitWarning) as rec:
        s = plan_settings(tm)
    (msg,) = [str(w.message) for w in rec]
    assert "[plan] radius.a: link 'a' has 1 primitive collision shape(s) in the URDF" in msg
    assert s.capsule_radius == {"a": 0.2, "base_link": 0.1}
    sk = _Checks(tm, s).sk
    assert sk.radius.tolist() == [0.05] and "cylinder" in sk.labels[0]  # base_link: a point (j at its origin)


def test_synthetic_kr270_model_plans_as_written(tmp_path, capsys):
    """stiffkit synth kr270 writes the loads the data used into [plan]
    (force 2500 N, moment 300 N m along the base axes; gravity loading: the
    weight alone), so the help's `stiffkit plan kr/model.toml ...` runs; the
    planned loads are those."""
    from stiffkit.calib.synth import plan_loads_toml
    from stiffkit.robot.plan_candidates import plan_settings

    assert main(["synth", "kr270", "--out", str(tmp_path / "kr"), "--configs", "6"]) == 0
    s = plan_settings(tmp_path / "kr" / "model.toml")
    f, m = 2500.0, 300.0
    assert s.loads == [[0, 0, -f, 0, 0, 0], [f, 0, 0, 0, 0, 0], [0, f, 0, 0, 0, 0],
                       [0, 0, 0, m, 0, 0], [0, 0, 0, 0, m, 0], [0, 0, 0, 0, 0, m]]  # fmt: skip
    argv = ["plan", str(tmp_path / "kr" / "model.toml"), "--select", "12", "--candidates", "100", "--criterion", "D"]
    assert main([*argv, "--json", str(tmp_path / "p.json")]) == 0, capsys.readouterr().err
    doc = json.loads((tmp_path / "p.json").read_text())
    assert all(sel["load"] in s.loads for sel in doc["selected"]) and doc["candidates"]["count"] == 6 * 100
    assert "loads = [[0, 0, -981, 0, 0, 0]]" in plan_loads_toml("gravity", 981.0, 0.0)


def test_discriminate_json_names_the_csv_configs(tmp_path, capsys):
    """--discriminate --json: each selected posture with the config label of
    its POSTURES.csv rows, its candidate index and joint values (as the
    parameter plan's report), equal to the CSV's numbers."""
    import csv

    from stiffkit.calib.absolute_data import write_absolute
    from stiffkit.calib.absolute_write import model_text
    from stiffkit.calib.synth_trees import MARKER_XYZ, TRACKER, random_tree_urdf
    from stiffkit.robot.tree import load_tree
    from stiffkit.robot.tree_model import GRAVITY, tree_model_from_tables

    (tmp_path / "robot.urdf").write_text(random_tree_urdf(np.random.default_rng(1), trunk=1, arm=2))
    tree = load_tree(tmp_path / "robot.urdf")
    frames = [{"kind": "tracker", "xyz": list(TRACKER["xyz"]), "rpy": list(TRACKER["rpy"])}]
    frames += [{"kind": "marker", "target": ln, "xyz": list(v)} for ln, v in MARKER_XYZ.items()]
    truth = tree_model_from_tables(tree, frames, GRAVITY)
    (tmp_path / "model.toml").write_text(
        model_text(frames, sigma_position=1e-4, gravity=GRAVITY) + "\n[plan]\nlimits = { finger_a = [0.0, 1e-9] }\n"
    )
    rng = np.random.default_rng(100)
    Q = rng.uniform(-1.4, 1.4, (9, len(tree.actuated)))
    Q[:, tree.actuated.index("finger_a")] = 0.0
    data = P._abs_data(truth, Q, path=str(tmp_path / "m.csv"))
    data.xyz = predict(truth, data, truth.theta0)["pred"] + 1e-4 * rng.normal(size=data.xyz.shape)
    write_absolute(tmp_path / "m.csv", data)
    argv = ["plan", tmp_path / "model.toml", "--select", "4", "--candidates", "40", "--measured", tmp_path / "m.csv"]
    argv += ["--discriminate", "link:l_link1,link:trunk_1", "--out", tmp_path / "p.csv", "--json", tmp_path / "p.json"]
    assert main([str(a) for a in argv]) == 0, capsys.readouterr().err
    doc = json.loads((tmp_path / "p.json").read_text())
    with open(tmp_path / "p.csv") as fh:
        rows = {r["config"]: r for r in csv.DictReader(fh)}
    assert [s["config"] for s in doc["selected"]] == ["plan01", "plan02", "plan03", "plan04"] == sorted(rows)
    for s in doc["selected"]:
        assert s["q"] == {j: float(rows[s["config"]][j]) for j in tree.actuated}
    assert len({s["candidate"] for s in doc["selected"]}) == 4
