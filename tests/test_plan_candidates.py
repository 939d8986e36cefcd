"""Candidate postures of ``stiffkit plan`` (robot/plan_candidates.py): every
sampled posture within the limits, clear of itself and the floor, markers in
view and unoccluded, checked against an independent forward kinematics
(written here from the URDF joints) and brute-force distances; rejections
with the right reason; [plan] errors naming file, table and key; the [plan]
table kept by the model writers."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from stiffkit.calib.absolute_write import model_text, write_model
from stiffkit.calib.dualarm import GRAVITY, NOMINAL_MARKERS, dualarm_urdf
from stiffkit.calib.fit import fit
from stiffkit.calib.fit import write_model as write_model_deflection
from stiffkit.calib.measure import read_measurements
from stiffkit.errors import InputError
from stiffkit.robot.capsules import collision_capsules, segment_distance
from stiffkit.robot.model import load_model, model_from_tables
from stiffkit.robot.plan_candidates import REASONS, PlanSettings, _Checks, feasible, plan_settings, sample_postures
from stiffkit.robot.tree import load_tree
from stiffkit.robot.tree_model import load_tree_model, tree_model_from_tables
from stiffkit.robot.urdf import load_chain

ROOT = Path(__file__).resolve().parents[1]
TRACKER = "tracker = {position = [2.8, 0.4, 1.1], direction = [-1, 0, -0.1], cone_deg = 30}"
DUAL_PLAN = f"[plan]\nfloor_z = 0.0\nmargin = 0.01\ndefault_radius = 0.05\nradius = {{chest = 0.06}}\n{TRACKER}\n"
KR_PLAN = """
[plan]
limits = {joint_a1 = [-2.5, 2.5], joint_a2 = [-1.4, 0.2], joint_a3 = [-1.0, 1.2], joint_a5 = [0.4, 1.9]}
default_radius = 0.12
radius = {link_6 = 0.06}
margin = 0.02
floor_z = 0.0
loads = [[0, 0, -2500, 0, 0, 0], [2500, 0, 0, 0, 0, 0]]
"""


def dual_model(folder: Path, plan: str = DUAL_PLAN, name: str = "model.toml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "robot.urdf").write_text(dualarm_urdf())
    start = [{"kind": "tracker"}] + [
        {"kind": "marker", "target": f, "xyz": list(p)} for f, p in NOMINAL_MARKERS.items()
    ]
    text = model_text(start, gravity=GRAVITY).replace("[gravity]", plan + "\n[gravity]")
    (folder / name).write_text(text)
    return folder / name


def kr_model(folder: Path, plan: str = KR_PLAN) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(ROOT / "examples/kr270/robot.urdf", folder / "robot.urdf")
    (folder / "model.toml").write_text((ROOT / "examples/kr270/model.toml").read_text() + plan)
    return folder / "model.toml"


@pytest.fixture(scope="module")
def dual(tmp_path_factory: pytest.TempPathFactory) -> tuple:
    path = dual_model(tmp_path_factory.mktemp("dual"))
    model = load_tree_model(path)
    return path, model, plan_settings(path)


@pytest.fixture(scope="module")
def kr(tmp_path_factory: pytest.TempPathFactory) -> tuple:
    path = kr_model(tmp_path_factory.mktemp("kr"))
    return path, load_model(path), plan_settings(path)


# --- an independent forward kinematics and brute-force distances (test-only references)


def _rot(axis: np.ndarray, a: float) -> np.ndarray:
    x, y, z = axis
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(a) * k + (1 - math.cos(a)) * (k @ k)


def reference_frames(tree, names: list[str], q: np.ndarray) -> dict[str, np.ndarray]:
    """link -> 4x4 base-frame transform: T_child = T_parent origin Rot(axis, q_joint), mimic by its law."""
    val = dict(zip(names, q))
    T = {tree.root: np.eye(4)}
    for j in tree.joints:
        M = np.eye(4)
        if j.moving:
            v = val.get(j.name)
            if v is None:
                lead, m, o = j.mimic
                v = m * val[lead] + o
            M[:3, :3] = _rot(j.axis, v)
        T[j.child] = T[j.parent] @ j.origin @ M
    return T


def reference_capsules(tree, settings, T: dict) -> dict[str, tuple]:
    """label -> (a, b, r) of every skeleton capsule (the module's labels)."""
    out = {}
    for j in tree.joints:
        if np.linalg.norm(j.origin[:3, 3]) > 1e-9:
            out[f"link {j.parent!r} (towards joint {j.name!r})"] = (
                T[j.parent][:3, 3],
                T[j.child][:3, 3],
                settings.radius(j.parent),
            )
    return out


def brute_distance(a1, b1, a2, b2, n: int = 401) -> float:
    """Segment distance by sampling the first segment finely and projecting on the second."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    x = a1 + s * (b1 - a1)
    d = b2 - a2
    dd = float(d @ d)
    t = np.clip((x - a2) @ d / dd, 0.0, 1.0) if dd > 0 else np.zeros(n)
    return float(np.min(np.linalg.norm(x - a2 - t[:, None] * d, axis=1)))


def test_segment_distance_against_brute_force() -> None:
    rng = np.random.default_rng(5)
    P = rng.normal(size=(300, 4, 3))
    P[:40, 1] = P[:40, 0]  # a point and a segment
    P[40:60, 3] = P[40:60, 2]
    P[60:70, 1], P[60:70, 3] = P[60:70, 0], P[60:70, 2]  # two points
    P[70:100, 3] = P[70:100, 2] + 0.7 * (P[70:100, 1] - P[70:100, 0])  # parallel segments
    got = segment_distance(P[:, 0], P[:, 1], P[:, 2], P[:, 3])
    ref = np.array([min(brute_distance(*p, n=4001), brute_distance(p[2], p[3], p[0], p[1], n=4001)) for p in P])
    assert np.all(got <= ref + 1e-12)
    np.testing.assert_allclose(got, ref, atol=2e-3)


def test_urdf_primitive_shapes_become_bounding_capsules(tmp_path: Path) -> None:
    urdf = tmp_path / "r.urdf"
    urdf.write_text(
        '<robot name="r"><link name="base_link"/><link name="a">'
        '<collision><origin xyz="0 0 0.2" rpy="0 1.5707963267948966 0"/>'
        '<geometry><cylinder radius="0.05" length="0.4"/></geometry></collision>'
        '<collision><geometry><box size="0.1 0.6 0.2"/></geometry></collision>'
        '<collision><geometry><sphere radius="0.07"/></geometry></collision>'
        '<collision><geometry><mesh filename="a.stl"/></geometry></collision></link>'
        '<joint name="j" type="revolute"><parent link="base_link"/><child link="a"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    caps = load_tree(urdf).collisions["a"]
    assert len(caps) == 3
    cyl, box, sph = caps
    np.testing.assert_allclose(cyl.a, (-0.2, 0, 0.2), atol=1e-12)  # z of the cylinder turned onto x
    np.testing.assert_allclose(cyl.b, (0.2, 0, 0.2), atol=1e-12)
    assert cyl.r == 0.05
    np.testing.assert_allclose([box.a, box.b], [(0, -0.3, 0), (0, 0.3, 0)], atol=1e-12)
    assert box.r == pytest.approx(0.5 * math.hypot(0.1, 0.2))
    assert sph.a == sph.b == (0.0, 0.0, 0.0) and sph.r == 0.07
    # the capsules go with the link's frame (the tree core's, the chain core's), replacing its skeleton
    tree = load_tree(urdf)
    tm = tree_model_from_tables(tree, [{"kind": "tracker"}, {"kind": "marker", "target": "a"}])
    sm = model_from_tables(load_chain(urdf, "base_link", "a"), [])
    Q = np.array([[0.3], [-0.9]])
    for model in (tm, sm):
        sk = _Checks(model, PlanSettings()).sk
        assert len(sk.labels) == 3 and all("collision" in lb for lb in sk.labels)
        A, B, _M = sk.world(Q)
        for k, q in enumerate(Q):
            T = reference_frames(tree, ["j"], q)["a"]
            for c, cap in enumerate(caps):
                np.testing.assert_allclose(A[k, c], T[:3, :3] @ cap.a + T[:3, 3], atol=1e-12)
                np.testing.assert_allclose(B[k, c], T[:3, :3] @ cap.b + T[:3, 3], atol=1e-12)
    import xml.etree.ElementTree as ET

    bad = ET.fromstring('<link name="a"><collision><geometry><sphere radius="-1"/></geometry></collision></link>')
    with pytest.raises(InputError, match="link 'a'.*radius"):
        collision_capsules([bad], "r.urdf")


def _check_tree_postures(model, settings, cands, must_pairs: list[tuple[str, str]]) -> None:
    """Limits, mimic law, clearance, floor, view and occlusion of every posture, independently."""
    tree = model.tree
    Q = cands.q
    lo = np.array([settings.limits.get(n, tree.joint(n).limit)[0] for n in cands.joint_names])
    hi = np.array([settings.limits.get(n, tree.joint(n).limit)[1] for n in cands.joint_names])
    assert np.all(Q >= lo) and np.all(Q <= hi)
    geo = _Checks(model, settings)
    labels = geo.sk.labels
    pairs = {(labels[i], labels[j]) for i, j in geo.sk.pairs}
    for a, b in must_pairs:
        assert (a, b) in pairs or (b, a) in pairs, (a, b)
    R, p = geo.sk.frames(Q)
    tr = settings.tracker
    for k, q in enumerate(Q):
        T = reference_frames(tree, cands.joint_names, q)
        for ln, i in zip(geo.sk.links, range(len(geo.sk.links))):  # the model's frames are the URDF's
            np.testing.assert_allclose(p[k, i], T[ln][:3, 3], atol=1e-12)
            np.testing.assert_allclose(R[k, i], T[ln][:3, :3], atol=1e-12)
        caps = reference_capsules(tree, settings, T)
        for la, lb in pairs:
            a1, b1, r1 = caps[la]
            a2, b2, r2 = caps[lb]
            assert brute_distance(a1, b1, a2, b2) >= r1 + r2 + settings.margin - 1e-12, (k, la, lb)
        for label, (a, b, r) in caps.items():
            if not label.startswith("link 'base_link'"):
                assert min(a[2], b[2]) - r >= settings.floor_z + settings.margin - 1e-12, (k, label)
        for f in model.frames:
            x = T[f][:3, :3] @ np.array(NOMINAL_MARKERS[f]) + T[f][:3, 3]
            v = x - tr["position"]
            angle = math.degrees(math.acos(v @ tr["direction"] / np.linalg.norm(v)))
            assert angle <= tr["cone_deg"] + 1e-9, (k, f, angle)
            own = {f, tree.parent_joint(f).parent, tree.parent_joint(tree.parent_joint(f).parent).parent}
            for label, (a, b, r) in caps.items():
                if label.split("'")[1] not in own:
                    assert brute_distance(tr["position"], x, a, b, n=2001) >= r - 1e-12, (k, f, label)


def test_dualarm_candidates_clear_and_in_view(dual) -> None:
    _path, model, s = dual
    c = sample_postures(model, 60, seed=3, settings=s)
    assert c.q.shape == (60, 17) and c.joint_names == model.tree.actuated
    assert c.tried == len(c) + sum(c.rejected.values())
    assert set(c.rejected) == set(REASONS) and c.rejected["self-collision"] > 0
    arm = [f"link '{side}_link3' (towards joint '{side}_4')" for side in ("left", "right")]
    must = [(arm[0], arm[1]), (arm[0], "link 'torso_link2' (towards joint 'torso_3')")]
    must.append(("link 'left_link5' (towards joint 'left_6')", "link 'left_link3' (towards joint 'left_4')"))
    _check_tree_postures(model, s, c, must)
    c.check()
    again = sample_postures(model, 60, seed=3, settings=s)
    np.testing.assert_array_equal(again.q, c.q)  # seeded


def test_dualarm_mimic_followers_follow_their_law(dual) -> None:
    _path, model, s = dual
    c = sample_postures(model, 40, seed=4, settings=s)
    geo = _Checks(model, s)
    R, _p = geo.sk.frames(c.q)
    li = {ln: k for k, ln in enumerate(geo.sk.links)}
    q2 = c.q[:, c.joint_names.index("torso_2")]
    for k in range(len(c)):  # torso_4a = -q2 and torso_4b = -q3 about y: the chest stays as upright as link 1
        rel = R[k, li["torso_link3"]].T @ R[k, li["torso_link4a"]]
        np.testing.assert_allclose(rel, _rot(np.array([0, 1, 0]), -q2[k]), atol=1e-12)
        np.testing.assert_allclose(R[k, li["chest"]], R[k, li["torso_link1"]], atol=1e-12)
    assert "torso_4a" not in c.joint_names and "torso_4b" not in c.joint_names
    # a follower limit tighter than its leader's range rejects by the law
    s2 = plan_settings(dual_model(Path(_path).parent / "f", DUAL_PLAN + "limits = {torso_4a = [-0.1, 0.1]}\n"))
    c2 = sample_postures(model, 30, seed=4, settings=s2)
    assert np.all(np.abs(c2.q[:, c2.joint_names.index("torso_2")]) <= 0.1 + 1e-12)
    assert c2.rejected["joint limit"] > 0


def test_planted_collision_and_occlusion_are_rejected(dual) -> None:
    path, model, s = dual
    names = model.tree.actuated
    ok = np.zeros(len(names))
    ok[names.index("left_4")] = ok[names.index("right_4")] = -0.5
    folded = ok.copy()
    folded[names.index("left_4")] = -2.6  # the elbow folded: forearm onto upper arm
    c = feasible(model, np.array([ok, folded]), s)
    assert list(c.rows) == [0] and list(c.failed) == [1]
    assert c.failed[1].startswith("self-collision") and "left_link" in c.failed[1]
    assert c.failure_lines(first_row=2) == [f"row 3: {c.failed[1]}"]
    assert c.take([0]).q.tolist() == [ok.tolist()] and list(c.take([0]).rows) == [0]
    good = sample_postures(model, 3, seed=8, settings=s)
    good.q[1] = folded
    with pytest.raises(InputError, match="candidate 2: self-collision"):
        good.check()
    T = reference_frames(model.tree, names, folded)
    caps = reference_capsules(model.tree, s, T)
    a1, b1, r1 = caps["link 'left_link3' (towards joint 'left_4')"]
    a2, b2, r2 = caps["link 'left_link5' (towards joint 'left_6')"]
    assert brute_distance(a1, b1, a2, b2) < r1 + r2 + s.margin
    # a tracker behind the chest, looking at the left marker through it
    T = reference_frames(model.tree, names, ok)
    x = T["left_tcp"][:3, :3] @ np.array(NOMINAL_MARKERS["left_tcp"]) + T["left_tcp"][:3, 3]
    chest = 0.5 * (T["chest"][:3, 3] + T["left_link1"][:3, 3])
    pos = x + 3.0 * (chest - x) / np.linalg.norm(chest - x)
    d = x - pos
    plan = DUAL_PLAN.replace(
        TRACKER, f"tracker = {{position = {pos.tolist()}, direction = {d.tolist()}, cone_deg = 60}}"
    )
    s2 = plan_settings(dual_model(Path(path).parent / "occ", plan))
    c2 = feasible(model, ok[None], s2)
    assert c2.failed[0].startswith("occluded") and "left_tcp" in c2.failed[0] and "chest" in c2.failed[0]
    plan = DUAL_PLAN.replace(
        TRACKER, f"tracker = {{position = {pos.tolist()}, direction = {(-d).tolist()}, cone_deg = 60}}"
    )
    c3 = feasible(model, ok[None], plan_settings(dual_model(Path(path).parent / "away", plan)))
    assert c3.failed[0].startswith("out of view") and c3.rejected["out of view"] == 1


@pytest.mark.parametrize(
    "plan, match",
    [
        ("limits = {left_1 = [-3.5, 0.0]}", r"\[plan\] limits.left_1 = \[-3.5, 0\] is outside the URDF's limits"),
        ("limits = {head = [0, 1]}", r"\[plan\] limits.head: the robot has no moving joint 'head'"),
        ("limits = {left_1 = [0.2, 0.1]}", r"limits.left_1 = \[0.2, 0.1\]: the lower limit"),
        ("radius = {left_link3 = -0.05}", r"\[plan\] radius.left_link3 = -0.05 m must be positive"),
        ("radius = {left_link3 = 50}", r"\[plan\] radius.left_link3 = 50 m is implausible.*mm\? write 0.05"),
        ("radius = {nolink = 0.05}", r"radius.nolink: the robot has no link"),
        ("margin = nan", r"\[plan\] margin = nan must be a finite number"),
        ("loads = [[0, 0, 1, 0, 0, 0]]", r"\[plan\] loads: loads are for deflection data"),
        ("colour = 1", r"\[plan\]: unknown key\(s\) colour"),
    ],
)
def test_bad_plan_tables_name_file_table_key(tmp_path: Path, plan: str, match: str) -> None:
    path = dual_model(tmp_path, f"[plan]\n{plan}\n")
    with pytest.raises(InputError, match=match) as e:
        plan_settings(path)
    assert str(path) in str(e.value)


@pytest.mark.parametrize(
    "tracker, match",
    [
        ("{position = [2, 0, 1], direction = [-1, 0, 0], cone_deg = 200}", r"tracker.cone_deg = 200 deg must be in"),
        ("{position = [2, 0, 1], direction = [0, 0, 0], cone_deg = 20}", r"tracker.direction .* must not be zero"),
        ("{position = [2, 0], direction = [1, 0, 0], cone_deg = 20}", r"tracker.position must have shape \(3,\)"),
        ("{position = [2, 0, 1], direction = [-1, 0, 0]}", r"tracker: missing cone_deg"),
    ],
)
def test_bad_tracker(tmp_path: Path, tracker: str, match: str) -> None:
    path = dual_model(tmp_path, f"[plan]\ntracker = {tracker}\n")
    with pytest.raises(InputError, match=match) as e:
        plan_settings(path)
    assert f"{path}: [plan]" in str(e.value)


def test_all_colliding_settings_stop_with_the_counts(tmp_path: Path) -> None:
    path = dual_model(tmp_path, "[plan]\nfloor_z = 0.9\n")  # above the torso's first joint
    model = load_tree_model(path)
    with pytest.raises(InputError) as e:
        sample_postures(model, 5, seed=1, settings=plan_settings(path, model))
    msg = str(e.value)
    assert msg.startswith(f"{path}: [plan]: no feasible candidate: 10,000 tried, ")
    counts = {r: int(n.replace(",", "")) for n, r in re.findall(r"([\d,]+) (self-collision|floor)", msg)}
    assert set(counts) == {"self-collision", "floor"} and sum(counts.values()) == 10_000
    assert "loosen [plan] margin or radius" in msg and "lower [plan] floor_z" in msg


def test_kr270_serial_candidates(kr) -> None:
    path, model, s = kr
    c = sample_postures(model, 200, seed=2, settings=s)
    assert c.joint_names == model.chain.actuated
    np.testing.assert_array_equal(c.loads, [[0, 0, -2500, 0, 0, 0], [2500, 0, 0, 0, 0, 0]])
    assert c.rejected["floor"] > 0 and c.tried == 200 + sum(c.rejected.values())
    tree = load_tree(model.chain.urdf)
    geo = _Checks(model, s)
    labels = geo.sk.labels
    number = [0 if lb.startswith("link 'base_link'") else int(lb.split("'")[1][-1]) for lb in labels]
    # links two joints apart or more are tested, but link_4 and link_6 (0.1 m apart, radii 0.12 and 0.06)
    tested = {(number[i], number[j]) for i, j in geo.sk.pairs}
    assert tested == {(i, j) for i in range(7) for j in range(i + 2, 7)} - {(4, 6)}
    for q in c.q:
        for n, v in zip(c.joint_names, q):
            lo, hi = s.limits.get(n, tree.joint(n).limit)
            assert lo <= v <= hi
        caps = reference_capsules(tree, s, reference_frames(tree, c.joint_names, q))
        assert list(caps) == labels
        for la, (a1, b1, r1) in caps.items():
            if not la.startswith("link 'base_link'"):
                assert min(a1[2], b1[2]) - r1 >= s.floor_z + s.margin - 1e-12
        for i, j in geo.sk.pairs:
            (a1, b1, r1), (a2, b2, r2) = caps[labels[i]], caps[labels[j]]
            assert brute_distance(a1, b1, a2, b2) >= r1 + r2 + s.margin - 1e-12, (labels[i], labels[j])
    c.check()
    low = np.array([[0.0, 0.2, 1.2, 0.0, 1.0, 0.0]])  # the forearm pointing down: the wrist below the floor
    assert feasible(model, low, s).failed[0].startswith("floor")


@pytest.mark.filterwarnings("ignore::stiffkit.errors.PlausibilityWarning")
def test_kr270_bad_loads_and_tracker(tmp_path: Path) -> None:
    cases = [
        ("[plan]\nloads = [[0, 0, 0, 0, 0, 0]]\n", r"\[plan\] loads\[0\] is all zero"),
        ("[plan]\nloads = [[0, 0, 1, 0, 0]]\n", r"\[plan\] loads\[0\] = .* must be 6 numbers"),
        ("[plan]\nloads = [[0, 0, inf, 0, 0, 0]]\n", r"\[plan\] loads\[0\]\[2\] = inf must be a finite number"),
        ("[plan]\nlimits = {joint_a2 = [-7, 0]}\n", r"limits.joint_a2 = \[-7, 0\] is outside the URDF's limits"),
        (f"[plan]\n{TRACKER}\n", r"\[plan\] tracker: the view test is for absolute"),
    ]
    for k, (plan, match) in enumerate(cases):
        path = kr_model(tmp_path / str(k), plan)
        with pytest.raises(InputError, match=match) as e:
            plan_settings(path)
        assert str(path) in str(e.value)


def test_writers_keep_the_plan_table(tmp_path: Path, dual, kr) -> None:
    path, model, s = dual
    out = tmp_path / "written.toml"
    shutil.copy(Path(path).parent / "robot.urdf", tmp_path / "robot.urdf")
    fake = SimpleNamespace(model=model, theta=model.theta0, data=SimpleNamespace(path="m.csv"))
    write_model(fake, out)
    back = load_tree_model(out)
    assert back.plan == model.plan and plan_settings(out).tracker["cone_deg"] == 30
    np.testing.assert_allclose(plan_settings(out).tracker["direction"], s.tracker["direction"])
    kpath, kmodel, ks = kr
    meas = read_measurements(ROOT / "examples/kr270/measurements.csv", kmodel.chain.dof)
    out = Path(kpath).parent / "fitted.toml"
    write_model_deflection(fit(kmodel, meas), out)
    kback = load_model(out)
    assert kback.plan == kmodel.plan
    assert plan_settings(out) == ks.__class__(**{**ks.__dict__, "path": str(out)})


def test_elastic_tree_model_samples_on_its_rigid_kinematics(dual) -> None:
    """Elastic effects (a dead zone whose width comes from data later) do not change the candidates."""
    _path, model, s = dual
    eff = list(model.effects) + [{"kind": k, "target": "all"} for k in ("joint_offset", "frame", "joint", "lateral")]
    eff += [{"kind": "joint_deadzone", "target": "left_2"}, {"kind": "link", "target": "left_link3"}, {"kind": "base"}]
    elastic = tree_model_from_tables(model.tree, eff, GRAVITY)
    assert elastic.ne > 0
    a, b = sample_postures(elastic, 30, seed=6, settings=s), sample_postures(model, 30, seed=6, settings=s)
    np.testing.assert_array_equal(a.q, b.q)
    assert a.rejected == b.rejected


def test_both_loaders_take_plan_and_refuse_a_plan_that_is_no_table(tmp_path: Path) -> None:
    good = load_model(kr_model(tmp_path / "k"))
    assert good.plan["floor_z"] == 0.0 and good.plan["radius"] == {"link_6": 0.06}
    path = kr_model(tmp_path / "k2", "")
    path.write_text("plan = 3\n" + path.read_text())
    with pytest.raises(InputError, match=r"model.toml: \[plan\] must be a table"):
        load_model(path)
    text = dual_model(tmp_path / "d").read_text().replace(DUAL_PLAN, "")
    (tmp_path / "d" / "bad.toml").write_text('plan = "x"\n' + text)
    with pytest.raises(InputError, match=r"bad.toml: \[plan\] must be a table"):
        load_tree_model(tmp_path / "d" / "bad.toml")
