"""stiffkit plan on bad inputs (issue 19): one line naming the file, row or
field, exit status 2, before any output is written; on both data kinds
and on the --discriminate paths (K larger than the feasible candidates, a
task file with an unknown joint, no feasible candidate, K too small with
the minimum K that then plans)."""

from __future__ import annotations

import math

import pytest
from _plan_robots import P, dualarm_files, kr_files, tied_tree_files
from test_plan_discriminate_defl import scenario_files

import stiffkit
from stiffkit.calib.scenarios import make_scenario
from stiffkit.cli.app import main

HEAD = "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6"
ROWS = ["0.1,-0.6,0.4,0.0,1.1,0.0", "0.3,-0.5,0.2,0.5,1.0,0.3", "-0.4,-0.8,0.6,-0.5,0.9,-0.3"]


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    root = tmp_path_factory.mktemp("plan_bad")
    kr_files(root / "kr")
    kr_files(root / "floor", extra="floor_z = 5.0\n")
    nl = root / "noloads"
    kr_files(nl)
    text = (nl / "model.toml").read_text()
    (nl / "model.toml").write_text("\n".join(ln for ln in text.splitlines() if not ln.startswith("loads")) + "\n")
    (root / "three.csv").write_text("\n".join([HEAD, *ROWS]) + "\n")
    (root / "task_unknown.csv").write_text(HEAD + ",joint_a7\n" + ROWS[0] + ",0.2\n")
    (root / "task_missing.csv").write_text("joint_a1,joint_a2\n0.1,0.2\n")
    (root / "task_text.csv").write_text("\n".join([HEAD, ROWS[0], "0.1,-0.6,x,0.0,1.1,0.0"]) + "\n")
    # tracker data: the dual-arm; three postures of it, and a task file with an unknown joint
    dualarm_files(root / "da")
    joints = P.build_setup(root / "da" / "model.toml", candidates=3, seed=0).candidates
    head = ",".join(joints.joint_names)
    rows = [",".join(f"{v:.17g}" for v in q) for q in joints.q]
    (root / "da_three.csv").write_text("\n".join([head, *rows]) + "\n")
    (root / "da_task_unknown.csv").write_text(head + ",bogus\n" + rows[0] + ",0.2\n")
    # --discriminate: a small tree with two tied link springs (tracker), 18-row KR-270-like data (deflection)
    for d in ("tree", "disc", "discfloor"):
        (root / d).mkdir()
    tied_tree_files(root / "tree")
    scenario_files(root / "disc", make_scenario("few_rows", seed=2))
    text = (root / "disc" / "model.toml").read_text().replace("[plan]\n", "[plan]\nfloor_z = 5.0\n", 1)
    for f in ("robot.urdf", "measurements.csv"):
        (root / "discfloor" / f).write_bytes((root / "disc" / f).read_bytes())
    (root / "discfloor" / "model.toml").write_text(text)
    return root


CASES = [
    # (id, argv after "plan", fragments of the message)
    ("k-over-candidates", ["kr/model.toml", "--select", "13", "--from", "three.csv"],
     ["--select 13", "only 12 (posture, load) candidates"]),
    ("task-unknown-joint", ["kr/model.toml", "--select", "4", "--candidates", "30", "--task", "task_unknown.csv"],
     ["task_unknown.csv, line 1, column 'joint_a7'", "not a joint of the robot"]),
    ("task-missing-joint", ["kr/model.toml", "--select", "4", "--candidates", "30", "--task", "task_missing.csv"],
     ["task_missing.csv, line 1: missing joint column(s) joint_a3"]),
    ("task-not-a-number", ["kr/model.toml", "--select", "4", "--candidates", "30", "--task", "task_text.csv"],
     ["task_text.csv, line 3", "joint_a3"]),
    ("no-feasible", ["floor/model.toml", "--select", "4", "--candidates", "30"], ["no feasible candidate", "floor"]),
    ("no-feasible-from", ["floor/model.toml", "--select", "2", "--from", "three.csv"],
     ["three.csv: no feasible candidate among 3 postures", "row 1"]),
    ("k-too-small", ["kr/model.toml", "--select", "1", "--candidates", "30"],
     ["--select 1", "the minimum is --select"]),
    ("no-loads", ["noloads/model.toml", "--select", "4", "--candidates", "30"], ["[plan] loads missing"]),
    ("png-suffix", ["kr/model.toml", "--select", "4", "--png", "plan.xyz"], ["--png plan.xyz", "must end in"]),
    ("out-is-input", ["kr/model.toml", "--select", "4", "--out", "kr/model.toml"], ["--out"]),
    ("criterion", ["kr/model.toml", "--select", "4", "--criterion", "E"], ["--criterion", "'E'"]),
    ("select-zero", ["kr/model.toml", "--select", "0"], ["--select"]),
    ("tracker-k-over-candidates", ["da/model.toml", "--select", "5", "--from", "da_three.csv"],
     ["--select 5: only 3 feasible candidates", "add postures to the --from list"]),
    ("tracker-task-unknown-joint", ["da/model.toml", "--select", "25", "--candidates", "30", "--task",
                                    "da_task_unknown.csv"],
     ["da_task_unknown.csv, line 1, column 'bogus'", "not a joint of the robot"]),
    ("tracker-k-too-small", ["da/model.toml", "--select", "3", "--candidates", "30"],
     ["--select 3: 3 x 6 observations per candidate = 18 <", "the minimum is --select"]),
    ("disc-k-over-candidates", ["tree/model.toml", "--select", "61", "--candidates", "60", "--measured", "tree/m.csv",
                                "--discriminate", "link:l_link1,link:trunk_1"],
     ["--select 61: only 60 feasible candidates", "sample more (--candidates)"]),
    ("disc-defl-k-over-candidates", ["disc/model.toml", "--select", "161", "--candidates", "40", "--measured",
                                     "disc/measurements.csv", "--discriminate"],
     ["--select 161: only 160 (posture, load) candidates", "4 loads"]),
    ("disc-no-feasible", ["discfloor/model.toml", "--select", "4", "--candidates", "40", "--measured",
                          "discfloor/measurements.csv", "--discriminate"],
     ["discfloor/model.toml: [plan]: no feasible candidate", "floor"]),
]  # fmt: skip


@pytest.mark.parametrize(("argv", "fragments"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input(argv, fragments, ws, capsys, monkeypatch):
    monkeypatch.chdir(ws)
    rc = main(["plan", *argv])
    out, err = capsys.readouterr()
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("stiffkit plan: error: "), err
    for f in fragments:
        assert f in lines[0], lines[0]
    assert not (ws / "plan.xyz").exists()


def test_tracker_k_too_small_gives_the_minimum(ws):
    """Tracker data (6 observations per posture: two markers): the message
    gives K = ceil(identifiable / 6), which plans (the deflection case:
    test_plan_files.test_k_too_small_gives_the_minimum)."""
    setup = P.build_setup(ws / "da" / "model.toml", candidates=40, seed=0)
    kmin = math.ceil(setup.npar / setup.nobs)
    assert setup.nobs == 6 and kmin > 2
    with pytest.raises(stiffkit.InputError) as exc:
        P.plan(None, kmin - 1, "D", setup=setup)
    assert str(exc.value) == (
        f"--select {kmin - 1}: {kmin - 1} x 6 observations per candidate = {6 * (kmin - 1)} < {setup.npar} "
        f"identifiable parameters: the minimum is --select {kmin}"
    )
    assert P.plan(None, kmin, "D", setup=setup).k == kmin
