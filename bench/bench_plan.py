"""Experiment-design core benchmark (stiffkit plan, issue 19): select 50 of
10,000 random candidates (3 whitened rows each, 100 parameters, no prior)
for the D, A and task criteria (task: 60 random task rows); CPU time of the
greedy selection and of the exchange, exchange passes and swaps, the
criterion before and after the exchange, and the check that the value the
low-rank updates carried equals a direct evaluation. Goal: < 5 s of CPU per
criterion on one core.

    python bench/bench_plan.py        (or: make bench BENCH=plan)
"""

from __future__ import annotations

import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from stiffkit._core import design  # noqa: E402

NCAND, NOBS, NPAR, K, NT = 10_000, 3, 100, 50, 60


def main() -> None:
    rng = np.random.default_rng(2026)
    jc = rng.standard_normal((NCAND, NOBS, NPAR))
    jt = rng.standard_normal((NT, NPAR))
    print(f"select {K} of {NCAND} candidates, {NOBS} rows each, {NPAR} parameters (CPU seconds, one core)")
    print(
        f"{'criterion':>9} {'greedy s':>9} {'exchange s':>10} {'total s':>8} {'passes':>6} {'swaps':>5} "
        f"{'greedy value':>13} {'value':>13} {'rel. vs direct':>14}"
    )
    for criterion in ("D", "A", "task"):
        t0 = time.process_time()
        greedy = design.select(jc, K, criterion, jt=jt, max_passes=0)
        t1 = time.process_time()
        res = design.select(jc, K, criterion, jt=jt)
        t2 = time.process_time()
        direct = design.criterion(jc, res.selected, criterion, jt=jt)
        rel = abs(res.value - direct) / abs(direct)
        tg, tt = t1 - t0, t2 - t1
        print(
            f"{criterion:>9} {tg:9.2f} {tt - tg:10.2f} {tt:8.2f} {res.passes:6d} {res.swaps:5d} "
            f"{greedy.value:13.6g} {res.value:13.6g} {rel:14.1e}"
        )
        assert rel < 1e-10 and res.value <= res.greedy_value


if __name__ == "__main__":
    main()
