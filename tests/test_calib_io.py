"""Bad inputs give clear messages naming the file, row and field; the CLI
prints one line and exits 2; JSON outputs carry the contract's keys."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _calib_util import MARKERS, joints_truth

import stiffkit
from stiffkit.calib import synth as S
from stiffkit.calib.measure import read_measurements
from stiffkit.cli import main


@pytest.fixture(scope="module")
def kr(tmp_path_factory):
    d = tmp_path_factory.mktemp("kr")
    truth = joints_truth() + [{"kind": "link", "target": "link_2", "value": S.kr270_links()["link_2"].tolist()}]
    S.write_synth(
        d,
        S.KR270_JOINTS,
        truth,
        [{"kind": "joint", "target": "all"}],
        sigma=1e-5,
        n_configs=12,
        ranges=S.KR270_RANGES,
        markers=MARKERS,
    )
    return d


def edit_csv(src, dst, line, field, value):
    rows = src.read_text().splitlines()
    head = rows[0].split(",")
    cells = rows[line - 1].split(",")
    cells[head.index(field)] = value
    rows[line - 1] = ",".join(cells)
    dst.write_text("\n".join(rows) + "\n")


def test_nan_row_names_file_line_field(kr, tmp_path):
    bad = tmp_path / "bad.csv"
    edit_csv(kr / "measurements.csv", bad, 7, "fy", "nan")
    with pytest.raises(stiffkit.InputError, match=r"bad.csv, line 7: field 'fy' is nan"):
        read_measurements(bad, 6)


def test_missing_column(kr, tmp_path):
    rows = (kr / "measurements.csv").read_text().splitlines()
    bad = tmp_path / "nodz.csv"
    bad.write_text("\n".join(",".join(c for i, c in enumerate(r.split(",")) if i != 18) for r in rows))
    with pytest.raises(stiffkit.InputError, match=r"nodz.csv, line 1: missing column\(s\) dz"):
        read_measurements(bad, 6)
    with pytest.raises(stiffkit.InputError, match=r"missing column\(s\) q7 .*7 joints"):
        read_measurements(kr / "measurements.csv", 7)


def test_non_number_and_short_row(kr, tmp_path):
    bad = tmp_path / "txt.csv"
    edit_csv(kr / "measurements.csv", bad, 3, "q2", "abc")
    with pytest.raises(stiffkit.InputError, match=r"line 3: field 'q2' = 'abc' is not a number"):
        read_measurements(bad, 6)
    rows = (kr / "measurements.csv").read_text().splitlines()
    rows[4] = ",".join(rows[4].split(",")[:10])
    bad.write_text("\n".join(rows))
    with pytest.raises(stiffkit.InputError, match=r"line 5: field '.*' is missing"):
        read_measurements(bad, 6)


@pytest.mark.parametrize(
    "effect,msg",
    [
        ('kind = "joint"\ntarget = "joint_a9"', r"#2 \(joint, target 'joint_a9'\): unknown joint 'joint_a9'"),
        ('kind = "link"\ntarget = "link_9"', r"unknown link 'link_9'; links of the chain: base_link, link_1"),
        ('kind = "spring"\ntarget = "link_2"', r"unknown kind 'spring'"),
        ('kind = "link"\ntarget = "link_2"\ntemplate = "bar"', r"unknown template 'bar'"),
        ('kind = "gravity_compensator"\ntarget = "joint_a2"\na = 0.4', r"missing 'b'"),
        ('kind = "link"\ntarget = "link_2"\nvalue = [[1.0, 2.0], [2.0, 1.0]]', r"must be a 6x6 matrix"),
        ('kind = "link"\ntarget = "link_2"\ntemplat = "beam"', r"unknown key\(s\) templat for kind 'link'"),
        ('kind = "joint_deadzone"\ntarget = "joint_a4"\nvalue = 1e-4', r"joint_deadzone with a value needs its tau0"),
        ('kind = "joint_deadzone"\ntarget = "joint_a4"\ntau0 = -2.0', r"tau0 = -2 N m must be positive"),
        ('kind = "joint_cubic"\ntarget = "all"', r"unknown joint 'all'"),
    ],
)
def test_bad_effect_tables(kr, tmp_path, effect, msg):
    text = (kr / "model.toml").read_text().replace('urdf = "robot.urdf"', f'urdf = "{kr}/robot.urdf"')
    f = tmp_path / "m.toml"
    f.write_text(text + "\n[[effect]]\n" + effect + "\n")
    with pytest.raises(stiffkit.InputError, match=msg):
        stiffkit.load_model(f)


def test_urdf_not_a_chain_to_the_tool(kr, tmp_path):
    urdf = (kr / "robot.urdf").read_text()
    (tmp_path / "r.urdf").write_text(
        urdf.replace('<link name="tool0"/>', '<link name="tool0"/>\n  <link name="camera"/>')
    )
    f = tmp_path / "m.toml"
    f.write_text('[robot]\nurdf = "r.urdf"\nbase_link = "base_link"\ntool_frame = "camera"\n')
    with pytest.raises(stiffkit.InputError, match=r"r.urdf: 'camera' is not connected to 'base_link'"):
        stiffkit.load_model(f)
    f.write_text('[robot]\nurdf = "r.urdf"\nbase_link = "base_link"\ntool_frame = "flange"\n')
    with pytest.raises(stiffkit.InputError, match=r"tool_frame 'flange' is not a link"):
        stiffkit.load_model(f)
    (tmp_path / "p.urdf").write_text(urdf.replace('type="revolute"', 'type="prismatic"', 1))
    f.write_text('[robot]\nurdf = "p.urdf"\n')
    with pytest.raises(stiffkit.InputError, match=r"joint 'joint_a1' on the chain is 'prismatic'"):
        stiffkit.load_model(f)


def test_cli_error_is_one_line_exit_2(kr, tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    edit_csv(kr / "measurements.csv", bad, 4, "dx", "inf")
    assert main(["fit", str(kr / "model.toml"), str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "line 4: field 'dx'" in err[0] and "Traceback" not in err[0]


def test_cli_fit_diagnose_compare_stiffness(kr, tmp_path, capsys):
    j = tmp_path / "j1.json"
    assert (
        main(
            [
                "fit",
                str(kr / "model.toml"),
                str(kr / "measurements.csv"),
                "--json",
                str(j),
                "--plots",
                str(tmp_path / "plots"),
                "--write-model",
                str(tmp_path / "id.toml"),
            ]
        )
        == 0
    )
    out = json.loads(j.read_text())
    for key in ("rms_position_m", "max_position_m", "axes", "compensated_fraction", "parameters"):
        assert key in out
    assert set(out["axes"]) == {"x", "y", "z"} and set(out["axes"]["x"]) >= {"rms_m", "max_m"}
    assert set(out["parameters"][0]) >= {"name", "value", "std", "group"}
    assert out["parameters"][0]["name"] == "joint_a1.c"
    assert len(list((tmp_path / "plots").glob("*.png"))) == 3
    d = tmp_path / "d.json"
    assert (
        main(
            [
                "diagnose",
                str(kr / "model.toml"),
                str(kr / "measurements.csv"),
                "--json",
                str(d),
                "--plots",
                str(tmp_path / "dplots"),
            ]
        )
        == 0
    )
    assert (tmp_path / "dplots" / "diagnose_candidates.png").is_file()
    dg = json.loads(d.read_text())
    assert dg["verdict"] == "inadequate"
    for key in ("sigma_position_m", "rms_position_m", "candidates"):
        assert key in dg
    c0 = dg["candidates"][0]
    assert set(c0) >= {"kind", "target", "statistic", "p_value", "explained_fraction", "rms_after_m", "effect"}
    assert c0["kind"] == "link" and c0["target"] == "link_2"
    # the user's loop: append the suggested table, fit again, compare
    m2 = tmp_path / "m2.toml"
    text = (kr / "model.toml").read_text().replace('urdf = "robot.urdf"', f'urdf = "{kr}/robot.urdf"')
    eff = "\n".join(f"{k} = {json.dumps(v)}" for k, v in c0["effect"].items())
    m2.write_text(text + "\n[[effect]]\n" + eff + "\n")
    j2 = tmp_path / "j2.json"
    assert main(["fit", str(m2), str(kr / "measurements.csv"), "--json", str(j2), "--compare", str(j)]) == 0
    assert json.loads(j2.read_text())["rms_position_m"] < 0.5 * out["rms_position_m"]
    capsys.readouterr()
    assert main(["compare", str(j), str(j2)]) == 0
    assert "positional RMS (mm)" in capsys.readouterr().out
    npz = tmp_path / "c.npz"
    assert (
        main(
            [
                "stiffness",
                str(tmp_path / "id.toml"),
                "--posture",
                "0,-0.5,0.3,0,1.2,0",
                "--npz",
                str(npz),
                "--json",
                str(tmp_path / "s.json"),
            ]
        )
        == 0
    )
    arr = np.load(npz)
    C = stiffkit.load_model(tmp_path / "id.toml").tool_compliance([[0, -0.5, 0.3, 0, 1.2, 0]])
    np.testing.assert_allclose(arr["compliance"], C)
    # six joint springs, a regular posture: C has rank 6 and K = C^-1
    assert arr["ok"][0] and arr["rank"][0] == 6
    np.testing.assert_allclose(arr["stiffness"][0] @ arr["compliance"][0], np.eye(6), atol=1e-7)


def test_cli_synth_writes_loadable_files(tmp_path):
    assert main(["synth", "kr270", "--out", str(tmp_path / "k"), "--configs", "5", "--offset", "0.01,0,0"]) == 0
    m = stiffkit.load_model(tmp_path / "k" / "truth.toml")
    assert any(t.kind == "point_offset" for t in m.terms)
    meas = read_measurements(tmp_path / "k" / "measurements.csv", 6)
    assert meas.n == 5 * 3 * 3
