"""The one check of an [[effect]] table's known values (robot/effect_values.py),
derived from the catalogue's parameter entries and used by both model readers."""

import numpy as np
import pytest

from stiffkit.errors import InputError
from stiffkit.robot import catalogue
from stiffkit.robot.effect_values import effect_kind, effect_values, effect_w0, effect_where, nonnegative

W = "m.toml: [[effect]] #2 (joint, target 'elbow')"


@pytest.mark.parametrize(
    ("kind", "table", "message"),
    [
        ("joint", {"value": -3e-07}, f"{W}: value = -3e-07 rad/(N m) must be >= 0"),
        ("joint", {"value": "stiff"}, f"{W}: value = 'stiff' must be a number"),
        ("joint", {"value": float("nan")}, f"{W}: value = nan must be a finite number"),
        ("joint_deadzone", {"value": -1e-4}, f"{W}: value = -0.0001 rad must be >= 0"),
        ("joint_profile", {"value": [1e-7, 0, 0, 0]}, f"{W}: value must be [c0, c1, c2, c3, c4] (rad/(N m))"),
        ("point_offset", {"r": [0.1, 0.2]}, f"{W}: r must be [x, y, z] (m)"),
        ("lateral", {"value": [1e-6, -2e-6]}, f"{W}: value[1] = -2e-06 rad/(N m) (cy) must be >= 0"),
        ("frame", {"value": [0.0] * 5}, f"{W}: value must be [dx, dy, dz, drx, dry, drz]"),
    ],
)
def test_messages_name_table_key_value(kind, table, message):
    with pytest.raises(InputError) as exc:
        effect_values(table, kind, W)
    assert str(exc.value).startswith(message)


def test_values_in_parameter_order():
    np.testing.assert_array_equal(effect_values({"value": 2e-7}, "joint", W), [2e-7])
    np.testing.assert_array_equal(effect_values({"value": 3e-7}, "lateral", W), [3e-7, 3e-7])  # one for both
    np.testing.assert_array_equal(effect_values({"value": [1e-7, -2e-8]}, "joint_harmonic", W), [1e-7, -2e-8])
    np.testing.assert_array_equal(effect_values({"r": [0.1, 0.0, -0.2]}, "point_offset", W), [0.1, 0.0, -0.2])
    assert effect_values({"target": "elbow"}, "joint", W) is None
    assert effect_w0({"tau0": 20}, "joint_deadzone", W) == 20.0
    assert effect_w0({}, "joint_deadzone", W) is None
    with pytest.raises(InputError, match=r"tau0 = 0 N m must be positive"):
        effect_w0({"tau0": 0}, "joint_deadzone", W)


def test_nonnegative_from_catalogue_bounds():
    assert nonnegative("joint", "elbow.c") and nonnegative("lateral", "elbow.cy")
    assert nonnegative("joint_deadzone", "elbow.backlash")
    assert nonnegative("link", "upper.c44") and not nonnegative("link", "upper.c45")
    assert not nonnegative("mass", "upper.mass")  # bounded on both sides: a factor, not a compliance
    assert not nonnegative("joint_offset", "elbow.dq0") and not nonnegative("joint_harmonic", "elbow.cos1")
    # every kind whose parameters the check bounds below by 0 alone
    have = sorted(e.name for e in catalogue.ENTRIES if any(nonnegative(e.name, f"x.{p.suffix}") for p in e.params))
    assert have == ["gravity_compensator", "joint", "joint_deadzone", "lateral"]


@pytest.mark.parametrize("data", catalogue.DATA_KINDS)
def test_one_kind_and_key_check_for_both_readers(data):
    table = {"kind": "joint", "target": "elbow", "valeu": 1e-7}
    w = effect_where("m.toml", 2, table)
    assert w == W.replace("#2", "#3")
    with pytest.raises(InputError) as exc:
        effect_kind(table, w, data)
    assert str(exc.value) == (
        f"{w}: unknown key(s) valeu for kind 'joint' (did you mean 'value'?) (allowed: kind, target, value, note)"
    )
    with pytest.raises(InputError, match=r"unknown kind 'jiont' \(did you mean 'joint'\?\); choose one of .*"):
        effect_kind({"kind": "jiont"}, w, data)
    assert effect_kind({"kind": "joint", "value": 1e-7, "note": "x"}, w, data) == "joint"
