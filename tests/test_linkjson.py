"""One reader of `stiffkit link` JSON results (stiffkit.io.linkjson) for the
spring trees and the robot model, and the atomic writes of stiffkit.io.files."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from stiffkit import InputError
from stiffkit.io.files import atomic_open, atomic_write_text, write_json
from stiffkit.io.linkjson import read_link_compliance
from stiffkit.springs import load_link_compliance
from stiffkit.springs.tree_json import load_tree


def _beam() -> np.ndarray:
    import stiffkit as sk

    return sk.cantilever_compliance(0.3, 7e10, 0.33, sk.section_properties("tube", [0.03, 0.026], 0.33))


def test_reader_returns_the_compliance(tmp_path):
    c = _beam()
    f = tmp_path / "l.json"
    f.write_text(json.dumps({"compliance": c.tolist(), "sigma_m": 1e-8}))
    np.testing.assert_array_equal(read_link_compliance(f), c)
    assert load_link_compliance is read_link_compliance  # the springs name is the same reader


def test_reader_symmetrises_fea_noise_and_refuses_what_is_no_spring(tmp_path):
    c = _beam()
    std = 1e-3 * np.abs(c).max() * np.ones((6, 6))
    noisy = c.copy()
    noisy[1, 5] *= 1 + 1e-6  # within the noise of its elements: silent
    f = tmp_path / "l.json"
    f.write_text(json.dumps({"compliance": noisy.tolist(), "compliance_std": std.tolist()}))
    got = read_link_compliance(f)
    np.testing.assert_allclose(got, got.T)
    skew = c.copy()
    skew[1, 5] *= 1.02  # 2 % beyond a noise of zero: symmetrised with a warning
    f.write_text(json.dumps({"compliance": skew.tolist(), "compliance_std": np.zeros((6, 6)).tolist()}))
    with pytest.warns(UserWarning, match="asymmetry"):
        read_link_compliance(f)
    skew[1, 5] *= 2  # not a compliance
    f.write_text(json.dumps({"compliance": skew.tolist()}))
    with pytest.raises(InputError, match="not symmetric"):
        read_link_compliance(f)
    bad = c.copy()
    bad[0, 0] = -bad[0, 0]
    f.write_text(json.dumps({"compliance": bad.tolist()}))
    with pytest.raises(InputError, match="negative eigenvalue"):
        read_link_compliance(f)


@pytest.mark.parametrize(
    "text, message",
    [
        (None, "no such `stiffkit link` JSON file"),
        ("{", "not valid JSON"),
        ('{"stiffness": 1}', "no 'compliance' key"),
        ('{"compliance": [[1, 2], [3, 4]]}', r"must be a 6x6 matrix, got shape \(2, 2\)"),
        ('{"compliance": [["a"]]}', "6 rows of 6 numbers"),
        (json.dumps({"compliance": [[float("nan")] * 6] * 6}), "NaN or Inf"),
    ],
)
def test_reader_names_the_file_and_the_problem(tmp_path, text, message):
    f = tmp_path / "l.json"
    if text is not None:
        f.write_text(text)
    with pytest.raises(InputError, match=rf"^bar link: .*l\.json: .*{message}"):
        read_link_compliance(f, "bar link")


def test_tree_spring_file_is_read_by_the_same_reader(tmp_path):
    (tmp_path / "t.json").write_text(json.dumps({"tree": {"spring": {"file": "missing.json"}}}))
    with pytest.raises(InputError, match=r"spring: .*missing\.json: no such `stiffkit link` JSON file"):
        load_tree(tmp_path / "t.json")


def test_atomic_writes_leave_old_file_or_new_file(tmp_path):
    f = tmp_path / "sub" / "a.json"
    write_json(f, {"a": 1})
    assert json.loads(f.read_text()) == {"a": 1}
    with pytest.raises(RuntimeError):
        with atomic_open(f) as fh:
            fh.write("half")
            raise RuntimeError
    assert json.loads(f.read_text()) == {"a": 1}  # the old content, no temporary left
    assert os.listdir(f.parent) == ["a.json"]
    atomic_write_text(f, "new")
    assert f.read_text() == "new" and oct(f.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m
