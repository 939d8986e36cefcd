"""Bad and awkward inputs, one row each, over every command and the Python
API: each row gives the exit status (or the exception) and a fragment of
the one line that must explain it; no row may print a traceback.

Command rows run ``stiffkit.cli.main`` in-process (fast); a few rows that
need the FEA use tiny meshes. Rows of the commands being reworked elsewhere
(fit, diagnose, convergence) that fail today are marked xfail ("phase 2").
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from _links import small_beam

import stiffkit as sk
from stiffkit.cli import main
from stiffkit.errors import PlausibilityWarning, StiffkitError
from stiffkit.field.synthetic import cantilever_fields, square_grid

# ---------------------------------------------------------------- workspace


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """Files every row starts from: a KR-270-like model with its data, a
    field of six load cases, a link JSON, a fit JSON, a small LINK.toml."""
    root = tmp_path_factory.mktemp("bad")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["synth", "kr270", "--out", str(root / "kr"), "--configs", "4", "--seed", "3"]) == 0
    kr = root / "kr"
    # the truth has values: a model for `stiffness`
    (kr / "values.toml").write_text((kr / "truth.toml").read_text())
    # a field of six load cases (SI)
    k = sk.cantilever_compliance(1.0, 2e11, 0.266, sk.section_properties("square", [0.01], 0.266))
    loads = np.array([100.0, 0.1, 0.1, 0.1, 0.1, 0.1])
    pts = square_grid(0.01, 0.002, x=1.0)
    fields = cantilever_fields(k, np.diag(loads), pts, [1.0, 0, 0], sigma=1e-9, rng=2)
    fd = root / "field"
    fd.mkdir()
    np.savetxt(fd / "nodes.csv", pts, delimiter=",", header="x,y,z", comments="")
    for j, f in enumerate(fields):
        np.savetxt(fd / f"d{j}.csv", f, delimiter=",", header="ux,uy,uz", comments="")
    # a `stiffkit link` JSON as the default job writes it: asymmetric to the FEA noise
    c = sk.cantilever_compliance(0.3, 7e10, 0.33, sk.section_properties("tube", [0.03, 0.026], 0.33))
    noisy = c.copy()
    noisy[1, 5] *= 1 + 6.67e-8
    std = 1e-4 * np.sqrt(np.abs(np.outer(np.diag(c), np.diag(c))))
    (root / "link.json").write_text(
        json.dumps({"compliance": noisy.tolist(), "compliance_std": std.tolist(), "symmetry_error": 6.67e-8})
    )
    fit = {
        "rms_position_m": 1e-4,
        "max_position_m": 3e-4,
        "axes": {a: {"rms_m": 1e-4, "max_m": 2e-4} for a in "xyz"},
        "compensated_fraction": 0.9,
        "parameters": [{"name": "joint_a1.c", "value": 3e-7, "std": 1e-9, "group": "identifiable"}],
    }
    (root / "fit.json").write_text(json.dumps(fit))
    (root / "beam.toml").write_text(BEAM)
    return root


# the small beam of tests/_links.py, with the field fitted on the load face
BEAM = small_beam(5.0).replace("[mesh]", '[field]\nregion = "face"\n[mesh]')

# ---------------------------------------------------------------- helpers


def edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def put(ws: Path, name: str, text: str | bytes) -> str:
    """A file of this row (in a folder of its own), its path."""
    d = ws / "rows"
    d.mkdir(exist_ok=True)
    p = d / name
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    return str(p)


def model_with(ws: Path, name: str, old: str = "", new: str = "", base: str = "values.toml") -> str:
    """A copy of a kr model (its URDF path made absolute) with one edit."""
    text = (ws / "kr" / base).read_text()
    text = text.replace('urdf = "robot.urdf"', f'urdf = "{ws / "kr" / "robot.urdf"}"')
    if old:
        text = edit(text, old, new)
    return put(ws, name, text)


def urdf_with(ws: Path, name: str, old: str, new: str, count: int = 1) -> str:
    text = (ws / "kr" / "robot.urdf").read_text()
    assert old in text, old
    text = text.replace(old, new, count)
    u = put(ws, name, text)
    return model_with(ws, name + ".toml", f'urdf = "{ws / "kr" / "robot.urdf"}"', f'urdf = "{u}"')


def csv_with(ws: Path, name: str, src: str, line: int | None = None, new: str | None = None, header=None) -> str:
    lines = (ws / src).read_text().splitlines()
    if header is not None:
        lines[0] = header
    if line is not None:
        lines[line - 1] = new
    return put(ws, name, "\n".join(lines) + "\n")


def link_with(ws: Path, name: str, old: str = "", new: str = "") -> str:
    text = BEAM if not old else edit(BEAM, old, new)
    return put(ws, name, text)


def fit_with(ws: Path, name: str, key: str, value) -> str:
    d = json.loads((ws / "fit.json").read_text())
    if value is KeyError:
        del d[key]
    else:
        d[key] = value
    return put(ws, name, json.dumps(d))


def field_args(ws: Path, nodes=None, *extra):
    fd = ws / "field"
    return [
        "field",
        nodes or str(fd / "nodes.csv"),
        *[str(fd / f"d{j}.csv") for j in range(6)],
        "--reference",
        "1,0,0",
        *extra,
    ]


def kr(ws: Path, name: str) -> str:
    return str(ws / "kr" / name)


Q0 = "0,-0.5,0.3,0,1.2,0"


@dataclass
class Row:
    id: str
    args: object  # ws -> argv (a command row) or ws -> callable (an API row)
    status: int | type  # exit status, or the exception class an API row raises
    fragment: str  # in the error line (or the warning line when status is 0)
    marks: list = field(default_factory=list)
    warns: bool = False  # a warning line must carry the fragment (status 0 or not)


def cmd(id, args, status, fragment, *marks, warns=False):
    return pytest.param(Row(id, args, status, fragment, list(marks), warns), id=id, marks=list(marks))


def api(id, call, exc, fragment, *marks):
    return pytest.param(Row(id, call, exc, fragment, list(marks)), id=id, marks=list(marks))


T_HEAD = "config,q1,q2,q3,q4,q5,q6"
T_ROW = "c1,0,-0.5,0.3,0,1.2,0"


def targets(ws: Path, name: str, head: str = T_HEAD, row: str = T_ROW) -> str:
    """A TARGETS.csv of this row (compensate)."""
    return put(ws, name, f"{head}\n{row}\n")


def comp(ws: Path, target: str, *extra) -> list:
    """stiffkit compensate on the KR model with values."""
    return ["compensate", kr(ws, "values.toml"), target, "--out", str(ws / "rows" / "commands.csv"), *extra]


# ---------------------------------------------------------------- the table

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
    # -- stiffness: the URDF behind the model
    cmd(
        "urdf-missing",
        lambda ws: ["stiffness", model_with(ws, "um.toml", "robot.urdf", "gone.urdf"), "--posture", Q0],
        2,
        "no such URDF",
    ),
    cmd(
        "urdf-truncated",
        lambda ws: ["stiffness", truncated_urdf(ws), "--posture", Q0],
        2,
        "not well-formed XML",
    ),
    cmd(
        "urdf-duplicate-joint-names",
        lambda ws: ["stiffness", urdf_with(ws, "dj.urdf", 'name="joint_a3"', 'name="joint_a2"'), "--posture", Q0],
        2,
        "duplicate joint name(s) joint_a2",
    ),
    cmd(
        "urdf-cycle",
        lambda ws: [
            "stiffness",
            urdf_with(ws, "cy.urdf", '<parent link="base_link"/>', '<parent link="link_3"/>'),
            "--posture",
            Q0,
        ],
        2,
        "loop",
    ),
    cmd(
        "urdf-two-parents",
        lambda ws: [
            "stiffness",
            urdf_with(
                ws,
                "tp.urdf",
                "</robot>",
                '<joint name="x" type="fixed"><parent link="link_6"/><child link="link_2"/></joint></robot>',
            ),
            "--posture",
            Q0,
        ],
        2,
        "child of two joints",
    ),
    cmd(
        "urdf-origin-not-numbers",
        lambda ws: [
            "stiffness",
            urdf_with(ws, "on.urdf", '<origin xyz="0 0 0.6', '<origin xyz="0 zero 0.6'),
            "--posture",
            Q0,
        ],
        2,
        "must be 3 finite number(s)",
    ),
    cmd(
        "urdf-root-not-robot",
        lambda ws: ["stiffness", urdf_with(ws, "rr.urdf", "robot", "machine", 3), "--posture", Q0],
        2,
        "the root element is <machine>, a URDF's is <robot>",
    ),
    cmd(
        "urdf-in-mm-warns",
        lambda ws: [
            "stiffness",
            urdf_with(ws, "mmu.urdf", '<origin xyz="0 0 0.6', '<origin xyz="0 0 600'),
            "--posture",
            Q0,
        ],
        0,
        "is it in mm?",
        warns=True,
    ),
    cmd(
        "urdf-prismatic-on-chain",
        lambda ws: ["stiffness", urdf_with(ws, "pr.urdf", 'type="revolute"', 'type="prismatic"'), "--posture", Q0],
        2,
        "only revolute, continuous and fixed",
    ),
    cmd(
        "urdf-tool-frame-missing",
        lambda ws: [
            "stiffness",
            model_with(ws, "tfm.toml", 'tool_frame = "tool0"', 'tool_frame = "flange"'),
            "--posture",
            Q0,
        ],
        2,
        "tool_frame 'flange' is not a link",
    ),
    # -- robot orthoglide / smg / tree
    cmd(
        "orthoglide-map-negative",
        lambda ws: ["robot", "orthoglide", "--map", "-3"],
        2,
        "--map = -3 must be in [2, 61]",
    ),
    cmd("orthoglide-map-zero", lambda ws: ["robot", "orthoglide", "--map", "0"], 2, "--map = 0 must be in [2, 61]"),
    cmd("orthoglide-map-text", lambda ws: ["robot", "orthoglide", "--map", "ten"], 2, "'ten' is not an integer"),
    cmd("orthoglide-map-huge", lambda ws: ["robot", "orthoglide", "--map", "500"], 2, "must be in [2, 61]"),
    cmd("orthoglide-point-negative-ok", lambda ws: ["robot", "orthoglide", "--point", "-50,0,0"], 0, ""),
    cmd("orthoglide-point-out-of-reach", lambda ws: ["robot", "orthoglide", "--point", "400,0,0"], 2, "out of reach"),
    cmd("orthoglide-point-huge", lambda ws: ["robot", "orthoglide", "--point", "1e9,0,0"], 2, "200 mm cube"),
    cmd(
        "orthoglide-png-without-map",
        lambda ws: ["robot", "orthoglide", "--png", str(ws / "m.png")],
        2,
        "--png needs --map",
    ),
    cmd(
        "orthoglide-png-suffix",
        lambda ws: ["robot", "orthoglide", "--map", "2", "--png", str(ws / "m.bmpx")],
        2,
        "must end in one of",
    ),
    cmd(
        "orthoglide-actuator-negative",
        lambda ws: ["robot", "orthoglide", "--actuator-compliance", "-1e-9"],
        2,
        "must be >= 0",
    ),
    cmd(
        "orthoglide-actuator-mm-warns",
        lambda ws: ["robot", "orthoglide", "--actuator-compliance", "0.5"],
        0,
        "it looks like mm/N",
        warns=True,
    ),
    cmd("orthoglide-link-file-no-equals", lambda ws: ["robot", "orthoglide", "--link-file", "bar"], 2, "NAME=PATH"),
    cmd(
        "orthoglide-link-file-unknown",
        lambda ws: ["robot", "orthoglide", "--link-file", f"arm={ws / 'link.json'}"],
        2,
        "unknown Orthoglide link 'arm'",
    ),
    cmd(
        "orthoglide-link-file-missing",
        lambda ws: ["robot", "orthoglide", "--link-file", f"bar={ws / 'none.json'}"],
        2,
        "no such `stiffkit link` JSON file",
    ),
    cmd(
        "orthoglide-link-file-twice",
        lambda ws: [
            "robot",
            "orthoglide",
            "--link-file",
            f"bar={ws / 'link.json'}",
            "--link-file",
            f"bar={ws / 'link.json'}",
        ],
        2,
        "'bar' is given twice",
    ),
    cmd(
        "orthoglide-json-is-link-file",
        lambda ws: ["robot", "orthoglide", "--link-file", f"bar={ws / 'link.json'}", "--json", str(ws / "link.json")],
        2,
        "is an input file",
    ),
    cmd("smg-postures-one", lambda ws: ["robot", "smg", "--postures", "1"], 2, "--postures = 1 must be in [2, 200000]"),
    cmd("smg-postures-negative", lambda ws: ["robot", "smg", "--postures", "-5"], 2, "must be in [2"),
    cmd("smg-lscale-zero", lambda ws: ["robot", "smg", "--lscale", "0"], 2, "--lscale = 0 m must be positive"),
    cmd(
        "smg-link-file-unknown",
        lambda ws: ["robot", "smg", "--link-file", f"bar={ws / 'link.json'}"],
        2,
        "unknown SMG link",
    ),
    cmd("tree-missing", lambda ws: ["robot", "tree", str(ws / "t.json")], 2, "no such tree JSON file"),
    cmd("tree-not-json", lambda ws: ["robot", "tree", put(ws, "t1.json", "{tree:")], 2, "not valid JSON"),
    cmd(
        "tree-nan-constant",
        lambda ws: ["robot", "tree", put(ws, "t2.json", '{"tree": NaN}')],
        2,
        "NaN is not a JSON number",
    ),
    cmd(
        "tree-no-tree-key", lambda ws: ["robot", "tree", put(ws, "t3.json", '{"tool": [0, 0, 0]}')], 2, "no 'tree' key"
    ),
    cmd("tree-top-level-list", lambda ws: ["robot", "tree", put(ws, "t4.json", "[1, 2]")], 2, "no 'tree' key"),
    cmd(
        "tree-unknown-key", lambda ws: ["robot", "tree", tree(ws, "t5.json", extra={"tol": 1})], 2, "unknown key(s) tol"
    ),
    cmd(
        "tree-unknown-node",
        lambda ws: ["robot", "tree", tree(ws, "t6.json", {"chain": []})],
        2,
        "unknown tree node 'chain'",
    ),
    cmd("tree-empty-series", lambda ws: ["robot", "tree", tree(ws, "t7.json", {"series": []})], 2, "non-empty list"),
    cmd(
        "tree-spring-two-kinds",
        lambda ws: ["robot", "tree", tree(ws, "t8.json", {"spring": {"compliance": EYE, "stiffness": EYE}})],
        2,
        "exactly one of compliance, stiffness, file",
    ),
    cmd(
        "tree-spring-indefinite",
        lambda ws: ["robot", "tree", tree(ws, "t9.json", {"spring": {"compliance": INDEF}})],
        2,
        "negative eigenvalue",
    ),
    cmd(
        "tree-spring-not-6x6",
        lambda ws: ["robot", "tree", tree(ws, "t10.json", {"spring": {"compliance": [[1, 0], [0, 1]]}})],
        2,
        "must be a 6x6 matrix",
    ),
    cmd(
        "tree-spring-pos-two",
        lambda ws: ["robot", "tree", tree(ws, "t11.json", {"spring": {"compliance": EYE, "pos": [0, 1]}})],
        2,
        "pos must have shape (3,)",
    ),
    cmd(
        "tree-spring-rot-not-rotation",
        lambda ws: [
            "robot",
            "tree",
            tree(ws, "t12.json", {"spring": {"compliance": EYE, "rot": [[2, 0, 0], [0, 1, 0], [0, 0, 1]]}}),
        ],
        2,
        "not a rotation matrix",
    ),
    cmd(
        "tree-spring-unknown-key",
        lambda ws: ["robot", "tree", tree(ws, "t13.json", {"spring": {"compliance": EYE, "position": [0, 0, 0]}})],
        2,
        "unknown key(s) position",
    ),
    cmd(
        "tree-joint-negative-compliance",
        lambda ws: ["robot", "tree", tree(ws, "t14.json", {"joint": {"axis": [0, 0, 1], "compliance": -1e-6}})],
        2,
        "compliance = -1e-06 must be >= 0",
    ),
    cmd(
        "tree-joint-zero-stiffness",
        lambda ws: ["robot", "tree", tree(ws, "t15.json", {"joint": {"axis": [0, 0, 1], "stiffness": 0}})],
        2,
        "stiffness = 0 must be positive",
    ),
    cmd(
        "tree-joint-no-axis",
        lambda ws: ["robot", "tree", tree(ws, "t16.json", {"joint": {"compliance": 1e-6}})],
        2,
        "missing 'axis'",
    ),
    cmd(
        "tree-joint-zero-axis",
        lambda ws: ["robot", "tree", tree(ws, "t17.json", {"joint": {"axis": [0, 0, 0], "compliance": 1e-6}})],
        2,
        "zero vector",
    ),
    cmd(
        "tree-joint-type-ball",
        lambda ws: ["robot", "tree", tree(ws, "t18.json", {"joint": {"type": "ball", "axis": [0, 0, 1]}})],
        2,
        "must be revolute or prismatic",
    ),
    cmd(
        "tree-joint-passive-text",
        lambda ws: ["robot", "tree", tree(ws, "t19.json", {"joint": {"axis": [0, 0, 1], "passive": "yes"}})],
        2,
        "passive = 'yes' must be true or false",
    ),
    cmd(
        "tree-lscale-negative",
        lambda ws: ["robot", "tree", tree(ws, "t20.json", extra={"lscale": -1})],
        2,
        "lscale = -1 m must be positive",
    ),
    cmd(
        "tree-tool-two",
        lambda ws: ["robot", "tree", tree(ws, "t21.json", extra={"tool": [0, 1]})],
        2,
        "tool must have shape (3,)",
    ),
    cmd(
        "tree-rcond-one",
        lambda ws: ["robot", "tree", tree(ws, "t22.json"), "--rcond", "1"],
        2,
        "--rcond = 1 must be in [0, 1)",
    ),
    cmd("tree-nested-too-deep", lambda ws: ["robot", "tree", deep_tree(ws)], 2, "not valid JSON"),
    cmd("tree-ok", lambda ws: ["robot", "tree", tree(ws, "t23.json")], 0, ""),
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
    # -- link: LINK.toml, options and outputs (no FEA)
    cmd("link-missing", lambda ws: ["link", str(ws / "none.toml")], 2, "no such LINK.toml file"),
    cmd("link-not-toml", lambda ws: ["link", put(ws, "l1.toml", "[geometry\n")], 2, "not valid TOML"),
    cmd("link-not-utf8", lambda ws: ["link", put(ws, "l2.toml", b'[geometry]\nunits = "\xb5m"\n')], 2, "not UTF-8"),
    cmd(
        "link-missing-section",
        lambda ws: ["link", link_with(ws, "l3.toml", "[material]\nE = 2.0e11\nnu = 0.3\n", "")],
        2,
        "section [material] is missing",
    ),
    cmd(
        "link-unknown-section",
        lambda ws: ["link", link_with(ws, "l4.toml", "[field]", "[feild]")],
        2,
        "did you mean 'field'?",
    ),
    cmd(
        "link-misspelt-optional-key",
        lambda ws: ["link", link_with(ws, "l5.toml", "size = 5.0", "szie = 5.0")],
        2,
        "[mesh] unknown key(s) szie",
    ),
    cmd(
        "link-misspelt-fit-key",
        lambda ws: ["link", link_with(ws, "l6.toml", "[mesh]", '[fit]\nmethd = "lin"\n[mesh]')],
        2,
        "unknown key(s) methd (did you mean 'method'?)",
    ),
    cmd(
        "link-E-1e300",
        lambda ws: ["link", link_with(ws, "l7.toml", "E = 2.0e11", "E = 1e300")],
        2,
        "is out of range for a Young's modulus E",
    ),
    cmd(
        "link-E-text",
        lambda ws: ["link", link_with(ws, "l8.toml", "E = 2.0e11", 'E = "steel"')],
        2,
        "E = 'steel' must be a number",
    ),
    cmd(
        "link-E-negative",
        lambda ws: ["link", link_with(ws, "l9.toml", "E = 2.0e11", "E = -2.0e11")],
        2,
        "must be positive",
    ),
    cmd(
        "link-E-in-MPa-warns",
        lambda ws: ["link", link_with(ws, "l10.toml", "E = 2.0e11\nnu = 0.3", "E = 2.0e5\nnu = 0.7")],
        2,
        "it looks like N/mm^2 (MPa): give 2e+11 Pa",
        warns=True,
    ),
    cmd(
        "link-nu-half",
        lambda ws: ["link", link_with(ws, "l11.toml", "nu = 0.3", "nu = 0.5")],
        2,
        "nu = 0.5 must be in (-1, 0.5)",
    ),
    cmd(
        "link-density-g-cm3-warns",
        lambda ws: [
            "link",
            link_with(ws, "l12.toml", "nu = 0.3", 'nu = 0.3\ndensity = 7.85\n[solver]\nroute = "matrx"'),
        ],
        2,
        "it looks like g/cm^3",
        warns=True,
    ),
    cmd(
        "link-units-misspelt",
        lambda ws: ["link", link_with(ws, "l13.toml", 'units = "mm"', 'units = "mmm"')],
        2,
        "units = 'mmm' (did you mean 'mm'?)",
    ),
    cmd(
        "link-box-two-sizes",
        lambda ws: ["link", link_with(ws, "l14.toml", "size = [40.0, 10.0, 10.0]", "size = [40.0, 10.0]")],
        2,
        "three positive lengths",
    ),
    cmd(
        "link-box-with-diameter",
        lambda ws: ["link", link_with(ws, "l15.toml", 'units = "mm"', 'units = "mm"\ninner_diameter = 5.0')],
        2,
        "not a key of shape = 'box'",
    ),
    cmd(
        "link-tube-inner-too-big",
        lambda ws: [
            "link",
            link_with(
                ws,
                "l16.toml",
                'shape = "box"\nsize = [40.0, 10.0, 10.0]',
                'shape = "tube"\nlength = 40.0\nouter_diameter = 10.0\ninner_diameter = 12.0',
            ),
        ],
        2,
        "inner_diameter = 12.0 must lie in (0, outer_diameter = 10.0)",
    ),
    cmd(
        "link-reference-two",
        lambda ws: ["link", link_with(ws, "l17.toml", "[40.0, 0.0, 0.0]", "[40.0, 0.0]")],
        2,
        "three coordinates",
    ),
    cmd(
        "link-reference-nan",
        lambda ws: ["link", link_with(ws, "l18.toml", "[40.0, 0.0, 0.0]", "[40.0, nan, 0.0]")],
        2,
        "must be a finite number",
    ),
    cmd(
        "link-amplitudes-five",
        lambda ws: [
            "link",
            link_with(ws, "l19.toml", "reference_point", "amplitudes = [1.0, 1.0, 1.0, 1.0, 1.0]\nreference_point"),
        ],
        2,
        "six positive",
    ),
    cmd(
        "link-amplitudes-negative",
        lambda ws: [
            "link",
            link_with(
                ws, "l20.toml", "reference_point", "amplitudes = [1.0, 1.0, -1.0, 1.0, 1.0, 1.0]\nreference_point"
            ),
        ],
        2,
        "amplitudes Fz = -1 N must be positive",
    ),
    cmd(
        "link-amplitudes-misspelt-auto",
        lambda ws: ["link", link_with(ws, "l21.toml", "reference_point", 'amplitudes = "autoo"\nreference_point')],
        2,
        '"auto" or six positive',
    ),
    cmd(
        "link-cube-without-size",
        lambda ws: ["link", link_with(ws, "l22.toml", 'region = "face"', 'region = "cube"')],
        2,
        "[field] size = 0.0 must be positive",
    ),
    cmd(
        "link-face-with-size",
        lambda ws: ["link", link_with(ws, "l23.toml", 'region = "face"', 'region = "face"\nsize = 3.0')],
        2,
        "is for region",
    ),
    cmd(
        "link-order-three",
        lambda ws: ["link", link_with(ws, "l24.toml", "order = 1", "order = 3")],
        2,
        "order = 3: choose one of 1, 2",
    ),
    cmd(
        "link-order-bool",
        lambda ws: ["link", link_with(ws, "l25.toml", "order = 1", "order = true")],
        2,
        "must be an integer",
    ),
    cmd(
        "link-size-negative",
        lambda ws: ["link", link_with(ws, "l26.toml", "size = 5.0", "size = -5.0")],
        2,
        "must be positive",
    ),
    cmd(
        "link-size-larger-than-part",
        lambda ws: ["link", link_with(ws, "l27.toml", "size = 5.0", "size = 50.0")],
        2,
        "larger than the whole part",
    ),
    cmd(
        "link-size-larger-than-section-warns",
        lambda ws: ["link", link_with(ws, "l28.toml", "size = 5.0", "size = 20.0\n[fit]\ntrim = 0.6")],
        2,
        "less than one element across",
        warns=True,
    ),
    cmd(
        "link-refine-range",
        lambda ws: ["link", link_with(ws, "l29.toml", "size = 5.0", "size = 5.0\nrefine = 1.5")],
        2,
        "refine = 1.5: a size factor in (0, 1)",
    ),
    cmd(
        "link-refine-radius-alone",
        lambda ws: ["link", link_with(ws, "l30.toml", "size = 5.0", "size = 5.0\nrefine_radius = 3.0")],
        2,
        "refine_radius needs refine",
    ),
    cmd(
        "link-across-without-structured",
        lambda ws: ["link", link_with(ws, "l31.toml", "size = 5.0", "size = 5.0\nacross_factor = 0.5")],
        2,
        "needs structured = true",
    ),
    cmd(
        "link-structured-text",
        lambda ws: ["link", link_with(ws, "l32.toml", "size = 5.0", 'size = 5.0\nstructured = "yes"')],
        2,
        "true or false",
    ),
    cmd(
        "link-trim-range",
        lambda ws: ["link", link_with(ws, "l33.toml", "[mesh]", "[fit]\ntrim = 0.6\n[mesh]")],
        2,
        "a fraction in [0, 0.5)",
    ),
    cmd(
        "link-confidence-percent",
        lambda ws: ["link", link_with(ws, "l34.toml", "[mesh]", "[fit]\nconfidence = 99.0\n[mesh]")],
        2,
        "a level in (0, 1)",
    ),
    cmd(
        "link-route-misspelt",
        lambda ws: ["link", link_with(ws, "l35.toml", "[mesh]", '[solver]\nroute = "matrx"\n[mesh]')],
        2,
        "did you mean 'matrix'?",
    ),
    cmd(
        "link-timeout-zero",
        lambda ws: ["link", link_with(ws, "l36.toml", "[mesh]", "[solver]\ntimeout = 0\n[mesh]")],
        2,
        "timeout = 0 s must be positive",
    ),
    cmd(
        "link-tolerance-negative",
        lambda ws: ["link", link_with(ws, "l37.toml", 'plane = "x-min"', 'plane = "x-min"\ntolerance = -1.0')],
        2,
        "tolerance = -1.0 must be positive",
    ),
    cmd(
        "link-same-planes",
        lambda ws: ["link", link_with(ws, "l38.toml", 'plane = "x-max"', 'plane = "x-min"')],
        2,
        "also the support plane",
    ),
    cmd(
        "link-plane-misspelt",
        lambda ws: ["link", link_with(ws, "l39.toml", 'plane = "x-max"', 'plane = "xmax"')],
        2,
        "did you mean 'x-max'?",
    ),
    cmd(
        "link-step-missing",
        lambda ws: [
            "link",
            link_with(ws, "l40.toml", 'shape = "box"\nsize = [40.0, 10.0, 10.0]', 'step = "gone.step"'),
        ],
        2,
        "file not found",
    ),
    cmd(
        "link-section-not-table",
        lambda ws: ["link", put(ws, "l41.toml", "field = 3\n" + BEAM.replace('[field]\nregion = "face"\n', ""))],
        2,
        "[field] must be a table",
    ),
    cmd(
        "link-option-size-zero",
        lambda ws: ["link", str(ws / "beam.toml"), "--size", "0"],
        2,
        "--size = 0 must be positive",
    ),
    cmd(
        "link-option-size-negative",
        lambda ws: ["link", str(ws / "beam.toml"), "--size=-1"],
        2,
        "--size = -1 must be positive",
    ),
    cmd(
        "link-option-size-too-large",
        lambda ws: ["link", str(ws / "beam.toml"), "--size", "100"],
        2,
        "larger than the whole part",
    ),
    cmd(
        "link-size-millions-of-elements",
        lambda ws: ["link", link_with(ws, "l42.toml", "size = 5.0", "size = 0.01")],
        2,
        "[mesh] size: element size 0.01 mm would need about 2.4e+10 tetrahedra",
    ),
    cmd(
        "link-json-duplicate-key",
        lambda ws: [
            "stiffness",
            json_link(ws, put(ws, "dk.json", '{"compliance": 1, "compliance": 2}')),
            "--posture",
            Q0,
        ],
        2,
        "the key 'compliance' appears twice",
    ),
    cmd(
        "field-semicolon-separated",
        lambda ws: field_args(ws, put(ws, "semi.csv", "x;y;z\n1;0;0\n")),
        2,
        "separated by a semicolon",
    ),
    cmd(
        "compare-huge-integer",
        lambda ws: ["compare", put(ws, "c13.json", '{"rms_position_m": 1' + "0" * 400 + "}"), str(ws / "fit.json")],
        2,
        "beyond double precision",
    ),
    cmd("link-option-order", lambda ws: ["link", str(ws / "beam.toml"), "--order", "3"], 2, "invalid choice"),
    cmd(
        "link-json-is-input",
        lambda ws: ["link", str(ws / "beam.toml"), "--json", str(ws / "beam.toml")],
        2,
        "is an input file",
    ),
    cmd(
        "link-vtu-suffix",
        lambda ws: ["link", str(ws / "beam.toml"), "--vtu", str(ws / "o.vtk")],
        2,
        "must end in one of .vtu",
    ),
    cmd(
        "link-png-suffix",
        lambda ws: ["link", str(ws / "beam.toml"), "--png", str(ws / "o.xyz")],
        2,
        "must end in one of .png",
    ),
    cmd(
        "link-json-same-as-png",
        lambda ws: ["link", str(ws / "beam.toml"), "--json", str(ws / "o.png"), "--png", str(ws / "o.png")],
        2,
        "the same file as --json",
    ),
    cmd(
        "link-cache-is-file",
        lambda ws: ["link", str(ws / "beam.toml"), "--cache", str(ws / "fit.json")],
        2,
        "a file, not a folder",
    ),
    # -- link with the FEA (tiny meshes)
    cmd(
        "link-field-cube-covers-clamp",
        lambda ws: [
            "link",
            link_with(ws, "f1.toml", 'region = "face"', 'region = "cube"\nsize = 200.0'),
            "--cache",
            str(ws / "cache"),
        ],
        2,
        "clamped node(s) of the [support] plane",
    ),
    cmd(
        "link-field-layer-covers-clamp",
        lambda ws: [
            "link",
            link_with(ws, "f2.toml", 'region = "face"', 'region = "layer"\nsize = 40.0'),
            "--cache",
            str(ws / "cache"),
        ],
        2,
        "clamped node(s)",
    ),
    cmd(
        "link-step-in-metres-declared-mm-warns",
        lambda ws: ["link", step_link(ws), "--cache", str(ws / "cache")],
        0,
        "is the geometry in metres?",
        warns=True,
    ),
    cmd(
        "link-truncated-cache-entry-is-a-miss",
        lambda ws: ["link", str(ws / "beam.toml"), "--cache", truncated_cache(ws)],
        0,
        "ignoring the unreadable cache entry",
        warns=True,
    ),
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
    # -- the Python API
    api(
        "api-synth-dualarm-sigma-nan",
        lambda ws: sk.calib.synth_dualarm(ws / "da", sigma=float("nan")),
        sk.InputError,
        "sigma = nan must be a finite number",
    ),
    api(
        "api-synth-dualarm-configs-bool",
        lambda ws: sk.calib.synth_dualarm(ws / "da", configs=True),
        sk.InputError,
        "configs = True must be an integer",
    ),
    api(
        "api-synth-dualarm-truth-unknown",
        lambda ws: sk.calib.synth_dualarm(ws / "da", truth="soft"),
        sk.InputError,
        "truth = 'soft': choose one of full, geometric",
    ),
    api(
        "api-fit-field-text",
        lambda ws: sk.fit_field([["a", "b", "c"]] * 4, np.zeros((4, 3)), [0, 0, 0]),
        sk.InputError,
        "must be an array of numbers; got text",
    ),
    api(
        "api-fit-field-ragged",
        lambda ws: sk.fit_field([[0, 0, 0], [1, 0]], np.zeros((2, 3)), [0, 0, 0]),
        sk.InputError,
        "rows of different lengths",
    ),
    api(
        "api-fit-field-2d-points",
        lambda ws: sk.fit_field(np.zeros((5, 2)), np.zeros((5, 2)), [0, 0, 0]),
        sk.InputError,
        "must have shape (n, 3)",
    ),
    api(
        "api-fit-field-nan",
        lambda ws: sk.fit_field(GRID, np.full_like(GRID, np.nan), [0, 0, 0]),
        sk.InputError,
        "displacements[0, 0] is nan",
    ),
    api(
        "api-fit-field-method-number",
        lambda ws: sk.fit_field(GRID, np.zeros_like(GRID), [0, 0, 0], method=4),
        sk.InputError,
        "unknown method 4",
    ),
    api(
        "api-fit-field-trim-text",
        lambda ws: sk.fit_field(GRID, np.zeros_like(GRID), [0, 0, 0], trim="0.1"),
        sk.InputError,
        "trim = '0.1' must be a number",
    ),
    api(
        "api-fit-field-reference-short",
        lambda ws: sk.fit_field(GRID, np.zeros_like(GRID), [0, 0]),
        sk.InputError,
        "reference must be a point",
    ),
    api(
        "api-fit-field-complex",
        lambda ws: sk.fit_field(GRID + 0j, np.zeros_like(GRID), [0, 0, 0]),
        sk.InputError,
        "complex numbers",
    ),
    api(
        "api-fit-field-exact-overflow",
        lambda ws: sk.fit_field(GRID, 1e200 * GRID[:, [1, 0, 2]], [0, 0, 0], method="exact"),
        StiffkitError,
        "did not converge",
    ),
    api(
        "api-fit-field-lin-overflow",
        lambda ws: sk.fit_field(GRID, 1e200 * GRID[:, [1, 0, 2]], [0, 0, 0]),
        sk.InputError,
        "not finite",
    ),
    api(
        "api-fit-fields-shape",
        lambda ws: sk.fit_fields(GRID, np.zeros((2, 5, 3)), [0, 0, 0]),
        sk.InputError,
        "must have shape (m, 27, 3)",
    ),
    api(
        "api-fit-fields-pooled-text",
        lambda ws: sk.fit_fields(GRID, np.zeros((1,) + GRID.shape), [0, 0, 0], pooled="no"),
        sk.InputError,
        "pooled = 'no'",
    ),
    api(
        "api-compliance-fits-ints",
        lambda ws: sk.compliance_from_experiments(np.eye(6), [1, 2, 3, 4, 5, 6]),
        sk.InputError,
        "fits[0] is a int, not a FieldFit",
    ),
    api(
        "api-compliance-five",
        lambda ws: sk.compliance_from_experiments(np.eye(6)[:5], np.zeros((5, 6))),
        sk.InputError,
        "at least 6 experiments",
    ),
    api(
        "api-compliance-confidence",
        lambda ws: sk.compliance_from_experiments(np.eye(6), np.zeros((6, 6)), confidence=99),
        sk.InputError,
        "confidence = 99 must be in (0, 1)",
    ),
    api(
        "api-compliance-wrench-shape",
        lambda ws: sk.compliance_from_experiments(np.eye(3), np.zeros((3, 3))),
        sk.InputError,
        "wrenches must have shape (n, 6)",
    ),
    api(
        "api-section-unknown",
        lambda ws: sk.section_properties("hexagon", [1.0]),
        sk.InputError,
        "unknown section 'hexagon'",
    ),
    api("api-section-count", lambda ws: sk.section_properties("tube", [1.0]), sk.InputError, "takes 2 size(s)"),
    api("api-section-negative", lambda ws: sk.section_properties("square", [-1.0]), sk.InputError, "must be positive"),
    api("api-section-empty", lambda ws: sk.section_properties("square", []), sk.InputError, "takes 1 size(s)"),
    api(
        "api-section-nu",
        lambda ws: sk.section_properties("square", [1.0], 0.6),
        sk.InputError,
        "nu (Poisson's ratio) = 0.6",
    ),
    api(
        "api-cantilever-length",
        lambda ws: sk.cantilever_compliance(-1, 2e11, 0.3, SEC),
        sk.InputError,
        "length = -1 must be positive",
    ),
    api(
        "api-cantilever-E-text",
        lambda ws: sk.cantilever_compliance(1, "steel", 0.3, SEC),
        sk.InputError,
        "E = 'steel' must be a number",
    ),
    api(
        "api-cantilever-section-empty",
        lambda ws: sk.cantilever_compliance(1, 2e11, 0.3, {}),
        sk.InputError,
        "section lacks A",
    ),
    api(
        "api-cantilever-section-list",
        lambda ws: sk.cantilever_compliance(1, 2e11, 0.3, [1, 2]),
        sk.InputError,
        "section must be the dict",
    ),
    api(
        "api-beam-stiffness-E-zero",
        lambda ws: sk.beam_stiffness(1, 0.0, 0.3, SEC),
        sk.InputError,
        "E = 0 must be positive",
    ),
    api("api-normal-quantile", lambda ws: sk.normal_quantile(2.0), sk.InputError, "level = 2 must be in (0, 1)"),
    api("api-load-model-number", lambda ws: sk.load_model(5), sk.InputError, "the path of a model TOML"),
    api("api-load-model-missing", lambda ws: sk.load_model(ws / "none.toml"), sk.InputError, "no such model file"),
    api(
        "api-tool-compliance-shape",
        lambda ws: sk.load_model(kr(ws, "values.toml")).tool_compliance(np.zeros((2, 5))),
        sk.InputError,
        "postures must have shape (N, 6)",
    ),
    api(
        "api-tool-compliance-nan",
        lambda ws: sk.load_model(kr(ws, "values.toml")).tool_compliance([[0, 0, np.nan, 0, 0, 0]]),
        sk.InputError,
        "postures[0, 2] is nan",
    ),
    api(
        "api-tool-compliance-text",
        lambda ws: sk.load_model(kr(ws, "values.toml")).tool_compliance("0,0,0,0,0,0"),
        sk.InputError,
        "got text",
    ),
    api(
        "api-indices-lscale",
        lambda ws: sk.load_model(kr(ws, "values.toml")).stiffness_indices(np.zeros((1, 6)), lscale=-1),
        sk.InputError,
        "lscale = -1 m must be positive",
    ),
    api("api-spring-indefinite", lambda ws: Spring(INDEF), sk.InputError, "negative eigenvalue"),
    api("api-spring-skew", lambda ws: Spring(np.triu(np.ones((6, 6)))), sk.InputError, "is not symmetric"),
    api("api-spring-rot", lambda ws: Spring(np.eye(6), rot=2 * np.eye(3)), sk.InputError, "not a rotation matrix"),
    api("api-spring-kind", lambda ws: Spring(np.eye(6), kind="damping"), sk.InputError, "kind must be"),
    api(
        "api-joint-negative",
        lambda ws: Joint("revolute", [0, 0, 1], compliance=-1.0),
        sk.InputError,
        "compliance = -1 must be >= 0",
    ),
    api("api-joint-type", lambda ws: Joint("ball", [0, 0, 1]), sk.InputError, "must be revolute or prismatic"),
    api("api-joint-axis-text", lambda ws: Joint("revolute", "z"), sk.InputError, "got text"),
    api(
        "api-evaluate-rcond",
        lambda ws: evaluate(Spring(np.eye(6)), rcond=2),
        sk.InputError,
        "rcond = 2 must be in [0, 1)",
    ),
    api(
        "api-evaluate-lscale",
        lambda ws: evaluate(Spring(np.eye(6)), lscale=0),
        sk.InputError,
        "lscale = 0 must be positive",
    ),
    api(
        "api-evaluate-tool", lambda ws: evaluate(Spring(np.eye(6)), tool=[1, 2]), sk.InputError, "tool must have shape"
    ),
    api("api-evaluate-not-a-node", lambda ws: evaluate(np.eye(6)), sk.InputError, "not a spring-tree node"),
    api("api-indices-shape", lambda ws: stiffness_indices(np.eye(5), 1.0), sk.InputError, "stiffness must be (6,6)"),
    api("api-indices-lscale-zero", lambda ws: stiffness_indices(np.eye(6), 0.0), sk.InputError, "lscale must be > 0"),
    api(
        "api-compare-null",
        lambda ws: sk.compare(
            json.loads((ws / "fit.json").read_text()) | {"rms_position_m": None}, str(ws / "fit.json")
        ),
        sk.InputError,
        "'rms_position_m' = None must be a number",
    ),
    api(
        "api-compare-number",
        lambda ws: sk.compare(5, str(ws / "fit.json")),
        sk.InputError,
        "a JSON file name or the dict",
    ),
    api(
        "api-read-measurements-dof",
        lambda ws: read_measurements(kr(ws, "measurements.csv"), 0),
        sk.InputError,
        "dof = 0 must be >= 1",
    ),
    api(
        "api-synthesize-configs",
        lambda ws: synthesize(KR270_JOINTS, kr270_truth(), n_configs=0, workdir=ws / "syn"),
        sk.InputError,
        "n_configs = 0",
    ),
    api(
        "api-synthesize-markers",
        lambda ws: synthesize(KR270_JOINTS, kr270_truth(), markers=[[0, 0]], workdir=ws / "syn"),
        sk.InputError,
        "markers must have shape (n, 3)",
    ),
    api(
        "api-synthesize-ranges",
        lambda ws: synthesize(KR270_JOINTS, kr270_truth(), ranges=[(1, 0)] * 6, workdir=ws / "syn"),
        sk.InputError,
        "the lower bound exceeds the upper",
    ),
    api(
        "api-write-json-nan",
        lambda ws: write_json(ws / "n.json", {"a": [1.0, float("nan")]}),
        StiffkitError,
        "the value at ['a'][1] is nan",
    ),
    api("api-load-link-number", lambda ws: load_link(3), sk.InputError, "the path of a LINK.toml"),
    api(
        "api-link-json-indefinite",
        lambda ws: read_link_compliance(put(ws, "ind.json", json.dumps({"compliance": INDEF}))),
        sk.InputError,
        "negative eigenvalue",
    ),
    api("api-rotate6-shape", lambda ws: rotate6(np.eye(2), np.eye(6)), sk.InputError, "rot must be (3,3)"),
]

# ---------------------------------------------------------------- row helpers (after the table: they use its names)

from stiffkit._core.springs import rotate6  # noqa: E402
from stiffkit.calib.measure import read_measurements  # noqa: E402
from stiffkit.calib.synth import KR270_JOINTS, kr270_truth, synthesize  # noqa: E402
from stiffkit.fea.config import load_link  # noqa: E402
from stiffkit.io.files import write_json  # noqa: E402
from stiffkit.io.linkjson import read_link_compliance  # noqa: E402
from stiffkit.robot.indices import stiffness_indices  # noqa: E402
from stiffkit.springs import Joint, Spring, evaluate  # noqa: E402

EYE = np.eye(6).tolist()
INDEF = (np.eye(6) + 2 * np.eye(6, k=1) + 2 * np.eye(6, k=-1)).tolist()
GRID = np.array([[x, y, z] for x in range(3) for y in range(3) for z in range(3)], dtype=float)
SEC = sk.section_properties("square", [0.01], 0.3)


def tree(ws, name, node=None, extra=None) -> str:
    doc = {"tool": [0.5, 0, 0], "tree": node or {"series": [{"spring": {"compliance": EYE, "pos": [0.5, 0, 0]}}]}}
    doc.update(extra or {})
    return put(ws, name, json.dumps(doc))


def deep_tree(ws) -> str:
    text = '{"tree": ' + '{"series": [' * 3000 + '{"spring": {"compliance": 1}}' + "]}" * 3000 + "}"
    return put(ws, "deep.json", text)


def _six_line(ws, base="values.toml") -> str:
    """The first 6x6 value of the model (tomli_w writes it over many lines)."""
    text = (ws / "kr" / base).read_text()
    start = text.index("value = [\n")
    return text[start : text.index("\n]", start) + 2]


def indefinite_link(ws) -> str:
    block = _six_line(ws)
    new = "value = " + json.dumps(INDEF)
    return model_with(ws, "ind.toml", block, new)


def skew_link(ws) -> str:
    c = np.diag([1e-9, 1e-8, 1e-8, 1e-7, 1e-6, 1e-6])
    c[0, 1] = 5e-9
    return model_with(ws, "skew.toml", _six_line(ws), "value = " + json.dumps(c.tolist()))


def json_link(ws, path, extra="") -> str:
    return model_with(
        ws,
        Path(str(path)).stem + extra.replace(" ", "")[:8] + "_jl.toml",
        _six_line(ws),
        f'value = "{ws / path}"\n{extra}',
    )


def profile_model(ws, value) -> str:
    return model_with(
        ws,
        f"prof{abs(hash(value)) % 1000}.toml",
        "[[effect]]",
        f'[[effect]]\nkind = "joint_profile"\ntarget = "joint_a4"\nvalue = {value}\n\n[[effect]]',
    )


def truncated_urdf(ws) -> str:
    text = (ws / "kr" / "robot.urdf").read_text()
    u = put(ws, "trunc.urdf", text[: len(text) // 2])
    return model_with(ws, "trunc.toml", f'urdf = "{ws / "kr" / "robot.urdf"}"', f'urdf = "{u}"')


def copies(ws, tag) -> tuple[str, str]:
    """A model (URDF path absolute) and its measurements, copied for a row
    that may overwrite them."""
    m = model_with(ws, f"{tag}.toml", base="model.toml")
    return m, put(ws, f"{tag}.csv", (ws / "kr" / "measurements.csv").read_text())


def kr_header(ws) -> str:
    return (ws / "kr" / "measurements.csv").read_text().splitlines()[0]


def kr_row(ws, line, col=None, value=None) -> str:
    lines = (ws / "kr" / "measurements.csv").read_text().splitlines()
    fields = lines[line - 1].split(",")
    if col is not None:
        fields[lines[0].split(",").index(col)] = value
    return ",".join(fields)


def scaled_measurements(ws, name, cols, factor) -> str:
    lines = (ws / "kr" / "measurements.csv").read_text().splitlines()
    head = lines[0].split(",")
    out = [lines[0]]
    for ln in lines[1:]:
        f = ln.split(",")
        for c in cols:
            k = head.index(c)
            f[k] = repr(float(f[k]) * factor)
        out.append(",".join(f))
    return put(ws, name, "\n".join(out) + "\n")


def duplicated_measurements(ws) -> str:
    lines = (ws / "kr" / "measurements.csv").read_text().splitlines()
    return put(ws, "dupm.csv", "\n".join(lines + lines[1:]) + "\n")


def step_link(ws) -> str:
    """A 40 x 10 x 10 mm box written in metres (0.04 x 0.01 x 0.01) but declared mm."""
    import gmsh

    step = ws / "rows" / "box_m.step"
    step.parent.mkdir(exist_ok=True)
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("b")
        gmsh.model.occ.addBox(0, -0.005, -0.005, 0.04, 0.01, 0.01)
        gmsh.model.occ.synchronize()
        gmsh.write(str(step))
    finally:
        gmsh.finalize()
    text = edit(BEAM, 'shape = "box"\nsize = [40.0, 10.0, 10.0]', f'step = "{step}"')
    text = edit(text, "[40.0, 0.0, 0.0]", "[0.04, 0.0, 0.0]")
    text = edit(text, "size = 5.0", "size = 0.005")
    return put(ws, "step_m.toml", text)


def truncated_cache(ws) -> str:
    """A cache whose entry for beam.toml is cut in half."""
    cache = ws / "cache_trunc"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["link", str(ws / "beam.toml"), "--cache", str(cache), "--quiet"]) == 0
    (entry,) = cache.glob("*.npz")
    data = entry.read_bytes()
    entry.write_bytes(data[: len(data) // 2])
    return str(cache)


# ---------------------------------------------------------------- the test


def _run(row: Row, ws: Path, capsys):
    argv = row.args(ws)
    rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.mark.parametrize("row", ROWS)
def test_bad_input(row: Row, ws, capsys, monkeypatch):
    monkeypatch.chdir(ws)
    if row.id.startswith("api-"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PlausibilityWarning)
            with pytest.raises(row.status) as exc:
                row.args(ws)()
        text = str(exc.value)
        assert isinstance(exc.value, StiffkitError), f"{type(exc.value).__name__}: {text}"
        assert row.fragment in text, text
        assert "\n" not in text and "info=" not in text, text
        return
    rc, out, err = _run(row, ws, capsys)
    assert "Traceback" not in err and "Traceback" not in out, err
    assert rc == row.status, f"exit {rc}, expected {row.status}\n{err}"
    if rc == 2:
        lines = [ln for ln in err.splitlines() if ": error: " in ln]
        assert len(lines) == 1, err
        assert lines[0].startswith("stiffkit"), lines[0]
        if not row.warns:
            assert row.fragment in lines[0], lines[0]
    if row.warns:
        warn_lines = [ln for ln in err.splitlines() if ": warning: " in ln]
        assert any(row.fragment in ln for ln in warn_lines), err
    assert "internal error" not in err, err


def test_the_table_is_large_and_covers_every_command():
    ids = [p.values[0].id for p in ROWS]
    assert len(ids) == len(set(ids)) and len(ids) >= 150
    for prefix in (
        "field",
        "stiffness",
        "urdf",
        "orthoglide",
        "smg",
        "tree",
        "synth",
        "compare",
        "link",
        "fit",
        "diagnose",
        "compensate",
        "convergence",
        "demo",
        "api",
        "app",
    ):
        assert any(i.startswith(prefix + "-") for i in ids), prefix
