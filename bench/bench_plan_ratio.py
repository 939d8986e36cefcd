"""The task error of planned against random postures (issue 19): the
expected RMS position error after calibration at 30 task postures in a
workcell (every joint within +-0.35 rad of a working posture), the plan of
each criterion over the median of 20 random feasible designs of the same K,
at K = 30, 50, 100, on the synthetic dual-arm robot (tracker data, 2000
sampled candidates) and a KR-270-like chain (deflection data, 500 postures
x 4 loads, 3 points each). Ratios below 1: the plan wins.

    python bench/bench_plan_ratio.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from _plan_robots import KR_POINTS, P, dualarm_files, kr_files, workcell_task  # noqa: E402

KS = (30, 50, 100)
CRITERIA = ("task", "D", "A")


def robot_rows(name: str, path: Path, candidates: int, points: object) -> None:
    model = P.load_plan_model(path)
    s0 = P.build_setup(model, candidates=200, seed=1, points=points)
    task = path.parent / "task.csv"
    workcell_task(model, s0.candidates.q[0], 30, 5, task, s0.joint_names)
    t0 = time.process_time()
    setup = P.build_setup(model, candidates=candidates, seed=1, task=task, points=points)
    built = time.process_time() - t0
    print(
        f"{name}: {setup.npar} identifiable parameters, {setup.jc.shape[0]} candidates x {setup.nobs} rows "
        f"(set up in {built:.1f} s CPU)"
    )
    print(f"  {'K':>4s} " + " ".join(f"{c:>8s}" for c in CRITERIA) + "   random median (mm)   CPU (s)")
    for k in KS:
        t0 = time.process_time()
        res = [P.plan(None, k, c, setup=setup, seed=1) for c in CRITERIA]
        cpu = time.process_time() - t0
        ratios = " ".join(f"{r.ratio:8.3f}" for r in res)
        print(f"  {k:4d} {ratios}   {res[0].random_task_rms * 1e3:18.4g}   {cpu:7.1f}")


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        print("task error of the plan / median of 20 random feasible designs (same K), 30 workcell task postures")
        robot_rows("dual-arm (tracker data)", dualarm_files(tmp / "da"), 2000, None)
        robot_rows("KR-270-like (deflection data)", kr_files(tmp / "kr"), 500, KR_POINTS)


if __name__ == "__main__":
    main()
