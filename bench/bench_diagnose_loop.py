"""The diagnosis loop on random trees with a known truth (issue 16 items 2
and 3), longer than its test (tests/test_diagnose_loop.py): more seeds,
more postures, with and without a declared sigma.

    python bench/bench_diagnose_loop.py             (or: make bench BENCH=diagnose_loop)
    python bench/bench_diagnose_loop.py 20 60       (seeds, postures)

Each robot (calib.synth_trees: a trunk, two arms with a marker each, a head
and a gripper's mimic fingers that carry mass and no marker) has a truth of
joint offsets and joint compliances on every joint; the loop
(calib.absolute_diagnose.diagnose_loop) starts from the tracker and the
markers. Per case: the steps taken (+ added, - removed), the final RMS over
the noise floor, the effects the truth lacks left in the final model, and
whether a candidate on a body that moves no marker was ever ranked.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from stiffkit.calib.absolute_diagnose import diagnose_loop  # noqa: E402
from stiffkit.calib.synth_trees import NO_MARKER_LINKS, TRUTH_KINDS, tree_case  # noqa: E402

SIGMA = 1e-4
NO_MARKER_JOINTS = ("neck", "finger_a", "finger_b")


def one(folder: str, seed: int, postures: int, declared: bool) -> dict:
    case = tree_case(folder, seed, postures=postures, sigma=SIGMA)
    t0 = time.perf_counter()
    effects, seen = diagnose_loop(lambda e: case.model(e, declared), case.data, case.start)
    dt = time.perf_counter() - t0
    steps = [
        ("-" + dg.removal.label) if dg.removal is not None else ("+" + dg.proposal.label)
        for dg in seen
        if dg.removal is not None or dg.proposal is not None
    ]
    bad_rank = any(c.target in NO_MARKER_JOINTS or c.target in NO_MARKER_LINKS for dg in seen for c in dg.candidates)
    spurious = [e for e in effects if e["kind"] not in TRUTH_KINDS + ("tracker", "marker")]
    ratio = seen[-1].fit.rms_position / (math.sqrt(3) * SIGMA)
    return {"steps": steps, "ratio": ratio, "spurious": spurious, "bad_rank": bad_rank, "time": dt}


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    postures = int(sys.argv[2]) if len(sys.argv) > 2 else 60
    with tempfile.TemporaryDirectory() as tmp:
        for declared in (True, False):
            ok = 0
            print(f"sigma {'declared' if declared else 'not declared'}: {seeds} seeds, {postures} postures x 2 markers")
            print(f"{'seed':>5s}  {'RMS/floor':>9s}  {'s':>5s}  steps")
            for seed in range(seeds):
                r = one(tmp, seed, postures, declared)
                good = r["ratio"] < 1.10 and not r["spurious"] and not r["bad_rank"]
                ok += good
                extra = f"  left: {', '.join(e['kind'] for e in r['spurious'])}" if r["spurious"] else ""
                print(f"{seed:5d}  {r['ratio']:9.3f}  {r['time']:5.1f}  {' '.join(r['steps'])}{extra}")
            print(f"within 10 % of the floor, no effect the truth lacks, nothing inert ranked: {ok}/{seeds}\n")


if __name__ == "__main__":
    main()
