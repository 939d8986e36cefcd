"""The catalogue of effect kinds (robot/catalogue.py): the readers, the
candidate lists and the docs table derive from it; its law codes are the
core's."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from _profiles import examples
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stiffkit.calib.absolute_candidates import absolute_candidates
from stiffkit.calib.absolute_write import model_effects, model_text
from stiffkit.calib.diagnose_candidates import candidate_tables
from stiffkit.calib.dualarm import synth_dualarm
from stiffkit.robot import catalogue, model, tree_model
from stiffkit.robot.model_file import model_toml

ROOT = Path(__file__).resolve().parents[1]


def _core_laws() -> dict[str, int]:
    """The ``law_*`` integer parameters of the core (wherever they are declared)."""
    text = "".join(re.sub(r"&\s*\n\s*", " ", p.read_text()) for p in sorted((ROOT / "core").glob("*.f90")))
    lines = text.splitlines()  # continuation lines joined
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


def test_term_codes_are_the_serial_cores():
    """The serial chain's term codes (core/sk_deflect.f90 term_*) are the
    catalogue's: the same numbers, each named after its kind."""
    text = re.sub(r"&\s*\n\s*", " ", (ROOT / "core" / "sk_deflect.f90").read_text())
    decl = "\n".join(ln for ln in text.splitlines() if re.match(r"\s*integer.*\bparameter\b", ln))
    core = {name: int(v) for name, v in re.findall(r"\bterm_([a-z0-9]+)\s*=\s*(\d+)\b", decl)}
    assert sorted(core.values()) == sorted(catalogue.TERMS.values())
    by_code = {v: k for k, v in catalogue.TERMS.items()}
    for name, code in core.items():
        assert name in by_code[code], (name, by_code[code])


def test_docs_table_is_the_catalogue():
    """docs/calibration.md section 8 holds the catalogue's table, row for row."""
    text = (ROOT / "docs" / "calibration.md").read_text()
    table = catalogue.docs_table()
    assert table in text
    rows = re.findall(r"^\| `([a-z_0-9]+)` \|", text[text.index(table.splitlines()[0]) :], flags=re.M)
    assert rows[: len(catalogue.ENTRIES)] == [e.name for e in catalogue.ENTRIES]


def test_fit_help_is_the_catalogue():
    """stiffkit fit --help lists every deflection kind once, in catalogue
    order, with its law, its parameters and units and what its keys mean,
    as the catalogue says them."""
    from stiffkit.cli.app import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    epilog = sub.choices["fit"].epilog
    section = epilog[epilog.index("effects (robot/catalogue.py") : epilog.index("  every kind of both data kinds")]
    heads = list(re.finditer(r"^  ([a-z_0-9]+) ", section, flags=re.M))
    assert [m.group(1) for m in heads] == list(catalogue.kinds(catalogue.DEFLECTION))
    ends = [m.start() for m in heads[1:]] + [len(section)]
    for m, end in zip(heads, ends):
        e = catalogue.KIND[m.group(1)]
        entry = " ".join(section[m.end() : end].split())  # the wrapping aside
        assert entry.startswith(" ".join(e.formula.split()) + ";"), e.name
        for p in e.params:
            assert p.suffix in entry and p.unit in entry, (e.name, p.suffix)
        if e.usage:
            assert " ".join(e.usage.split()) in entry, e.name
        assert ("needs a joint effect" in entry) == (catalogue.DEFLECTION in e.needs_joint), e.name


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

    # a law on a joint's compliance: only where the model has that joint's compliance
    m2 = model.model_from_tables(ch, [{"kind": "joint", "target": ch.actuated[1]}])
    harm = [t["target"] for t, _ in catalogue.candidates(m2, "deflection") if t["kind"] == "joint_harmonic"]
    assert harm == [ch.actuated[1]]
    assert sum(t["kind"] == "joint_harmonic" for t, _ in cands) == n

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
    assert [t["target"] for t in acands if t["kind"] == "joint_harmonic"] == moving  # every joint has its c


def test_value_table_reads_back():
    """value_table writes the key each kind is read from (scalar or list)."""
    assert catalogue.value_table("joint", [2e-7]) == {"value": 2e-7}
    assert catalogue.value_table("gravity_compensator", [1e4]) == {"k_s": 1e4}
    assert catalogue.value_table("point_offset", [1, 2, 3]) == {"r": [1.0, 2.0, 3.0]}
    assert catalogue.value_table("joint_profile", range(5)) == {"value": [0.0, 1.0, 2.0, 3.0, 4.0]}
    for e in catalogue.ENTRIES:
        for data in e.data:
            assert e.value_key in e.keys[data], (e.name, data)


# ------------------------------------------------------------------ every catalogued kind reads back

