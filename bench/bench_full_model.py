"""The full model against a hand calibration (issue 16 item 5,
docs/calibration.md section 6.12) on the synthetic dual-arm robot
(calib/dualarm.py) at POSTURES postures x 2 markers, noise 0.1 mm:

- truth "tool": `stiffkit synth dualarm`'s truth (offsets, frame errors,
  joint and lateral compliance in stiffkit's own lateral convention),
  simulated by the core;
- truth "normal": the same offsets, frame errors and joint compliances,
  with each joint's lateral compliance a tilt about the common normal with
  the previous joint's axis (both tilts for the first joint), simulated by
  the independent numpy model of tests/_hand_model.py.

On each: `stiffkit fit` of the model with every kind on all joints
(joint_offset, frame, joint, lateral; converged equilibrium, and
`[gravity] iterations = 1`), and the hand reference (tests/_hand_model.py:
a minimal set chosen by rule, numpy least squares; compliances free, or
held at 0 when identified below 0 as the full model does); mean point
error in-sample and 5-fold CV (mm).

    python bench/bench_full_model.py [POSTURES]
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import _hand_model as H  # noqa: E402
import numpy as np  # noqa: E402

from stiffkit.calib import dualarm as D  # noqa: E402
from stiffkit.calib.absolute_fit import fit_absolute  # noqa: E402
from stiffkit.calib.absolute_report import load_absolute  # noqa: E402
from stiffkit.robot.tree_model import tree_model_from_tables  # noqa: E402


def tool_fit(start, data, iterations: int) -> tuple[float, float, int]:
    eff = [dict(e) for e in start.effects] + [{"kind": k, "target": "all"} for k in D.STORY]
    m = tree_model_from_tables(start.tree, eff, D.GRAVITY, iterations=iterations, sigma_position=D.DEFAULT_SIGMA)
    f = fit_absolute(m, data, cv=5)
    return np.linalg.norm(f.residual, axis=1).mean(), f.cv["mean_position_m"], f.reduction.kept.size


def hand_fit(tree, Q, xyz, nonneg: bool) -> tuple[float, float, int]:
    hm = H.HandModel(tree, list(D.MARKERS), lateral="normal", hand=True)
    th, R0, free = H.fit(hm, Q, xyz, H.start(hm, D.NOMINAL_MARKERS), maxit=60, nonneg=nonneg)
    cv = H.cross_validate(hm, Q, xyz, th, free)
    return H.errors(hm, th, R0, Q, xyz).mean(), cv.mean(), free.size


def main(postures: int = 500) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out = D.synth_dualarm(Path(tmp) / "d", configs=postures, seed=1)
        start, data = load_absolute(out / "model.toml", out / "measurements.csv")
        tree = start.tree
        normal = data.subset(np.ones(data.n, bool))
        normal.xyz = H.normal_truth_points(tree, D.dualarm_truth(out / "robot.urdf"), data.Q, seed=7).reshape(-1, 3)
        for name, d in (("tool", data), ("normal", normal)):
            xyz = d.xyz.reshape(-1, len(D.MARKERS), 3)
            for label, fn in (
                ("full, converged", lambda: tool_fit(start, d, 100)),
                ("full, one-pass ", lambda: tool_fit(start, d, 1)),
                ("hand, free     ", lambda: hand_fit(tree, d.Q, xyz, False)),
                ("hand, c >= 0   ", lambda: hand_fit(tree, d.Q, xyz, True)),
            ):
                t0 = time.process_time()
                mean, cv, n = fn()
                print(
                    f"truth {name:6s} {label}: {n:4d} parameters  mean {1e3 * mean:.4f} mm  "
                    f"5-fold CV {1e3 * cv:.4f} mm  ({time.process_time() - t0:.0f} s)",
                    flush=True,
                )


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
