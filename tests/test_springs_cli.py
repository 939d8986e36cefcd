"""``stiffkit robot``: the commands write the numbers the Python calls give."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from stiffkit.cli import main
from stiffkit.springs import Joint, Spring, evaluate, series
from stiffkit.springs import orthoglide as og

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "springs_beam_behind_hinge.json"


def test_orthoglide_json_and_map(tmp_path):
    out, png = tmp_path / "og.json", tmp_path / "map.png"
    assert main(["robot", "orthoglide", "--map", "5", "--png", str(png), "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    C = og.compliance(np.zeros((1, 3))).compliance[0]
    assert data["isotropic"]["k_tran_1e-4_mm_per_N"] == pytest.approx(C[0, 0] * 1e7, rel=1e-12)
    assert data["isotropic"]["k_rot_1e-7_rad_per_N_mm"] == pytest.approx(C[3, 3] * 1e4, rel=1e-12)
    ct = np.array(data["map"]["ct_max_mm_per_N"])
    assert ct.shape == (5, 5, 5) and ct[2, 2, 2] == pytest.approx(C[0, 0] * 1e3, rel=1e-9)
    assert png.stat().st_size > 10_000


def test_orthoglide_singular_point_reports_free_motions(tmp_path, capsys):
    L = og.OrthoglideGeometry().L * 1e3
    t = L / np.sqrt(3) * (1 - 1e-9)
    out = tmp_path / "s.json"
    assert main(["robot", "orthoglide", "--point", f"{t},{t},{t}", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["rank"] == 4 and len(data["free_twists"]) == 2
    assert "2 free motion(s)" in capsys.readouterr().out


def test_smg_json(tmp_path):
    out = tmp_path / "smg.json"
    assert main(["robot", "smg", "--postures", "11", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert len(data["kappa_t_N"]) == 11 and min(data["rank"]) == 6
    assert all(k > 0 for k in data["kappa_r_N"])


def test_tree_example_matches_python(tmp_path):
    out = tmp_path / "t.json"
    assert main(["robot", "tree", str(EXAMPLE), "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    spec = json.loads(EXAMPLE.read_text())
    c = np.array(spec["tree"]["series"][1]["spring"]["compliance"])
    res = evaluate(
        series(Joint("revolute", [0, 0, 1], [0, 0, 0], passive=True), Spring(c, pos=[0.5, 0, 0])),
        tool=[0.5, 0, 0],
        lscale=0.5,
    )
    assert data["rank"] == 5 and not data["compliance_exists"] and data["stiffness_exists"]
    np.testing.assert_allclose(data["stiffness"], res.stiffness[0], rtol=0, atol=1e-12 * np.abs(res.stiffness).max())
    # the free motion: rotation about the hinge, seen at the tool (0, 0.5, 0, 0, 0, 1)
    f = np.array(data["free_twists"][0])
    assert abs(abs(f @ [0, 0.5, 0, 0, 0, 1]) / np.linalg.norm(f) / np.hypot(0.5, 1) - 1) < 1e-12


def test_bad_tree_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text('{"tree": {"series": []}}')
    assert main(["robot", "tree", str(bad)]) == 2
    assert "non-empty list" in capsys.readouterr().err
    assert main(["robot", "orthoglide", "--link-file", "bar"]) == 2
