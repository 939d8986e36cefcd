"""Bad inputs of ``stiffkit evaluate`` and ``fit --validate``, one row each:
the exit status and a fragment of the one line that must explain it (the
file, the line or the field, what is wrong); no row prints a traceback, and
no row with a bad input exits 0 with a table of errors."""

from __future__ import annotations

import csv
import warnings
from pathlib import Path

import pytest

import stiffkit
from stiffkit.cli import main


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """A KR-270-like model with its data and a fitted model; the dual-arm
    tracker data with their truth (a model with every value)."""
    root = tmp_path_factory.mktemp("evalbad")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["synth", "kr270", "--out", str(root / "kr"), "--configs", "4", "--seed", "3"]) == 0
        kr = root / "kr"
        assert main(["fit", str(kr / "model.toml"), str(kr / "measurements.csv"), "--quiet", "--write-model",
                     str(kr / "f.toml")]) == 0  # fmt: skip
        stiffkit.calib.synth_dualarm(root / "da", configs=6, targets=2)
    return root


def _rows(path: Path) -> list[list[str]]:
    return list(csv.reader(path.read_text().splitlines()))


def _put(ws: Path, name: str, rows: list[list[str]]) -> str:
    p = ws / name
    p.write_text("\n".join(",".join(r) for r in rows) + "\n")
    return str(p)


def _edit(ws: Path, src: str, name: str, line: int, col: str, value: str) -> str:
    rows = _rows(ws / src)
    rows[line - 1][rows[0].index(col)] = value
    return _put(ws, name, rows)


def _drop(ws: Path, src: str, name: str, col: str) -> str:
    rows = _rows(ws / src)
    k = rows[0].index(col)
    return _put(ws, name, [r[:k] + r[k + 1 :] for r in rows])


def _insert(ws: Path, src: str, name: str, after: str, col: str, value: str) -> str:
    rows = _rows(ws / src)
    k = rows[0].index(after) + 1
    return _put(ws, name, [rows[0][:k] + [col] + rows[0][k:]] + [r[:k] + [value] + r[k:] for r in rows[1:]])


def _header_only(ws: Path, src: str, name: str) -> str:
    return _put(ws, name, _rows(ws / src)[:1])


def _no_value(ws: Path) -> str:
    p = ws / "da" / "noval.toml"
    p.write_text((ws / "da" / "truth.toml").read_text() + '\n[[effect]]\nkind = "joint_cubic"\ntarget = "left_2"\n')
    return str(p)


def _all_fixed(ws: Path) -> str:
    p = ws / "da" / "fixed.toml"
    text = (ws / "da" / "truth.toml").read_text()
    for kind in ("tracker", "marker"):
        text = text.replace(f'kind = "{kind}"\n', f'kind = "{kind}"\nfixed = true\n')
    p.write_text(text)
    return str(p)


def _weights_zero(ws: Path) -> str:
    rows = _rows(ws / "da" / "measurements.csv")
    return _put(ws, "da/w0.csv", [rows[0] + ["weight"]] + [r + ["0"] for r in rows[1:]])


KR_M, KR_F, KR_D = "kr/measurements.csv", "kr/f.toml", "kr/model.toml"
DA_M, DA_T, DA_U = "da/measurements.csv", "da/truth.toml", "da/model.toml"

