"""URDF trees: order, mimic couplings, inertials, and every malformed input
named in one line (robot/tree.py)."""

from __future__ import annotations

import numpy as np
import pytest

import stiffkit
from stiffkit.robot.tree import load_tree

LINK = '<link name="{n}"/>'
INERTIAL = '<link name="{n}"><inertial><origin xyz="{c}"/><mass value="{m}"/></inertial></link>'


def joint(name, parent, child, kind="revolute", xyz="0 0 0.1", axis="0 0 1", extra=""):
    lim = '<limit lower="-3" upper="3" effort="1" velocity="1"/>' if kind != "fixed" else ""
    ax = f'<axis xyz="{axis}"/>' if kind != "fixed" else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/>{ax}{lim}{extra}</joint>'
    )


def write(tmp_path, links, joints, name="r.urdf"):
    p = tmp_path / name
    p.write_text('<?xml version="1.0"?><robot name="r">' + "".join(links) + "".join(joints) + "</robot>")
    return p


def humanoid(tmp_path, mass="2.0"):
    links = [LINK.format(n="base_link"), INERTIAL.format(n="torso", c="0 0 0.2", m=mass)]
    links += [INERTIAL.format(n=f"{s}{k}", c="0.1 0 0", m="1.5") for s in "lr" for k in (1, 2)]
    links += [LINK.format(n=f"{s}_tcp") for s in "lr"]
    joints = [joint("torso_j", "base_link", "torso")]
    for s, y in (("l", "0.2"), ("r", "-0.2")):
        joints.append(joint(f"{s}_1", "torso", f"{s}1", xyz=f"0 {y} 0.4", axis="0 1 0"))
        extra = '<mimic joint="torso_j" multiplier="-1" offset="0.05"/>' if s == "r" else ""
        joints.append(joint(f"{s}_2", f"{s}1", f"{s}2", xyz="0.3 0 0", axis="0 1 0", extra=extra))
        joints.append(joint(f"{s}_tool", f"{s}2", f"{s}_tcp", kind="fixed", xyz="0.25 0 0"))
    return write(tmp_path, links, joints)


def test_tree_order_mimic_and_inertials(tmp_path):
    t = load_tree(humanoid(tmp_path))
    names = [j.name for j in t.joints]
    assert names.index("torso_j") < names.index("l_1") < names.index("l_2") < names.index("l_tool")
    assert t.actuated == ["torso_j", "l_1", "l_2", "r_1"]
    assert t.leader("r_2") == ("torso_j", -1.0, 0.05)
    assert t.leader("l_2") == ("l_2", 1.0, 0.0)
    assert [j.name for j in t.path("r_tcp")] == ["torso_j", "r_1", "r_2", "r_tool"]
    assert t.total_mass == pytest.approx(2.0 + 4 * 1.5)
    np.testing.assert_allclose(t.inertials["torso"].com, [0, 0, 0.2])
    assert "l_tcp" not in t.inertials  # a link without <inertial> has no mass


def test_mimic_chain_composes(tmp_path):
    links = [LINK.format(n=n) for n in ("base_link", "a", "b", "c")]
    joints = [
        joint("j1", "base_link", "a"),
        joint("j2", "a", "b", extra='<mimic joint="j1" multiplier="2" offset="0.1"/>'),
        joint("j3", "b", "c", extra='<mimic joint="j2" multiplier="-0.5" offset="0.3"/>'),
    ]
    t = load_tree(write(tmp_path, links, joints))
    # q3 = -0.5 (2 q1 + 0.1) + 0.3 = -q1 + 0.25
    lead, m, o = t.leader("j3")
    assert lead == "j1" and m == pytest.approx(-1.0) and o == pytest.approx(0.25)


@pytest.mark.parametrize(
    "case, needle",
    [
        ("negative_mass", "has mass -2.0"),
        ("nan_mass", "has mass nan"),
        ("mimic_loop", "mimic joints form a loop"),
        ("mimic_missing", "mimics 'nope', which is not a joint"),
        ("mimic_fixed", "mimics the fixed joint"),
        ("duplicate_joint", "duplicate joint name(s) j1"),
        ("two_parents", "is the child of two joints"),
        ("loop", "the joints form a loop"),
        ("missing_link", "which the URDF does not define"),
        ("zero_axis", "zero or non-finite axis"),
        ("floating", "supported joint types"),
        ("truncated", "cannot parse the URDF"),
    ],
)
def test_malformed_trees_are_named(tmp_path, case, needle):
    L = [LINK.format(n=n) for n in ("base_link", "a", "b")]
    if case == "negative_mass":
        p = humanoid(tmp_path, mass="-2.0")
    elif case == "nan_mass":
        p = humanoid(tmp_path, mass="nan")
    elif case == "mimic_loop":
        p = write(
            tmp_path,
            L,
            [
                joint("j1", "base_link", "a", extra='<mimic joint="j2"/>'),
                joint("j2", "a", "b", extra='<mimic joint="j1"/>'),
            ],
        )
    elif case == "mimic_missing":
        p = write(tmp_path, L, [joint("j1", "base_link", "a", extra='<mimic joint="nope"/>')])
    elif case == "mimic_fixed":
        p = write(
            tmp_path,
            L,
            [joint("j0", "base_link", "a", kind="fixed"), joint("j1", "a", "b", extra='<mimic joint="j0"/>')],
        )
    elif case == "duplicate_joint":
        p = write(tmp_path, L, [joint("j1", "base_link", "a"), joint("j1", "a", "b")])
    elif case == "two_parents":
        p = write(tmp_path, L, [joint("j1", "base_link", "b"), joint("j2", "a", "b")])
    elif case == "loop":
        p = write(tmp_path, L, [joint("j2", "a", "b"), joint("j3", "b", "a")])
    elif case == "missing_link":
        p = write(tmp_path, L, [joint("j1", "base_link", "ghost")])
    elif case == "zero_axis":
        p = write(tmp_path, L, [joint("j1", "base_link", "a", axis="0 0 0")])
    elif case == "floating":
        p = write(tmp_path, L, [joint("j1", "base_link", "a", kind="floating")])
    else:
        p = tmp_path / "t.urdf"
        p.write_text('<?xml version="1.0"?><robot name="r"><link name="base_link"/><joint name="j1" type="rev')
    with pytest.raises(stiffkit.InputError, match=r"\.urdf: .*" if case != "truncated" else "t.urdf") as exc:
        load_tree(p)
    assert needle in str(exc.value)
