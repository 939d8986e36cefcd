"""Bad and awkward inputs: the URDF behind a model and `stiffkit urdf` /
`robot` (Orthoglide, SMG, spring trees), one row each (the rules every row
obeys and the shared workspace: tests/_bad_inputs.py)."""

from __future__ import annotations

import pytest
from _bad_inputs import (
    EYE,
    INDEF,
    Q0,
    check_row,
    cmd,
    deep_tree,
    make_workspace,
    model_with,
    put,
    tree,
    truncated_urdf,
    urdf_with,
)

ws = pytest.fixture(scope="module")(make_workspace)

ROWS = [
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
]


@pytest.mark.parametrize("row", ROWS)
def test_bad_input(row, ws, capsys, monkeypatch):
    check_row(row, ws, capsys, monkeypatch)
