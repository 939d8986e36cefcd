"""Property tests: random bytes and values into every parser and checker.

Whatever comes in, a parser either returns a checked result or raises
stiffkit's own error (InputError and subclasses) with a one-line message;
never another exception, never a NaN/Inf in what it returns.
"""

from __future__ import annotations

import json
import math
import os
import warnings

import numpy as np
import pytest
from _profiles import examples
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import stiffkit as sk
from stiffkit.calib.compare import check_result
from stiffkit.calib.measure import read_measurements
from stiffkit.cli import args as A
from stiffkit.errors import StiffkitError
from stiffkit.fea.config import parse_link
from stiffkit.io import validate as V
from stiffkit.io.linkjson import read_link_compliance
from stiffkit.io.tables import read_json, read_table, read_toml
from stiffkit.robot.tree import check_urdf_text
from stiffkit.springs import Spring
from stiffkit.springs.tree_json import load_tree

SETTINGS = settings(
    max_examples=examples(int(os.environ.get("STIFFKIT_FUZZ_EXAMPLES", 60))),
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

# values a file or an API user may hand over
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
)
values = st.recursive(
    scalars,
    lambda kids: st.lists(kids, max_size=7) | st.dictionaries(st.text(max_size=6), kids, max_size=5),
    max_leaves=40,
)

CSV_TEXT = st.lists(
    st.lists(
        st.sampled_from(["x", "y", "z", "q1", "1", "-2.5e-3", "nan", "1e300", "", " ", "a", '"', "1,5"]), max_size=6
    ),
    max_size=6,
).map(lambda rows: "\n".join(",".join(r) for r in rows))


def _ok(exc: BaseException) -> None:
    assert isinstance(exc, StiffkitError), f"{type(exc).__name__}: {exc}"
    assert "\n" not in str(exc).strip(), str(exc)


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sk.errors.PlausibilityWarning)
        return fn(*args, **kwargs)


@SETTINGS
@given(data=st.binary(max_size=300) | CSV_TEXT.map(str.encode))
def test_csv_tables(tmp_path, data):
    p = tmp_path / "t.csv"
    p.write_bytes(data)
    try:
        t = _quiet(read_table, p)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assert t.rows and all(len(r) == len(t.header) for r in t.rows)
    assert len(set(t.header)) == len(t.header)
    try:
        a = _quiet(t.numbers, t.header[:1], "position")
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assert np.all(np.isfinite(a))


@SETTINGS
@given(data=st.binary(max_size=400), header=st.booleans())
def test_measurement_files(tmp_path, data, header):
    head = b"config,q1,q2,fx,fy,fz,mx,my,mz,dx,dy,dz\n" if header else b""
    p = tmp_path / "m.csv"
    p.write_bytes(head + data)
    try:
        m = _quiet(read_measurements, p, 2)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assert m.q.shape == (m.n, 2) and np.all(np.isfinite(m.d))


@SETTINGS
@given(data=st.binary(max_size=200) | values.map(lambda v: json.dumps(v, allow_nan=True).encode()))
def test_json_and_toml_documents(tmp_path, data):
    p = tmp_path / "d"
    p.write_bytes(data)
    for reader in (read_json, read_toml):
        try:
            reader(p, "document")
        except Exception as exc:  # noqa: BLE001
            _ok(exc)


@SETTINGS
@given(doc=values)
def test_link_json_and_fit_results(tmp_path, doc):
    p = tmp_path / "l.json"
    p.write_text(json.dumps({"compliance": doc} if not isinstance(doc, dict) else doc))
    try:
        c = _quiet(read_link_compliance, p)
        assert c.shape == (6, 6) and np.all(np.isfinite(c)) and np.allclose(c, c.T)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
    try:
        check_result(doc)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)


@SETTINGS
@given(tree=values, extra=st.dictionaries(st.sampled_from(["tool", "lscale", "tool_axes"]), values, max_size=2))
def test_spring_tree_files(tmp_path, tree, extra):
    p = tmp_path / "t.json"
    p.write_text(json.dumps({"tree": tree, **extra}))
    try:
        _quiet(load_tree, p)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)


SECTION_VALUES = st.dictionaries(
    st.sampled_from(
        ["shape", "size", "units", "E", "nu", "plane", "reference_point", "region", "order", "method", "x"]
    ),
    values,
    max_size=4,
)


@SETTINGS
@given(
    edits=st.dictionaries(
        st.sampled_from(["geometry", "material", "support", "load", "field", "mesh", "fit", "solver", "extra"]),
        SECTION_VALUES,
        max_size=3,
    )
)
def test_link_toml_tables(edits):
    doc = {
        "geometry": {"shape": "box", "size": [40.0, 10.0, 10.0], "units": "mm"},
        "material": {"E": 2e11, "nu": 0.3},
        "support": {"plane": "x-min"},
        "load": {"plane": "x-max", "reference_point": [40.0, 0.0, 0.0]},
        "mesh": {"size": 5.0},
    }
    for k, v in edits.items():
        doc.setdefault(k, {}).update(v)
    try:
        job = _quiet(parse_link, doc, "fuzz.toml")
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assert math.isfinite(job.E) and job.E > 0 and job.size > 0


