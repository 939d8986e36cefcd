"""Bad and awkward inputs: the program and `stiffkit field` (the CSV files),
one row each (the rules every row obeys and the shared workspace:
tests/_bad_inputs.py)."""

from __future__ import annotations

import pytest
from _bad_inputs import (
    check_row,
    cmd,
    csv_with,
    field_args,
    kr,
    make_workspace,
    put,
)

ws = pytest.fixture(scope="module")(make_workspace)

ROWS = [
    # -- the program
    cmd("app-unknown-command", lambda ws: ["frobnicate"], 2, "invalid choice"),
    cmd("app-missing-argument", lambda ws: ["link"], 2, "required"),
    cmd("app-option-without-value", lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture"], 2, "expected one"),
    cmd("app-both-exclusive", lambda ws: ["stiffness", "m", "--posture", "0", "--trajectory", "q"], 2, "not allowed"),
    # -- field: the CSV files
    cmd("field-missing-nodes", lambda ws: field_args(ws, str(ws / "none.csv")), 2, "no such node file"),
    cmd("field-empty-file", lambda ws: field_args(ws, put(ws, "e.csv", "")), 2, "empty file"),
    cmd("field-header-only", lambda ws: field_args(ws, put(ws, "h.csv", "x,y,z\n")), 2, "no data rows"),
    cmd(
        "field-duplicate-header",
        lambda ws: field_args(ws, csv_with(ws, "dup.csv", "field/nodes.csv", header="x,x,z")),
        2,
        "duplicate column name(s) x",
    ),
    cmd(
        "field-missing-column",
        lambda ws: field_args(ws, csv_with(ws, "mc.csv", "field/nodes.csv", header="x,y,w")),
        2,
        "missing column(s) z",
    ),
    cmd(
        "field-extra-field",
        lambda ws: field_args(ws, csv_with(ws, "xf.csv", "field/nodes.csv", 3, "1.0,0.001,0,5")),
        2,
        "line 3: 4 fields, but the header has 3",
    ),
    cmd(
        "field-short-row",
        lambda ws: field_args(ws, csv_with(ws, "sr.csv", "field/nodes.csv", 4, "1.0,0.001")),
        2,
        "line 4: field 'z' is missing",
    ),
    cmd(
        "field-not-a-number",
        lambda ws: field_args(ws, csv_with(ws, "nan.csv", "field/nodes.csv", 2, "1.0,abc,0")),
        2,
        "line 2: field 'y' = 'abc' is not a number",
    ),
    cmd(
        "field-nan",
        lambda ws: field_args(ws, csv_with(ws, "nan2.csv", "field/nodes.csv", 2, "1.0,nan,0")),
        2,
        "must be finite",
    ),
    cmd(
        "field-inf",
        lambda ws: field_args(ws, csv_with(ws, "inf.csv", "field/nodes.csv", 2, "1.0,-inf,0")),
        2,
        "must be finite",
    ),
    cmd(
        "field-1e300",
        lambda ws: field_args(ws, csv_with(ws, "big.csv", "field/nodes.csv", 2, "1e300,0,0")),
        2,
        "line 2: field 'x' = 1e300 is out of range",
    ),
    cmd(
        "field-not-utf8",
        lambda ws: field_args(ws, put(ws, "l1.csv", b"x,y,z\n1,0,0\n\xff\xfe,0,0\n")),
        2,
        "line 3: not UTF-8",
    ),
    cmd("field-nul-byte", lambda ws: field_args(ws, put(ws, "nul.csv", b"x,y,z\n1,0\x00,0\n")), 2, "NUL byte"),
    cmd(
        "field-trailing-comma-header",
        lambda ws: field_args(ws, csv_with(ws, "tc.csv", "field/nodes.csv", header="x,y,z,")),
        2,
        "column 4 of the header has no name",
    ),
    cmd(
        "field-row-count-mismatch",
        lambda ws: [
            "field",
            str(ws / "field/nodes.csv"),
            put(ws, "two.csv", "ux,uy,uz\n0,0,0\n0,0,0\n"),
            "--reference",
            "1,0,0",
        ],
        2,
        "2 displacement rows for 36 nodes",
    ),
    cmd(
        "field-too-few-nodes",
        lambda ws: [
            "field",
            put(ws, "n2.csv", "x,y,z\n0,0,0\n1,0,0\n"),
            put(ws, "d2.csv", "ux,uy,uz\n0,0,0\n0,0,0\n"),
            "--reference",
            "0,0,0",
        ],
        2,
        "at least 3 nodes",
    ),
    cmd(
        "field-collinear-nodes",
        lambda ws: [
            "field",
            put(ws, "n3.csv", "x,y,z\n0,0,0\n1,1,1\n2,2,2\n3,3,3\n"),
            put(ws, "d3.csv", "ux,uy,uz\n0,0,0\n0,0,0\n0,0,0\n0,0,0\n"),
            "--reference",
            "0,0,0",
        ],
        2,
        "collinear",
    ),
    cmd("field-reference-two-values", lambda ws: field_args(ws)[:-1] + ["1,0"], 2, "expected 3 comma-separated"),
    cmd("field-reference-text", lambda ws: field_args(ws)[:-1] + ["a,b,c"], 2, "expected 3 comma-separated"),
    cmd("field-reference-nan", lambda ws: field_args(ws)[:-1] + ["nan,0,0"], 2, "NaN or Inf"),
    cmd("field-reference-negative-ok", lambda ws: field_args(ws)[:-1] + ["-1,0,0"], 0, ""),
    cmd(
        "field-trim-too-large", lambda ws: field_args(ws, None, "--trim", "0.7"), 2, "--trim = 0.7 must be in [0, 0.5)"
    ),
    cmd("field-trim-negative", lambda ws: field_args(ws, None, "--trim", "-0.1"), 2, "--trim = -0.1 must be in"),
    cmd("field-trim-text", lambda ws: field_args(ws, None, "--trim", "lots"), 2, "'lots' is not a number"),
    cmd("field-confidence-one", lambda ws: field_args(ws, None, "--confidence", "1"), 2, "must be in (0, 1)"),
    cmd("field-confidence-percent", lambda ws: field_args(ws, None, "--confidence", "99"), 2, "must be in (0, 1)"),
    cmd("field-method-unknown", lambda ws: field_args(ws, None, "--method", "qr"), 2, "invalid choice"),
    cmd("field-loads-five", lambda ws: field_args(ws, None, "--loads", "1,1,1,1,1"), 2, "expected 6 comma-separated"),
    cmd(
        "field-loads-zero",
        lambda ws: field_args(ws, None, "--loads", "0,0,0,0,0,0"),
        2,
        "do not span all six directions",
    ),
    cmd(
        "field-wrenches-count",
        lambda ws: field_args(ws, None, "--wrenches", put(ws, "w.csv", "fx,fy,fz,mx,my,mz\n1,0,0,0,0,0\n")),
        2,
        "1 wrenches for 6 load cases",
    ),
    cmd(
        "field-json-is-input",
        lambda ws: field_args(ws, None, "--json", str(ws / "field/nodes.csv")),
        2,
        "is an input file of this command",
    ),
    cmd("field-json-is-folder", lambda ws: field_args(ws, None, "--json", str(ws)), 2, "is a folder"),
    cmd(
        "field-nodes-in-mm-warns",
        lambda ws: [
            "field",
            put(ws, "mm.csv", "x,y,z\n1000,0,0\n1000,10,0\n1000,0,10\n1000,10,10\n"),
            put(ws, "dmm.csv", "ux,uy,uz\n0,0,0\n0,0,0\n0,0,0\n0,0,0\n"),
            "--reference",
            "1000,0,0",
        ],
        0,
        "it looks like mm",
        warns=True,
    ),
    cmd(
        "field-displacements-large-warns",
        lambda ws: [
            "field",
            put(ws, "nn.csv", "x,y,z\n0,0,0\n0.01,0,0\n0,0.01,0\n0,0,0.01\n"),
            put(ws, "dd.csv", "ux,uy,uz\n0.005,0,0\n0.005,0,0\n0.005,0,0\n0.005,0,0\n"),
            "--reference",
            "0,0,0",
        ],
        0,
        "displacements up to 0.005 m on a field 0.01 m across",
        warns=True,
    ),
]


@pytest.mark.parametrize("row", ROWS)
def test_bad_input(row, ws, capsys, monkeypatch):
    check_row(row, ws, capsys, monkeypatch)
