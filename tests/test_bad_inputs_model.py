"""Bad and awkward inputs: `stiffkit stiffness`: the model file, one row each
(the rules every row obeys and the shared workspace: tests/_bad_inputs.py)."""

from __future__ import annotations

import pytest
from _bad_inputs import (
    Q0,
    _six_line,
    check_row,
    cmd,
    indefinite_link,
    json_link,
    kr,
    make_workspace,
    model_with,
    profile_model,
    put,
    skew_link,
)

ws = pytest.fixture(scope="module")(make_workspace)

ROWS = [
    # -- stiffness: the model file
    cmd("stiffness-missing-model", lambda ws: ["stiffness", str(ws / "no.toml"), "--posture", Q0], 2, "no such model"),
    cmd(
        "stiffness-model-not-toml",
        lambda ws: ["stiffness", put(ws, "bad.toml", "[robot\nurdf = 1"), "--posture", Q0],
        2,
        "not valid TOML",
    ),
    cmd(
        "stiffness-model-not-utf8",
        lambda ws: ["stiffness", put(ws, "l1.toml", b'[robot]\nurdf = "\xe9.urdf"\n'), "--posture", Q0],
        2,
        "not UTF-8",
    ),
    cmd(
        "stiffness-model-is-a-folder",
        lambda ws: ["stiffness", str(ws), "--posture", Q0],
        2,
        "not a file",
    ),
    cmd(
        "stiffness-no-robot-table",
        lambda ws: ["stiffness", put(ws, "nr.toml", "[[effect]]\nkind = 'joint'\n"), "--posture", Q0],
        2,
        "missing [robot] table",
    ),
    cmd(
        "stiffness-urdf-not-string",
        lambda ws: [
            "stiffness",
            model_with(ws, "u5.toml", f'urdf = "{ws / "kr" / "robot.urdf"}"', "urdf = 5"),
            "--posture",
            Q0,
        ],
        2,
        "[robot] urdf = 5 must be a name",
    ),
    cmd(
        "stiffness-robot-key-misspelt",
        lambda ws: ["stiffness", model_with(ws, "tf.toml", "tool_frame =", "tool_fram ="), "--posture", Q0],
        2,
        "unknown key(s) tool_fram (did you mean 'tool_frame'?)",
    ),
    cmd(
        "stiffness-unknown-section",
        lambda ws: ["stiffness", model_with(ws, "us.toml", "[measurements]", "[measurement]"), "--posture", Q0],
        2,
        "unknown section(s) measurement (did you mean 'measurements'?)",
    ),
    cmd(
        "stiffness-sigma-negative",
        lambda ws: [
            "stiffness",
            model_with(ws, "sn.toml", "sigma_position = 2e-05", "sigma_position = -1"),
            "--posture",
            Q0,
        ],
        2,
        "sigma_position = -1 m must be positive",
    ),
    cmd(
        "stiffness-sigma-in-mm-warns",
        lambda ws: [
            "stiffness",
            model_with(ws, "smm.toml", "sigma_position = 2e-05", "sigma_position = 0.02"),
            "--posture",
            Q0,
        ],
        0,
        "sigma_position = 0.02 m is implausibly large",
        warns=True,
    ),
    cmd(
        "stiffness-measurements-kind-absolute",
        lambda ws: [
            "stiffness",
            model_with(ws, "ab.toml", "[measurements]", '[measurements]\nkind = "absolute"'),
            "--posture",
            Q0,
        ],
        2,
        "kind = 'absolute'",
    ),
    cmd(
        "stiffness-effect-kind-misspelt",
        lambda ws: ["stiffness", model_with(ws, "km.toml", 'kind = "joint"', 'kind = "jiont"'), "--posture", Q0],
        2,
        "unknown kind 'jiont' (did you mean 'joint'?)",
    ),
    cmd(
        "stiffness-effect-key-misspelt",
        lambda ws: ["stiffness", model_with(ws, "vk.toml", "value = 3", "valeu = 3"), "--posture", Q0],
        2,
        "unknown key(s) valeu for kind 'joint' (did you mean 'value'?)",
    ),
    cmd(
        "stiffness-effect-unknown-joint",
        lambda ws: [
            "stiffness",
            model_with(ws, "uj.toml", 'target = "joint_a1"', 'target = "joint_a9"'),
            "--posture",
            Q0,
        ],
        2,
        "unknown joint 'joint_a9'",
    ),
    cmd(
        "stiffness-effect-target-number",
        lambda ws: ["stiffness", model_with(ws, "tn.toml", 'target = "joint_a1"', "target = 1"), "--posture", Q0],
        2,
        "target = 1 must be a name",
    ),
    cmd(
        "stiffness-joint-value-negative",
        lambda ws: ["stiffness", model_with(ws, "jn.toml", "value = 3e-07", "value = -3e-07"), "--posture", Q0],
        2,
        "value = -3e-07 rad/(N m) must be >= 0",
    ),
    cmd(
        "stiffness-joint-value-text",
        lambda ws: ["stiffness", model_with(ws, "jt.toml", "value = 3e-07", 'value = "stiff"'), "--posture", Q0],
        2,
        "value = 'stiff' must be a number",
    ),
    cmd(
        "stiffness-joint-value-nan",
        lambda ws: ["stiffness", model_with(ws, "jnan.toml", "value = 3e-07", "value = nan"), "--posture", Q0],
        2,
        "must be a finite number",
    ),
    cmd(
        "stiffness-joint-value-implausible-warns",
        lambda ws: ["stiffness", model_with(ws, "jbig.toml", "value = 3e-07", "value = 0.5"), "--posture", Q0],
        0,
        "value = 0.5 rad/(N m) is implausibly large for a joint compliance",
        warns=True,
    ),
    cmd(
        "stiffness-duplicated-effect",
        lambda ws: [
            "stiffness",
            model_with(
                ws,
                "de.toml",
                "[[effect]]",
                '[[effect]]\nkind = "joint"\ntarget = "joint_a1"\nvalue = 1e-7\n\n[[effect]]',
            ),
            "--posture",
            Q0,
        ],
        2,
        "duplicates #1",
    ),
    cmd(
        "stiffness-effect-not-a-table",
        lambda ws: [
            "stiffness",
            put(ws, "ent.toml", f'effect = [1]\n[robot]\nurdf = "{ws / "kr/robot.urdf"}"\n'),
            "--posture",
            Q0,
        ],
        2,
        "[[effect]] #1 must be a table",
    ),
    cmd(
        "stiffness-link-value-not-6x6",
        lambda ws: [
            "stiffness",
            model_with(ws, "la.toml", _six_line(ws), "value = [[1.0, 0.0], [0.0, 1.0]]"),
            "--posture",
            Q0,
        ],
        2,
        "must be a 6x6 matrix",
    ),
    cmd(
        "stiffness-link-value-text",
        lambda ws: ["stiffness", model_with(ws, "lt.toml", _six_line(ws), "value = 3"), "--posture", Q0],
        2,
        "must be 6 rows of 6 numbers or a JSON file name",
    ),
    cmd(
        "stiffness-link-value-indefinite",
        lambda ws: ["stiffness", indefinite_link(ws), "--posture", Q0],
        2,
        "has a negative eigenvalue",
    ),
    cmd(
        "stiffness-link-value-skew",
        lambda ws: ["stiffness", skew_link(ws), "--posture", Q0],
        2,
        "is not symmetric",
    ),
    cmd(
        "stiffness-link-json-default-asymmetry-ok",
        lambda ws: ["stiffness", json_link(ws, "link.json"), "--posture", Q0],
        0,
        "",
    ),
    cmd(
        "stiffness-link-json-missing",
        lambda ws: ["stiffness", json_link(ws, "nope.json"), "--posture", Q0],
        2,
        "no such `stiffkit link` JSON file",
    ),
    cmd(
        "stiffness-link-json-nan-constant",
        lambda ws: ["stiffness", json_link(ws, put(ws, "nanl.json", '{"compliance": NaN}')), "--posture", Q0],
        2,
        "not valid JSON",
    ),
    cmd(
        "stiffness-link-json-not-utf8",
        lambda ws: ["stiffness", json_link(ws, put(ws, "l1l.json", b'{"compliance": "\xff"}')), "--posture", Q0],
        2,
        "not UTF-8",
    ),
    cmd(
        "stiffness-link-rpy-degrees-warns",
        lambda ws: ["stiffness", json_link(ws, "link.json", "rpy = [0.0, 90.0, 0.0]"), "--posture", Q0],
        0,
        "it looks like deg",
        warns=True,
    ),
    cmd(
        "stiffness-template-misspelt",
        lambda ws: [
            "stiffness",
            model_with(
                ws, "tm.toml", "[[effect]]", '[[effect]]\nkind = "base"\ntemplate = "ful"\n\n[[effect]]', "model.toml"
            ),
            "--posture",
            Q0,
        ],
        2,
        "unknown template 'ful' (did you mean 'full'?)",
    ),
    cmd(
        "stiffness-effect-without-value",
        lambda ws: ["stiffness", model_with(ws, "nv.toml", base="model.toml"), "--posture", Q0],
        2,
        "has no value; identify it first",
    ),
    cmd(
        "stiffness-compensator-negative-arm",
        lambda ws: ["stiffness", model_with(ws, "ca.toml", "a = 0.45", "a = -0.45"), "--posture", Q0],
        2,
        "a = -0.45 m must be positive",
    ),
    cmd(
        "stiffness-profile-four-values",
        lambda ws: ["stiffness", profile_model(ws, "[1e-7, 0.0, 0.0, 0.0]"), "--posture", Q0],
        2,
        "value must be [c0, c1, c2, c3, c4]",
    ),
    cmd(
        "stiffness-profile-negative-compliance",
        lambda ws: ["stiffness", profile_model(ws, "[-1e-5, 0.0, 0.0, 0.0, 0.0]"), "--posture", Q0],
        2,
        "a joint compliance must be >= 0",
    ),
    cmd(
        "stiffness-offset-two-values",
        lambda ws: [
            "stiffness",
            model_with(ws, "po.toml", "[[effect]]", '[[effect]]\nkind = "point_offset"\nr = [0.1, 0.2]\n\n[[effect]]'),
            "--posture",
            Q0,
        ],
        2,
        "r must be [x, y, z]",
    ),
    cmd(
        "stiffness-posture-count",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", "0,0,0"],
        2,
        "expected 6 comma-separated numbers, got 3",
    ),
    cmd(
        "stiffness-posture-degrees-warns",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", "0,-30,45,0,90,0"],
        0,
        "it looks like deg",
        warns=True,
    ),
    cmd(
        "stiffness-posture-1e300",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", "0,0,1e300,0,0,0"],
        2,
        "is out of range for an angle",
    ),
    cmd(
        "stiffness-posture-negative-first-ok",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", "-0.5,0,0.3,0,1.2,0"],
        0,
        "",
    ),
    cmd(
        "stiffness-trajectory-missing-column",
        lambda ws: [
            "stiffness",
            kr(ws, "values.toml"),
            "--trajectory",
            put(ws, "q.csv", "q1,q2,q3,q4,q5\n0,0,0,0,0\n"),
        ],
        2,
        "missing column(s) q6",
    ),
    cmd(
        "stiffness-trajectory-nan",
        lambda ws: [
            "stiffness",
            kr(ws, "values.toml"),
            "--trajectory",
            put(ws, "qn.csv", "q1,q2,q3,q4,q5,q6\n0,0,nan,0,0,0\n"),
        ],
        2,
        "field 'q3' is nan (must be finite)",
    ),
    cmd(
        "stiffness-lscale-zero",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", Q0, "--lscale", "0"],
        2,
        "--lscale = 0 m must be positive",
    ),
    cmd(
        "stiffness-lscale-negative",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", Q0, "--lscale", "-1"],
        2,
        "--lscale = -1 m must be positive",
    ),
    cmd(
        "stiffness-lscale-mm-warns",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", Q0, "--lscale", "3500"],
        0,
        "it looks like mm",
        warns=True,
    ),
    cmd(
        "stiffness-json-is-model",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", Q0, "--json", kr(ws, "values.toml")],
        2,
        "is an input file",
    ),
    cmd(
        "stiffness-plot-suffix",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", Q0, "--plot", str(ws / "p.txt")],
        2,
        "must end in one of .png",
    ),
    cmd(
        "stiffness-same-output-twice",
        lambda ws: [
            "stiffness",
            kr(ws, "values.toml"),
            "--posture",
            Q0,
            "--json",
            str(ws / "o.npz"),
            "--npz",
            str(ws / "o.npz"),
        ],
        2,
        "the same file as --json",
    ),
    cmd(
        "stiffness-output-folder-unwritable",
        lambda ws: ["stiffness", kr(ws, "values.toml"), "--posture", Q0, "--json", "/proc/stiffkit/o.json"],
        2,
        "/proc/stiffkit",
    ),
]


@pytest.mark.parametrize("row", ROWS)
def test_bad_input(row, ws, capsys, monkeypatch):
    check_row(row, ws, capsys, monkeypatch)
