"""Design sweeps on Dask (stiffkit sweep, stiffkit.sweep): real gmsh and ccx
on coarse meshes (C3D10 5 mm beams of 100 and 200 mm)."""

from __future__ import annotations

import copy
import csv
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

pytest.importorskip("distributed")

import stiffkit  # noqa: E402
from stiffkit.cli import main as cli_main  # noqa: E402
from stiffkit.fea.config import parse_link  # noqa: E402
from stiffkit.sweep import plan as pl  # noqa: E402
from stiffkit.sweep import table as tb  # noqa: E402

BEAM = """\
[geometry]
{geometry}
units = "mm"
[material]
E = 2.0e11
nu = 0.266
[support]
plane = "x-min"
[load]
plane = "x-max"
reference_point = [100.0, 0.0, 0.0]
[mesh]
order = 2
size = 5.0
features = false  # the plain mesh these sweeps were measured on (the structured box has 8x the nodes)
"""
BOX = 'shape = "box"\nsize = [100.0, 5.0, 5.0]'
#: two lengths (the reference point stays at the tip) x two materials
LENGTH = "geometry.size.0=100,200 load.reference_point.0=100,200"
MATERIAL = "material.E=7e10,2e11"
VARIED = ["geometry.size.0", "load.reference_point.0", "material.E"]


@pytest.fixture(scope="module")
def link(tmp_path_factory):
    p = tmp_path_factory.mktemp("link") / "beam.toml"
    p.write_text(BEAM.format(geometry=BOX))
    return p


def stiffkit_cli(*args, env=None, **kw):
    return subprocess.run(
        [sys.executable, "-m", "stiffkit", *map(str, args)], capture_output=True, text=True, timeout=600, env=env, **kw
    )


def rows_of(table) -> list[dict]:
    if isinstance(table, list):
        return table
    return table.to_dict("records")  # pandas installed


def read_csv(path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.startswith("stiffkit")]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# ---------------------------------------------------------------- the sweep itself


@pytest.fixture(scope="module")
def two_worker_sweep(link, tmp_path_factory):
    """The 4 runs on a LocalCluster of two workers (the Python API, a client given)."""
    from distributed import Client, LocalCluster

    cache = tmp_path_factory.mktemp("cache-api")
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as lc,
        Client(lc, set_as_default=False) as client,
    ):
        assert len(client.scheduler_info()["workers"]) == 2
        table = stiffkit.sweep(
            link,
            vary={
                "length": {"geometry.size.0": [100, 200], "load.reference_point.0": [100, 200]},
                "material.E": [7e10, 2e11],
            },
            client=client,
            cache=cache,
        )
    return rows_of(table)