# (id, args(ws) -> argv, exit status, fragments of stderr)
ROWS = [
    ("no-values", lambda w: ["evaluate", str(w / KR_D), str(w / KR_M)], 2,
     ["kr/model.toml: 6 parameter(s) have no value", "joint_a1.c", "--write-model"]),
    ("empty", lambda w: ["evaluate", str(w / KR_F), _header_only(w, KR_M, "kr/empty.csv")], 2,
     ["kr/empty.csv", "no data rows"]),
    ("joint-missing", lambda w: ["evaluate", str(w / KR_F), _drop(w, KR_M, "kr/q5.csv", "q6")], 2,
     ["kr/q5.csv, line 1: missing column(s) q6", "the robot has 6 joints"]),
    ("nan", lambda w: ["evaluate", str(w / KR_F), _edit(w, KR_M, "kr/nan.csv", 3, "dz", "nan")], 2,
     ["kr/nan.csv, line 3: field 'dz' is nan"]),
    ("inf", lambda w: ["evaluate", str(w / KR_F), _edit(w, KR_M, "kr/inf.csv", 4, "fx", "inf")], 2,
     ["kr/inf.csv, line 4: field 'fx'"]),
    ("absolute-data-deflection-model", lambda w: ["evaluate", str(w / KR_F), str(w / DA_M)], 2,
     ["da/measurements.csv: tracker points", 'kind = "absolute"']),
    ("deflection-data-absolute-model", lambda w: ["evaluate", str(w / DA_T), str(w / KR_M)], 2,
     ["kr/measurements.csv: deflections under loads", "model of absolute data"]),
    ("json-onto-input", lambda w: ["evaluate", str(w / KR_F), str(w / KR_M), "--json", str(w / KR_M)], 2,
     ["--json", "is an input file"]),
    ("plots-a-file", lambda w: ["evaluate", str(w / KR_F), str(w / KR_M), "--plots", str(w / KR_F)], 2,
     ["--plots", "a file, not a folder"]),
    ("missing-model", lambda w: ["evaluate", str(w / "kr/none.toml"), str(w / KR_M)], 2, ["none.toml"]),
    ("validate-joint-missing", lambda w: ["fit", str(w / KR_D), str(w / KR_M), "--validate",
                                          _drop(w, KR_M, "kr/v5.csv", "q6")], 2,
     ["kr/v5.csv, line 1: missing column(s) q6"]),
    ("validate-other-kind", lambda w: ["fit", str(w / KR_D), str(w / KR_M), "--validate", str(w / DA_M)], 2,
     ["da/measurements.csv: tracker points"]),
    ("abs-no-tracker-pose", lambda w: ["evaluate", str(w / DA_U), str(w / DA_M)], 2,
     ["da/model.toml: the tracker effect has no pose", "fit --write-model writes it"]),
    ("abs-no-value", lambda w: ["evaluate", _no_value(w), str(w / DA_M)], 2,
     ["noval.toml: 1 parameter(s) have no value (left_2.cubic)"]),
    ("abs-unknown-marker", lambda w: ["evaluate", str(w / DA_T),
                                      _edit(w, DA_M, "da/frame.csv", 2, "frame", "left_foot")], 2,
     ["da/frame.csv, line 2: frame 'left_foot' has no marker in the model", "left_tcp, right_tcp"]),
    ("abs-joint-missing", lambda w: ["evaluate", str(w / DA_T), _drop(w, DA_M, "da/nj.csv", "torso_1")], 2,
     ["da/nj.csv: missing joint column(s) torso_1"]),
    ("abs-nan", lambda w: ["evaluate", str(w / DA_T), _edit(w, DA_M, "da/nan.csv", 3, "y", "nan")], 2,
     ["da/nan.csv, line 3: field 'y' is nan"]),
    ("abs-empty", lambda w: ["evaluate", str(w / DA_T), _header_only(w, DA_M, "da/empty.csv")], 2,
     ["da/empty.csv", "no data rows"]),
    ("abs-every-weight-zero", lambda w: ["evaluate", str(w / DA_T), _weights_zero(w)], 2,
     ["da/w0.csv: every row has weight 0"]),
    ("abs-fit-nothing-free", lambda w: ["fit", _all_fixed(w), str(w / DA_M)], 2,
     ["fixed.toml: every parameter is fixed; nothing to identify", "stiffkit evaluate"]),
    ("abs-validate-unknown-marker", lambda w: ["fit", str(w / DA_U), str(w / DA_M), "--validate",
                                               _edit(w, DA_M, "da/vf.csv", 2, "frame", "head")], 2,
     ["da/vf.csv, line 2: frame 'head' has no marker"]),
]  # fmt: skip


@pytest.mark.parametrize("row", ROWS, ids=[r[0] for r in ROWS])
def test_bad_input(ws, row, capsys):
    _id, argv, status, fragments = row
    assert main(argv(ws)) == status
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    line = [x for x in err.splitlines() if ": error: " in x]
    assert len(line) == 1, err
    for f in fragments:
        assert f in line[0], line[0]
    assert "nothing fitted" not in out  # no table of errors from a bad input


def test_extra_joint_column_warns(ws, capsys):
    """A q7 column on a 6-joint robot: measurements of another robot? (a
    warning naming the column; the table still follows)."""
    assert main(["evaluate", str(ws / KR_F), _insert(ws, KR_M, "kr/q7.csv", "q6", "q7", "0.1")]) == 0
    out, err = capsys.readouterr()
    assert "kr/q7.csv, line 1: column(s) q7 ignored: the robot has 6 joints" in err
    assert "nothing fitted" in out


def test_truth_evaluated_is_at_the_noise(ws, capsys):
    """The dual-arm truth on its own data: the errors are the noise (RMS
    within 30 % of the floor sqrt(3) sigma on 12 points), the nominal far off."""
    import json

    out_json = ws / "da" / "truth.json"
    assert main(["evaluate", str(ws / DA_T), str(ws / DA_M), "--json", str(out_json)]) == 0
    ev = json.loads(out_json.read_text())
    floor = 3**0.5 * ev["sigma_m"]
    assert 0.7 < ev["rms_position_m"] / floor < 1.3
    assert ev["before"]["rms_position_m"] > 50 * floor
    assert set(ev["frames"]) == {"left_tcp", "right_tcp"} and len(ev["rows"]) == 12
