"""The output-path rules (issue 17, items 1, 2, 3, 10) as one table over
every command that writes: each output option given

- a character device that is full (``/dev/full``, or a node of the same
  device made here when running as root, so that a regression cannot
  replace the machine's own): exit 2, "no space left", the device stays;
- a FIFO that no process reads: exit 2, named, the FIFO stays;
- one of the command's inputs (the model TOML, the URDF it names, the
  measurements, LINK.toml, ...): exit 2 before any work, the input unchanged;
- a path under a regular file (a folder that cannot be created) and, when
  not root, a read-only folder: exit 2 before any work;
- (folders of outputs) existing user data: refused, named.

Every message names the user's path and never a temporary. Commands run
in-process (stiffkit.cli.main); the FEA commands use a tiny mesh and one
shared cache, so only their first run meshes and solves.
"""

from __future__ import annotations

import json
import os
import stat
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from _links import small_beam

import stiffkit as sk
from stiffkit.cli import main
from stiffkit.field.synthetic import cantilever_fields, square_grid

ROOT = os.geteuid() == 0

BEAM = small_beam(10.0)


def run(argv: list, capsys: pytest.CaptureFixture) -> tuple[int, str, str]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """A deflection model with data (kr), an absolute one (da), six fields,
    a tiny LINK.toml, an Orthoglide link file; a regular file 'afile'."""
    root = tmp_path_factory.mktemp("outputs")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["synth", "kr270", "--out", str(root / "kr"), "--configs", "4", "--seed", "3"]) == 0
        assert main(["synth", "dualarm", "--out", str(root / "da"), "--configs", "12", "--targets", "4"]) == 0
    k = sk.cantilever_compliance(1.0, 2e11, 0.266, sk.section_properties("square", [0.01], 0.266))
    pts = square_grid(0.01, 0.002, x=1.0)
    fields = cantilever_fields(k, np.diag([100.0, 0.1, 0.1, 0.1, 0.1, 0.1]), pts, [1.0, 0, 0], sigma=1e-9, rng=2)
    fd = root / "field"
    fd.mkdir()
    np.savetxt(fd / "nodes.csv", pts, delimiter=",", header="x,y,z", comments="")
    for j, f in enumerate(fields):
        np.savetxt(fd / f"d{j}.csv", f, delimiter=",", header="ux,uy,uz", comments="")
    (root / "beam.toml").write_text(BEAM)
    (root / "afile").write_text("a regular file\n")
    return root


def _field_args(ws: Path) -> list:
    fd = ws / "field"
    return ["field", fd / "nodes.csv", *[fd / f"d{j}.csv" for j in range(6)], "--reference", "1,0,0"]


def _cache(ws: Path) -> list:
    return ["--cache", ws / "cache"]


Argv = Callable[[Path], list]


@dataclass
class Out:
    """An output option: its file's suffix, the command without it, the
    inputs it may not overwrite."""

    id: str
    option: str
    suffix: str
    argv: Argv
    inputs: Callable[[Path], list[Path]]
    folder: bool = False  # the option names a folder (--plots, synth --out)


KR = lambda w: [w / "kr" / "model.toml", w / "kr" / "measurements.csv"]  # noqa: E731
KR_IN = lambda w: [w / "kr" / "model.toml", w / "kr" / "robot.urdf", w / "kr" / "measurements.csv"]  # noqa: E731
DA = lambda w: [w / "da" / "model.toml", w / "da" / "measurements.csv"]  # noqa: E731
DA_IN = lambda w: [w / "da" / "model.toml", w / "da" / "robot.urdf", w / "da" / "measurements.csv"]  # noqa: E731
COMP_IN = lambda w: [w / "da" / "truth.toml", w / "da" / "robot.urdf", w / "da" / "targets.csv"]  # noqa: E731
PLAN = lambda w: [w / "da" / "model.toml", "--select", "6", "--candidates", "20", "--task", w / "da" / "targets.csv"]  # noqa: E731
PLAN_IN = lambda w: [w / "da" / "model.toml", w / "da" / "robot.urdf", w / "da" / "targets.csv"]  # noqa: E731
LINK_IN = lambda w: [w / "beam.toml"]  # noqa: E731
FIELD_IN = lambda w: [w / "field" / "nodes.csv", w / "field" / "d3.csv"]  # noqa: E731
VALUES_IN = lambda w: [w / "kr" / "truth.toml", w / "kr" / "robot.urdf"]  # noqa: E731

