"""Stiffness indices kappa_t, kappa_r in ``stiffkit stiffness`` and Model.stiffness_indices.

Numbers checked: the indices of the model's tool stiffness equal the closed
form of eqs. 31-39 (with S, H orthogonal, G G^T has trace l^2 |K11|_F^2 +
|K12|_F^2, resp. |K12|_F^2 + |K22|_F^2 / l^2), computed here in numpy from
the inverse of the model's compliance; the same robot written in mm (URDF
lengths and every compliance converted) gives the same indices in N; where
the stiffness does not exist the indices are NaN (null in JSON) with a
status, never numbers.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import stiffkit
from stiffkit.calib import synth as S
from stiffkit.cli import main
from stiffkit.robot.urdf import urdf_text
from stiffkit.springs import stiffness_indices, stiffness_indices_where

Q_REG = [[0.0, -0.5, 0.3, 0.0, 1.2, 0.0], [0.4, -1.0, 0.6, 1.0, 0.7, -0.5], [2.0, -0.2, -0.4, -1.5, 1.6, 2.2]]


def closed_form(K, l):
    k11, k12, k22 = K[:3, :3], K[:3, 3:], K[3:, 3:]
    kt = math.sqrt((l**2 * np.sum(k11**2) + np.sum(k12**2)) / 3)
    kr = math.sqrt((np.sum(k12**2) + np.sum(k22**2) / l**2) / 3)
    return kt, kr


def write_robot(d, effects, unit=1.0):
    """The KR-270-like robot and its springs in a unit of length where 1 m = ``unit``:
    URDF lengths times unit; compliances converted (m/N -> unit/N, rad/(N m) ->
    rad/(N unit))."""
    joints = copy.deepcopy(S.KR270_JOINTS)
    for j in joints:
        j["xyz"] = tuple(v * unit for v in j["xyz"])
    d.mkdir(parents=True, exist_ok=True)
    (d / "robot.urdf").write_text(urdf_text("kr270", joints))
    eff = []
    for e in effects:
        e = dict(e)
        if e["kind"] == "joint":
            e["value"] = e["value"] / unit
        elif e["kind"] in ("link", "base", "tool"):
            C = np.array(e["value"], float)
            C[:3, :3] *= unit
            C[3:, 3:] /= unit
            e["value"] = C.tolist()
        eff.append(e)
    (d / "model.toml").write_text(S.model_toml(eff))
    return d / "model.toml"


def values_truth():
    return S.kr270_truth(compensator=False)


def test_indices_equal_closed_form_of_the_model_stiffness(tmp_path):
    path = write_robot(tmp_path / "m", values_truth())
    m = stiffkit.load_model(path)
    Q = np.array(Q_REG)
    idx, ok = m.stiffness_indices(Q)
    assert ok.all()
    l = m.chain.characteristic_length
    # the chain length: joint offsets and tool offset of the URDF
    assert l == pytest.approx(sum(np.linalg.norm(j["xyz"]) for j in S.KR270_JOINTS), rel=1e-14)
    C = m.tool_compliance(Q)
    for i in range(len(Q)):
        kt, kr = closed_form(np.linalg.inv(C[i]), l)
        assert idx.kappa_t[i] == pytest.approx(kt, rel=1e-9)
        assert idx.kappa_r[i] == pytest.approx(kr, rel=1e-9)
    # another length scale: kappa_t grows with l, kappa_r falls (eq. 38 scaled)
    idx2, _ = m.stiffness_indices(Q, lscale=0.5)
    kt, kr = closed_form(np.linalg.inv(C[0]), 0.5)
    assert idx2.kappa_t[0] == pytest.approx(kt, rel=1e-9) and idx2.kappa_r[0] == pytest.approx(kr, rel=1e-9)


@pytest.mark.filterwarnings("ignore::stiffkit.errors.PlausibilityWarning")  # a URDF in mm, on purpose
def test_same_robot_in_mm_gives_the_same_indices(tmp_path):
    m_si = stiffkit.load_model(write_robot(tmp_path / "si", values_truth()))
    m_mm = stiffkit.load_model(write_robot(tmp_path / "mm", values_truth(), unit=1e3))
    assert m_mm.chain.characteristic_length == pytest.approx(1e3 * m_si.chain.characteristic_length, rel=1e-12)
    Q = np.array(Q_REG)
    a, _ = m_si.stiffness_indices(Q)
    b, _ = m_mm.stiffness_indices(Q)
    assert_allclose(b.kappa_t, a.kappa_t, rtol=1e-9)
    assert_allclose(b.kappa_r, a.kappa_r, rtol=1e-9)
    # the literal formula (l = 1 in the input unit) is not invariant
    a1, _ = m_si.stiffness_indices(Q, lscale=1.0)
    b1, _ = m_mm.stiffness_indices(Q, lscale=1.0)
    assert not np.allclose(a1.kappa_t, b1.kappa_t, rtol=1e-3)


def test_cli_json_npz_plot_and_singular_postures(tmp_path, capsys):
    # joint springs only: at q5 = 0 the wrist axes 4 and 6 line up, C has rank 5
    joints_only = [e for e in values_truth() if e["kind"] == "joint"]
    path = write_robot(tmp_path / "j", joints_only)
    Q = np.array(Q_REG + [[0.3, -0.6, 0.4, 0.5, 0.0, 0.2]])
    traj = tmp_path / "Q.csv"
    traj.write_text("q1,q2,q3,q4,q5,q6\n" + "\n".join(",".join(f"{v:.17g}" for v in q) for q in Q) + "\n")
    js, npz, png = tmp_path / "s.json", tmp_path / "s.npz", tmp_path / "s.png"
    assert (
        main(
            [
                "stiffness",
                str(path),
                "--trajectory",
                str(traj),
                "--json",
                str(js),
                "--npz",
                str(npz),
                "--plot",
                str(png),
            ]
        )
        == 0
    )
    assert png.stat().st_size > 10_000
    out = json.loads(js.read_text())  # strict JSON: no NaN
    m = stiffkit.load_model(path)
    l = m.chain.characteristic_length
    assert out["indices_lscale_m"] == pytest.approx(l, rel=1e-15)
    assert out["indices_units"] == {"kappa_t": "N", "kappa_r": "N"}
    C = m.tool_compliance(Q)
    for i, p in enumerate(out["postures"][:3]):
        assert p["indices_status"] == "ok" and p["rank"] == 6
        kt, kr = closed_form(np.linalg.inv(C[i]), l)
        assert p["indices"]["kappa_t"] == pytest.approx(kt, rel=1e-9)
        assert p["indices"]["kappa_r"] == pytest.approx(kr, rel=1e-9)
    last = out["postures"][3]
    assert last["rank"] == 5 and last["stiffness"] is None
    assert last["indices"] == {"kappa_t": None, "kappa_r": None}
    assert last["indices_status"].startswith("undefined") and "rank 5" in last["indices_status"]
    arr = np.load(npz)
    assert np.isnan(arr["kappa_t"][3]) and np.isnan(arr["kappa_r"][3])
    assert list(arr["indices_ok"]) == [True, True, True, False]
    assert_allclose(arr["kappa_t"][:3], [p["indices"]["kappa_t"] for p in out["postures"][:3]], rtol=1e-15)
    assert float(arr["lscale"]) == pytest.approx(l)
    assert "indices undefined (NaN, no stiffness matrix) at 1 posture(s): 4" in capsys.readouterr().out
    # --lscale is used as given
    assert main(["stiffness", str(path), "--posture", "0,-0.5,0.3,0,1.2,0", "--json", str(js), "--lscale", "0.25"]) == 0
    p0 = json.loads(js.read_text())["postures"][0]
    kt, kr = closed_form(np.linalg.inv(C[0]), 0.25)
    assert p0["indices"]["kappa_t"] == pytest.approx(kt, rel=1e-9)
    assert main(["stiffness", str(path), "--posture", "0,0,0,0,0,0", "--lscale", "-1"]) == 2


def test_indices_where_masks_undefined_postures():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(4, 6, 6))
    K = A @ np.swapaxes(A, 1, 2) + 6 * np.eye(6)
    ok = np.array([True, False, True, False])
    idx = stiffness_indices_where(K, ok, 0.7)
    full = stiffness_indices(K, 0.7)
    assert_allclose(idx.kappa_t[ok], full.kappa_t[ok], rtol=1e-15)
    assert np.all(np.isnan(idx.kappa_t[~ok])) and np.all(np.isnan(idx.lambda_n[~ok]))
    none = stiffness_indices_where(K, np.zeros(4, bool), 0.7)
    assert np.all(np.isnan(none.kappa_r))
