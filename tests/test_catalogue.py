"""The catalogue of effect kinds (robot/catalogue.py): the readers, the
candidate lists and the docs table derive from it; its law codes are the
core's."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from stiffkit.calib.absolute_candidates import absolute_candidates
from stiffkit.calib.diagnose_candidates import candidate_tables
from stiffkit.robot import catalogue, model, tree_model

ROOT = Path(__file__).resolve().parents[1]


def _core_laws() -> dict[str, int]:
    """The ``law_*`` integer parameters of the core (wherever they are declared)."""
    lines = [ln for p in sorted((ROOT / "core").glob("*.f90")) for ln in p.read_text().splitlines()]
    decl = "\n".join(ln for ln in lines if re.match(r"\s*integer.*\bparameter\b", ln))
    found = re.findall(r"\b(law_[a-z0-9]+)\s*=\s*(\d+)\b", decl)
    return {name.upper(): int(v) for name, v in found}


def test_law_codes_are_the_cores():
    """Every law an entry names is a code of the core, with the same number,
    and the catalogue knows every law code of the core."""
    core = _core_laws()
    assert core == catalogue.LAWS
    for e in catalogue.ENTRIES:
        if e.law:
            assert e.law in core, e.name


def test_docs_table_is_the_catalogue():
    """docs/calibration.md section 8 holds the catalogue's table, row for row."""
    text = (ROOT / "docs" / "calibration.md").read_text()
    table = catalogue.docs_table()
    assert table in text
    rows = re.findall(r"^\| `([a-z_0-9]+)` \|", text[text.index(table.splitlines()[0]) :], flags=re.M)
    assert rows[: len(catalogue.ENTRIES)] == [e.name for e in catalogue.ENTRIES]


def test_readers_take_the_catalogue():
    """Both readers' kind lists and key tables are the catalogue's, and the
    dead-zone fraction is defined once."""
    assert set(model.KINDS) == {e.name for e in catalogue.ENTRIES if "deflection" in e.data}
    assert set(tree_model.ABS_KINDS) == {e.name for e in catalogue.ENTRIES if "absolute" in e.data}
    for kind, keys in model.KEYS.items():
        assert keys == set(catalogue.KIND[kind].keys["deflection"])
    for kind, keys in tree_model.KEYS.items():
        assert keys == set(catalogue.KIND[kind].keys["absolute"])
    assert model.DEADZONE_TAU0_FRACTION is tree_model.DEADZONE_TAU0_FRACTION is catalogue.DEADZONE_TAU0_FRACTION
    # the reduction's preference (absolute_fit.PREFERENCE): compliances before the gravity parameters
    kinds = list(tree_model.ABS_KINDS)
    assert kinds.index("base") < kinds.index("mass") and kinds[:2] == ["tracker", "marker"]


def test_every_key_of_a_kind_is_read(tmp_path):
    """A key the catalogue does not list for a kind is refused by the reader,
    naming the allowed keys (the reader's table is the catalogue's)."""
    from stiffkit.errors import InputError

    urdf = ROOT / "examples" / "kr270" / "robot.urdf"
    ch = model.load_chain(urdf, "base_link", "tool0")
    with pytest.raises(InputError, match="unknown key.*tau0.*allowed: kind, target, value, note"):
        model.model_from_tables(ch, [{"kind": "joint_cubic", "target": ch.actuated[0], "tau0": 1.0}])


def test_candidates_follow_the_catalogue():
    """Both diagnoses' candidates come from catalogue.candidates, in
    catalogue order, and name only kinds of their data kind."""
    urdf = ROOT / "examples" / "kr270" / "robot.urdf"
    ch = model.load_chain(urdf, "base_link", "tool0")
    m = model.model_from_tables(ch, [{"kind": "joint", "target": "all"}])
    cands = candidate_tables(m, None)
    assert cands == catalogue.candidates(m, "deflection")
    order = [e.name for e in catalogue.ENTRIES]
    ranks = [order.index(t["kind"]) for t, _ in cands]
    assert ranks == sorted(ranks)
    kinds = {t["kind"] for t, _ in cands}
    assert "joint" not in kinds  # the model has it on every joint
    assert {"joint_profile", "joint_cubic", "joint_deadzone", "link", "base", "tool", "point_offset"} <= kinds
    n = len(ch.actuated)
    assert sum(t["kind"] == "joint_profile" for t, _ in cands) == n
    assert sum(t["kind"] == "link" for t, _ in cands) == 3 * sum(not ch.is_tool_spring(ln) for ln in ch.links)

    tree = tree_model.load_tree(urdf, "base_link")
    tm = tree_model.tree_model_from_tables(
        tree, [{"kind": "tracker"}, {"kind": "marker", "target": "tool0"}, {"kind": "joint", "target": "all"}]
    )
    acands = absolute_candidates(tm)
    assert acands == [t for t, _ in catalogue.candidates(tm, "absolute")]
    assert {t["kind"] for t in acands} <= set(tree_model.ABS_KINDS)
    moving = [j.name for j in tree.joints if j.moving]
    assert acands[0] == {"kind": "joint_offset", "target": "all"}
    assert [t["target"] for t in acands if t["kind"] == "joint_offset"] == ["all"] + moving
    assert not any(t["kind"] == "joint" for t in acands)


def test_value_table_reads_back():
    """value_table writes the key each kind is read from (scalar or list)."""
    assert catalogue.value_table("joint", [2e-7]) == {"value": 2e-7}
    assert catalogue.value_table("gravity_compensator", [1e4]) == {"k_s": 1e4}
    assert catalogue.value_table("point_offset", [1, 2, 3]) == {"r": [1.0, 2.0, 3.0]}
    assert catalogue.value_table("joint_profile", range(5)) == {"value": [0.0, 1.0, 2.0, 3.0, 4.0]}
    for e in catalogue.ENTRIES:
        for data in e.data:
            assert e.value_key in e.keys[data], (e.name, data)