@SETTINGS
@given(
    effects=st.lists(
        st.dictionaries(st.sampled_from(["kind", "target", "value", "template", "r", "a"]), values, max_size=4),
        max_size=3,
    )
)
def test_model_effect_tables(tmp_path_factory, effects):
    from stiffkit.calib.synth import KR270_JOINTS
    from stiffkit.robot.model import model_from_tables
    from stiffkit.robot.urdf import load_chain, urdf_text

    d = tmp_path_factory.getbasetemp() / "fuzz_urdf"
    d.mkdir(exist_ok=True)
    u = d / "r.urdf"
    if not u.exists():
        u.write_text(urdf_text("r", KR270_JOINTS))
    chain = load_chain(u, "base_link", "tool0")
    try:
        _quiet(model_from_tables, chain, effects)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)


@SETTINGS
@given(data=st.binary(max_size=300) | st.text(alphabet='<>/=" robtlinkjoa0123.', max_size=200).map(str.encode))
def test_urdf_text(tmp_path, data):
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return
    try:
        _quiet(check_urdf_text, text, "fuzz.urdf")
    except Exception as exc:  # noqa: BLE001
        _ok(exc)


@SETTINGS
@given(v=values, lo=st.none() | st.floats(-10, 10), q=st.sampled_from([None, "length", "angle", "E", "sigma_position"]))
def test_numbers(v, lo, q):
    try:
        x = _quiet(V.number, v, "value", q, lo=lo)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assert math.isfinite(x) and (lo is None or x >= lo)


@SETTINGS
@given(v=values)
def test_arrays(v):
    try:
        a = _quiet(V.array, v, "a", (None, 3), "position")
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assert a.ndim == 2 and a.shape[1] == 3 and np.all(np.isfinite(a))


@SETTINGS
@given(text=st.text(max_size=40))
def test_option_vectors(text):
    try:
        v = _quiet(A.vector, text, 3, "--point", "position")
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assert v.shape == (3,) and np.all(np.isfinite(v))


@SETTINGS
@given(
    m=st.lists(st.floats(-1e3, 1e3) | st.sampled_from([math.nan, math.inf, -math.inf]), min_size=36, max_size=36),
    kind=st.sampled_from(["compliance", "stiffness"]),
)
def test_springs(m, kind):
    try:
        s = _quiet(Spring, np.reshape(m, (6, 6)), kind=kind)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assert np.allclose(s.matrix, s.matrix.T) and np.all(np.linalg.eigvalsh(s.matrix) >= -1e-6 * np.abs(s.matrix).max())


@SETTINGS
@given(
    pts=st.lists(
        st.lists(st.floats(-1e6, 1e6) | st.sampled_from([math.nan, math.inf]), min_size=3, max_size=3),
        min_size=0,
        max_size=8,
    ),
    scale=st.sampled_from([0.0, 1e-9, 1.0, 1e150, 1e300]),
    method=st.sampled_from(["lin", "svd+", "svd-", "svd+-", "exact"]),
)
def test_field_fits(pts, scale, method):
    p = np.array(pts, dtype=float).reshape(-1, 3)
    with np.errstate(invalid="ignore", over="ignore"):
        d = scale * np.roll(p, 1, axis=1) if p.size else p
    try:
        f = sk.fit_field(p, d, [0.0, 0.0, 0.0], method=method)
    except Exception as exc:  # noqa: BLE001
        _ok(exc)
        return
    assume(f is not None)
    assert np.all(np.isfinite(f.deflection)) and np.all(np.isfinite(f.cov)) and math.isfinite(f.sigma)


@pytest.mark.parametrize("text", ["", "x", "1,2", "1,,2", "1;2;3", "1 2 3", "inf,0,0", "0x1,0,0"])
def test_option_vectors_named_examples(text):
    with pytest.raises(sk.InputError, match="--point"):
        A.vector(text, 3, "--point", "position")


@pytest.mark.parametrize(
    "effect",
    [{"kind": "\n"}, {"kind": "joint\r\nx"}, {"kind": "joint", "\n": 1}, {"kind": "joint", "target": "a\nb"}],
)
def test_user_words_are_quoted_in_one_line_messages(tmp_path, effect):
    """What `make fuzz` found: an effect kind of "\\n" made a two-line
    message; user words are shown with repr-like escaping."""
    from stiffkit.calib.synth import KR270_JOINTS
    from stiffkit.robot.model import model_from_tables
    from stiffkit.robot.urdf import load_chain, urdf_text

    u = tmp_path / "r.urdf"
    u.write_text(urdf_text("r", KR270_JOINTS))
    with pytest.raises(sk.InputError) as exc:
        _quiet(model_from_tables, load_chain(u, "base_link", "tool0"), [effect])
    _ok(exc.value)
    assert "\\n" in str(exc.value)
