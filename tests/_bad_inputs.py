"""The shared part of the bad-input tables (tests/test_bad_inputs_*.py):
the workspace every row starts from, the helpers that build a row's bad
file, and the rules every row obeys (``check_row``).

Each row gives the exit status (or the exception) and a fragment of the one
line that must explain it; no row may print a traceback. Command rows run
``stiffkit.cli.main`` in-process (fast); a few rows that need the FEA use
tiny meshes. Rows of the commands being reworked elsewhere (fit, diagnose,
convergence) that fail today are marked xfail ("phase 2").
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


def make_workspace(tmp_path_factory):
    """The workspace of a table (each module's fixture ``ws``): files every
    row starts from, a KR-270-like model with its data, a field of six load
    cases, a link JSON, a fit JSON, a small LINK.toml."""
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


# ---------------------------------------------------------------- row helpers

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


# ---------------------------------------------------------------- the rules


def _run(row: Row, ws: Path, capsys):
    argv = row.args(ws)
    rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def check_row(row: Row, ws: Path, capsys, monkeypatch) -> None:
    """The rules every row obeys: one line naming the trouble, no traceback."""
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
