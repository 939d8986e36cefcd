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
