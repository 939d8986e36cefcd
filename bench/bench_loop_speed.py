"""Speed of the diagnose loop on absolute data (issue 16 item 7): the
synthetic dual-arm robot (`stiffkit synth dualarm`: torso with a coupled
pitch, two 7-joint arms, two hand markers) at 500 postures, the loop from
frames only (calib.absolute_diagnose.diagnose_loop: diagnose, append the
proposal or remove what no longer earns its place, then prune).

    python bench/bench_loop_speed.py [POSTURES] [--profile]

Prints per step: the model's effects, CPU seconds (time.process_time: the
machine may be shared), wall seconds, the number of Levenberg-Marquardt
fits and of core evaluations (each LM counts its own evaluations: residual
and Jacobian calls inside the core), candidates ranked and the RMS; then
the whole loop's CPU time. ``--profile``: cProfile of the whole loop,
the 25 costliest functions by cumulative time.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from stiffkit._core import tree as core  # noqa: E402
from stiffkit.calib.absolute_diagnose import diagnose_absolute  # noqa: E402
from stiffkit.calib.absolute_report import load_absolute  # noqa: E402
from stiffkit.io.tables import read_toml  # noqa: E402
from stiffkit.robot.tree_model import tree_model_from_tables  # noqa: E402

COUNTS = {"lm": 0, "lm_iterations": 0, "evaluate": 0}


def _counting() -> None:
    """Count the core's LM fits (and their iterations) and evaluations."""
    lm, evaluate = core.lm, core.evaluate

    def lm_counted(*a, **k):
        out = lm(*a, **k)
        COUNTS["lm"] += 1
        COUNTS["lm_iterations"] += out["niter"]
        return out

    def evaluate_counted(*a, **k):
        COUNTS["evaluate"] += 1
        return evaluate(*a, **k)

    core.lm, core.evaluate = lm_counted, evaluate_counted


def main(postures: int = 500, profile: bool = False) -> None:
    _counting()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "dualarm"
        subprocess.run(
            [sys.executable, "-m", "stiffkit", "synth", "dualarm", "--out", str(out), "--configs", str(postures)],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        model, data = load_absolute(out / "model.toml", out / "measurements.csv")
        doc = read_toml(out / "model.toml", "model")
        effects = [dict(e) for e in doc.get("effect", [])]

        def model_of(effs: list[dict]):
            return tree_model_from_tables(
                model.tree, effs, where=str(out / "model.toml"), sigma_position=model.sigma_position
            )

        print(f"{data.n} rows, {len(model.tree.joints)} joints; loop from: {[e['kind'] for e in effects]}")
        prof = None
        if profile:
            import cProfile

            prof = cProfile.Profile()
            prof.enable()
        c_all, t_all = time.process_time(), time.perf_counter()
        for step in range(10):
            c0, t0 = time.process_time(), time.perf_counter()
            n0 = dict(COUNTS)
            dg = diagnose_absolute(model_of(effects), data, prune=step >= 8)
            cpu, wall = time.process_time() - c0, time.perf_counter() - t0
            what = "adequate"
            if dg.removal is not None:
                what = f"- {dg.removal.label}"
                effects.pop(dg.removal.index)
            elif dg.proposal is not None:
                what = f"+ {dg.proposal.label}"
                effects.append(dict(dg.proposal.effect))
            rms, cv = 1e3 * dg.fit.rms_position, 1e3 * dg.cv_rms_position_m
            d = {k: COUNTS[k] - n0[k] for k in COUNTS}
            print(
                f"step {step + 1}: cpu {cpu:6.1f} s (wall {wall:6.1f})  {d['lm']:2d} LM fits "
                f"({d['lm_iterations']:3d} it)  {d['evaluate']:2d} evaluations  rms {rms:.4f} mm  cv {cv:.4f} mm  "
                f"{len(dg.candidates):3d} ranked  {dg.verdict:10s} {what}",
                flush=True,
            )
            if what == "adequate":
                break
        cpu_all, wall_all = time.process_time() - c_all, time.perf_counter() - t_all
        print(
            f"whole loop: cpu {cpu_all:.1f} s (wall {wall_all:.1f} s), {COUNTS['lm']} LM fits "
            f"({COUNTS['lm_iterations']} iterations), {COUNTS['evaluate']} evaluations"
        )
        if prof is not None:
            import pstats

            prof.disable()
            pstats.Stats(prof).sort_stats("cumulative").print_stats(25)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(*(int(a) for a in args), profile="--profile" in sys.argv[1:])
