"""Bad inputs give one clear line and exit status 2, never a traceback;
the commands run end to end."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from stiffkit.fea.ccx import CcxError, run_ccx

BEAM = """
[geometry]
{geometry}
units = "mm"
[material]
E = 2.0e11
nu = 0.266
[support]
plane = "{support}"
[load]
plane = "{load}"
reference_point = [{ref}]
[mesh]
order = {order}
size = {size}
[solver]
route = "{route}"
"""


def write(
    tmp_path,
    name="link.toml",
    geometry='shape = "box"\nsize = [100.0, 10.0, 10.0]',
    support="x-min",
    load="x-max",
    ref="100.0, 0.0, 0.0",
    order=2,
    size=5.0,
    route="auto",
):
    p = tmp_path / name
    p.write_text(
        BEAM.format(geometry=geometry, support=support, load=load, ref=ref, order=order, size=size, route=route)
    )
    return p


def stiffkit(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "stiffkit", *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=600
    )


def assert_clean_error(proc, *needles):
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("stiffkit")]
    assert len(lines) == 1, proc.stderr
    for n in needles:
        assert n in lines[0], lines[0]


def test_missing_file(tmp_path):
    assert_clean_error(stiffkit("link", tmp_path / "nope.toml"), "nope.toml", "no such")


def test_missing_cad_file(tmp_path):
    p = write(tmp_path, geometry='step = "gone.step"')
    assert_clean_error(stiffkit("link", p), "gone.step", "not found")


def test_not_a_solid(tmp_path):
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addRectangle(0, -5, -5, 100, 10)
        gmsh.model.occ.synchronize()
        gmsh.write(str(tmp_path / "sheet.step"))
    finally:
        gmsh.finalize()
    p = write(tmp_path, geometry='step = "sheet.step"')
    assert_clean_error(stiffkit("link", p, "--cache", tmp_path / "c"), "not a solid")


def test_plane_that_selects_no_face(tmp_path):
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        # a wedge whose x-max is only an edge (along y at x = 100, z = -5)
        gmsh.model.occ.addWedge(0, -5, -5, 100, 10, 10, ltx=0)
        gmsh.model.occ.synchronize()
        gmsh.write(str(tmp_path / "wedge.step"))
    finally:
        gmsh.finalize()
    p = write(tmp_path, geometry='step = "wedge.step"', size=8.0, order=1)
    assert_clean_error(stiffkit("link", p, "--cache", tmp_path / "c"), "[load] plane", "no element face")


def test_load_face_is_support_face(tmp_path):
    p = write(tmp_path, load="x-min")
    assert_clean_error(stiffkit("link", p), "[load] plane", "support")


@pytest.mark.parametrize(
    "field,value,needle",
    [
        ('plane = "x-max"', 'plane = "top"', "choose one of"),
        ("nu = 0.266", "nu = 0.7", "nu"),
        ("order = 2", "order = 3", "order"),
    ],
)
def test_bad_values(tmp_path, field, value, needle):
    p = write(tmp_path)
    p.write_text(p.read_text().replace(field, value, 1))
    assert_clean_error(stiffkit("link", p), needle)


def test_ccx_input_error_text_is_surfaced(tmp_path):
    deck = tmp_path / "bad.inp"
    deck.write_text("*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D4, ELSET=EALL\n1, 1, 2, 3, 4\n*STEP\n*STATIC\n*END STEP\n")
    with pytest.raises(CcxError) as exc:
        run_ccx(deck, timeout=60)
    msg = str(exc.value)
    # exit status 201 is ccx's input error; its own text is surfaced
    assert "ccx input error" in msg and "bad.inp" in msg and "no material was assigned" in msg


def test_ccx_timeout(tmp_path, monkeypatch):
    # a deck with a number wider than ccx's 20-character field made ccx 2.20
    # loop for minutes here; the runner must stop any such run
    fake = tmp_path / "slowccx"
    fake.write_text("#!/bin/sh\nsleep 30\n")
    fake.chmod(0o755)
    monkeypatch.setenv("STIFFKIT_CCX", str(fake))
    deck = tmp_path / "slow.inp"
    deck.write_text("*NODE\n")
    with pytest.raises(CcxError, match="within 2 s"):
        run_ccx(deck, timeout=2)


def test_gmsh_failure_is_a_clean_error(tmp_path):
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addCone(0, 0, 0, 100, 0, 0, 10, 0)  # apex at x = 100
        gmsh.model.occ.synchronize()
        gmsh.write(str(tmp_path / "cone.step"))
    finally:
        gmsh.finalize()
    p = write(tmp_path, geometry='step = "cone.step"', size=8.0, order=1)
    proc = stiffkit("link", p, "--cache", tmp_path / "c")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr


def test_link_and_convergence_end_to_end(tmp_path):
    p = write(tmp_path, size=5.0)
    out = tmp_path / "o.json"
    proc = stiffkit("link", p, "--json", out, "--cache", tmp_path / "c", "--quiet")
    assert proc.returncode == 0, proc.stderr
    d = json.loads(out.read_text())
    assert d["route"] == "matrix" and d["mesh"]["order"] == 2
    assert d["closed_form"]["max_abs_relative_error"] < 0.05
    proc = stiffkit(
        "convergence",
        p,
        "--orders",
        "1,2",
        "--sizes",
        "5,4",
        "-j",
        "2",
        "--cache",
        tmp_path / "c",
        "--json",
        tmp_path / "s.json",
        "--png",
        tmp_path / "s.png",
    )
    assert proc.returncode == 0, proc.stderr
    s = json.loads((tmp_path / "s.json").read_text())
    runs = {(r["order"], r["size"]): r for r in s["runs"]}
    assert set(runs) == {(1, 5.0), (1, 4.0), (2, 5.0), (2, 4.0)}
    assert runs[(2, 5.0)]["cached"]  # the link run above
    # linear tets are far worse than quadratic ones (paper Table 5)
    assert runs[(1, 4.0)]["max_relative_error"] > 10 * runs[(2, 4.0)]["max_relative_error"]
    assert (tmp_path / "s.png").stat().st_size > 1000
    assert "order" in proc.stdout and "error %" in proc.stdout
    assert "[" in proc.stderr  # progress bar


def test_help_teaches():
    proc = stiffkit("link", "--help")
    assert proc.returncode == 0 and "LINK.toml" in proc.stdout and "example" in proc.stdout
    assert "structured = false | true" in proc.stdout and "across_factor" in proc.stdout
    proc = stiffkit("convergence", "--help")
    assert proc.returncode == 0 and "--orders" in proc.stdout


def test_orthoglide_axle_example_from_step(tmp_path):
    """A CAD file through the whole pipeline (STEP import in mm), compared
    with its single-beam approximation ([approximation] of the example)."""
    from stiffkit.fea import load_link, run_link

    root = Path(__file__).resolve().parents[1] / "examples"
    job = load_link(root / "orthoglide_axle.toml").with_mesh(size=4.0)
    r = run_link(job, cache_dir=tmp_path)
    assert r.mesh.order == 2 and r.solution.route == "matrix"
    lo, hi = r.mesh.bbox()
    assert np.allclose(hi - lo, [0.050, 0.040, 0.040], rtol=1e-3)  # mm -> m
    d, beam = np.diag(r.compliance.matrix), np.diag(r.closed_form)
    assert np.abs(d / beam - 1).max() < 0.15  # a flanged tube ~ a tube
    assert r.to_json()["closed_form"]["kind"] == "single-beam approximation"


def test_ccx_input_error_through_the_cli(tmp_path):
    # a stand-in ccx that fails the way ccx 2.20 does on a bad deck (exit 201)
    fake = tmp_path / "ccx201"
    fake.write_text(
        "#!/bin/sh\necho ' *ERROR in calinput: no material was assigned to element 1'\n"
        "echo ' *ERROR: fatal'\nexit 201\n"
    )
    fake.chmod(0o755)
    import os

    p = write(tmp_path)
    proc = subprocess.run(
        [sys.executable, "-m", "stiffkit", "link", str(p), "--no-cache"],
        capture_output=True,
        text=True,
        env=dict(os.environ, STIFFKIT_CCX=str(fake)),
    )
    assert_clean_error(proc, "ccx input error", "no material was assigned")