OUTPUTS = [
    Out("link-json", "--json", ".json", lambda w: ["link", w / "beam.toml", "--quiet", *_cache(w)], LINK_IN),
    Out("link-vtu", "--vtu", ".vtu", lambda w: ["link", w / "beam.toml", "--quiet", *_cache(w)], LINK_IN),
    Out("link-png", "--png", ".png", lambda w: ["link", w / "beam.toml", "--quiet", *_cache(w)], LINK_IN),
    Out("fit-json", "--json", ".json", lambda w: ["fit", *KR(w), "--quiet"], KR_IN),
    Out("fit-write-model", "--write-model", ".toml", lambda w: ["fit", *KR(w), "--quiet"], KR_IN),
    Out("fit-plots", "--plots", "", lambda w: ["fit", *KR(w), "--quiet"], KR_IN, folder=True),
    Out("fit-abs-write-urdf", "--write-urdf", ".urdf", lambda w: ["fit", *DA(w), "--quiet"], DA_IN),
    Out("fit-abs-write-model", "--write-model", ".toml", lambda w: ["fit", *DA(w), "--quiet"], DA_IN),
    Out("diagnose-json", "--json", ".json", lambda w: ["diagnose", *KR(w), "--top", "2"], KR_IN),
    Out("diagnose-plots", "--plots", "", lambda w: ["diagnose", *KR(w), "--top", "2"], KR_IN, folder=True),
    Out(
        "compensate-out",
        "--out",
        ".csv",
        lambda w: ["compensate", w / "da" / "truth.toml", w / "da" / "targets.csv"],
        COMP_IN,
    ),
    Out(
        "stiffness-json",
        "--json",
        ".json",
        lambda w: ["stiffness", w / "kr" / "truth.toml", "--posture", "0,0.5,-0.5,0,0.7,0"],
        VALUES_IN,
    ),
    Out(
        "stiffness-npz",
        "--npz",
        ".npz",
        lambda w: ["stiffness", w / "kr" / "truth.toml", "--posture", "0,0.5,-0.5,0,0.7,0"],
        VALUES_IN,
    ),
    Out(
        "stiffness-plot",
        "--plot",
        ".png",
        lambda w: ["stiffness", w / "kr" / "truth.toml", "--posture", "0,0.5,-0.5,0,0.7,0"],
        VALUES_IN,
    ),
    Out("plan-out", "--out", ".csv", lambda w: ["plan", *PLAN(w)], PLAN_IN),
    Out("plan-json", "--json", ".json", lambda w: ["plan", *PLAN(w)], PLAN_IN),
    Out("plan-png", "--png", ".png", lambda w: ["plan", *PLAN(w)], PLAN_IN),
    Out("robot-orthoglide-json", "--json", ".json", lambda w: ["robot", "orthoglide"], lambda w: []),
    Out("field-json", "--json", ".json", _field_args, FIELD_IN),
    Out(
        "sweep-csv",
        "--csv",
        ".csv",
        lambda w: ["sweep", w / "beam.toml", "--vary", "mesh.size=10", "-j", "1", "--quiet", *_cache(w)],
        LINK_IN,
    ),
    Out(
        "sweep-json",
        "--json",
        ".json",
        lambda w: ["sweep", w / "beam.toml", "--vary", "mesh.size=10", "-j", "1", "--quiet", *_cache(w)],
        LINK_IN,
    ),
    Out(
        "convergence-json",
        "--json",
        ".json",
        lambda w: [
            "convergence",
            w / "beam.toml",
            "--orders",
            "1",
            "--sizes",
            "10",
            "--quiet",
            "--png",
            "",
            *_cache(w),
        ],
        LINK_IN,
    ),
    Out(
        "synth-out",
        "--out",
        "",
        lambda w: ["synth", w / "kr" / "truth.toml", "--configs", "2"],
        lambda w: [w / "kr" / "truth.toml"],
        folder=True,
    ),
]
#: outputs written after the work: a device or FIFO there costs a run (the FEA ones: one each)
AFTER_WORK = [o for o in OUTPUTS if not o.folder and o.id not in ("sweep-json", "link-vtu", "link-png")]
IDS = [o.id for o in OUTPUTS]
#: options whose file name must carry a suffix (checked first)
SUFFIX_CHECKED = ("--vtu", "--png", "--plot", "--write-model", "--write-urdf")


def _line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ": error: " in ln]
    assert len(lines) == 1, err
    assert ".tmp" not in lines[0] and "stiffkit-probe" not in lines[0], lines[0]
    return lines[0]


def full_device(tmp: Path, suffix: str) -> Path:
    """A character device that is always full, under the row's suffix."""
    if ROOT:
        p = tmp / f"full{suffix}"
        try:
            os.mknod(p, stat.S_IFCHR | 0o666, os.makedev(1, 7))
            return p
        except OSError:
            pass
    if not suffix:
        return Path("/dev/full")
    pytest.skip("a full device with a suffix needs mknod (root)")


@pytest.mark.parametrize("o", AFTER_WORK, ids=[o.id for o in AFTER_WORK])
def test_full_device_is_written_in_place_and_its_error_named(o, ws, tmp_path, capsys):
    dev = full_device(tmp_path, o.suffix)
    rc, out, err = run([*o.argv(ws), o.option, dev], capsys)
    assert rc == 2, (out, err)
    line = _line(err)
    assert f"{dev}: no space left on the device" in line
    assert f"wrote {dev}" not in out
    assert stat.S_ISCHR(os.stat(dev).st_mode)  # still the device, not a file holding the output
    assert not list(tmp_path.glob(".*tmp*"))


