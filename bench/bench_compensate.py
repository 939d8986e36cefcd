"""Compensation throughput (docs/calibration.md 6.5): a 7-joint arm read
from a URDF with masses, joint offsets, frame errors on every joint, joint
and lateral compliance (an absolute model with values, full gravity
equilibrium), compensated at random postures through the Python API
(robot/compensate.py: nominal targets by the core, then the core's Newton)
and through `stiffkit compensate` on a CSV (reading, checking and writing
included). Regular postures keep the pitch joints (elbow, wrist) at least
0.3 rad from their singular zero, as a robot program does; uniform
postures include near-singular ones, where rows take many Newton steps or
are flagged. Postures per second of wall clock and of process CPU time (the
machine may be shared); best of three runs.

    python bench/bench_compensate.py        (or: make bench BENCH=compensate)
"""

from __future__ import annotations

import os
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import tomli_w  # noqa: E402

from stiffkit.cli import main  # noqa: E402
from stiffkit.robot.compensate import load_compensation_model  # noqa: E402


def arm_urdf(nj: int) -> str:
    out = ['<?xml version="1.0"?>', f'<robot name="arm{nj}">', '<link name="base_link"/>']
    for j in range(nj):
        out.append(
            f'<link name="l{j + 1}"><inertial><origin xyz="0 0.02 0.1"/><mass value="{6.0 - 0.5 * j}"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )
    out.append('<link name="tool0"/>')
    for j in range(nj):
        axis = "0 0 1" if j % 2 == 0 else "0 1 0"
        z = 0.34 if j == 0 else (0.2 if j < 5 else 0.1)
        parent = "base_link" if j == 0 else f"l{j}"
        out.append(
            f'<joint name="j{j + 1}" type="revolute"><parent link="{parent}"/><child link="l{j + 1}"/>'
            f'<origin xyz="0 0 {z}" rpy="0 0 {0.1 * j}"/><axis xyz="{axis}"/>'
            '<limit lower="-3" upper="3" effort="100" velocity="1"/></joint>'
        )
    out.append(
        f'<joint name="tool" type="fixed"><parent link="l{nj}"/><child link="tool0"/>'
        '<origin xyz="0 0 0.1"/></joint></robot>'
    )
    return "\n".join(out) + "\n"


def arm_model(folder: Path, nj: int) -> Path:
    (folder / "robot.urdf").write_text(arm_urdf(nj))
    rng = np.random.default_rng(3)
    eff = [{"kind": "tracker"}, {"kind": "marker", "target": "tool0"}]
    for j in range(nj):
        eff.append({"kind": "joint_offset", "target": f"j{j + 1}", "value": float(0.01 * rng.normal())})
        eff.append({"kind": "frame", "target": f"j{j + 1}", "value": rng.normal(0, 1e-3, 6).tolist()})
    eff += [
        {"kind": "joint", "target": "all", "value": 2e-5},
        {"kind": "lateral", "target": "all", "value": [1e-5, 1e-5]},
    ]
    doc = {
        "robot": {"urdf": "robot.urdf", "base_link": "base_link", "tool_frame": "tool0"},
        "measurements": {"kind": "absolute"},
        "effect": eff,
    }
    path = folder / f"arm{nj}.toml"
    path.write_text(tomli_w.dumps(doc))
    return path


def best(f, reps=3):
    ts, cs, out = [], [], None
    for _ in range(reps):
        t0, c0 = time.perf_counter(), time.process_time()
        out = f()
        cs.append(time.process_time() - c0)
        ts.append(time.perf_counter() - t0)
    return min(ts), min(cs), out


def bench(nj=7, nrows=10000):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        path = arm_model(tmp, nj)
        cm = load_compensation_model(path)
        rng = np.random.default_rng(5)
        # a robot program keeps away from singular postures: the pitch joints
        # (elbow straight, wrist aligned) at least 0.3 rad from zero
        Q = rng.uniform(-1.2, 1.2, (nrows, nj))
        Q[:, 1::2] = rng.choice([-1.0, 1.0], (nrows, nj // 2)) * rng.uniform(0.3, 1.2, (nrows, nj // 2))
        Qu = rng.uniform(-1.2, 1.2, (nrows, nj))
        print(
            f"compensation: {nj}-joint arm, {cm.model.ne} elastic coordinates (joint + 2 lateral per joint), "
            f"offsets and frame errors on every joint, gravity equilibrium; {nrows} random postures"
        )
        print(
            f"{'':>44s} {'postures/s':>11s} {'/s CPU':>9s} {'converged':>10s} {'max resid (m)':>14s}"
            f" {'Newton steps':>13s}"
        )
        for Qs, frame, label in (
            (Q, "tool0", "API, pose (7 joints), regular postures"),
            (Q, "l5", "API, position (5 joints), regular postures"),
            (Qu, "tool0", "API, pose, uniform in [-1.2, 1.2]"),
        ):
            t, c, r = best(lambda: cm.compensate(Qs, frame))
            ok = r.converged
            print(
                f"{label:>44s} {nrows / t:11.0f} {nrows / c:9.0f} {ok.mean():10.2%} {r.resp[ok].max():14.1e}"
                f" {r.nit.mean():13.1f}",
                flush=True,
            )
        # the command: CSV in, checks, CSV out
        names = [f"j{k + 1}" for k in range(nj)]
        lines = [",".join(names)] + [",".join(repr(float(v)) for v in q) for q in Q]
        (tmp / "targets.csv").write_text("\n".join(lines) + "\n")
        argv = ["compensate", str(path), str(tmp / "targets.csv"), "--out", str(tmp / "commands.csv")]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import contextlib
            import io

            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                t, c, rc = best(lambda: main(argv), reps=1)
        assert rc == 0, rc
        print(f"{'stiffkit compensate, CSV to CSV, regular':>44s} {nrows / t:11.0f} {nrows / c:9.0f}", flush=True)


def main_():
    bench(7, 10000)


if __name__ == "__main__":
    main_()
