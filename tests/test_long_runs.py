"""Long runs (issue 17, items 11 and 12): compensation in batches (the same
numbers, an interrupt acts between batches), and the sweep's guards (number
of runs, --png suffix, an unreadable cache entry said, no unclosed file, no
run folder left when the solver is missing)."""

from __future__ import annotations

import _thread
import os
import signal
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from _links import small_beam

from stiffkit.cli import main
from stiffkit.robot import compensate as C
from stiffkit.sweep.plan import MAX_RUNS

BEAM = small_beam(10.0)


@pytest.fixture(scope="module")
def da(tmp_path_factory):
    root = tmp_path_factory.mktemp("long")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["synth", "dualarm", "--out", str(root / "da"), "--configs", "4", "--targets", "150"]) == 0
    return root / "da"


@pytest.fixture
def beam(tmp_path):
    p = tmp_path / "beam.toml"
    p.write_text(BEAM)
    return p


def stiffkit(*args, env=None, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "stiffkit", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
        env=dict(os.environ, OMP_NUM_THREADS="1", **(env or {})),
        cwd=cwd,
    )


# ---------------------------------------------------------------- 17.11


def test_batches_give_the_numbers_of_one_call(da, monkeypatch):
    """300 rows in batches of 7 (43 core calls) equal the rows in one call,
    bit for bit: a row's solve does not depend on the others."""
    cm = C.load_compensation_model(da / "truth.toml")
    tg = C.read_targets(da / "targets.csv", cm)
    calls = []
    real = C.core.compensate

    def counting(*a, **k):
        calls.append(len(a[4]))
        return real(*a, **k)

    monkeypatch.setattr(C.core, "compensate", counting)
    monkeypatch.setattr(C, "BATCH", 10**6)
    one = cm.compensate(tg.Q, tg.frames, tg.wrench)
    n_one = len(calls)
    monkeypatch.setattr(C, "BATCH", 7)
    calls.clear()
    many = cm.compensate(tg.Q, tg.frames, tg.wrench)
    assert tg.Q.shape[0] == 300 and n_one == 1
    assert len(calls) == 43 and max(calls) == 7
    np.testing.assert_array_equal(one.q, many.q)
    np.testing.assert_array_equal(one.resp, many.resp)
    assert one.converged.all() and many.converged.all()
    assert np.abs(many.q - tg.Q).max() > 1e-3  # something was compensated


def test_interrupt_acts_between_batches(da, monkeypatch):
    """Ctrl-C (here: interrupt_main, which is how Python sees SIGINT) during
    a long compensation stops it at the end of the batch in flight."""
    cm = C.load_compensation_model(da / "truth.toml")
    tg = C.read_targets(da / "targets.csv", cm)
    Q = np.repeat(tg.Q, 60, axis=0)  # 18,000 rows: tens of seconds
    frames = [f for f in tg.frames for _ in range(60)]
    t0 = time.perf_counter()
    cm.compensate(Q[:256], frames[:256])
    per_batch = (time.perf_counter() - t0) * C.BATCH / 256
    fired = {}

    def fire():
        fired["t"] = time.perf_counter()
        _thread.interrupt_main()

    # Python's own SIGINT handler (an earlier test or CLI run may have left
    # another one installed), and the interrupt well inside the run
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    total = per_batch * len(Q) / C.BATCH
    timer = threading.Timer(min(1.0, total / 4), fire)
    try:
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            cm.compensate(Q, frames)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, old)
    late = time.perf_counter() - fired["t"]
    assert late < max(1.0, 3 * per_batch), (late, per_batch)


# ---------------------------------------------------------------- 17.12


def test_sweep_run_guard_includes_dry_run(beam, capsys):
    many = ",".join(str(1 + i / 1000) for i in range(MAX_RUNS // 100 + 1))
    for extra in (["--dry-run"], []):
        rc = main(
            [
                "sweep",
                str(beam),
                "--vary",
                f"mesh.size={many}",
                "--vary",
                "material.nu=" + ",".join(f"0.{10 + i}" for i in range(100)),
                *extra,
            ]
        )
        err = capsys.readouterr().err
        assert rc == 2
        assert f"{(MAX_RUNS // 100 + 1) * 100} runs" in err and f"at most {MAX_RUNS}" in err, err


def test_sweep_png_needs_a_figure_name(beam, tmp_path, capsys):
    rc = main(["sweep", str(beam), "--vary", "mesh.size=10", "--png", str(tmp_path / "plot.txt")])
    err = capsys.readouterr().err
    assert rc == 2 and f"{tmp_path / 'plot.txt'}" in err and ".png" in err
    assert not (tmp_path / "plot.txt").exists()


def test_sweep_says_it_recomputes_an_unreadable_entry_and_closes_its_files(beam, tmp_path):
    cache = tmp_path / "cache"
    p = stiffkit("sweep", beam, "--vary", "mesh.size=10,9", "-j", "1", "--cache", cache, "--quiet")
    assert p.returncode == 0, p.stderr
    assert "ResourceWarning" not in p.stderr and "unclosed" not in p.stderr, p.stderr
    entries = sorted(cache.glob("*.npz"))
    assert len(entries) == 2
    entries[0].write_bytes(entries[0].read_bytes()[:100])  # a truncated entry
    p = stiffkit(
        "sweep", beam, "--vary", "mesh.size=10,9", "-j", "1", "--cache", cache, "--quiet", "--csv", tmp_path / "s.csv"
    )
    assert p.returncode == 0, p.stderr
    warns = [ln for ln in p.stderr.splitlines() if ": warning: " in ln]
    assert len(warns) == 1 and "unreadable cache entry" in warns[0] and str(entries[0]) in warns[0], p.stderr
    assert "ResourceWarning" not in p.stderr
    rows = (tmp_path / "s.csv").read_text().splitlines()
    assert len(rows) == 3 and all(",ok," in r for r in rows[1:])
    assert not list(cache.glob("run-*"))


def test_sweep_beside_another_cluster_says_nothing(beam, tmp_path):
    """Another Dask cluster on the machine (here: a socket holding Dask's
    default port 8787) does not make a sweep warn or leak a socket."""
    import socket

    held = socket.socket()
    held.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        held.bind(("0.0.0.0", 8787))
        held.listen()
    except OSError:
        pass  # already taken by something else: the same condition
    try:
        p = stiffkit("sweep", beam, "--vary", "mesh.size=10", "-j", "1", "--cache", tmp_path / "c", "--quiet")
    finally:
        held.close()
    assert p.returncode == 0, p.stderr
    assert "warning" not in p.stderr and "unclosed" not in p.stderr, p.stderr


def test_no_run_folder_left_when_the_solver_is_missing(beam, tmp_path):
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {"STIFFKIT_CCX": "no-such-ccx", "TMPDIR": str(tmp)}
    p = stiffkit("link", beam, "--no-cache", "--quiet", env=env)
    assert p.returncode == 2 and "ccx" in p.stderr
    assert list(tmp.iterdir()) == []
    cache = tmp_path / "cache"
    p = stiffkit("sweep", beam, "--vary", "mesh.size=10", "-j", "1", "--cache", cache, "--quiet", env=env)
    assert p.returncode == 3 and "ccx" in p.stdout + p.stderr
    assert not list(cache.glob("run-*")) and not list(Path(tmp).glob("run-*"))
