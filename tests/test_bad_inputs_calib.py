"""Bad and awkward inputs: `fit`, `diagnose`, `convergence`, `compensate` and
`demo`, one row each (the rules every row obeys and the shared workspace:
tests/_bad_inputs.py)."""

from __future__ import annotations

import numpy as np
import pytest
from _bad_inputs import (
    T_HEAD,
    T_ROW,
    check_row,
    cmd,
    comp,
    copies,
    csv_with,
    duplicated_measurements,
    kr,
    kr_header,
    kr_row,
    link_with,
    make_workspace,
    model_with,
    put,
    scaled_measurements,
    targets,
)

ws = pytest.fixture(scope="module")(make_workspace)

ROWS = [
    # -- fit, diagnose, convergence (commands reworked elsewhere)
    cmd(
        "fit-missing-measurements",
        lambda ws: ["fit", kr(ws, "model.toml"), str(ws / "none.csv")],
        2,
        "no such measurement file",
    ),
    cmd(
        "fit-measurements-extra-field",
        lambda ws: [
            "fit",
            kr(ws, "model.toml"),
            csv_with(ws, "m1.csv", "kr/measurements.csv", 3, kr_row(ws, 3) + ",7"),
        ],
        2,
        "fields, but the header has",
    ),
    cmd(
        "fit-measurements-duplicate-header",
        lambda ws: [
            "fit",
            kr(ws, "model.toml"),
            csv_with(ws, "m2.csv", "kr/measurements.csv", header=kr_header(ws).replace("fz", "fy")),
        ],
        2,
        "duplicate column name(s) fy",
    ),
    cmd(
        "fit-measurements-1e300",
        lambda ws: [
            "fit",
            kr(ws, "model.toml"),
            csv_with(ws, "m3.csv", "kr/measurements.csv", 2, kr_row(ws, 2, "dx", "1e300")),
        ],
        2,
        "field 'dx' = 1e300 is out of range",
    ),
    cmd(
        "fit-measurements-not-utf8",
        lambda ws: [
            "fit",
            kr(ws, "model.toml"),
            put(ws, "m4.csv", (ws / "kr/measurements.csv").read_bytes().replace(b"c1", b"c\xe91", 1)),
        ],
        2,
        "not UTF-8",
    ),
    cmd(
        "fit-measurements-q6-missing",
        lambda ws: [
            "fit",
            kr(ws, "model.toml"),
            csv_with(ws, "m5.csv", "kr/measurements.csv", header=kr_header(ws).replace("q6", "q7")),
        ],
        2,
        "missing column(s) q6",
    ),
    cmd(
        "fit-measurements-in-mm-warns",
        lambda ws: ["fit", kr(ws, "model.toml"), scaled_measurements(ws, "m6.csv", ["dx", "dy", "dz"], 1e3)],
        0,
        "it looks like mm",
        warns=True,
    ),
    cmd(
        "fit-measurements-degrees-warns",
        lambda ws: ["fit", kr(ws, "model.toml"), scaled_measurements(ws, "m7.csv", ["q2"], 180 / np.pi)],
        0,
        "it looks like deg",
        warns=True,
    ),
    cmd(
        "fit-sigma-zero",
        lambda ws: ["fit", kr(ws, "model.toml"), kr(ws, "measurements.csv"), "--sigma", "0"],
        2,
        "--sigma",
    ),
    cmd(
        "fit-sigma-negative",
        lambda ws: ["fit", kr(ws, "model.toml"), kr(ws, "measurements.csv"), "--sigma", "-1"],
        2,
        "--sigma",
    ),
    cmd(
        "fit-reduce-zero-loads",
        lambda ws: [
            "fit",
            kr(ws, "model.toml"),
            scaled_measurements(ws, "m8.csv", ["fx", "fy", "fz", "mx", "my", "mz", "dx", "dy", "dz"], 0.0),
            "--reduce",
        ],
        2,
        "load",
    ),
    cmd(
        "fit-json-is-input",
        lambda ws: ["fit", *copies(ws, "fj"), "--json", copies(ws, "fj")[0]],
        2,
        "input file",
    ),
    cmd(
        "diagnose-duplicated-rows",
        lambda ws: [
            "diagnose",
            model_with(ws, "nosig.toml", "sigma_position = 2e-05", "", "model.toml"),
            duplicated_measurements(ws),
        ],
        2,
        "exact",
    ),
    cmd(
        "diagnose-alpha-two",
        lambda ws: ["diagnose", kr(ws, "model.toml"), kr(ws, "measurements.csv"), "--alpha", "2"],
        2,
        "--alpha",
    ),
    cmd(
        "diagnose-sigma-zero",
        lambda ws: ["diagnose", kr(ws, "model.toml"), kr(ws, "measurements.csv"), "--sigma", "0"],
        2,
        "--sigma",
    ),
    cmd(
        "diagnose-top-negative",
        lambda ws: ["diagnose", kr(ws, "model.toml"), kr(ws, "measurements.csv"), "--top", "-1"],
        2,
        "--top",
    ),
    cmd(
        "diagnose-kinds-unknown",
        lambda ws: ["diagnose", kr(ws, "model.toml"), kr(ws, "measurements.csv"), "--kinds", "jont"],
        2,
        "unknown kind(s) jont",
    ),
    cmd(
        "diagnose-json-is-input",
        lambda ws: ["diagnose", *copies(ws, "dj"), "--json", copies(ws, "dj")[1]],
        2,
        "input file",
    ),
    cmd(
        "convergence-sizes-zero",
        lambda ws: ["convergence", str(ws / "beam.toml"), "--sizes", "0"],
        2,
        "sizes must be positive",
    ),
    cmd(
        "convergence-sizes-text",
        lambda ws: ["convergence", str(ws / "beam.toml"), "--sizes", "a,b"],
        2,
        "not a comma-separated list",
    ),
    cmd(
        "convergence-orders-three",
        lambda ws: ["convergence", str(ws / "beam.toml"), "--orders", "3"],
        2,
        "orders are 1 (C3D4) and 2",
    ),
    cmd("convergence-jobs-zero", lambda ws: ["convergence", str(ws / "beam.toml"), "-j", "0"], 2, "at least 1"),
    cmd(
        "convergence-sizes-negative",
        lambda ws: ["convergence", str(ws / "beam.toml"), "--sizes", "-2"],
        2,
        "sizes must be positive",
    ),
    cmd(
        "convergence-json-is-input",
        lambda ws: ["convergence", link_with(ws, "cj.toml"), "--sizes", "-2", "--json", str(ws / "rows/cj.toml")],
        2,
        "input file",
    ),
    cmd(
        "convergence-png-suffix",
        lambda ws: ["convergence", str(ws / "beam.toml"), "--sizes", "-2", "--png", str(ws / "c.txt")],
        2,
        "must end in",
    ),
    # -- compensate
    cmd(
        "compensate-missing-out", lambda ws: ["compensate", kr(ws, "values.toml"), targets(ws, "t0.csv")], 2, "required"
    ),
    cmd(
        "compensate-missing-joint-column",
        lambda ws: comp(ws, targets(ws, "t1.csv", head="config,q1,q2,q4,q5,q6", row="c1,0,-0.5,0,1.2,0")),
        2,
        "missing joint column(s) joint_a1",
    ),
    cmd(
        "compensate-nan",
        lambda ws: comp(ws, targets(ws, "t2.csv", row="c1,0,nan,0.3,0,1.2,0")),
        2,
        "line 2: field 'q2' is nan (must be finite)",
    ),
    cmd(
        "compensate-not-a-number",
        lambda ws: comp(ws, targets(ws, "t3.csv", row="c1,0,-0.5,x,0,1.2,0")),
        2,
        "field 'q3' = 'x' is not a number",
    ),
    cmd(
        "compensate-unknown-frame",
        lambda ws: comp(ws, targets(ws, "t4.csv", head=T_HEAD + ",frame", row=T_ROW + ",nowhere")),
        2,
        "line 2: unknown frame 'nowhere'; frames of the model: link_1",
    ),
    cmd(
        "compensate-base-frame",
        lambda ws: comp(ws, targets(ws, "t5.csv"), "--frame", "base_link"),
        2,
        "--frame: unknown frame 'base_link'",
    ),
    cmd(
        "compensate-empty-frame",
        lambda ws: comp(ws, targets(ws, "t6.csv", head=T_HEAD + ",frame", row=T_ROW + ",")),
        2,
        "line 2: field 'frame' is empty",
    ),
    cmd(
        "compensate-frame-twice",
        lambda ws: comp(ws, targets(ws, "t7.csv", head=T_HEAD + ",frame", row=T_ROW + ",tool0"), "--frame", "tool0"),
        2,
        "has a frame column",
    ),
    cmd(
        "compensate-partial-payload",
        lambda ws: comp(ws, targets(ws, "t8.csv", head=T_HEAD + ",fx,fy,fz", row=T_ROW + ",1,2,3")),
        2,
        "payload columns must be all of fx fy fz mx my mz or none; missing mx, my, mz",
    ),
    cmd(
        "compensate-payload-overflow",
        lambda ws: comp(ws, targets(ws, "t9.csv", head=T_HEAD + ",fx,fy,fz,mx,my,mz", row=T_ROW + ",1e300,0,0,0,0,0")),
        2,
        "field 'fx' = 1e300 is out of range for a force",
    ),
    cmd(
        "compensate-degrees",
        lambda ws: comp(ws, targets(ws, "t10.csv", row="c1,0,-30,20,0,70,0")),
        0,
        "looks like deg",
        warns=True,
    ),
    cmd(
        "compensate-names-and-q-columns-mixed",
        lambda ws: comp(ws, targets(ws, "t11.csv", head="config,joint_a1,q2,q3,q4,q5,q6")),
        2,
        "missing joint column(s) joint_a2",
    ),
    cmd(
        "compensate-model-without-values",
        lambda ws: ["compensate", kr(ws, "model.toml"), targets(ws, "t12.csv"), "--out", str(ws / "rows" / "c.csv")],
        2,
        "has no value; compensation evaluates a model with values",
    ),
    cmd(
        "compensate-out-is-input",
        lambda ws: ["compensate", kr(ws, "values.toml"), targets(ws, "t13.csv"), "--out", str(ws / "rows" / "t13.csv")],
        2,
        "is an input file",
    ),
    cmd(
        "compensate-out-is-folder",
        lambda ws: ["compensate", kr(ws, "values.toml"), targets(ws, "t14.csv"), "--out", str(ws)],
        2,
        "is a folder",
    ),
    cmd("compensate-header-only", lambda ws: comp(ws, put(ws, "t15.csv", T_HEAD + "\n")), 2, "no data rows"),
    cmd(
        "compensate-missing-targets",
        lambda ws: comp(ws, str(ws / "rows" / "none.csv")),
        2,
        "no such targets file",
    ),
    # -- demo
    cmd("demo-size-tiny", lambda ws: ["demo", "--only", "fea", "--size", "0.1"], 2, "--size = 0.1 must be in [1, 10]"),
    cmd("demo-seed-negative", lambda ws: ["demo", "--only", "field", "--seed", "-1"], 2, "--seed = -1 must be >= 0"),
    cmd(
        "demo-out-is-file",
        lambda ws: ["demo", "--only", "calib", "--out", str(ws / "fit.json")],
        2,
        "a file, not a folder",
    ),
]


@pytest.mark.parametrize("row", ROWS)
def test_bad_input(row, ws, capsys, monkeypatch):
    check_row(row, ws, capsys, monkeypatch)
