"""Issue 17, items 5, 6, 8 and 13: no verdict from garbage, and the weak
inputs of the first catalogue named. Each test runs the command (in
process) or the reader and asserts the exit status and the line that
explains it (file, row, field, value)."""

from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest

import stiffkit as sk
from stiffkit.calib.absolute_diagnose import diagnose_absolute
from stiffkit.calib.absolute_report import load_absolute
from stiffkit.calib.diagnose import diagnose
from stiffkit.calib.dualarm import synth_dualarm
from stiffkit.calib.measure import read_measurements
from stiffkit.cli import main
from stiffkit.errors import PlausibilityWarning
from stiffkit.fea.config import parse_link
from stiffkit.robot.model import load_model
from stiffkit.robot.urdf import load_chain


@pytest.fixture(scope="module")
def kr(tmp_path_factory):
    """synth kr270 (4 configurations, 36 rows, sigma declared) and a copy of
    its model without sigma."""
    d = tmp_path_factory.mktemp("kr")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["synth", "kr270", "--out", str(d), "--configs", "4", "--seed", "3"]) == 0
    text = (d / "model.toml").read_text()
    (d / "nosig.toml").write_text("\n".join(ln for ln in text.splitlines() if "sigma_position" not in ln) + "\n")
    return d


@pytest.fixture(scope="module")
def da(tmp_path_factory):
    """synth dualarm: absolute tracker data, 30 postures, two markers."""
    d = tmp_path_factory.mktemp("da")
    synth_dualarm(d, configs=30, seed=3)
    return d


def lines_of(path):
    return path.read_text().splitlines()


def write(path, lines):
    path.write_text("\n".join(lines) + "\n")
    return path


def run(capsys, *argv):
    capsys.readouterr()
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


# ------------------------------------------------- 17.5 exact copies are not replicates


@pytest.mark.parametrize("model", ["model.toml", "nosig.toml"])
def test_one_row_copied_40_times_gives_no_verdict(kr, tmp_path, capsys, model):
    m = lines_of(kr / "measurements.csv")
    copies = write(tmp_path / "copies.csv", [m[0]] + [m[1]] * 40)
    code, out, err = run(capsys, "diagnose", kr / model, copies)
    assert code == 2
    assert f"{copies}: cannot judge: 1 distinct row (39 more rows are exact copies" in err
    assert "ADEQUATE" not in out.upper() and "pure error" not in out


def test_copies_give_no_pure_error(kr, tmp_path, capsys):
    """Every row twice, no sigma: before, the copies were 'replicates' with a
    pure error of round-off (1e-15 mm) and a verdict followed."""
    m = lines_of(kr / "measurements.csv")
    twice = write(tmp_path / "twice.csv", m + m[1:])
    code, out, err = run(capsys, "diagnose", kr / "nosig.toml", twice)
    assert code == 2
    assert f"{twice}: cannot judge: 36 distinct rows (36 more rows are exact copies" in err
    assert "no replicated rows" in err
    assert "line 38: repeats line 2 exactly (36 such rows)" in err  # the reader's warning