SETTINGS = settings(
    max_examples=examples(20),
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
MAG = st.floats(min_value=1e-12, max_value=1e-3, allow_nan=False, allow_subnormal=False)
SIGN = st.sampled_from([-1.0, 1.0])


def _draw_values(draw, e: catalogue.Kind) -> list[float]:
    """Values of every parameter of kind ``e`` within its catalogue bounds."""
    out = []
    for p in e.params:
        v = draw(MAG) * (1.0 if p.lo >= 0 else draw(SIGN))
        out.append(min(v, p.hi))
    return out


@st.composite
def deflection_tables(draw, chain):
    """Random [[effect]] tables with values of every per-joint kind of the
    catalogue for deflection data (a joint effect where a kind needs one),
    6x6 springs and a point offset."""
    per_joint = [k for k in model.JOINT_KINDS if catalogue.KIND[k].params and k != "gravity_compensator"]
    out = []
    for j in draw(st.lists(st.sampled_from(chain.actuated), unique=True, min_size=1, max_size=6)):
        kind = draw(st.sampled_from(per_joint))
        e = catalogue.KIND[kind]
        if "deflection" in e.needs_joint or kind != "joint" and draw(st.booleans()):
            out.append({"kind": "joint", "target": j, **catalogue.value_table("joint", [draw(MAG)])})
        if kind != "joint":
            tab = {"kind": kind, "target": j, **catalogue.value_table(kind, _draw_values(draw, e))}
            if e.w0_key:
                tab[e.w0_key] = 1.0 + 1e3 * draw(MAG)
            out.append(tab)
    if draw(st.booleans()):
        out.append(
            {
                "kind": "point_offset",
                **catalogue.value_table("point_offset", _draw_values(draw, catalogue.KIND["point_offset"])),
            }
        )
    if draw(st.booleans()):
        out.append({"kind": "base", "value": (draw(MAG) * np.eye(6)).tolist()})
    return out


@pytest.fixture(scope="module")
def kr_chain():
    return model.load_chain(ROOT / "examples" / "kr270" / "robot.urdf", "base_link", "tool0")


@SETTINGS
@given(data=st.data())
def test_every_deflection_kind_reads_back_exactly(kr_chain, tmp_path_factory, data):
    """A model file of random catalogued kinds with values, written by the
    one writer (robot/model_file.py on stiffkit.io.tomlw), reads back with
    the same numbers, and every term's value is the written one."""
    effects = data.draw(deflection_tables(kr_chain))
    path = tmp_path_factory.mktemp("c") / "model.toml"
    text = model_toml(effects, urdf=str(ROOT / "examples" / "kr270" / "robot.urdf"))
    path.write_text(text)
    back = model.load_model(path)
    assert back.effects == effects
    for t in back.terms:
        e = catalogue.KIND.get(t.kind)
        if e is not None:
            src = effects[t.effect][e.value_key]
            np.testing.assert_array_equal(np.ravel(t.value), np.ravel(src))


@pytest.fixture(scope="module")
def dual_truth(tmp_path_factory):
    d = tmp_path_factory.mktemp("cat_dual")
    synth_dualarm(d, configs=6, seed=2)
    tree = tree_model.load_tree(d / "robot.urdf", "base_link")
    return d, tree, tree_model.load_tree_model(d / "truth.toml").effects


@SETTINGS
@given(data=st.data())
def test_every_absolute_kind_reads_back_exactly(dual_truth, tmp_path_factory, data):
    """The dual-arm truth plus a random law of the catalogue (cubic, dead
    zone, harmonic) on random joints, every parameter at a random value
    within its bounds: the absolute writer's tables (calib/absolute_write)
    read back with every value exactly."""
    d, tree, truth = dual_truth
    moving = [j.name for j in tree.joints if j.moving]
    extra = []
    for j in data.draw(st.lists(st.sampled_from(moving), unique=True, min_size=1, max_size=4)):
        kind = data.draw(st.sampled_from(catalogue.LAW_KINDS))
        tab = {"kind": kind, "target": j}
        if catalogue.KIND[kind].w0_key:
            tab[catalogue.KIND[kind].w0_key] = 1.0 + data.draw(MAG) * 1e3
        if kind == "gravity_compensator":  # its geometry, fixed parameters that read back too
            tab.update(a=0.1 + data.draw(MAG), b=0.2 + data.draw(MAG), beta=data.draw(MAG), s0=data.draw(MAG))
        extra.append(tab)
    m = tree_model.tree_model_from_tables(tree, truth + extra, (0.0, 0.0, -9.81))
    theta = m.theta0.copy()
    for i, p in enumerate(m.params):
        e = catalogue.KIND[p.kind]
        par = {q.suffix: q for q in e.params}.get(p.name.rsplit(".", 1)[-1])
        if p.kind in ("tracker", "link", "base") or par is None:
            continue
        theta[i] = data.draw(MAG) * (1.0 if par.lo >= 0 else data.draw(SIGN))
    tables, notes = model_effects(m, theta)
    assert notes == []
    path = tmp_path_factory.mktemp("a") / "model.toml"
    path.write_text(model_text(tables, urdf=str(d / "robot.urdf"), gravity=m.gravity))
    back = tree_model.load_tree_model(path)
    assert back.names == m.names
    rest = [i for i, p in enumerate(m.params) if p.kind != "tracker"]
    np.testing.assert_array_equal(back.theta0[rest], theta[rest])
    assert [int(k) for k in back.arrays["ktype"]] == [int(k) for k in m.arrays["ktype"]]
