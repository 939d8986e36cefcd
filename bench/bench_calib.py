"""Calibration benchmark: fit + diagnose time of the KR-270-like
6R example for 270, 1,000 and 10,000 measurement rows, every candidate
kind on every target (goal: diagnose of 1,000 rows under 5 s on one core),
and the tool-compliance throughput of load_model(...).tool_compliance.

    python bench/bench_calib.py        (or: make bench BENCH=calib)
"""

from __future__ import annotations

import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from stiffkit.calib import synth as S  # noqa: E402
from stiffkit.calib.diagnose import candidate_tables, diagnose  # noqa: E402
from stiffkit.calib.fit import fit  # noqa: E402
from stiffkit.robot.model import model_from_tables  # noqa: E402

MARKERS = ((0.0, 0.0, 0.25), (0.12, 0.0, 0.2), (0.0, 0.12, 0.2))
SIGMA = 2e-5


def best_of(fn, repeat):
    t = []
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        t.append(time.perf_counter() - t0)
    return min(t), out


def main():
    truth = S.kr270_truth(compensator=True)
    print(
        f"{'rows':>7s} {'fit J1 (s)':>11s} {'fit J1+links+GC (s)':>20s} {'diagnose J1 (s)':>16s}"
        f" {'candidates':>11s} {'verdict':>11s} {'diagnose J1+links+GC (s)':>25s} {'verdict':>11s}"
    )
    for rows in (270, 1000, 10000):
        n_cfg = int(np.ceil(rows / 9))
        chain, tm, meas = S.synthesize(
            S.KR270_JOINTS, truth, n_configs=n_cfg, sigma=SIGMA, seed=1, ranges=S.KR270_RANGES, markers=MARKERS
        )
        meas = meas.subset(np.arange(rows))
        j1 = model_from_tables(chain, [{"kind": "joint", "target": "all"}], sigma_position=SIGMA)
        full = model_from_tables(
            chain,
            [{"kind": "joint", "target": "all"}]
            + [{"kind": "link", "target": f"link_{i}", "template": "beam"} for i in (2, 3, 4)]
            + [
                {
                    "kind": "gravity_compensator",
                    "target": "joint_a2",
                    **{k: S.KR270_COMPENSATOR[k] for k in ("a", "b", "beta", "s0")},
                }
            ],
            sigma_position=SIGMA,
        )
        rep = 3 if rows <= 1000 else 1
        t_fit, _ = best_of(lambda: fit(j1, meas), rep)
        t_full, _ = best_of(lambda: fit(full, meas), rep)
        t_dg, dg = best_of(lambda: diagnose(j1, meas), rep)
        ncand = len(candidate_tables(j1))
        t_dgf, dgf = best_of(lambda: diagnose(full, meas), rep)
        print(
            f"{rows:7d} {t_fit:11.3f} {t_full:20.3f} {t_dg:16.3f} {ncand:11d} {dg.verdict:>11s}"
            f" {t_dgf:25.3f} {dgf.verdict:>11s}",
            flush=True,
        )
    # stiffness maps: one core call for N postures
    tm = model_from_tables(chain, S.kr270_truth(compensator=True))
    Q = S.random_postures(100_000, S.KR270_RANGES, np.random.default_rng(0))
    t, _ = best_of(lambda: tm.tool_compliance(Q), 3)
    print(
        f"\ntool_compliance, 6 joints + 3 links + compensator: {len(Q)} postures in {t:.3f} s "
        f"= {len(Q) / t:.3g} postures/s (one core call)"
    )


if __name__ == "__main__":
    main()
