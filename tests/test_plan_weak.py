"""Which parameters a plan leaves weak and why (issue 19, calib/plan_weak.py):
weakly excited, correlated with named others, or not identifiable, each
with its numbers, checked against numpy on the plan's own rows: on
synthetic designs (one column barely seen, two near-collinear, two
collinear) and on a KR-270-like chain whose [plan] loads barely load joint
1 while the task load does."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _plan_robots import KR_POINTS, P, k_rule, kr_files, workcell_task

from stiffkit.calib.plan_weak import NULL_SHARE, WEAK_EXCITATION, WEAK_VIF
from stiffkit.cli.app import main


def _setup(jc: np.ndarray, jt: np.ndarray, not_planned: list | None = None) -> P.PlanSetup:
    """A design problem of rows alone (tracker-like: no model, no candidates' postures)."""
    ncand, npar = jc.shape[0], jc.shape[2]
    return P.PlanSetup(
        kind="absolute", model=None, names=[f"p{j}" for j in range(npar)], jc=jc, posture=np.arange(ncand),
        loads=None, candidates=None, jt=jt, task_q=np.zeros((jt.shape[0] // 3, 1)),
        task_of=np.repeat(np.arange(jt.shape[0] // 3), 3), task_source="synthetic", m0=None, measured_rows=0,
        sigma=1.0, sigma_source="", not_planned=not_planned or [],
    )  # fmt: skip


def _numbers(s: P.PlanSetup, chosen: np.ndarray) -> dict:
    """The weak-parameter numbers from the rows with numpy (calib/plan_weak.py's definitions)."""
    A = s.jc[chosen].reshape(-1, s.npar)
    M = A.T @ A
    pool = np.einsum("cij,cij->j", s.jc, s.jc)
    task = np.sum(s.jt**2, axis=0)
    cov = np.linalg.inv(M)
    std = np.sqrt(np.diag(cov))
    ex = np.sqrt(np.diag(M) / pool)
    tex = np.sqrt(np.diag(M) / task)
    ptex = np.sqrt(pool / task)
    return dict(
        std=std, std0=1 / np.sqrt(np.diag(M)), vif=np.diag(cov) * np.diag(M), corr=cov / np.outer(std, std),
        excitation=ex / np.median(ex), task_excitation=tex / np.median(tex), pool_task=ptex / np.median(ptex),
    )  # fmt: skip


def test_weakly_excited_and_correlated_synthetic():
    """p0 moves the task as much as the others but its rows are 1e-3 of
    theirs: weakly excited for the task (not correlated); p2 = p1 + small
    noise: both correlated, each naming the other with numpy's r."""
    rng = np.random.default_rng(5)
    jc = rng.normal(size=(40, 3, 6))
    jc[:, :, 0] *= 1e-3
    jc[:, :, 2] = jc[:, :, 1] + 0.05 * rng.normal(size=(40, 3))
    jt = rng.normal(size=(12, 6))
    s = _setup(jc, jt, not_planned=[("q", "no influence on the data (G2)")])
    res = P.plan(None, 8, "D", setup=s)
    ref = _numbers(s, res.selected)
    weak = {w["name"]: w for w in res.weak}
    w0 = weak["p0"]
    assert w0["reasons"] == ["weakly excited"] and w0["source"] == "plan"
    assert w0["task_excitation"] == pytest.approx(ref["task_excitation"][0], rel=1e-9)
    assert w0["task_excitation"] < 2e-3 < WEAK_EXCITATION
    assert w0["excitation"] == pytest.approx(ref["excitation"][0], rel=1e-9)  # the plan loads it as the pool does
    assert w0["excitation"] > WEAK_EXCITATION
    assert w0["std"] == pytest.approx(ref["std"][0], rel=1e-8)
    assert w0["std_uncorrelated"] == pytest.approx(ref["std0"][0], rel=1e-9)
    assert w0["vif"] == pytest.approx(ref["vif"][0], rel=1e-8) and w0["vif"] < WEAK_VIF
    assert f"{w0['task_excitation']:.3g} x as strongly as the median parameter" in w0["why"]
    # no candidate loads it more: the report says to add some
    assert w0["candidates_task_excitation"] == pytest.approx(ref["pool_task"][0], rel=1e-9)
    assert f"all candidates together: {w0['candidates_task_excitation']:.3g} x; add candidate postures" in w0["why"]
    for a, b in (("p1", "p2"), ("p2", "p1")):
        w = weak[a]
        assert w["reasons"] == ["correlated"]
        ja, jb = int(a[1]), int(b[1])
        assert w["vif"] == pytest.approx(ref["vif"][ja], rel=1e-8) and w["vif"] > WEAK_VIF
        assert w["correlated_with"][0]["name"] == b
        assert w["correlated_with"][0]["r"] == pytest.approx(ref["corr"][ja, jb], rel=1e-8)
        assert w["inflation"] == pytest.approx(np.sqrt(ref["vif"][ja]), rel=1e-8)
        assert f"correlated with {b} (r = {ref['corr'][ja, jb]:+.3f})" in w["why"]
    # the well-determined parameters are not weak; the reduction's set-aside ones come last
    assert {"p3", "p4", "p5"}.isdisjoint(weak)
    assert res.weak[-1] == {
        "name": "q", "source": "reduction", "reasons": ["not identifiable"],
        "why": "set aside by the fit's reduction: no influence on the data (G2)",
    }  # fmt: skip


def test_not_identifiable_synthetic():
    """p4 = 2 p3 in every row: the plan's information is singular and both
    lie in its null space, each half of it (numpy's projector), naming the other."""
    rng = np.random.default_rng(3)
    jc = rng.normal(size=(30, 3, 5))
    jc[:, :, 4] = 2 * jc[:, :, 3]
    s = _setup(jc, rng.normal(size=(6, 5)))
    res = P.plan(None, 4, "D", setup=s)
    A = s.jc[res.selected].reshape(-1, 5)
    M = A.T @ A
    d = 1 / np.sqrt(np.diag(M))
    ev, V = np.linalg.eigh(M * np.outer(d, d))
    V0 = V[:, ev < 1e-10]
    proj = V0 @ V0.T
    assert V0.shape[1] == 1 and res.weakness.nnull == 1
    assert res.weakness.null == pytest.approx(proj, abs=1e-9)
    weak = {w["name"]: w for w in res.weak}
    assert set(weak) == {"p3", "p4"}
    for a, b in (("p3", 3), ("p4", 4)):
        w = weak[a]
        assert w["reasons"] == ["not identifiable"] and w["std"] is None
        assert w["null_share"] == pytest.approx(proj[b, b], abs=1e-9) and w["null_share"] > NULL_SHARE
        assert w["null_share"] == pytest.approx(0.5, abs=1e-9)
        assert [p["name"] for p in w["null_with"]] == [{"p3": "p4", "p4": "p3"}[a]]
        assert "not identifiable from the plan" in w["why"]


@pytest.fixture(scope="module")
def kr_weak(tmp_path_factory):
    """The KR-270-like chain whose [plan] loads are a vertical force, two
    moments and a small (25 N) horizontal force (joint 1's axis is
    vertical: only the horizontal force loads it), and whose task load is
    2500 N horizontal."""
    root = tmp_path_factory.mktemp("kr_weak")
    path = kr_files(root, extra=f"points = {[list(p) for p in KR_POINTS]}\n")
    text = path.read_text()
    loads = "loads = [[0, 0, -2500, 0, 0, 0], [0, 0, 0, 300, 0, 0], [0, 0, 0, 0, 300, 0], [25, 0, 0, 0, 0, 0]]"
    path.write_text("\n".join(loads if ln.startswith("loads") else ln for ln in text.splitlines()) + "\n")
    model = P.load_plan_model(path)
    s0 = P.build_setup(model, candidates=150, seed=2)
    task = root / "task.csv"
    T = workcell_task(model, s0.candidates.q[3], 12, 7, task, s0.joint_names)
    rows = ["q1,q2,q3,q4,q5,q6,fx,fy,fz,mx,my,mz"]
    rows += [",".join(f"{v:.17g}" for v in q) + ",2500,0,0,0,0,0" for q in T]
    task.write_text("\n".join(rows) + "\n")
    setup = P.build_setup(model, candidates=150, seed=2, task=task)
    return dict(root=root, path=path, task=task, setup=setup, res=P.plan(None, k_rule(setup.npar), "task", setup=setup))


def test_kr_joint_barely_loaded(kr_weak, tmp_path, capsys):
    s, res = kr_weak["setup"], kr_weak["res"]
    ref = _numbers(s, res.selected)
    weak = {w["name"]: w for w in res.weak}
    j1 = s.names.index("joint_a1.c")
    w = weak["joint_a1.c"]
    print(f"joint_a1.c: {w['why']}")
    assert w["reasons"] == ["weakly excited"]
    assert w["task_excitation"] == pytest.approx(ref["task_excitation"][j1], rel=1e-8)
    assert w["task_excitation"] < 0.1
    # the [plan] loads barely load joint 1 whichever posture: add loads that do
    assert w["candidates_task_excitation"] == pytest.approx(ref["pool_task"][j1], rel=1e-8)
    assert w["candidates_task_excitation"] < WEAK_EXCITATION and "[plan] loads, that load it" in w["why"]
    assert w["vif"] == pytest.approx(ref["vif"][j1], rel=1e-6) and w["vif"] < WEAK_VIF
    # the most inflated parameter the plan excites well: correlated, naming numpy's strongest partner
    ok = [j for j in range(s.npar) if min(ref["excitation"][j], ref["task_excitation"][j]) >= WEAK_EXCITATION]
    jc = max(ok, key=lambda j: ref["vif"][j])
    wc = weak[s.names[jc]]
    print(f"{s.names[jc]}: {wc['why']}")
    assert wc["reasons"] == ["correlated"]
    r = np.abs(ref["corr"][jc])
    r[jc] = 0
    assert wc["correlated_with"][0]["name"] == s.names[int(np.argmax(r))]
    assert wc["correlated_with"][0]["r"] == pytest.approx(ref["corr"][jc, int(np.argmax(r))], rel=1e-6)
    assert wc["vif"] == pytest.approx(ref["vif"][jc], rel=1e-6)
    # every reason matches numpy's numbers and the thresholds
    for name, d in weak.items():
        if d["source"] != "plan":
            continue
        j = s.names.index(name)
        low = min(ref["excitation"][j], ref["task_excitation"][j]) < WEAK_EXCITATION
        assert ("weakly excited" in d["reasons"]) == low, name
        assert ("correlated" in d["reasons"]) == (ref["vif"][j] > WEAK_VIF), name
    assert {d["name"] for d in res.weak if d["source"] == "reduction"} == {n for n, _ in s.not_planned}
    # the command's report and JSON say the same
    argv = ["plan", str(kr_weak["path"]), "--select", str(res.k), "--candidates", "150", "--seed", "2"]
    argv += ["--task", str(kr_weak["task"]), "--json", str(tmp_path / "p.json")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    doc = json.loads((tmp_path / "p.json").read_text())
    assert doc["weak"] == json.loads(json.dumps(res.weak))  # the same plan as the Python one
    cli = {d["name"]: d for d in doc["weak"]}
    assert f"  joint_a1.c: {cli['joint_a1.c']['why']}" in out
    par = {p["name"]: p for p in doc["parameters"]}
    assert par["joint_a1.c"]["task_excitation"] == pytest.approx(cli["joint_a1.c"]["task_excitation"])
