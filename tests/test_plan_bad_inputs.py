"""stiffkit plan on bad inputs (issue 19): one line naming the file, row or
field, exit status 2, before any output is written."""

from __future__ import annotations

import pytest
from _plan_robots import kr_files

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
