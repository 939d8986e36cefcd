"""Bad and awkward inputs: `stiffkit synth` and `stiffkit compare`, one row
each (the rules every row obeys and the shared workspace:
tests/_bad_inputs.py)."""

from __future__ import annotations

import pytest
from _bad_inputs import (
    check_row,
    cmd,
    fit_with,
    kr,
    make_workspace,
    put,
)

ws = pytest.fixture(scope="module")(make_workspace)

ROWS = [
    # -- synth
    cmd(
        "synth-configs-zero",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--configs", "0"],
        2,
        "--configs = 0 must be in [1,",
    ),
    cmd(
        "synth-configs-negative",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--configs", "-3"],
        2,
        "--configs = -3",
    ),
    cmd(
        "synth-configs-text",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--configs", "many"],
        2,
        "not an integer",
    ),
    cmd(
        "synth-too-many-rows",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--configs", "1000000", "--loads-per-config", "10"],
        2,
        "rows; at most 1000000",
    ),
    cmd(
        "synth-sigma-negative",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--sigma", "-1"],
        2,
        "--sigma = -1 m must be >= 0",
    ),
    cmd(
        "synth-sigma-nan",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--sigma", "nan"],
        2,
        "must be a finite number",
    ),
    cmd(
        "synth-sigma-mm-warns",
        lambda ws: ["synth", "kr270", "--out", str(ws / "smm"), "--configs", "1", "--sigma", "0.02"],
        0,
        "it looks like mm",
        warns=True,
    ),
    cmd(
        "synth-force-zero",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--force", "0"],
        2,
        "--force = 0 N must be positive",
    ),
    cmd(
        "synth-moment-negative",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--moment", "-1"],
        2,
        "must be >= 0",
    ),
    cmd(
        "synth-replicates-zero",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--replicates", "0"],
        2,
        "--replicates = 0",
    ),
    cmd(
        "synth-loads-per-config-zero",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--loads-per-config", "0"],
        2,
        "must be in [1",
    ),
    cmd(
        "synth-seed-negative",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--seed", "-1"],
        2,
        "--seed = -1 must be >= 0",
    ),
    cmd(
        "synth-offset-two",
        lambda ws: ["synth", "kr270", "--out", str(ws / "s"), "--offset", "0.1,0.2"],
        2,
        "expected 3",
    ),
    cmd("synth-out-is-file", lambda ws: ["synth", "kr270", "--out", str(ws / "fit.json")], 2, "a file, not a folder"),
    cmd(
        "synth-dualarm-sigma-negative",
        lambda ws: ["synth", "dualarm", "--out", str(ws / "s"), "--sigma", "-1"],
        2,
        "--sigma = -1 m must be >= 0",
    ),
    cmd(
        "synth-dualarm-sigma-mm-warns",
        lambda ws: ["synth", "dualarm", "--out", str(ws / "dmm"), "--configs", "2", "--targets", "1", "--sigma", "0.1"],
        0,
        "it looks like mm",
        warns=True,
    ),
    cmd(
        "synth-dualarm-truth-unknown",
        lambda ws: ["synth", "dualarm", "--out", str(ws / "s"), "--truth", "elastic"],
        2,
        "invalid choice: 'elastic'",
    ),
    cmd(
        "synth-dualarm-targets-zero",
        lambda ws: ["synth", "dualarm", "--out", str(ws / "s"), "--targets", "0"],
        2,
        "--targets = 0",
    ),
    cmd(
        "synth-dualarm-out-is-file",
        lambda ws: ["synth", "dualarm", "--out", str(ws / "fit.json")],
        2,
        "a file, not a folder",
    ),
    cmd(
        "synth-truth-missing",
        lambda ws: ["synth", str(ws / "truth.toml"), "--out", str(ws / "s")],
        2,
        "no such truth model",
    ),
    cmd(
        "synth-truth-without-values",
        lambda ws: ["synth", kr(ws, "model.toml"), "--out", str(ws / "s")],
        2,
        "has no value; a truth needs values",
    ),
    cmd(
        "synth-out-overwrites-truth",
        lambda ws: ["synth", kr(ws, "truth.toml"), "--out", str(ws / "kr")],
        2,
        "would overwrite the truth model",
    ),
    # -- compare
    cmd(
        "compare-missing",
        lambda ws: ["compare", str(ws / "none.json"), str(ws / "fit.json")],
        2,
        "no such fit result file",
    ),
    cmd("compare-not-json", lambda ws: ["compare", put(ws, "c1.json", "{"), str(ws / "fit.json")], 2, "not valid JSON"),
    cmd(
        "compare-nan",
        lambda ws: ["compare", fit_with(ws, "c2.json", "rms_position_m", "NaN"), str(ws / "fit.json")],
        2,
        "'rms_position_m' = 'NaN' must be a number",
    ),
    cmd(
        "compare-nan-literal",
        lambda ws: ["compare", put(ws, "c12.json", '{"rms_position_m": NaN}'), str(ws / "fit.json")],
        2,
        "NaN is not a JSON number",
    ),
    cmd(
        "compare-null",
        lambda ws: ["compare", fit_with(ws, "c3.json", "rms_position_m", None), str(ws / "fit.json")],
        2,
        "'rms_position_m' = None must be a number",
    ),
    cmd(
        "compare-string",
        lambda ws: ["compare", fit_with(ws, "c4.json", "max_position_m", "1 mm"), str(ws / "fit.json")],
        2,
        "'max_position_m' = '1 mm' must be a number",
    ),
    cmd(
        "compare-negative",
        lambda ws: ["compare", fit_with(ws, "c5.json", "max_position_m", -1), str(ws / "fit.json")],
        2,
        "must be >= 0",
    ),
    cmd(
        "compare-missing-key",
        lambda ws: ["compare", fit_with(ws, "c6.json", "axes", KeyError), str(ws / "fit.json")],
        2,
        "'axes' must be an object",
    ),
    cmd(
        "compare-axes-list",
        lambda ws: ["compare", fit_with(ws, "c7.json", "axes", [1, 2, 3]), str(ws / "fit.json")],
        2,
        "'axes' must be an object",
    ),
    cmd(
        "compare-parameters-null",
        lambda ws: ["compare", fit_with(ws, "c8.json", "parameters", None), str(ws / "fit.json")],
        2,
        "'parameters' must be a list",
    ),
    cmd(
        "compare-parameter-value-null",
        lambda ws: [
            "compare",
            fit_with(ws, "c9.json", "parameters", [{"name": "a", "value": None}]),
            str(ws / "fit.json"),
        ],
        2,
        "(a) 'value' = None must be a number",
    ),
    cmd(
        "compare-top-level-list",
        lambda ws: ["compare", put(ws, "c10.json", "[1]"), str(ws / "fit.json")],
        2,
        "a JSON object is expected",
    ),
    cmd(
        "compare-not-utf8",
        lambda ws: ["compare", put(ws, "c11.json", b"\xff\xfe{}"), str(ws / "fit.json")],
        2,
        "not UTF-8",
    ),
    cmd("compare-ok", lambda ws: ["compare", str(ws / "fit.json"), str(ws / "fit.json")], 0, ""),
]


@pytest.mark.parametrize("row", ROWS)
def test_bad_input(row, ws, capsys, monkeypatch):
    check_row(row, ws, capsys, monkeypatch)
