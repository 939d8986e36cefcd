"""Interrupted and concurrent runs: Ctrl-C (SIGINT to the process group, as
a terminal sends it) and SIGTERM while ccx runs leave no process behind, no
run folder and no partial output, and a rerun finishes; two runs writing
the same output files leave valid files; a reader that closes the pipe
early ends the command quietly.

ccx is replaced by a script that starts a grandchild and sleeps, so the
runs are stopped while "ccx" is surely running; the meshes are tiny.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _links import small_beam

BEAM = small_beam(5.0)

FAKE_CCX = """#!/bin/sh
# a ccx that never finishes: a grandchild in its group, both pids recorded
sleep 300 &
echo "$$ $!" > "$STIFFKIT_TEST_PIDS.tmp"
mv "$STIFFKIT_TEST_PIDS.tmp" "$STIFFKIT_TEST_PIDS"
wait
"""


def _alive(pid: int) -> bool:
    """True for a process that exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("State:"):
                    return "Z" not in line.split()[1]
    except FileNotFoundError:
        return False
    return True


@pytest.fixture
def fake_ccx(tmp_path):
    exe = tmp_path / "fake-ccx"
    exe.write_text(FAKE_CCX)
    exe.chmod(0o755)
    return exe


def _start(args, cwd, env=None):
    return subprocess.Popen(
        [sys.executable, "-m", "stiffkit", *map(str, args)],
        cwd=cwd,
        env={**os.environ, **(env or {})},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own group: the test sends Ctrl-C to it as a terminal would
    )


def _wait_for(path: Path, proc, seconds: float = 120.0) -> list[int]:
    t0 = time.time()
    while not path.exists():
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"the run ended before ccx started (exit {proc.returncode}): {err}")
        if time.time() - t0 > seconds:
            proc.kill()
            pytest.fail("ccx did not start")
        time.sleep(0.05)
    return [int(x) for x in path.read_text().split()]


def _leftovers(folder: Path) -> list[str]:
    return sorted(
        str(p.relative_to(folder))
        for p in folder.rglob("*")
        if p.name.startswith("run-") or ".tmp" in p.name or p.suffix in (".inp", ".frd", ".sti")
    )


@pytest.mark.parametrize(
    "sig, status, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")]
)
def test_link_stopped_while_ccx_runs_leaves_nothing_and_reruns(tmp_path, fake_ccx, sig, status, word):
    (tmp_path / "beam.toml").write_text(BEAM)
    pids = tmp_path / "pids"
    out = tmp_path / "out"
    args = ["link", "beam.toml", "--json", out / "beam.json", "--vtu", out / "beam.vtu", "--cache", "cache"]
    proc = _start(args, tmp_path, {"STIFFKIT_CCX": str(fake_ccx), "STIFFKIT_TEST_PIDS": str(pids)})
    try:
        ccx, grandchild = _wait_for(pids, proc)
        os.killpg(proc.pid, sig)
        _stdout, err = proc.communicate(timeout=60)
        deadline = time.time() + 10
        while (_alive(ccx) or _alive(grandchild)) and time.time() < deadline:
            time.sleep(0.05)
        alive = _alive(ccx) or _alive(grandchild)
    finally:
        _reap(proc, pids)
    assert proc.returncode == status, err
    assert "Traceback" not in err and err.strip().splitlines()[-1] == f"stiffkit link: {word}", err
    assert not alive, "ccx or its child survived"
    assert not out.exists() or not any(out.iterdir()), "partial output"
    assert _leftovers(tmp_path) == [], _leftovers(tmp_path)
    # the rerun (real ccx) finishes and writes valid files
    done = subprocess.run(
        [sys.executable, "-m", "stiffkit", *map(str, args), "--quiet"], cwd=tmp_path, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    data = json.loads((out / "beam.json").read_text())
    assert np.array(data["compliance"]).shape == (6, 6)
    assert _leftovers(tmp_path) == []


def _reap(proc, pids: Path) -> None:
    """Whatever the outcome, no process of this test stays: the run's group
    and the group of the last fake ccx (each runs in a session of its own)."""
    groups = [proc.pid] + ([int(pids.read_text().split()[0])] if pids.exists() else [])
    for g in groups:
        try:
            os.killpg(g, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
    try:
        proc.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        pass


def test_convergence_interrupted_leaves_nothing_and_resumes(tmp_path, fake_ccx):
    (tmp_path / "beam.toml").write_text(BEAM)
    pids = tmp_path / "pids"
    args = ["convergence", "beam.toml", "--orders", "1", "--sizes", "5,4", "-j", "1", "--quiet"]
    args += ["--json", "conv.json", "--png", "conv.png", "--cache", "cache"]
    proc = _start(args, tmp_path, {"STIFFKIT_CCX": str(fake_ccx), "STIFFKIT_TEST_PIDS": str(pids)})
    try:
        ccx, grandchild = _wait_for(pids, proc)
        os.killpg(proc.pid, signal.SIGINT)
        try:
            _stdout, err = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            pytest.fail("convergence goes on after Ctrl-C")
        deadline = time.time() + 10
        while (_alive(ccx) or _alive(grandchild)) and time.time() < deadline:
            time.sleep(0.05)
        assert not _alive(ccx) and not _alive(grandchild), "ccx or its child survived"
        assert proc.returncode == 130 and "Traceback" not in err, err
        assert not (tmp_path / "conv.json").exists() and not (tmp_path / "conv.png").exists()
        assert _leftovers(tmp_path) == []
    finally:
        _reap(proc, pids)
    done = subprocess.run([sys.executable, "-m", "stiffkit", *args], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert len(json.loads((tmp_path / "conv.json").read_text())["runs"]) == 2


def test_two_runs_writing_the_same_outputs_leave_valid_files(tmp_path):
    """Both runs solve (no cache entry yet) and write the same cache entry,
    JSON, VTU and PNG at about the same time: every file is one run's
    whole file, and no temporary is left."""
    import meshio

    (tmp_path / "beam.toml").write_text(BEAM)
    args = ["link", "beam.toml", "--json", "o.json", "--vtu", "o.vtu", "--png", "o.png", "--cache", "cache", "--quiet"]
    procs = [_start(args, tmp_path) for _ in range(2)]
    for p in procs:
        _out, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    assert np.array(json.loads((tmp_path / "o.json").read_text())["compliance"]).shape == (6, 6)
    m = meshio.read(tmp_path / "o.vtu")
    assert m.points.shape[1] == 3 and "u_Fx" in m.point_data
    assert (tmp_path / "o.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(list((tmp_path / "cache").glob("*.npz"))) == 1
    assert _leftovers(tmp_path) == []
    again = subprocess.run(
        [sys.executable, "-m", "stiffkit", *args], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert again.returncode == 0 and "warning" not in again.stderr, again.stderr  # the entry is whole


def test_output_piped_to_head_ends_quietly(tmp_path):
    """`stiffkit robot orthoglide --map 5 --json o.json | head -1`: no
    'Broken pipe' message, exit 0, and the JSON is still written."""
    p = subprocess.Popen(
        [sys.executable, "-m", "stiffkit", "robot", "orthoglide", "--map", "5", "--json", "o.json"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    p.stdout.readline()
    p.stdout.close()  # the reader goes away, as head does
    err = p.stderr.read().decode()
    p.wait(timeout=120)
    assert p.returncode == 0 and "Broken pipe" not in err and "Traceback" not in err, err
    assert json.loads((tmp_path / "o.json").read_text())["rank"] == 6
