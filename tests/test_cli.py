"""The command line as a user runs it: exit codes, messages, outputs."""

import json
import subprocess
import sys

import numpy as np
import pytest

import stiffkit as sk
from stiffkit.field.synthetic import cantilever_fields, square_grid


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "stiffkit", *args], capture_output=True, text=True, cwd=cwd)


def test_help_lists_commands():
    r = run("--help")
    assert r.returncode == 0
    for cmd in ("field", "demo"):
        assert cmd in r.stdout


def test_demo_detects_zeros_and_trimming_helps(tmp_path):
    r = run("demo", cwd=tmp_path)  # its default output folder build/demo is relative
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("zero elements flagged non-significant: 26/26") == 2
    errs = [
        float(line.split(":")[1].split("%")[0])
        for line in r.stdout.splitlines()
        if "max error of the 10 non-zero" in line
    ]
    assert len(errs) == 2 and errs[1] < errs[0] / 3 and errs[1] < 0.1


@pytest.fixture
def field_files(tmp_path):
    k = sk.cantilever_compliance(1.0, 2e11, 0.266, sk.section_properties("square", [0.01], 0.266))
    loads = np.array([100.0, 0.1, 0.1, 0.1, 0.1, 0.1])
    pts = square_grid(0.01, 0.001, x=1.0)
    fields = cantilever_fields(k, np.diag(loads), pts, [1.0, 0, 0], sigma=1e-9, rng=2)
    np.savetxt(tmp_path / "nodes.csv", pts, delimiter=",", header="x,y,z", comments="")
    names = []
    for j, f in enumerate(fields):
        name = tmp_path / f"case{j}.csv"
        np.savetxt(name, f, delimiter=",", header="ux,uy,uz", comments="")
        names.append(str(name))
    return tmp_path, names, loads, k


def test_field_command_computes_compliance(field_files):
    tmp, names, loads, k = field_files
    out = tmp / "k.json"
    r = run(
        "field",
        str(tmp / "nodes.csv"),
        *names,
        "--reference",
        "1,0,0",
        "--loads",
        ",".join(map(str, loads)),
        "--json",
        str(out),
    )
    assert r.returncode == 0, r.stderr
    data = json.loads(out.read_text())
    K = np.array(data["compliance"])
    nz = k != 0
    np.testing.assert_allclose(K[nz], k[nz], rtol=1e-3)
    assert np.array(data["significant"]).sum() == 10
    assert "10 of 36 significant" in r.stdout


def test_field_command_names_bad_row(field_files):
    tmp, names, loads, _ = field_files
    lines = open(names[2]).read().splitlines()
    lines[5] = "0.0,abc,0.0"
    open(names[2], "w").write("\n".join(lines) + "\n")
    r = run("field", str(tmp / "nodes.csv"), *names, "--reference", "1,0,0")
    assert r.returncode == 2
    assert f"{names[2]}, line 6: field 'uy' = 'abc' is not a number" in r.stderr
    assert "Traceback" not in r.stderr


def test_field_command_missing_file_and_column(field_files, tmp_path):
    tmp, names, _, _ = field_files
    r = run("field", str(tmp / "nope.csv"), *names, "--reference", "1,0,0")
    assert r.returncode == 2 and "nope.csv: no such node file" in r.stderr
    (tmp_path / "bad.csv").write_text("ux,uz\n1,2\n")
    r = run("field", str(tmp / "nodes.csv"), str(tmp_path / "bad.csv"), "--reference", "1,0,0")
    assert r.returncode == 2 and "missing column(s) uy" in r.stderr


def test_field_command_degenerate_nodes(tmp_path):
    (tmp_path / "n.csv").write_text("x,y,z\n0,0,0\n1,1,1\n2,2,2\n3,3,3\n")
    (tmp_path / "d.csv").write_text("ux,uy,uz\n0,0,0\n0,0,0\n0,0,0\n0,0,0\n")
    r = run("field", str(tmp_path / "n.csv"), str(tmp_path / "d.csv"), "--reference", "0,0,0")
    assert r.returncode == 2 and "collinear" in r.stderr
