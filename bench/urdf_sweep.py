"""The URDFs of the PyPI package example-robot-data (69 robots, BSD; the
wheel, 131 MB, is fetched with ``pip download`` into bench/.cache/, which
git ignores) through the reader and a frames-only fit: for each URDF, the
tree below its root (below a floating or planar joint at the root: the
robot's own base, as the reader's message asks), a marker on the link
farthest from the base, 30 random postures simulated by the core, the fit
of the tracker and the marker (the tracker from the data, the marker from
1 mm away). Prints
one line per URDF and how many read and fit (rms < 1e-9 m). Not part of
`make test` or `make bench` (it needs the download).

    python bench/urdf_sweep.py
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import warnings
import zipfile
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from stiffkit._core import tree as core  # noqa: E402
from stiffkit.calib.absolute_data import AbsoluteData  # noqa: E402
from stiffkit.calib.absolute_fit import fit_absolute  # noqa: E402
from stiffkit.errors import StiffkitError  # noqa: E402
from stiffkit.robot.tree import load_tree, read_urdf  # noqa: E402
from stiffkit.robot.tree_model import tree_model_from_tables  # noqa: E402

HERE = Path(__file__).resolve().parent
CACHE = HERE / ".cache"
PACKAGE = "example-robot-data==6.0.0"


def wheel() -> Path:
    found = sorted(CACHE.glob("example_robot_data-*.whl"))
    if not found:
        CACHE.mkdir(exist_ok=True)
        cmd = [sys.executable, "-m", "pip", "download", PACKAGE, "--no-deps", "-d", str(CACHE)]
        subprocess.run(cmd, check=True)
        found = sorted(CACHE.glob("example_robot_data-*.whl"))
    return found[-1]


def base_of(doc) -> str:
    """The root with the most links below it, stepped past floating/planar joints."""
    kids: dict[str, list] = {}
    for j in doc.joints:
        kids.setdefault(j.parent, []).append(j)

    def size(link: str) -> int:
        n, todo = 0, [link]
        while todo:
            ln = todo.pop()
            n += 1
            todo += [j.child for j in kids.get(ln, ())]
        return n

    links = [ln.name for ln in doc.links]
    base = max(doc.roots or links[:1] or ["base_link"], key=size)  # no root: a loop or no link, named by load_tree
    while len(kids.get(base, ())) == 1 and kids[base][0].type in ("floating", "planar"):
        base = kids[base][0].child
    return base


def one(name: str, text: str, rng: np.random.Generator) -> tuple[str, str]:
    path = CACHE / "urdf" / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            doc = read_urdf(text, path)
            base = base_of(doc)
            tree = load_tree(path, base, urdf=doc)
        except StiffkitError as exc:
            return "read failed", str(exc).split(": ", 1)[-1][:150]
    moving = [j for j in tree.joints if j.moving]
    if not tree.actuated:
        return "read", f"base {base!r}: no moving joint ({len(tree.joints)} joints)"
    depth = {tree.root: 0}
    for j in tree.joints:
        depth[j.child] = depth[j.parent] + (j.moving and j.mimic is None)
    frame = max(tree.links, key=lambda ln: depth[ln])
    point = np.array([0.02, 0.01, -0.03])
    # the marker's start 1 mm off the truth (a user knows roughly where a reflector sits)
    eff = [{"kind": "tracker"}, {"kind": "marker", "target": frame, "xyz": list(point + 0.001)}]
    model = tree_model_from_tables(tree, eff)
    truth = model.theta0.copy()
    truth[:6] = [1.0, -0.5, 0.3, 0.0, 0.0, 0.0]
    truth[6:9] = point
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    model.arrays["rref"] = np.asfortranarray(R)
    n = 30
    kinds = {j.name: j.type for j in moving}
    Q = np.column_stack(
        [rng.uniform(-0.05, 0.05, n) if kinds[a] == "prismatic" else rng.uniform(-1.5, 1.5, n) for a in tree.actuated]
    )
    ev = core.evaluate(
        model.packed,
        truth,
        Q,
        None,
        np.arange(n),
        np.zeros(n, int),
        np.zeros((n, 3)),
        np.ones(n),
        np.zeros(0, int),
        0,
        1e-9,
    )
    data = AbsoluteData(
        path=name,
        joints=tree.actuated,
        configs=[f"c{k}" for k in range(n)],
        Q=Q,
        posture=np.arange(n),
        frame=np.zeros(n, int),
        frames=[frame],
        xyz=ev["pred"],
        weight=np.ones(n),
        lines=np.arange(n) + 2,
    )
    start = model.copy()
    start.arrays["rref"] = np.asfortranarray(R @ np.array([[1, 0, 0], [0, 0.99875, -0.04998], [0, 0.04998, 0.99875]]))
    try:
        fit = fit_absolute(start, data)
    except StiffkitError as exc:
        return "fit failed", str(exc)[:150]
    what = f"base {base!r}, {len(tree.joints)} joints ({len(tree.actuated)} actuated), marker on {frame!r}"
    return ("fit" if fit.rms_position < 1e-9 else "fit inexact"), f"{what}: rms {fit.rms_position:.1e} m"


def main() -> None:
    z = zipfile.ZipFile(wheel())
    names = sorted(n for n in z.namelist() if n.endswith(".urdf"))
    rng = np.random.default_rng(1)
    counts: dict[str, int] = {}
    t0 = time.perf_counter()
    for n in names:
        short = n.split("robots/", 1)[-1]
        status, text = one(short, z.read(n).decode("utf-8", "replace"), rng)
        counts[status] = counts.get(status, 0) + 1
        print(f"{status:12s} {short}: {text}", flush=True)
    read = sum(v for k, v in counts.items() if k != "read failed")
    print(
        f"\n{len(names)} URDFs: {read} read, {counts.get('fit', 0)} fitted exactly "
        f"({', '.join(f'{k}: {v}' for k, v in sorted(counts.items()))}); {time.perf_counter() - t0:.0f} s"
    )


if __name__ == "__main__":
    main()