def test_copies_do_not_count_in_the_test(kr, tmp_path):
    """With a declared sigma the test on rows + copies is the test on the
    distinct rows: same statistic, same degrees of freedom."""
    m = lines_of(kr / "measurements.csv")
    twice = write(tmp_path / "twice.csv", m + m[1:20])
    model = load_model(kr / "model.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = diagnose(model, read_measurements(kr / "measurements.csv", 6), checks=False, cv_folds=0, nsim=9)
        b = diagnose(model, read_measurements(twice, 6), checks=False, cv_folds=0, nsim=9)
    assert a.dof == b.dof == 36 * 3 - a.fit.rank
    assert b.statistic == pytest.approx(a.statistic, rel=1e-9)
    assert b.verdict == a.verdict


def test_tracker_copies_give_no_verdict(da, tmp_path, capsys):
    m = lines_of(da / "measurements.csv")
    copies = write(tmp_path / "copies.csv", [m[0]] + [m[1]] * 40)
    code, out, err = run(capsys, "diagnose", da / "model.toml", copies)
    assert code == 2
    assert f"{copies}: cannot judge: 1 distinct row (39 more rows are exact copies" in err
    assert "verdict" not in out


def test_tracker_copies_do_not_count(da, tmp_path):
    m = lines_of(da / "measurements.csv")
    twice = write(tmp_path / "twice.csv", m + m[1:])
    model, data = load_absolute(da / "model.toml", twice)
    assert any("line 62: repeats line 2 exactly (60 such rows)" in w for w in data.warnings)  # 17.8
    dg2 = diagnose_absolute(model, data, cv_folds=3)
    dg1 = diagnose_absolute(*load_absolute(da / "model.toml", da / "measurements.csv"), cv_folds=3)
    assert dg2.fit.data.n == dg1.fit.data.n == 60
    assert dg2.dof == dg1.dof and dg2.sigma_position == pytest.approx(dg1.sigma_position, rel=1e-9)


# ------------------------------------------------- 17.6 compensate with nothing identified


def test_compensate_with_a_model_of_zeros_fails(kr, tmp_path, capsys):
    text = (kr / "model.toml").read_text().replace('urdf = "robot.urdf"', f'urdf = "{kr / "robot.urdf"}"')
    zero = tmp_path / "zero.toml"
    zero.write_text(text.replace('target = "all"', 'target = "all"\nvalue = 0.0'))
    m = lines_of(kr / "measurements.csv")
    targets = write(tmp_path / "targets.csv", m[:11])
    out = tmp_path / "commands.csv"
    code, _, err = run(capsys, "compensate", zero, targets, "--out", out)
    assert code == 2 and not out.exists()
    assert f"{zero}: the model changes no command" in err and "10 command(s)" in err
    # the same model with a value compensates
    ok = tmp_path / "ok.toml"
    ok.write_text(text.replace('target = "all"', 'target = "all"\nvalue = 2e-7'))
    assert run(capsys, "compensate", ok, targets, "--out", out)[0] == 0
    assert out.exists()


def test_compensate_with_the_frames_only_start_model_fails(da, tmp_path, capsys):
    out = tmp_path / "commands.csv"
    code, _, err = run(capsys, "compensate", da / "model.toml", da / "targets.csv", "--out", out)
    assert code == 2 and not out.exists()
    assert "the model changes no command" in err


# ------------------------------------------------- 17.8 URDF numbers


def urdf_with(src, dst, old, new):
    text = src.read_text()
    assert old in text, old
    dst.write_text(text.replace(old, new, 1))
    return dst


def test_postures_beyond_a_joint_limit_are_named(kr, tmp_path, capsys):
    d = tmp_path / "kr"
    shutil.copytree(kr, d)
    text = (d / "robot.urdf").read_text()
    i = text.index('<joint name="joint_a2"')
    j = text.index("<limit", i)
    k = text.index("/>", j)
    (d / "robot.urdf").write_text(text[:j] + '<limit lower="-0.8" upper="0.8" effort="1000" velocity="1"' + text[k:])
    q2 = float(lines_of(d / "measurements.csv")[1].split(",")[2])
    assert q2 < -0.8
    code, _, err = run(capsys, "fit", d / "model.toml", d / "measurements.csv")
    assert code == 0
    assert f"measurements.csv, line 2: joint 'joint_a2' = {q2:.6g} is beyond its URDF lower limit -0.8" in err


def test_compensate_targets_beyond_a_limit_are_named(kr, tmp_path, capsys):
    d = tmp_path / "kr"
    shutil.copytree(kr, d)
    text = (d / "robot.urdf").read_text()
    i = text.index('<joint name="joint_a2"')
    j = text.index("<limit", i)
    k = text.index("/>", j)
    (d / "robot.urdf").write_text(text[:j] + '<limit lower="-0.8" upper="0.8" effort="1000" velocity="1"' + text[k:])
    m = lines_of(d / "measurements.csv")
    targets = write(tmp_path / "targets.csv", m[:4])
    q2 = float(m[1].split(",")[2])
    code, _, err = run(capsys, "compensate", d / "truth.toml", targets, "--out", tmp_path / "c.csv")
    assert code == 0
    assert f"targets.csv, line 2: joint 'joint_a2' = {q2:.6g} is beyond its URDF lower limit -0.8" in err


def test_tracker_postures_beyond_a_limit_are_named(da, tmp_path):
    d = tmp_path / "da"
    shutil.copytree(da, d)
    text = (d / "robot.urdf").read_text()
    i = text.index('<joint name="torso_1"')
    j = text.index("<limit", i)
    k = text.index("/>", j)
    (d / "robot.urdf").write_text(text[:j] + '<limit lower="-0.1" upper="0.1" effort="300" velocity="2"' + text[k:])
    q = float(lines_of(d / "measurements.csv")[1].split(",")[1])
    _, data = load_absolute(d / "model.toml", d / "measurements.csv")
    msg = [w for w in data.warnings if "torso_1" in w]
    assert len(msg) == 1 and f"line 2: joint 'torso_1' = {q:.6g} is beyond its URDF lower limit -0.1" in msg[0]


INERTIAL = '<link name="link_3"/>'


def test_a_link_mass_in_grams_is_named(kr, tmp_path):
    u = urdf_with(
        kr / "robot.urdf",
        tmp_path / "g.urdf",
        INERTIAL,
        '<link name="link_3"><inertial><mass value="16000"/><origin xyz="0.1 0 0"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>',
    )
    with pytest.warns(PlausibilityWarning, match=r"link 'link_3' has mass 16000 kg.*grams"):
        load_chain(u)


def test_a_centre_of_mass_in_mm_is_called_so(kr, tmp_path):
    u = urdf_with(
        kr / "robot.urdf",
        tmp_path / "mm.urdf",
        INERTIAL,
        '<link name="link_3"><inertial><mass value="16"/><origin xyz="150 0 20"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>',
    )
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        load_chain(u)
    text = [str(w.message) for w in got]
    assert any("the centre of mass of link 'link_3' is 151.3 m from the link frame" in t for t in text), text
    assert not any("joint origin" in t for t in text)


def test_no_stray_parser_lines(kr, tmp_path, capfd):
    """The URDF is read by stiffkit's own one-pass reader (xml.etree): a file
    that made lxml print "Excessive depth" lines (elements nested 300 deep)
    reads with nothing on stderr, and malformed XML is one error naming the file."""
    deep = "<x>" * 300 + "</x>" * 300
    u = urdf_with(kr / "robot.urdf", tmp_path / "deep.urdf", INERTIAL, f'<link name="link_3">{deep}</link>')
    chain = load_chain(u)
    assert chain.dof == load_chain(kr / "robot.urdf").dof
    bad = tmp_path / "broken.urdf"
    bad.write_text(u.read_text().replace("</robot>", ""))
    with pytest.raises(sk.InputError, match=r"broken.urdf"):
        load_chain(bad)
    assert capfd.readouterr().err == ""


# ------------------------------------------------- 17.13 weak inputs named


def columns(path, drop=(), zero=(), add=None):
    rows = [ln.split(",") for ln in lines_of(path)]
    head = rows[0]
    keep = [k for k, h in enumerate(head) if h not in drop]
    out = []
    for r_i, r in enumerate(rows):
        cells = [("0" if head[k] in zero and r_i else r[k]) for k in keep]
        if add:
            cells.append(add[0] if r_i == 0 else add[1])
        out.append(",".join(cells))
    return out


def test_every_load_zero_is_said(kr, tmp_path):
    p = write(tmp_path / "m.csv", columns(kr / "measurements.csv", zero=("fx", "fy", "fz", "mx", "my", "mz")))
    with pytest.warns(PlausibilityWarning, match=r"m.csv: every load is zero \(fx..mz\)"):
        read_measurements(p, 6)


def test_a_missing_point_is_named(kr, tmp_path):
    p = write(tmp_path / "m.csv", columns(kr / "measurements.csv", drop=("px", "py", "pz")))
    with pytest.warns(PlausibilityWarning, match=r"m.csv: no px, py, pz columns: every deflection is taken at"):
        m = read_measurements(p, 6)
    assert np.all(m.p == 0)


def test_a_q7_column_on_a_six_joint_robot_is_named(kr, tmp_path):
    p = write(tmp_path / "m.csv", columns(kr / "measurements.csv", add=("q7", "0.5")))
    with pytest.warns(PlausibilityWarning, match=r"m.csv: column\(s\) q7 not used \(the robot has 6 joints"):
        read_measurements(p, 6)


def test_a_model_with_no_effects_fails_fit(kr, tmp_path, capsys):
    text = (kr / "model.toml").read_text()
    none = tmp_path / "none.toml"
    none.write_text(text[: text.index("[[effect]]")].replace('urdf = "robot.urdf"', f'urdf = "{kr}/robot.urdf"'))
    code, _, err = run(capsys, "fit", none, kr / "measurements.csv")
    assert code == 2 and f"{none}: the model has no [[effect]] table: nothing to fit" in err


def test_link_toml_without_units_says_mm_once():
    doc = {
        "geometry": {"shape": "box", "size": [40.0, 10.0, 10.0]},
        "material": {"E": 2e11, "nu": 0.3},
        "support": {"plane": "x-min"},
        "load": {"plane": "x-max", "reference_point": [40.0, 0.0, 0.0]},
        "mesh": {"size": 5.0},
    }
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        job = parse_link(doc, "nounits.toml")
    said = [str(w.message) for w in got if "no units" in str(w.message)]
    assert said == ['nounits.toml: [geometry] has no units: millimetres assumed (write units = "mm", or "m")']
    assert job.units == "mm"


def test_field_with_one_file_for_six_cases_warns(tmp_path, capsys):
    from stiffkit.field.synthetic import cantilever_fields, square_grid

    k = sk.cantilever_compliance(1.0, 2e11, 0.266, sk.section_properties("square", [0.01], 0.266))
    pts = square_grid(0.01, 0.002, x=1.0)
    f = cantilever_fields(k, np.diag([100.0, 0.1, 0.1, 0.1, 0.1, 0.1]), pts, [1.0, 0, 0], sigma=1e-9, rng=2)
    np.savetxt(tmp_path / "nodes.csv", pts, delimiter=",", header="x,y,z", comments="")
    np.savetxt(tmp_path / "d0.csv", f[0], delimiter=",", header="ux,uy,uz", comments="")
    d0 = tmp_path / "d0.csv"
    code, _, err = run(
        capsys, "field", tmp_path / "nodes.csv", *[d0] * 6, "--reference", "1,0,0", "--loads", "100,0.1,0.1,0.1,0.1,0.1"
    )
    assert f"{d0}: load case 2 has the displacement field of case 1 ({d0}; the same file)" in err
