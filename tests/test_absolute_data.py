"""The absolute-measurement CSV (docs/calibration.md 6.3) against a tree:
joints that move no measured frame may be left out, rows without a config
column are grouped by posture, and the model's joints and frames are
checked."""

from __future__ import annotations

import numpy as np
import pytest

import stiffkit
from stiffkit.calib.absolute_report import load_absolute

URDF = """<?xml version="1.0"?><robot name="r">
<link name="base_link"/><link name="a"><inertial><origin xyz="0 0 0.2"/><mass value="3"/></inertial></link>
<link name="b"/><link name="tcp"/><link name="head"><inertial><origin xyz="0 0 0.1"/><mass value="2"/></inertial></link>
<joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/><origin xyz="0 0 0.3"/>
<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.4"/>
<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="tool" type="fixed"><parent link="b"/><child link="tcp"/><origin xyz="0.5 0 0"/></joint>
<joint name="neck" type="revolute"><parent link="a"/><child link="head"/><origin xyz="0 0 0.5"/>
<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>"""

MODEL = """[robot]
urdf = "r.urdf"
[measurements]
kind = "absolute"
[[effect]]
kind = "tracker"
[[effect]]
kind = "marker"
target = "tcp"
"""


def files(tmp_path, header, rows):
    (tmp_path / "r.urdf").write_text(URDF)
    (tmp_path / "m.toml").write_text(MODEL)
    (tmp_path / "d.csv").write_text(header + "\n" + "\n".join(rows) + "\n")
    return tmp_path / "m.toml", tmp_path / "d.csv"


def test_a_joint_that_moves_no_measured_frame_may_be_left_out(tmp_path):
    m, d = files(tmp_path, "j1,j2,x,y,z", ["0.1,0.2,1,2,3", "0.1,0.2,1.1,2,3", "0.3,-0.2,1,2.2,3"])
    model, data = load_absolute(m, d)
    assert any("no column for neck" in w for w in data.warnings)
    assert data.Q.shape == (2, 3)
    np.testing.assert_array_equal(data.Q[:, model.actuated.index("neck")], 0.0)
    # no config column: the rows of one posture are one configuration
    assert data.configs == ["posture 1", "posture 2"]
    assert list(data.posture) == [0, 0, 1]


def test_a_joint_on_the_measured_path_is_required(tmp_path):
    m, d = files(tmp_path, "j1,neck,x,y,z", ["0.1,0.2,1,2,3"])
    with pytest.raises(stiffkit.InputError, match=r"missing joint column\(s\) j2 \(they move a measured frame"):
        load_absolute(m, d)


def test_rows_whose_marker_was_not_seen_are_left_out_with_their_lines(tmp_path):
    """A tracker export marks an occluded marker by empty or NaN x, y, z:
    those rows carry no point and are left out (named, by line); a row with
    only some of x, y, z missing is an error."""
    rows = ["0.1,0.2,0,1,2,3", "0.1,0.2,0,,,", "0.3,-0.2,0,1,2.2,3", "0.3,-0.2,0,NaN,nan,NAN", "0.5,0.1,0,1,2,3.1"]
    m, d = files(tmp_path, "j1,j2,neck,x,y,z", rows)
    model, data = load_absolute(m, d)
    assert data.n == 3 and list(data.lines) == [2, 4, 6]
    assert any("2 row(s) without a measured position" in w and "line(s) 3, 5" in w for w in data.warnings)
    rows[1] = "0.1,0.2,0,1,,3"
    m, d = files(tmp_path, "j1,j2,neck,x,y,z", rows)
    with pytest.raises(stiffkit.InputError, match=r"line 3: field 'y' = '' is not a number"):
        load_absolute(m, d)
    m, d = files(tmp_path, "j1,j2,neck,x,y,z", ["0.1,0.2,0,,,"])
    with pytest.raises(stiffkit.InputError, match=r"no data rows with a measured position \(1 without\)"):
        load_absolute(m, d)


def test_a_column_that_is_not_used_is_named(tmp_path):
    """An extra column (a time stamp, a misspelt joint that moves no marker)
    is read past with a warning naming it, on stderr from the command line."""
    m, d = files(tmp_path, "time,j1,j2,nek,x,y,z", ["0,0.1,0.2,0,1,2,3", "1,0.3,-0.2,0,1,2.2,3"])
    model, data = load_absolute(m, d)
    assert any("column(s) 'time', 'nek' not used" in w for w in data.warnings)
    import contextlib
    import io

    from stiffkit.cli import main

    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        main(["fit", str(m), str(d)])
    assert "stiffkit fit: warning: " in err.getvalue() and "'nek' not used" in err.getvalue()
    assert "not used" not in out.getvalue()