def test_two_worker_sweep_equals_the_runs_one_by_one(two_worker_sweep, link, tmp_path):
    rows = two_worker_sweep
    assert [list(r) for r in rows] == [tb.columns(VARIED)] * 4
    assert [(r["run"], r["geometry.size.0"], r["load.reference_point.0"], r["material.E"]) for r in rows] == [
        (1, 100.0, 100.0, 7e10),
        (2, 100.0, 100.0, 2e11),
        (3, 200.0, 200.0, 7e10),
        (4, 200.0, 200.0, 2e11),
    ]
    assert all(r["status"] == "ok" and r["reason"] == "" and not r["cached"] for r in rows)
    assert {r["element"] for r in rows} == {"C3D10"} and {r["cf_kind"] for r in rows} == {"eq22"}
    # the same four runs one by one, in a process with the runs' own thread
    # settings (a BLAS on more threads rounds differently)
    from stiffkit.sweep.runner import _child_env

    base = pl.read_link(link)[0]
    datas = []
    for r in rows:
        data = copy.deepcopy(base)
        data["geometry"]["size"][0] = r["geometry.size.0"]
        data["load"]["reference_point"][0] = r["load.reference_point.0"]
        data["material"]["E"] = r["material.E"]
        datas.append(data)
    (tmp_path / "runs.json").write_text(json.dumps(datas))
    proc = subprocess.run(
        [sys.executable, "-c", ONE_BY_ONE, str(tmp_path / "runs.json"), str(link), str(tmp_path / "solo")],
        capture_output=True,
        text=True,
        env=_child_env(),
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    for r, data, solo in zip(rows, datas, json.loads(proc.stdout)):
        assert not solo["cached"] and r["nodes"] == solo["nodes"]
        for i in range(6):  # number for number
            for j in range(6):
                assert r[f"k{i + 1}{j + 1}"] == solo["k"][i][j]
                assert r[f"k{i + 1}{j + 1}_ci"] == solo["ci"][i][j]
        assert r["sigma_m"] == solo["sigma"] and r["cf_max_error"] == solo["cf"]
        assert r["cache_key"] == solo["key"]
        # the estimate the run was placed by is of the right size
        assert 0.5 < pl_estimate(data, link) / r["nodes"] < 1.6
        assert r["memory_est_mb"] > 50 and r["memory_mb"] > 0 and r["wall_s"] > 0
    # physics: twice as long, 8 x the tip compliance in bending; E divides it
    k = {(r["geometry.size.0"], r["material.E"]): r["k22"] for r in rows}
    assert k[(200.0, 2e11)] / k[(100.0, 2e11)] == pytest.approx(8.0, rel=0.02)
    assert k[(100.0, 7e10)] / k[(100.0, 2e11)] == pytest.approx(2e11 / 7e10, rel=1e-6)


ONE_BY_ONE = """
import json, sys
from pathlib import Path
import numpy as np
from stiffkit.fea.config import parse_link
from stiffkit.fea.job import run_link
link = Path(sys.argv[2])
out = []
for data in json.loads(Path(sys.argv[1]).read_text()):
    r = run_link(parse_link(data, str(link), link.parent), cache_dir=sys.argv[3])
    out.append({"cached": r.cached, "nodes": r.mesh.n_nodes, "k": r.compliance.matrix.tolist(),
                "ci": r.compliance.ci.tolist(), "sigma": r.compliance.sigma, "key": r.key,
                "cf": float(np.nanmax(np.abs(r.closed_form_errors())))})
print(json.dumps(out))
"""


def pl_estimate(data, link):
    from stiffkit.sweep.runner import estimate_nodes

    return estimate_nodes(parse_link(data, str(link), link.parent))


def test_cli_csv_json_png_equal_the_python_table(two_worker_sweep, link, tmp_path):
    """-j 2 (a local cluster of two run slots), fresh cache: the CSV is the
    Python table, number for number; JSON and PNG are written."""
    out = tmp_path / "out"
    proc = stiffkit_cli(
        "sweep",
        link,
        "--vary",
        LENGTH,
        "--vary",
        MATERIAL,
        "-j",
        "2",
        "--cache",
        tmp_path / "c",
        "--csv",
        out / "s.csv",
        "--json",
        out / "s.json",
        "--png",
        out / "s.png",
        "--x",
        "material.E",
        "--y",
        "k22,k44,cf_max_error",
    )
    assert proc.returncode == 0, proc.stderr
    assert "4 of 4 runs ok" in proc.stdout
    assert re.search(r"\[#+\] 4/4 ok 4, failed 0", proc.stderr)  # the progress bar
    got = read_csv(out / "s.csv")
    assert list(got[0]) == tb.columns(VARIED) and len(got) == 4
    for g, r in zip(got, two_worker_sweep):
        assert int(g["run"]) == r["run"] and float(g["material.E"]) == r["material.E"]
        assert g["status"] == "ok" and int(g["nodes"]) == r["nodes"]
        for e in tb.ELEMENTS:
            assert float(g[e]) == r[e] and float(g[f"{e}_ci"]) == r[f"{e}_ci"]
        assert float(g["cf_max_error"]) == r["cf_max_error"] and g["cache_key"] == r["cache_key"]
    doc = json.loads((out / "s.json").read_text())
    assert doc["runs_ok"] == 4 and doc["runs_failed"] == 0 and doc["columns"] == tb.columns(VARIED)
    assert [d["k11"] for d in doc["runs"]] == [r["k11"] for r in two_worker_sweep]
    assert (out / "s.png").stat().st_size > 5000
    assert not [p for p in out.iterdir() if p.suffix == ".tmp"]


# ---------------------------------------------------------------- resume, Ctrl-C


@pytest.fixture
def counting_ccx(tmp_path):
    """A ccx that counts its solver launches (not `ccx -v`) in a file."""
    real = subprocess.run(["sh", "-c", "command -v ccx"], capture_output=True, text=True).stdout.strip()
    if not real:
        pytest.skip("ccx not on PATH")
    count = tmp_path / "ccx-launches"
    count.write_text("")
    wrapper = tmp_path / "ccx-counting"
    wrapper.write_text(f'#!/bin/sh\n[ "$1" = "-i" ] && echo "$2" >> "{count}"\nexec "{real}" "$@"\n')
    wrapper.chmod(0o755)
    mark = uuid.uuid4().hex
    env = dict(os.environ, STIFFKIT_CCX=str(wrapper), STIFFKIT_TEST_MARK=mark)
    return env, (lambda: len(count.read_text().split())), count, mark


def marked_processes(mark: str) -> list[str]:
    """Processes (ours or left behind) that carry the test's environment mark."""
    found = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            env = Path(f"/proc/{d}/environ").read_bytes()
            if f"STIFFKIT_TEST_MARK={mark}".encode() in env.split(b"\0"):
                found.append(Path(f"/proc/{d}/cmdline").read_bytes().replace(b"\0", b" ").decode()[:80])
        except OSError:
            continue
    return found


def test_interrupted_sweep_resumes_and_leaves_no_process(link, tmp_path, counting_ccx):
    env, launches, count, mark = counting_ccx
    cache = tmp_path / "cache"
    args = [
        sys.executable,
        "-m",
        "stiffkit",
        "sweep",
        str(link),
        "--vary",
        LENGTH,
        "--vary",
        MATERIAL,
        "-j",
        "1",
        "--cache",
        str(cache),
    ]
    # Ctrl-C at the terminal: SIGINT to the whole process group, after 2 runs
    proc = subprocess.Popen(
        args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    t0 = time.time()
    while len(list(cache.glob("[!.]*.npz"))) < 2 and time.time() - t0 < 120 and proc.poll() is None:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    time.sleep(0.5)
    assert marked_processes(mark) == []  # no worker, launcher, run or ccx left
    done = len(list(cache.glob("[!.]*.npz")))
    assert 2 <= done < 4
    assert not list(cache.glob(".*.tmp*"))  # no half-written entry of the stopped run
    assert not list(cache.glob("run-*"))  # the stopped run's folder is gone
    first = launches()
    assert first >= done
    # resume: only the runs not in the cache launch ccx
    count.write_text("")
    proc = subprocess.run(
        args + ["--csv", str(tmp_path / "s.csv")], env=env, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr
    assert launches() == 4 - done
    rows = read_csv(tmp_path / "s.csv")
    assert sum(r["cached"] == "True" for r in rows) == done and all(r["status"] == "ok" for r in rows)
    assert marked_processes(mark) == []


def test_half_written_entries_of_dead_runs_are_removed(tmp_path):
    """A run killed while writing its cache entry leaves a temporary; the next
    sweep removes it, but not one whose writer is still alive."""
    from stiffkit.fea.cache import remove_stale_temporaries

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".abc.npz.{dead.pid}-0123456789ab.tmp.npz"
    live = tmp_path / f".abd.npz.{os.getpid()}-0123456789ab.tmp.npz"
    entry = tmp_path / "abe.npz"
    for f in (stale, live, entry):
        f.write_bytes(b"x")
    assert remove_stale_temporaries(tmp_path) == 1
    assert not stale.exists() and live.exists() and entry.exists()


# ---------------------------------------------------------------- failures


def test_a_failed_run_is_reported_and_the_others_finish(tmp_path):
    import gmsh

    for name, add in (
        ("box", lambda o: o.addBox(0, -2.5, -2.5, 100, 5, 5)),
        ("sheet", lambda o: o.addRectangle(0, -2.5, 0, 100, 5)),
    ):
        gmsh.initialize(readConfigFiles=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            add(gmsh.model.occ)
            gmsh.model.occ.synchronize()
            gmsh.write(str(tmp_path / f"{name}.step"))
        finally:
            gmsh.finalize()
    p = tmp_path / "cad.toml"
    p.write_text(BEAM.format(geometry='step = "box.step"'))
    proc = stiffkit_cli(
        "sweep",
        p,
        "--vary",
        "geometry.step=box.step,sheet.step",
        "--vary",
        "mesh.order=1,2",
        "-j",
        "2",
        "--cache",
        tmp_path / "c",
        "--json",
        tmp_path / "s.json",
        "--csv",
        tmp_path / "s.csv",
        "--png",
        tmp_path / "s.png",
    )
    assert proc.returncode == 3, proc.stdout + proc.stderr  # partial failure
    assert "Traceback" not in proc.stderr
    doc = json.loads((tmp_path / "s.json").read_text())
    assert doc["runs_ok"] == 2 and doc["runs_failed"] == 2
    for r in doc["runs"]:
        if r["geometry.step"] == "sheet.step":
            assert r["status"] == "failed" and "not a solid" in r["reason"] and "\n" not in r["reason"]
            assert r["k11"] is None and r["nodes"] is None
        else:
            assert r["status"] == "ok" and r["nodes"] > 100 and r["reason"] == ""
    assert "FAILED" in proc.stdout and "2 of 4 runs ok, 2 failed" in proc.stdout
    assert (tmp_path / "s.png").is_file()
    # a worker that does not see the CAD file gets it with the task
    from stiffkit.sweep import runner

    job = pl.make_plan(p, [pl.parse_vary("mesh.order=1")]).runs[0].job
    cad = Path(job.geometry["step"]).read_bytes()
    job.geometry["step"] = str(tmp_path / "elsewhere" / "box.step")
    try:
        out = runner.run_task({"job": job, "cache_dir": str(tmp_path / "c2"), "cad": cad})
    finally:
        runner.close_launchers()
    assert out["status"] == "ok", out
    assert out["cache_key"] == doc["runs"][0]["cache_key"]  # the key is the file's content


def test_runs_that_differ_only_in_the_fit_share_one_fea(link, tmp_path, counting_ccx):
    env, launches, _count, _mark = counting_ccx
    proc = stiffkit_cli(
        "sweep",
        link,
        "--vary",
        "fit.method=lin,exact,svd+-",
        "-j",
        "2",
        "--cache",
        tmp_path / "c",
        "--json",
        tmp_path / "s.json",
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    assert launches() == 1
    runs = json.loads((tmp_path / "s.json").read_text())["runs"]
    assert sorted(r["cached"] for r in runs) == [False, True, True]
    assert len({r["cache_key"] for r in runs}) == 1
    assert len({tuple(r[e] for e in tb.ELEMENTS) for r in runs}) == 3  # three fits


def test_scheduler_where_nothing_listens(link, tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # closed again: nothing listens there
    t0 = time.time()
    proc = stiffkit_cli(
        "sweep", link, "--vary", "mesh.size=5,4", "--scheduler", f"tcp://127.0.0.1:{port}", "--cache", tmp_path / "c"
    )
    assert time.time() - t0 < 15
    assert proc.returncode == 2
    line = one_error_line(proc.stderr)
    assert f"127.0.0.1:{port}" in line and "no Dask scheduler" in line
    assert not list((tmp_path / "c").glob("*.npz"))
    proc = stiffkit_cli(
        "convergence",
        link,
        "--orders",
        "2",
        "--sizes",
        "5",
        "--scheduler",
        f"127.0.0.1:{port}",
        "--png",
        "",
        cwd=tmp_path,  # its default cache folder is relative
    )
    assert proc.returncode == 2 and "no Dask scheduler" in one_error_line(proc.stderr)


@pytest.mark.parametrize(
    "argv,needles",
    [
        (["--vary", "mesh.sise=3"], ["mesh.sise", "unknown key"]),
        (["--vary", "meshing.size=3"], ["meshing", "unknown section"]),
        (["--vary", "mesh.size="], ["mesh.size", "no values"]),
        (["--vary", "mesh.size=5,,3"], ["mesh.size", "empty value"]),
        (["--vary", "mesh.size=5,three"], ["mesh.size=three", "number"]),
        (["--vary", "mesh.order=1,2.5"], ["mesh.order=2.5", "integer"]),
        (["--vary", "mesh.size=5,-2"], ["mesh.size=-2", "positive"]),
        (["--vary", "mesh.size=0"], ["mesh.size=0", "positive"]),
        (["--vary", "material.E=2e11,nan"], ["material.E=nan", "number"]),
        (["--vary", "material.nu=0.3,0.6"], ["material.nu=0.6", "nu"]),
        (["--vary", "mesh.structured=yes"], ["mesh.structured=yes", "true or false"]),
        (["--vary", "mesh.mesher=gmsh,netgen"], ["mesh.mesher=netgen", "choose one of"]),
        (["--vary", "geometry.size=[100,5]"], ["geometry.size=[100,5]", "three numbers"]),
        (["--vary", "geometry.size.3=1"], ["geometry.size.3", "three elements"]),
        (["--vary", "geometry.length=100"], ["geometry.length", "no effect"]),
        (["--vary", "geometry.wall=1"], ["geometry.wall", "tube"]),
        (["--vary", "field.size=3"], ["field.size", "no effect"]),
        (["--vary", "mesh.size=5,4", "--vary", "mesh.size=3"], ["mesh.size", "varied already"]),
        (["--vary", "mesh.size=5,4 material.E=2e11"], ["same number of values"]),
        (["--vary", "mesh.size=5,4", "--vary", "material.E=1e11,2e11,3e11", "--zip"], ["--zip", "same number"]),
        (["--vary", "mesh.size=5,4", "-j", "0"], ["-j 0", ">= 1"]),
        (["--vary", "mesh.size=5,4", "--memory=-1G"], ["--memory", "-1G"]),
        (["--vary", "mesh.size=5,4", "--memory", "0"], ["--memory", "positive"]),
        (["--vary", "mesh.size=5,4", "--memory", "lots"], ["--memory", "lots"]),
        (["--vary", "mesh.size=5,4", "--scheduler", "nowhere"], ["--scheduler", "nowhere"]),
        (["--vary", "mesh.size=5,4", "--x", "material.E", "--png", "p.png"], ["--x material.E", "varied key"]),
        (["--vary", "mesh.size=5,4", "--y", "k77", "--png", "p.png"], ["--y k77", "numeric result column"]),
    ],
)
def test_bad_input_is_one_line_and_nothing_runs(link, tmp_path, capsys, argv, needles, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc = cli_main(["sweep", str(link), "--cache", str(tmp_path / "c"), *argv])
    err = capsys.readouterr().err
    assert rc == 2, err
    line = one_error_line(err)
    for n in needles:
        assert n in line, line
    assert not (tmp_path / "c").exists()  # nothing ran


def test_memory_budget_keeps_two_runs_apart(link, tmp_path):
    """Each 100 mm run is estimated at ~105 MB: with 150 MB to hand out, the
    two run slots never run two at once; with 1 GB they may."""
    res = stiffkit.sweep.run_sweep(link, ["material.E=1e11,2e11,3e11"], jobs=2, memory="150M", cache=tmp_path / "c")
    rows = sorted(res.rows, key=lambda r: r["start_s"])
    assert all(r["status"] == "ok" and 100 < r["memory_est_mb"] < 150 for r in rows)
    for a, b in zip(rows, rows[1:]):
        assert b["start_s"] >= a["end_s"] - 0.05, (a["start_s"], a["end_s"], b["start_s"])


# ---------------------------------------------------------------- plan, API, packaging


def test_plan_product_zip_and_keys_that_move_together(link):
    plan = pl.make_plan(link, [pl.parse_vary(LENGTH), pl.parse_vary("mesh.order=1,2")])
    assert [r.overrides for r in plan.runs] == [
        {"geometry.size.0": 100.0, "load.reference_point.0": 100.0, "mesh.order": 1},
        {"geometry.size.0": 100.0, "load.reference_point.0": 100.0, "mesh.order": 2},
        {"geometry.size.0": 200.0, "load.reference_point.0": 200.0, "mesh.order": 1},
        {"geometry.size.0": 200.0, "load.reference_point.0": 200.0, "mesh.order": 2},
    ]
    assert plan.runs[3].job.geometry["size"] == [200.0, 5.0, 5.0]
    assert plan.runs[3].job.reference_point == pytest.approx([0.2, 0.0, 0.0])
    z = pl.make_plan(link, [pl.parse_vary("mesh.size=5,4"), pl.parse_vary("fit.method=lin,exact")], zipped=True)
    assert [(r.job.size, r.job.method) for r in z.runs] == [(5.0, "lin"), (4.0, "exact")]
    whole = pl.make_plan(link, [pl.parse_vary("geometry.size=[100,5,5],[100,6,4]")])
    assert [r.job.geometry["size"] for r in whole.runs] == [[100.0, 5.0, 5.0], [100.0, 6.0, 4.0]]
    # the derived wall of a tube
    tube = {
        "geometry": {"shape": "tube", "length": 200.0, "outer_diameter": 20.0, "inner_diameter": 16.0, "units": "mm"},
        "material": {"E": 7e10, "nu": 0.33},
        "support": {"plane": "x-min"},
        "load": {"plane": "x-max", "reference_point": [200.0, 0.0, 0.0]},
        "mesh": {"size": 4.0},
    }
    t = pl.make_plan(tube, pl.axes_from_python({"geometry.wall": [1, 2.5]}))
    assert [r.job.geometry["inner_diameter"] for r in t.runs] == [18.0, 15.0]
    with pytest.raises(pl.PlanError, match="geometry.wall=10"):
        pl.make_plan(tube, pl.axes_from_python({"geometry.wall": [10]}))
    # Python values are typed like the command line's
    with pytest.raises(pl.PlanError, match=r"mesh.order=2.0.*integer"):
        pl.axes_from_python({"mesh.order": [1, 2.0]})
    with pytest.raises(pl.PlanError, match="material.E=True"):
        pl.axes_from_python({"material.E": [True]})


def test_schema_matches_parse_link():
    """Every key parse_link reads is in the sweep's schema, and no other."""
    src = (Path(__file__).resolve().parents[1] / "fea" / "config.py").read_text()
    body = src[src.index("def parse_link") : src.index("def load_link")]
    var = {
        "g": "geometry",
        "m": "material",
        "ld": "load",
        "fl": "field",
        "me": "mesh",
        "fit": "fit",
        "so": "solver",
        "ap": "approximation",
        'data["support"]': "support",
    }
    read = {(sec, key) for key, sec in re.findall(r'_get\([^,]+, "(\w+)", "(\w+)"', body)}
    read |= {(var[v], key) for v, key in re.findall(r'\b(\w+)\.get\("(\w+)"', body) if v in var}
    read.add(("geometry", "shape"))  # read as g["shape"]
    # face selectors (plane, face, cylinder, ...) and their tolerance are read by
    # fea/selectors.py:parse_set for the sections parse_link hands to _selector_set;
    # the sweep's schema may hold the ones it can vary
    from stiffkit.fea.selectors import KINDS

    with_selectors = set(re.findall(r'_selector_set\([^,]+, "(\w+)"', body))
    assert with_selectors == {"support", "load", "field"}
    read |= {(s, k) for s, keys in pl.SCHEMA.items() if s in with_selectors for k in keys if k in (*KINDS, "tolerance")}
    schema = {(s, k) for s, keys in pl.SCHEMA.items() for k in keys}
    assert read == schema


def test_import_stiffkit_does_not_import_dask():
    code = (
        "import sys, stiffkit; f = stiffkit.sweep; assert callable(f); "
        "import stiffkit.sweep.plan, stiffkit.sweep.table; "
        "bad = [m for m in ('dask', 'distributed', 'tqdm') if m in sys.modules]; "
        "assert not bad, bad; print('ok')"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "ok" in proc.stdout, proc.stderr


def test_help_teaches():
    proc = stiffkit_cli("sweep", "--help")
    assert proc.returncode == 0
    for needle in (
        "examples:",
        "exit status",
        "--scheduler",
        "cache",
        "geometry.size.0",
        "3  some runs failed",
        "stiffkit.sweep(",
    ):
        assert needle in proc.stdout, needle
    proc = stiffkit_cli("--help")
    assert "sweep" in proc.stdout


def test_dry_run_lists_runs_and_estimates(link, tmp_path):
    proc = stiffkit_cli(
        "sweep", link, "--vary", MATERIAL, "--vary", "mesh.size=5,2.5", "--dry-run", "--cache", tmp_path / "c"
    )
    assert proc.returncode == 0, proc.stderr
    assert "4 runs" in proc.stdout and "nodes" in proc.stdout and "MB" in proc.stdout
    assert not (tmp_path / "c").exists()