@pytest.mark.parametrize("o", AFTER_WORK, ids=[o.id for o in AFTER_WORK])
def test_fifo_without_reader_is_refused_and_stays(o, ws, tmp_path, capsys):
    fifo = tmp_path / f"fifo{o.suffix}"
    os.mkfifo(fifo)
    rc, out, err = run([*o.argv(ws), o.option, fifo], capsys)
    assert rc == 2, (out, err)
    line = _line(err)
    assert str(fifo) in line and "FIFO" in line
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_fifo_with_a_reader_gets_the_whole_file(ws, tmp_path, capsys):
    """A FIFO that is read gets the content, the same bytes as a file."""
    import threading

    fifo = tmp_path / "f.json"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo, "rb").read()))  # noqa: SIM115
    reader.start()
    args = _field_args(ws)
    rc, out, err = run([*args, "--json", fifo], capsys)
    reader.join(30)
    assert rc == 0, err
    rc, out, err = run([*args, "--json", tmp_path / "plain.json"], capsys)
    assert rc == 0 and got and got[0] == (tmp_path / "plain.json").read_bytes()
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


@pytest.mark.parametrize("o", OUTPUTS, ids=IDS)
def test_an_input_is_never_an_output(o, ws, capsys):
    for src in o.inputs(ws):
        if o.folder:
            if src.is_dir():
                continue
            target = src if o.option == "--plots" else src.parent
        else:
            target = src
        before = src.read_bytes()
        rc, out, err = run([*o.argv(ws), o.option, target], capsys)
        assert rc == 2, (src, out, err)
        line = _line(err)
        assert str(target) in line, line
        if o.folder:
            assert "a file, not a folder" in line or "truth model" in line, line
        elif target.suffix == o.suffix or o.option not in SUFFIX_CHECKED:
            assert "is an input file of this command" in line, line
        else:  # refused by its suffix first
            assert "must end in" in line, line
        assert src.read_bytes() == before
        assert "wrote" not in out


@pytest.mark.parametrize("o", OUTPUTS, ids=IDS)
def test_folder_that_cannot_be_created_is_found_before_the_work(o, ws, capsys):
    target = ws / "afile" / ("out" + o.suffix)
    rc, out, err = run([*o.argv(ws), o.option, target], capsys)
    assert rc == 2, (out, err)
    line = _line(err)
    assert str(target) in line and "afile" in line and "not a folder" in line, line
    assert out == ""  # refused before any work: nothing printed


@pytest.mark.skipif(ROOT, reason="root writes into read-only folders; the path under a file covers it")
@pytest.mark.parametrize("o", OUTPUTS, ids=IDS)
def test_read_only_folder_is_found_before_the_work(o, ws, tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        target = ro / ("out" + o.suffix)
        rc, out, err = run([*o.argv(ws), o.option, target], capsys)
    finally:
        ro.chmod(0o700)
    assert rc == 2, (out, err)
    line = _line(err)
    assert str(target) in line and "permission denied" in line, line
    assert out == ""


@pytest.mark.parametrize("robot,files", [("kr270", "measurements.csv"), ("dualarm", "targets.csv")])
def test_synth_keeps_existing_data_unless_overwrite(robot, files, tmp_path, capsys):
    out = tmp_path / "data"
    out.mkdir()
    (out / files).write_text("my own measurements\n")
    rc, o, err = run(["synth", robot, "--out", out, "--configs", "2"], capsys)
    assert rc == 2
    line = _line(err)
    assert str(out) in line and files in line and "--overwrite" in line
    assert (out / files).read_text() == "my own measurements\n"
    rc, o, err = run(["synth", robot, "--out", out, "--configs", "2", "--overwrite"], capsys)
    assert rc == 0, err
    assert (out / files).read_text() != "my own measurements\n"


def test_block_device_and_socket_are_refused_before_the_work(ws, tmp_path, capsys):
    import socket

    sock = tmp_path / "s.json"
    s = socket.socket(socket.AF_UNIX)
    s.bind(str(sock))
    try:
        rc, out, err = run([*_field_args(ws), "--json", sock], capsys)
    finally:
        s.close()
    assert rc == 2 and out == ""
    line = _line(err)
    assert str(sock) in line and "a socket" in line
    if ROOT:
        blk = tmp_path / "b.json"
        try:
            os.mknod(blk, stat.S_IFBLK | 0o600, os.makedev(7, 200))  # a loop device number nothing uses
        except OSError:
            return
        rc, out, err = run([*_field_args(ws), "--json", blk], capsys)
        assert rc == 2 and out == ""
        assert str(blk) in _line(err) and "a block device" in _line(err)
        assert stat.S_ISBLK(os.stat(blk).st_mode)


def test_symlink_output_keeps_the_link(ws, tmp_path, capsys):
    real = tmp_path / "real.json"
    real.write_text("{}")
    link = tmp_path / "link.json"
    link.symlink_to(real)
    rc, out, err = run([*_field_args(ws), "--json", link], capsys)
    assert rc == 0, err
    assert link.is_symlink() and real.is_file() and not real.is_symlink()
    assert json.loads(real.read_text()) != {}
