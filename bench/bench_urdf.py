"""Large URDFs (issue 17.7): a chain of N links joined by fixed joints (one
revolute joint at the root, a marker on the last link, a mass on every
link), read and fitted frames-only (tracker + marker) from 20 postures.
Each step is timed alone (wall clock and process CPU time; the machine may
be shared), for N = 10,000 .. 100,000: parse (the file read and its numbers
checked, robot/tree.py read_urdf), checks (the tree below base_link:
names, references, loops, masses, load_tree), model (tree_model.py) and
fit (the CSV read and the frames-only fit, calib/absolute_fit.py). The
time per link should not grow with N (linear), and 100,000 links read +
fit in under 10 s of CPU time.

    python bench/bench_urdf.py [N ...]      (or: make bench BENCH=urdf)
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from stiffkit.calib.absolute_data import read_absolute  # noqa: E402
from stiffkit.calib.absolute_fit import fit_absolute  # noqa: E402
from stiffkit.robot.tree import load_tree, parse_urdf  # noqa: E402
from stiffkit.robot.tree_model import tree_model_from_tables  # noqa: E402

STEP = 1e-5  # m between consecutive fixed links (the chain is 1 m long at 100,000 links)


def chain_urdf(n: int) -> str:
    out = ['<?xml version="1.0"?>', '<robot name="long">', '  <link name="base_link"/>']
    out.append(
        '  <joint name="j0" type="revolute"><parent link="base_link"/><child link="l0"/>'
        '<origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
    )
    out.append('  <link name="l0"/>')
    for k in range(1, n):
        out.append(
            f'  <link name="l{k}"><inertial><origin xyz="0 0 0.0001" rpy="0 0 0"/><mass value="0.001"/>'
            '<inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial></link>'
        )
        out.append(
            f'  <joint name="f{k}" type="fixed"><parent link="l{k - 1}"/><child link="l{k}"/>'
            f'<origin xyz="{STEP} 0 0" rpy="0 0 0.0001"/></joint>'
        )
    out.append("</robot>")
    return "\n".join(out) + "\n"


def clock() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def run(n: int, folder: Path) -> dict:
    urdf = folder / f"chain{n}.urdf"
    urdf.write_text(chain_urdf(n))
    last = f"l{n - 1}"
    t = {}
    w0, c0 = clock()
    doc = parse_urdf(urdf)
    wp, cp = clock()
    t["parse"] = (wp - w0, cp - c0)
    tree = load_tree(urdf, urdf=doc)
    del doc
    w1, c1 = clock()
    t["checks"] = (w1 - wp, c1 - cp)
    model = tree_model_from_tables(tree, [{"kind": "tracker"}, {"kind": "marker", "target": last}])
    w2, c2 = clock()
    t["model"] = (w2 - w1, c2 - c1)
    # data: the tool point of the chain in a tracker frame, 20 postures of j0
    rng = np.random.default_rng(1)
    q = rng.uniform(-3, 3, 20)
    from stiffkit._core import tree as core

    P = core.poses(model.packed, model.theta0, q[:, None], None, 0, 1e-9)
    tip = P["pa"][:, model.arrays["mvj"][0] - 1]
    Rt = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    xyz = (tip + [0.01, 0.0, 0.0]) @ Rt.T + [1.0, 2.0, 0.5]
    csv = folder / f"chain{n}.csv"
    rows = ["config,j0,frame,x,y,z"] + [
        f"c{k},{q[k]:.17g},{last},{x:.17g},{y:.17g},{z:.17g}" for k, (x, y, z) in enumerate(xyz)
    ]
    csv.write_text("\n".join(rows) + "\n")
    w3, c3 = clock()
    data = read_absolute(csv, model.actuated, model.frames)
    fit = fit_absolute(model, data)
    w4, c4 = clock()
    t["fit"] = (w4 - w3, c4 - c3)
    t["rms_m"] = fit.rms_position
    return t


STEPS = ("parse", "checks", "model", "fit")


def main(sizes: list[int]) -> None:
    heads = " ".join(f"{k + ' s':>14}" for k in STEPS + ("total",))
    print(f"{'links':>8} {heads} {'us/link':>8}  rms (m)")
    units = " ".join(f"{'(wall/cpu)':>14}" for _ in STEPS + ("total",))
    print(f"{'':>8} {units} {'(cpu)':>8}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            t = run(n, Path(tmp))
            t["total"] = tuple(sum(t[k][i] for k in STEPS) for i in (0, 1))
            cells = " ".join(f"{f'{t[k][0]:6.2f}/{t[k][1]:6.2f}':>14}" for k in STEPS + ("total",))
            print(f"{n:8d} {cells} {1e6 * t['total'][1] / n:8.1f}  {t['rms_m']:.2e}")
            print(f"{'':8} total CPU time {t['total'][1]:.2f} s for {n} links")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [10_000, 30_000, 100_000])
